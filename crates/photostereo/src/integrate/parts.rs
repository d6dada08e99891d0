//! Placing the separate parts of a mask relative to each other.
//!
//! Normals give depth up to one constant per 4-connected part of the mask (with a camera:
//! one constant of v = f_x ln t, i.e. one scale of the distance t per part). Nothing in
//! the normals measures how far apart two parts are, so every rule here is an
//! assumption about the scene; [`Parts`] names them and says when each holds.
//!
//! # Occluding contours at a common depth ([`Parts::Contour`])
//!
//! Where the mask's outline is an occluding contour, the surface turns away from the
//! viewer: s = |n·d̂| → 0, with d̂ the unit viewing ray of the pixel (orthographic:
//! s = n_z). For a body of revolution whose axis is parallel to the image plane (a
//! goblet's cup and foot, a vase, a bottle) the occluding contour is the meridian
//! section through the axis, so every part's contour lies at the depth of the axis
//! (orthographic exactly; through a pinhole, a sphere of radius R at distance D has its
//! contour R²/D nearer than its centre, 1 mm for R = 40 mm at D = 1.5 m).
//!
//! The pixel centres next to the outline are not on the contour: a surface whose normal
//! section has radius of curvature ρ there stands about ρ·s in front of its contour
//! (z − z_c = ρ n_z exactly on a sphere or cylinder seen orthographically): a pixel
//! centre half a pixel inside the outline of a 50 px sphere has s ≈ 0.14 and stands
//! 7 px in front. So each outline pixel i with s_i < [`CONTOUR_SLANT`] (an outline
//! pixel is a mask pixel with a 4-neighbour outside the mask; the image border does not
//! count) is extrapolated to s = 0 along the mask's inward direction: with the next two
//! pixels inward, while s grows by more than [`MIN_TURN`] per step (the surface turns
//! toward the viewer inward, as at a convex occluding contour), the polynomial z(s)
//! through the [`CONTOUR_POINTS`] points (s, z) is evaluated at s = 0 (quadratic;
//! linear with two points). Quadratic, because a flat part (a goblet's foot seen edge
//! on) curves away sharply within the last pixel: its z(s) is far from linear over the
//! outline pixels once the mask lies a pixel inside the silhouette, as DiLiGenT's masks
//! do (median n_z of the outline pixels 0.29 on bear, 0.41 on harvest). A part's
//! contour level is the median of these estimates; every part is shifted so that its
//! level is the common one. A part with fewer than [`MIN_CONTOUR`] estimates (no
//! occluding contour in view, a speck) gets the median depth of the placed parts.
//!
//! # Continuity across the narrowest gap ([`Parts::Gap`])
//!
//! The parts are joined by a minimum spanning tree over their gaps: the nearest pair of
//! outline pixels between each pair of parts that face each other across the background
//! (found by a breadth-first search through the background from every outline pixel, an
//! approximate Voronoi diagram, O(pixels)); along the tree, the two ends of each gap are
//! put at the same depth. Parts of fewer than [`GAP_MIN_PIXELS`] pixels (specks) are
//! left out of the search and the tree and get the median depth of the joined parts.
//! This holds where a thin connection of constant depth was cut
//! out of the mask (a stem of constant radius, a wire, a strip masked by a specular
//! highlight); it fails where the gap is a true depth jump.
//!
//! # Equal median depth ([`Parts::Median`]) and separate parts ([`Parts::Separate`])
//!
//! Every part gets the same median (or mean) depth: right for parts of similar size at
//! the same distance, wrong by about the difference of their half-thicknesses otherwise.
//!
//! # Measured (`tests/integrate_parts.rs`, README "Disconnected parts")
//!
//! On a synthetic goblet (cup and foot separate, 1.5 m from a pinhole), MADE after the
//! median scale with BiNI, perspective / orthographic: separate 0.816 / 0.781 mm,
//! median 0.887 / 0.789, contour 0.224 / 0.267, gap 0.236 / 0.333 (lsq: contour
//! 0.220 / 0.107); with the mask eroded by a pixel (DiLiGenT-like outlines) separate
//! 0.586, contour 0.191, gap 0.244; with noisy normals (σ 0.05) separate 0.877,
//! contour 0.132, gap 0.279. Hence [`Parts::Contour`] is the default. Variants measured
//! and left out (BiNI, perspective): the linear extrapolation (two points) gives 0.060
//! as rendered but 0.339 eroded and 0.230 noisy; skipping pixels with s < 0.1 before
//! the quadratic fit 0.136 / 0.191 / 0.340; no extrapolation (the median of the
//! outline pixels' own depths) 0.159 as rendered. Extrapolating each end of a gap with
//! its own gradient before matching gives 0.071 perspective but 2.29 mm orthographic
//! (0.063 / 2.51 lsq): the gradients at a cut-out stem are the steep, clamped ones of
//! the cup's bottom and the foot's top (slopes 9 and 31 on this goblet), which cancel by
//! chance under the perspective clamp of 10 and not under the orthographic clamp of 20.
//! On a goblet tilted 25° toward the camera or two spheres 100 mm apart in depth every
//! rule is 5–50 mm off: no rule measures a depth difference that the normals do not
//! contain.

use super::support::Components;
use crate::image::Mask;
use std::collections::{HashMap, VecDeque};

/// How separate (4-connected) parts of the mask are placed relative to each other
/// (module `parts` of [`crate::integrate`] states the assumptions).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Parts {
    /// Each part on its own: mean depth 0 (orthographic) or geometric-mean distance f_x
    /// (camera) per part, the behaviour before this option existed. Equal mean depth.
    Separate,
    /// Equal median depth of every part.
    Median,
    /// The occluding contours of all parts at a common depth (default): exact for
    /// bodies of revolution about an axis parallel to the image plane, seen
    /// orthographically; wrong by the true depth difference for parts at different
    /// distances.
    #[default]
    Contour,
    /// Equal depth across the narrowest gap between parts (a cut-out thin connection).
    Gap,
}

impl Parts {
    /// Command-line name (`separate`, `median`, `contour`, `gap`).
    pub fn name(&self) -> &'static str {
        match self {
            Parts::Separate => "separate",
            Parts::Median => "median",
            Parts::Contour => "contour",
            Parts::Gap => "gap",
        }
    }

    /// Parse a name produced by [`Parts::name`].
    pub fn from_name(name: &str) -> crate::error::Result<Self> {
        Ok(match name {
            "separate" => Parts::Separate,
            "median" => Parts::Median,
            "contour" => Parts::Contour,
            "gap" => Parts::Gap,
            other => {
                return Err(crate::error::Error::invalid(
                    format!("part placement `{other}`"),
                    "use one of contour, gap, median, separate",
                ))
            }
        })
    }
}

/// Largest s = |n·d̂| of an outline pixel taken as on an occluding contour.
pub const CONTOUR_SLANT: f64 = 0.5;
/// Smallest increase of s from an outline pixel to its inward neighbour for the
/// extrapolation to the contour.
pub const MIN_TURN: f64 = 0.02;
/// Pixels along the inward direction used to extrapolate to the contour (2: linear,
/// 3: quadratic in s).
const CONTOUR_POINTS: usize = 3;
/// Fewest pixels of a part joined by [`Parts::Gap`] (smaller ones, specks, are placed at
/// the median depth of the joined parts).
pub const GAP_MIN_PIXELS: usize = 25;
/// Fewest contour estimates for a part to be placed by its contour.
pub const MIN_CONTOUR: usize = 5;

/// What the rules need besides the depth: per mask pixel, s = |n·d̂|.
pub(crate) struct Cues<'a> {
    pub slant: &'a dyn Fn(usize) -> f64,
}

/// The offset to add to each part of `z` under `rule` (before any global centring).
pub(crate) fn offsets(
    rule: Parts,
    z: &[f32],
    comps: &Components,
    mask: &Mask,
    cues: &Cues,
) -> Vec<f64> {
    let k = comps.count;
    let mut per_part: Vec<Vec<f64>> = vec![Vec::new(); k];
    for (i, &l) in comps.labels.iter().enumerate() {
        if l != u32::MAX {
            per_part[l as usize].push(z[i] as f64);
        }
    }
    let means: Vec<f64> = per_part
        .iter()
        .map(|v| v.iter().sum::<f64>() / v.len().max(1) as f64)
        .collect();
    let medians: Vec<f64> = per_part.iter_mut().map(|v| median(v)).collect();
    match rule {
        Parts::Separate => means.iter().map(|m| -m).collect(),
        Parts::Median => medians.iter().map(|m| -m).collect(),
        Parts::Contour => {
            let levels = contour_levels(z, comps, mask, cues.slant);
            place_or_median(levels, &medians, &per_part)
        }
        Parts::Gap => {
            let usable: Vec<bool> = per_part.iter().map(|v| v.len() >= GAP_MIN_PIXELS).collect();
            let levels = gap_levels(z, comps, mask, &medians, &usable);
            place_or_median(levels, &medians, &per_part)
        }
    }
}

/// `z` with `offsets` added per part, then shifted to mean 0 over the whole mask; NaN
/// outside the mask.
pub(crate) fn apply(z: &[f32], comps: &Components, offsets: &[f64], mask: &Mask) -> Vec<f32> {
    let mut out: Vec<f64> = z
        .iter()
        .zip(&comps.labels)
        .map(|(&v, &l)| match l {
            u32::MAX => f64::NAN,
            l => v as f64 + offsets[l as usize],
        })
        .collect();
    let n = mask.data.iter().filter(|&&m| m).count().max(1);
    let mean = out.iter().filter(|v| !v.is_nan()).sum::<f64>() / n as f64;
    out.iter_mut().for_each(|v| *v -= mean);
    out.into_iter().map(|v| v as f32).collect()
}

/// Median of a slice (reorders it); 0 for an empty one.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let m = v.len() / 2;
    *v.select_nth_unstable_by(m, f64::total_cmp).1
}

/// Offsets that put every part's level at 0; parts without a level get the median
/// depth of the placed parts.
fn place_or_median(levels: Vec<Option<f64>>, medians: &[f64], values: &[Vec<f64>]) -> Vec<f64> {
    let mut off: Vec<Option<f64>> = levels.iter().map(|l| l.map(|v| -v)).collect();
    if off.iter().all(Option::is_none) {
        return medians.iter().map(|m| -m).collect();
    }
    let mut placed: Vec<f64> = values
        .iter()
        .zip(&off)
        .filter_map(|(v, o)| o.map(|o| v.iter().map(move |x| x + o)))
        .flatten()
        .collect();
    let target = median(&mut placed);
    for (o, m) in off.iter_mut().zip(medians) {
        o.get_or_insert(target - m);
    }
    off.into_iter().map(|o| o.unwrap_or(0.0)).collect()
}

/// The 8 neighbour steps (dr, dc).
const STEPS: [(isize, isize); 8] = [
    (-1, -1),
    (-1, 0),
    (-1, 1),
    (0, -1),
    (0, 1),
    (1, -1),
    (1, 0),
    (1, 1),
];

/// Pixel at (r + dr, c + dc) if inside the grid.
fn step(w: usize, h: usize, i: usize, (dr, dc): (isize, isize)) -> Option<usize> {
    let (r, c) = ((i / w) as isize + dr, (i % w) as isize + dc);
    (r >= 0 && c >= 0 && (r as usize) < h && (c as usize) < w).then(|| r as usize * w + c as usize)
}

/// The inward step of an outline pixel (the opposite of the sum of the steps to its
/// 8 neighbours outside the mask, by sign), or `None` if no 4-neighbour inside the grid
/// is outside the mask (interior pixel, or only the image border).
fn inward(mask: &Mask, i: usize) -> Option<(isize, isize)> {
    let (w, h) = (mask.width, mask.height);
    let four_out = [(-1, 0), (1, 0), (0, -1), (0, 1)]
        .iter()
        .any(|&s| step(w, h, i, s).is_some_and(|j| !mask.data[j]));
    if !four_out {
        return None;
    }
    let (mut sr, mut sc) = (0isize, 0isize);
    for s in STEPS {
        if step(w, h, i, s).is_some_and(|j| !mask.data[j]) {
            sr += s.0;
            sc += s.1;
        }
    }
    Some((-sr.signum(), -sc.signum())).filter(|&s| s != (0, 0))
}

/// Per part: the median depth of its occluding contour extrapolated to s = 0, or
/// `None` with fewer than [`MIN_CONTOUR`] estimates.
fn contour_levels(
    z: &[f32],
    comps: &Components,
    mask: &Mask,
    slant: &dyn Fn(usize) -> f64,
) -> Vec<Option<f64>> {
    let (w, h) = (mask.width, mask.height);
    let mut est: Vec<Vec<f64>> = vec![Vec::new(); comps.count];
    for i in (0..w * h).filter(|&i| mask.data[i]) {
        let si = slant(i);
        if si >= CONTOUR_SLANT {
            continue;
        }
        let Some(dir) = inward(mask, i) else {
            continue;
        };
        let l = comps.labels[i];
        // The outline pixel and up to two more inward, while s keeps growing.
        let mut pts = vec![(si, z[i] as f64)];
        let mut at = i;
        while pts.len() < CONTOUR_POINTS {
            let Some(j) = step(w, h, at, dir).filter(|&j| comps.labels[j] == l) else {
                break;
            };
            let sj = slant(j);
            if sj - pts[pts.len() - 1].0 <= MIN_TURN {
                break;
            }
            pts.push((sj, z[j] as f64));
            at = j;
        }
        if pts.len() >= 2 {
            est[l as usize].push(extrapolate_to_zero(&pts));
        }
    }
    est.iter_mut()
        .map(|e| (e.len() >= MIN_CONTOUR).then(|| median(e)))
        .collect()
}

/// The value at s = 0 of the polynomial through the points (s, z) (Newton's divided
/// differences; distinct s).
fn extrapolate_to_zero(pts: &[(f64, f64)]) -> f64 {
    let n = pts.len();
    let mut coef: Vec<f64> = pts.iter().map(|p| p.1).collect();
    for k in 1..n {
        for m in (k..n).rev() {
            coef[m] = (coef[m] - coef[m - 1]) / (pts[m].0 - pts[m - k].0);
        }
    }
    let mut v = coef[n - 1];
    for m in (0..n - 1).rev() {
        v = v * (0.0 - pts[m].0) + coef[m];
    }
    v
}

/// Offsets from the minimum spanning tree of the gaps between parts (module docs).
/// Per part: the level (minus the offset) from the minimum spanning tree of the gaps
/// between `usable` parts; `None` for the others.
fn gap_levels(
    z: &[f32],
    comps: &Components,
    mask: &Mask,
    medians: &[f64],
    usable: &[bool],
) -> Vec<Option<f64>> {
    let k = comps.count;
    let mut links: Vec<(f64, usize, usize)> =
        gap_links(comps, mask, usable).into_values().collect();
    links.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Kruskal: join parts across the shortest gaps first.
    let mut root: Vec<usize> = (0..k).collect();
    fn find(root: &mut [usize], mut a: usize) -> usize {
        while root[a] != a {
            root[a] = root[root[a]];
            a = root[a];
        }
        a
    }
    let mut adj: Vec<Vec<(usize, f64)>> = vec![Vec::new(); k];
    for &(_, a, b) in &links {
        let (la, lb) = (comps.labels[a] as usize, comps.labels[b] as usize);
        let (ra, rb) = (find(&mut root, la), find(&mut root, lb));
        if ra != rb {
            root[ra] = rb;
            // z_b + off_b = z_a + off_a
            let d = z[a] as f64 - z[b] as f64;
            adj[la].push((lb, d));
            adj[lb].push((la, -d));
        }
    }
    // Walk each tree from its first part; unlinked parts keep their median at 0.
    let mut off: Vec<Option<f64>> = vec![None; k];
    for start in 0..k {
        if off[start].is_some() || !usable[start] {
            continue;
        }
        off[start] = Some(-medians[start]);
        let mut stack = vec![start];
        while let Some(a) = stack.pop() {
            let oa = off[a].unwrap_or(0.0);
            for &(b, d) in &adj[a] {
                if off[b].is_none() {
                    off[b] = Some(oa + d);
                    stack.push(b);
                }
            }
        }
    }
    off.into_iter().map(|o| o.map(|o| -o)).collect()
}

/// For each pair of parts that meet across the background: the squared distance and the
/// two outline pixels of their nearest pair found by a breadth-first search from all
/// outline pixels of the `usable` parts through the background (and the other parts).
fn gap_links(
    comps: &Components,
    mask: &Mask,
    usable: &[bool],
) -> HashMap<(u32, u32), (f64, usize, usize)> {
    let (w, h) = (mask.width, mask.height);
    let mut src = vec![usize::MAX; w * h];
    let mut queue = VecDeque::new();
    let source = |i: usize| mask.data[i] && usable[comps.labels[i] as usize];
    for i in (0..w * h).filter(|&i| source(i)) {
        src[i] = i;
        queue.push_back(i);
    }
    let dist2 = |a: usize, b: usize| {
        let (dr, dc) = (
            (a / w) as f64 - (b / w) as f64,
            (a % w) as f64 - (b % w) as f64,
        );
        dr * dr + dc * dc
    };
    let mut best: HashMap<(u32, u32), (f64, usize, usize)> = HashMap::new();
    while let Some(i) = queue.pop_front() {
        let si = src[i];
        for s in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
            let Some(j) = step(w, h, i, s) else { continue };
            let sj = src[j];
            if sj == usize::MAX {
                src[j] = si;
                queue.push_back(j);
                continue;
            }
            let (la, lb) = (comps.labels[si], comps.labels[sj]);
            if la == lb {
                continue;
            }
            let (key, pair) = if la < lb {
                ((la, lb), (si, sj))
            } else {
                ((lb, la), (sj, si))
            };
            let d = dist2(pair.0, pair.1);
            let e = best.entry(key).or_insert((f64::INFINITY, 0, 0));
            if d < e.0 {
                *e = (d, pair.0, pair.1);
            }
        }
    }
    best
}
