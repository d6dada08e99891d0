//! Order statistics of sample buffers, by selection (no full sort), shared by the stages
//! that take a median or a percentile of their samples.

/// The median of `v` (the upper one of an even count), reordering `v`; `None` when empty.
pub(crate) fn median(v: &mut [f32]) -> Option<f32> {
    percentile_at(v, v.len() / 2)
}

/// The value at rank ⌊(n − 1)·`p`⌋ of the n values `v` (`p` in [0, 1]), reordering `v`;
/// `None` when empty.
pub(crate) fn percentile(v: &mut [f32], p: f64) -> Option<f32> {
    let rank = (v.len().saturating_sub(1) as f64 * p) as usize;
    percentile_at(v, rank)
}

/// The value of rank `rank` (0-based, ascending, NaNs last) of `v`, reordering `v`.
fn percentile_at(v: &mut [f32], rank: usize) -> Option<f32> {
    (rank < v.len()).then(|| *v.select_nth_unstable_by(rank, f32::total_cmp).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_percentiles_of_small_buffers() {
        assert_eq!(median(&mut []), None);
        assert_eq!(percentile(&mut [], 0.5), None);
        assert_eq!(median(&mut [3.0]), Some(3.0));
        // the upper median of an even count
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(3.0));
        let mut v: Vec<f32> = (0..11).rev().map(|i| i as f32).collect();
        assert_eq!(percentile(&mut v, 0.0), Some(0.0));
        assert_eq!(percentile(&mut v, 0.1), Some(1.0));
        assert_eq!(percentile(&mut v, 0.25), Some(2.0)); // rank ⌊2.5⌋
        assert_eq!(percentile(&mut v, 1.0), Some(10.0));
    }
}
