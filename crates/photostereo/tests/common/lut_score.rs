//! Scoring of lookup outputs against true normals, shared by `lut_shared.rs` and
//! `lut_scenes.rs`: mean angular error over the mask, by band of the true normal's angle
//! from the view axis, and Spearman's rank correlation between confidence and error.

use super::angle_deg;
use photostereo::image::{Mask, NormalMap};
use photostereo::lut::Output;

/// Upper edges of the bands of true normal angle (degrees).
pub const BANDS: [f64; 4] = [60.0, 75.0, 80.0, 90.01];

/// Mean error by band, whole-mask mean, median, share above 2° and Spearman's rank
/// correlation between confidence and error.
#[derive(Debug)]
pub struct Score {
    pub bands: [f64; 4],
    pub counts: [usize; 4],
    pub mean: f64,
    pub median: f64,
    pub over2: f64,
    pub spearman: f64,
}

pub fn score(out: &Output, truth: &NormalMap, mask: &Mask) -> Score {
    let (mut sums, mut counts) = ([0.0; 4], [0usize; 4]);
    let (mut errs, mut conf) = (Vec::new(), Vec::new());
    for i in 0..mask.data.len() {
        if !mask.data[i] {
            continue;
        }
        let t = truth.data[i];
        let e = angle_deg(out.normals.data[i], t);
        let tilt = (t[2] as f64).clamp(-1.0, 1.0).acos().to_degrees();
        let b = BANDS.iter().position(|&hi| tilt < hi).unwrap_or(3);
        sums[b] += e;
        counts[b] += 1;
        errs.push(e);
        conf.push(out.confidence.data[i] as f64);
    }
    let n = errs.len().max(1) as f64;
    let mean = errs.iter().sum::<f64>() / n;
    let over2 = errs.iter().filter(|&&e| e > 2.0).count() as f64 / n;
    let spearman = spearman(&conf, &errs);
    let mut sorted = errs.clone();
    sorted.sort_by(f64::total_cmp);
    Score {
        bands: std::array::from_fn(|b| sums[b] / counts[b].max(1) as f64),
        counts,
        mean,
        median: sorted.get(sorted.len() / 2).copied().unwrap_or(0.0),
        over2,
        spearman,
    }
}

/// Ranks with ties averaged.
pub fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
            j += 1;
        }
        for &k in &idx[i..=j] {
            r[k] = (i + j) as f64 / 2.0;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation (Pearson's on the ranks).
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let (ra, rb) = (ranks(a), ranks(b));
    let n = ra.len() as f64;
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

pub fn print(name: &str, s: &Score) {
    println!(
        "{name:<40} mean {:.3}° median {:.3}° >2°: {:.2}%  bands 0-60 {:.3}° | 60-75 {:.3}° | 75-80 {:.3}° | 80-90 {:.3}° (px {:?})  spearman(conf, err) {:+.2}",
        s.mean, s.median, 100.0 * s.over2, s.bands[0], s.bands[1], s.bands[2], s.bands[3], s.counts, s.spearman
    );
}
