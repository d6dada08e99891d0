//! Search index over the table entries: principal components + a KD-tree.
//!
//! The K-dimensional tuples of a sphere lie on a 2-D surface (parameterised by the
//! normal), so a few principal components hold nearly all of their spread. The index
//! projects the tuples onto the top `d` components (d ≤ 8, chosen at run time) and
//! stores them in a KD-tree with small leaf buckets (split on the widest axis at the
//! median). A query returns the `m` nearest entries in that space; the caller re-ranks
//! them on the full K-dimensional distance. Queries can be *seeded* with entries known
//! to be close (e.g. the match of the neighbouring pixel): the seeds tighten the
//! search radius from the start, while the answer stays the exact m nearest.

mod build;

use build::{build_node, principal_axes, Node};
use rayon::prelude::*;

/// Largest number of candidates one query returns.
pub const MAX_CANDIDATES: usize = 16;
/// Stored width of a projected point (the largest `d`).
const PAD: usize = 8;
/// Rounding tolerance of a distance from the principal subspace, relative to the
/// distance of the point from the mean (f32 sums of K products, axes orthonormal to
/// about 1e-7).
const OFF_TOLERANCE: f32 = 1e-5;

/// A projected query zero-padded to [`PAD`] values.
#[inline]
fn padded(q: &[f32]) -> [f32; PAD] {
    let mut out = [0.0; PAD];
    out[..q.len()].copy_from_slice(q);
    out
}

/// PCA projection + KD-tree over a set of K-dimensional points.
#[derive(Clone, Debug)]
pub struct Index {
    k: usize,
    d: usize,
    mean: Vec<f32>,
    /// Principal axes, transposed: K rows of 8 (the d axes' components, zero-padded).
    axes: Vec<f32>,
    /// Projected points in tree order, [`PAD`] per point (zeros beyond `d`: the
    /// distances run on fixed-width blocks that the compiler vectorises).
    coords: Vec<f32>,
    /// Distance of each point (tree order) from the principal subspace through the mean.
    off: Vec<f32>,
    /// Rounding tolerance of those distances (a bound for the largest).
    off_tol: f32,
    /// Entry id of each point in tree order.
    ids: Vec<u32>,
    /// Position in tree order of each entry id (`u32::MAX` when not indexed).
    slot: Vec<u32>,
    nodes: Vec<Node>,
}

/// State of the branch and bound of [`Index::least`].
struct Bound<R, C> {
    best: f32,
    id: u32,
    /// Squared search radius, `reach(best)`.
    r2: f32,
    /// The query's distance from the principal subspace and the tolerance of the gaps.
    off: f32,
    tol: f32,
    reach: R,
    cost: C,
}

/// The best candidates of a query, nearest first.
#[derive(Clone, Copy, Debug)]
pub struct Candidates {
    /// Squared distances in projected space.
    pub dist: [f32; MAX_CANDIDATES],
    /// Entry ids.
    pub ids: [u32; MAX_CANDIDATES],
    /// Number of valid candidates.
    pub len: usize,
    cap: usize,
}

impl Candidates {
    fn new(cap: usize) -> Self {
        Candidates {
            dist: [f32::INFINITY; MAX_CANDIDATES],
            ids: [u32::MAX; MAX_CANDIDATES],
            len: 0,
            cap: cap.clamp(1, MAX_CANDIDATES),
        }
    }

    #[inline]
    fn worst(&self) -> f32 {
        if self.len < self.cap {
            f32::INFINITY
        } else {
            self.dist[self.len - 1]
        }
    }

    #[inline]
    fn push(&mut self, d: f32, id: u32) {
        if d >= self.worst() || self.ids[..self.len].contains(&id) {
            return;
        }
        let mut i = self.len.min(self.cap - 1);
        while i > 0 && self.dist[i - 1] > d {
            self.dist[i] = self.dist[i - 1];
            self.ids[i] = self.ids[i - 1];
            i -= 1;
        }
        self.dist[i] = d;
        self.ids[i] = id;
        self.len = (self.len + 1).min(self.cap);
    }
}

impl Index {
    /// Index `points` (n × k, point-major), keeping only those with `keep[i]`, on the top
    /// `dims` principal components (`dims` is clamped to 1..=min(k, 8)).
    pub fn build(points: &[f32], k: usize, keep: &[bool], dims: usize) -> Index {
        let n = keep.len();
        let d = dims.clamp(1, k.min(8));
        let (mean, axes) = principal_axes(points, k, keep, d);
        let mut ids: Vec<u32> = (0..n as u32).filter(|&i| keep[i as usize]).collect();
        let mut proj = vec![0.0f32; n * d];
        // each point's distance from the principal subspace, and its distance from the mean
        let mut off = vec![(0.0f32, 0.0f32); n];
        proj.par_chunks_mut(d * 1024)
            .zip(off.par_chunks_mut(1024))
            .zip(points.par_chunks(k * 1024))
            .zip(keep.par_chunks(1024))
            .for_each(|(((out, offs), pts), kp)| {
                for (((o, f), p), _) in out
                    .chunks_exact_mut(d)
                    .zip(offs)
                    .zip(pts.chunks_exact(k))
                    .zip(kp)
                    .filter(|(_, &kept)| kept)
                {
                    project_into(p, &mean, &axes, o);
                    *f = off_subspace(p, &mean, &axes, o);
                }
            });
        let mut nodes = Vec::new();
        build_node(&mut ids, &proj, d, &mut nodes);
        let mut coords = vec![0.0; ids.len() * PAD];
        let mut slot = vec![u32::MAX; n];
        let mut offs = vec![0.0; ids.len()];
        let mut spread = 0.0f32;
        for (pos, &i) in ids.iter().enumerate() {
            coords[pos * PAD..pos * PAD + d]
                .copy_from_slice(&proj[i as usize * d..(i as usize + 1) * d]);
            slot[i as usize] = pos as u32;
            offs[pos] = off[i as usize].0;
            spread = spread.max(off[i as usize].1);
        }
        Index {
            k,
            d,
            mean,
            axes,
            coords,
            off: offs,
            off_tol: OFF_TOLERANCE * spread,
            ids,
            slot,
            nodes,
        }
    }

    /// Distance of a K-tuple from the principal subspace (through the mean) and the
    /// rounding tolerance of that figure: see [`Index::least`].
    pub fn off_subspace(&self, tuple: &[f32]) -> (f32, f32) {
        let mut p = [0.0f32; PAD];
        project_into(tuple, &self.mean, &self.axes, &mut p[..self.d]);
        let (off, from_mean) = off_subspace(tuple, &self.mean, &self.axes, &p[..self.d]);
        (off, OFF_TOLERANCE * from_mean)
    }

    /// Number of projected dimensions.
    pub fn dims(&self) -> usize {
        self.d
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when nothing is indexed.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Project a K-tuple onto the principal axes (`out` has `dims()` values).
    #[inline]
    pub fn project(&self, tuple: &[f32], out: &mut [f32]) {
        project_into(tuple, &self.mean, &self.axes, out);
    }

    /// The `m` indexed points nearest to the projected query `q`; `seeds` are entry ids
    /// tried first (they only speed the search up).
    pub fn nearest(&self, q: &[f32], m: usize, seeds: &[u32]) -> Candidates {
        let q = &padded(q);
        let mut best = Candidates::new(m);
        for &s in seeds {
            if let Some(&pos) = self.slot.get(s as usize) {
                if pos != u32::MAX {
                    best.push(self.dist_at(pos as usize, q), s);
                }
            }
        }
        if !self.nodes.is_empty() {
            self.search(0, q, &mut best);
        }
        best
    }

    /// The indexed point nearest to the projected query `q` among those `accept` takes,
    /// as (squared distance, entry id); (∞, `u32::MAX`) when it takes none. Exact: the
    /// points refused are skipped, not counted as neighbours. `seeds` are entry ids
    /// tried first (those `accept` takes tighten the search from the start; they only
    /// speed it up).
    pub fn nearest_where(
        &self,
        q: &[f32],
        seeds: impl IntoIterator<Item = u32>,
        accept: impl Fn(u32) -> bool,
    ) -> (f32, u32) {
        let q = &padded(q);
        let mut best = (f32::INFINITY, u32::MAX);
        for s in seeds {
            if let Some(&pos) = self.slot.get(s as usize) {
                if pos != u32::MAX {
                    let dist = self.dist_at(pos as usize, q);
                    if dist < best.0 && accept(s) {
                        best = (dist, s);
                    }
                }
            }
        }
        if !self.nodes.is_empty() {
            self.search_where(0, q, &accept, &mut best);
        }
        best
    }

    fn search_where(
        &self,
        node: usize,
        q: &[f32; PAD],
        accept: &impl Fn(u32) -> bool,
        best: &mut (f32, u32),
    ) {
        match self.nodes[node] {
            Node::Leaf { start, end } => {
                for pos in start as usize..end as usize {
                    let dist = self.dist_at(pos, q);
                    if dist < best.0 && accept(self.ids[pos]) {
                        *best = (dist, self.ids[pos]);
                    }
                }
            }
            Node::Split { dim, value, right } => {
                let (near, far, plane2) = Self::sides(node, dim, value, right, q);
                self.search_where(near, q, accept, best);
                if plane2 < best.0 {
                    self.search_where(far, q, accept, best);
                }
            }
        }
    }

    /// Branch and bound for the indexed entry of least full cost below `best`: `cost(id)`
    /// is the caller's cost of entry `id`, and `reach(b)` the squared distance (in the
    /// full K-dimensional space) from the query beyond which no entry can cost less than
    /// b (from the caller's lower bound of the cost by that distance); `q` is the
    /// query's projection and `q_off` its [`Index::off_subspace`]. The tree is pruned on
    /// projected distances; an entry's full distance is bounded from below by
    /// d² + (|off(q) − off(e)| − tolerances)² (the projection is orthogonal: the squared
    /// full distance is the projected one plus that of the parts off the subspace, whose
    /// lengths differ by at least that gap), and the entry is costed only when that
    /// bound lies within the radius. Returns the best entry found as (cost, id),
    /// id `u32::MAX` when none costs less than `best`, or `None` when the ball of radius
    /// reach(`best`) around `q` meets more than `budget` leaves (then nothing is known).
    /// Those leaves are counted first, without a cost (the search visits at most them,
    /// since its radius only shrinks): a search over its budget costs no entry at all.
    pub fn least(
        &self,
        q: &[f32],
        q_off: (f32, f32),
        best: f32,
        reach: impl Fn(f32) -> f32,
        cost: impl FnMut(u32) -> f32,
        budget: usize,
    ) -> Option<(f32, u32)> {
        let q = &padded(q);
        let r2 = reach(best);
        if !self.nodes.is_empty() && self.leaves_within(0, q, r2, budget).is_none() {
            return None;
        }
        let mut b = Bound {
            best,
            id: u32::MAX,
            r2,
            off: q_off.0,
            tol: q_off.1 + self.off_tol,
            reach,
            cost,
        };
        if !self.nodes.is_empty() {
            self.search_least(0, q, &mut b);
        }
        Some((b.best, b.id))
    }

    /// Leaves below `node` that the depth-first search of a ball of squared radius `r2`
    /// around `q` visits, `None` when more than `budget`; the remaining budget otherwise.
    fn leaves_within(&self, node: usize, q: &[f32; PAD], r2: f32, budget: usize) -> Option<usize> {
        match self.nodes[node] {
            Node::Leaf { .. } => budget.checked_sub(1),
            Node::Split { dim, value, right } => {
                let (near, far, plane2) = Self::sides(node, dim, value, right, q);
                let left = self.leaves_within(near, q, r2, budget)?;
                if plane2 < r2 {
                    self.leaves_within(far, q, r2, left)
                } else {
                    Some(left)
                }
            }
        }
    }

    /// [`Index::least`] below `node`.
    fn search_least<R, C>(&self, node: usize, q: &[f32; PAD], b: &mut Bound<R, C>)
    where
        R: Fn(f32) -> f32,
        C: FnMut(u32) -> f32,
    {
        match self.nodes[node] {
            Node::Leaf { start, end } => {
                for pos in start as usize..end as usize {
                    let gap = ((b.off - self.off[pos]).abs() - b.tol).max(0.0);
                    if self.dist_at(pos, q) + gap * gap < b.r2 {
                        let id = self.ids[pos];
                        let c = (b.cost)(id);
                        if c < b.best {
                            (b.best, b.id, b.r2) = (c, id, (b.reach)(c));
                        }
                    }
                }
            }
            Node::Split { dim, value, right } => {
                let (near, far, plane2) = Self::sides(node, dim, value, right, q);
                self.search_least(near, q, b);
                if plane2 < b.r2 {
                    self.search_least(far, q, b);
                }
            }
        }
    }

    /// Projected coordinates of entry `id` (`None` when it is not indexed).
    pub fn point(&self, id: u32) -> Option<&[f32]> {
        match self.slot.get(id as usize) {
            Some(&pos) if pos != u32::MAX => {
                Some(&self.coords[pos as usize * PAD..pos as usize * PAD + self.d])
            }
            _ => None,
        }
    }

    /// Squared projected distance from the projected query `q` to entry `id` (infinite
    /// when the entry is not indexed).
    #[inline]
    pub fn distance(&self, q: &[f32], id: u32) -> f32 {
        match self.slot.get(id as usize) {
            Some(&pos) if pos != u32::MAX => self.dist_at(pos as usize, &padded(q)),
            _ => f32::INFINITY,
        }
    }

    /// The children of split node `node` at (`dim`, `value`, `right`) nearer to and
    /// farther from `q`, and the squared distance from `q` to the split plane.
    #[inline]
    fn sides(node: usize, dim: u16, value: f32, right: u32, q: &[f32; PAD]) -> (usize, usize, f32) {
        let diff = q[dim as usize] - value;
        if diff < 0.0 {
            (node + 1, right as usize, diff * diff)
        } else {
            (right as usize, node + 1, diff * diff)
        }
    }

    #[inline]
    fn dist_at(&self, pos: usize, q: &[f32; PAD]) -> f32 {
        let p = &self.coords[pos * PAD..(pos + 1) * PAD];
        let mut acc = [0.0f32; PAD];
        for ((a, x), y) in acc.iter_mut().zip(p).zip(q) {
            *a = (x - y) * (x - y);
        }
        (acc[0] + acc[4]) + (acc[1] + acc[5]) + ((acc[2] + acc[6]) + (acc[3] + acc[7]))
    }

    fn search(&self, node: usize, q: &[f32; PAD], best: &mut Candidates) {
        match self.nodes[node] {
            Node::Leaf { start, end } => {
                for pos in start as usize..end as usize {
                    let dist = self.dist_at(pos, q);
                    if dist < best.worst() {
                        best.push(dist, self.ids[pos]);
                    }
                }
            }
            Node::Split { dim, value, right } => {
                let (near, far, plane2) = Self::sides(node, dim, value, right, q);
                self.search(near, q, best);
                if plane2 < best.worst() {
                    self.search(far, q, best);
                }
            }
        }
    }

    /// Dimension of the indexed tuples.
    pub fn k(&self) -> usize {
        self.k
    }
}

/// out = Aᵀ(tuple − mean) with `axes` transposed (K rows of 8; see [`Index`]).
fn project_into(tuple: &[f32], mean: &[f32], axes: &[f32], out: &mut [f32]) {
    let mut acc = [0.0f32; 8];
    for ((t, m), row) in tuple.iter().zip(mean).zip(axes.chunks_exact(8)) {
        let c = t - m;
        for (a, r) in acc.iter_mut().zip(row) {
            *a += c * r;
        }
    }
    let d = out.len();
    out.copy_from_slice(&acc[..d]);
}

/// (‖(I − AAᵀ)(tuple − mean)‖, ‖tuple − mean‖) with `p` = Aᵀ(tuple − mean): the
/// distance from the principal subspace through the mean (computed from the residual
/// itself, not as a difference of squares), and from the mean.
fn off_subspace(tuple: &[f32], mean: &[f32], axes: &[f32], p: &[f32]) -> (f32, f32) {
    let (mut off, mut all) = (0.0f32, 0.0f32);
    for ((t, m), row) in tuple.iter().zip(mean).zip(axes.chunks_exact(8)) {
        let c = t - m;
        let along: f32 = row.iter().zip(p).map(|(a, x)| a * x).sum();
        off += (c - along) * (c - along);
        all += c * c;
    }
    (off.sqrt(), all.sqrt())
}

#[cfg(test)]
mod tests {
    use super::build::jacobi_eigen;
    use super::*;

    /// Dimensions of [`twisted_surface`]'s points.
    const TWISTED_K: usize = 5;

    /// 40 × 40 points on a twisted 2-D surface in 5-D (flattened).
    fn twisted_surface() -> Vec<f32> {
        let mut pts = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let (u, v) = (i as f32 / 10.0, j as f32 / 10.0);
                pts.extend_from_slice(&[u, v, (u * v).sin(), u * u - v, (u + 2.0 * v).cos()]);
            }
        }
        pts
    }

    /// Squared distance in full K from `query` to point `e` of `pts`.
    fn full_distance(pts: &[f32], query: &[f32], e: u32) -> f32 {
        let k = query.len();
        let p = &pts[e as usize * k..(e as usize + 1) * k];
        p.iter().zip(query).map(|(a, b)| (a - b) * (a - b)).sum()
    }

    #[test]
    fn jacobi_diagonalises_a_symmetric_matrix() {
        let a = vec![4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 1.0];
        let (vals, vecs) = jacobi_eigen(a.clone(), 3);
        for j in 0..3 {
            for i in 0..3 {
                let av: f64 = (0..3).map(|m| a[i * 3 + m] * vecs[m * 3 + j]).sum();
                assert!((av - vals[j] * vecs[i * 3 + j]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn kd_tree_returns_the_exact_nearest_points() {
        // points on a twisted 2-D surface in 5-D, queries off the surface
        let (pts, k) = (twisted_surface(), TWISTED_K);
        let n = pts.len() / k;
        let idx = Index::build(&pts, k, &vec![true; n], 5);
        let mut q = vec![0.0; 5];
        for t in 0..50 {
            let query = [t as f32 * 0.07, 3.0 - t as f32 * 0.05, 0.3, 1.0, -0.2];
            idx.project(&query, &mut q);
            let got = idx.nearest(&q, 3, &[7, 100]);
            let full = |e: u32| full_distance(&pts, &query, e);
            let mut all: Vec<(f32, u32)> = (0..n as u32).map(|e| (full(e), e)).collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0));
            assert_eq!(got.len, 3);
            // the nearest point with an odd id, against brute force
            let (d, id) = idx.nearest_where(&q, [], |e| e % 2 == 1);
            let want = all.iter().find(|(_, e)| e % 2 == 1).unwrap();
            assert_eq!(id % 2, 1);
            // branch and bound on the full distance (projected distance ≤ full: exact)
            let (c, e) = idx
                .least(
                    &q,
                    idx.off_subspace(&query),
                    f32::INFINITY,
                    |b| b,
                    full,
                    usize::MAX,
                )
                .unwrap();
            assert_eq!(e, all[0].1);
            assert!((c - all[0].0).abs() < 1e-5);
            let (_, none) = idx
                .least(
                    &q,
                    idx.off_subspace(&query),
                    all[0].0 * 0.99,
                    |b| b,
                    full,
                    usize::MAX,
                )
                .unwrap();
            assert_eq!(none, u32::MAX);
            assert!(idx
                .least(&q, idx.off_subspace(&query), f32::INFINITY, |b| b, full, 1)
                .is_none());
            assert!((d - want.0).abs() < 1e-3 * (1.0 + want.0));
            // seeds (taken or refused) change nothing
            let seeded = idx.nearest_where(&q, [3, 8, 101, t * 31], |e| e % 2 == 1);
            assert_eq!(seeded, (d, id));
            for (c, want) in all.iter().take(3).enumerate() {
                assert!((got.dist[c] - want.0).abs() < 1e-3 * (1.0 + want.0));
            }
        }
    }

    #[test]
    fn branch_and_bound_is_exact_on_two_components() {
        // the twisted surface of the test above, indexed on 2 of its 5 dimensions: the
        // gap between distances from the subspace must bound the full distance, and the
        // branch and bound stay exact while costing fewer entries than the projection
        // alone would let through
        let (pts, k) = (twisted_surface(), TWISTED_K);
        let n = pts.len() / k;
        let idx = Index::build(&pts, k, &vec![true; n], 2);
        let (mut costed, mut within) = (0, 0);
        let mut q = vec![0.0; 2];
        for t in 0..50 {
            let query = [t as f32 * 0.07, 3.0 - t as f32 * 0.05, 0.3, 1.0, -0.2];
            idx.project(&query, &mut q);
            let (off, tol) = idx.off_subspace(&query);
            let mut best = (f32::INFINITY, 0u32);
            for e in 0..n as u32 {
                let p = &pts[e as usize * k..(e as usize + 1) * k];
                let (off_e, tol_e) = idx.off_subspace(p);
                let gap = ((off - off_e).abs() - tol - tol_e).max(0.0);
                let d = idx.distance(&q, e);
                let c = full_distance(&pts, &query, e);
                assert!(
                    d + gap * gap <= c * (1.0 + 1e-5) + 1e-6,
                    "{d} + {gap}² > {c}"
                );
                if c < best.0 {
                    best = (c, e);
                }
            }
            // a radius that lets a few hundred entries through the projection
            let r2 = best.0 * 1.5 + 0.05;
            within += (0..n as u32).filter(|&e| idx.distance(&q, e) < r2).count();
            let cost = |e: u32| {
                costed += 1;
                full_distance(&pts, &query, e)
            };
            let (c, e) = idx
                .least(&q, (off, tol), r2, |b| b, cost, usize::MAX)
                .unwrap();
            assert_eq!((c, e), best);
        }
        // measured: 4715 of the 9896 entries within the projected radius are costed (the
        // radius also shrinks as better entries are found)
        assert!(costed * 4 < within * 3, "{costed} of {within} costed");
    }
}
