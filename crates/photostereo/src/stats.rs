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

/// The median over value sets of each set's smallest gap between two distinct values:
/// the quantisation step of images whose samples lie on a grid. Each set is sorted and
/// deduplicated in place; sets with fewer than `min_distinct` distinct values (and always
/// those with fewer than two) are left out; 0 when none is left.
pub(crate) fn median_smallest_gap<'a>(
    sets: impl Iterator<Item = &'a mut Vec<f32>>,
    min_distinct: usize,
) -> f32 {
    let mut gaps: Vec<f32> = sets
        .filter_map(|v| {
            v.sort_unstable_by(f32::total_cmp);
            v.dedup();
            if v.len() < min_distinct {
                return None;
            }
            v.windows(2).map(|w| w[1] - w[0]).min_by(f32::total_cmp)
        })
        .collect();
    median(&mut gaps).unwrap_or(0.0)
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

    #[test]
    fn median_smallest_gap_of_gridded_sets() {
        let mut sets = [
            vec![0.5, 0.0, 0.25, 0.25, 1.0], // gap 0.25
            vec![3.0, 1.0, 2.0],             // gap 1
            vec![7.0, 7.0],                  // one distinct value: left out
            vec![0.0, 0.1, 0.2],             // gap ≈ 0.1
        ];
        let gap = median_smallest_gap(sets.iter_mut(), 2);
        assert_eq!(gap, 0.25);
        assert_eq!(sets[0], vec![0.0, 0.25, 0.5, 1.0]);
        assert_eq!(median_smallest_gap(sets.iter_mut(), 4), 0.25);
        assert_eq!(median_smallest_gap(sets.iter_mut(), 5), 0.0);
        assert_eq!(median_smallest_gap(std::iter::empty(), 2), 0.0);
    }
}
