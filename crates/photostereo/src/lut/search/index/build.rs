//! Building the index: the principal axes of the entries (Jacobi eigen-decomposition of
//! their covariance) and the KD-tree over the projected points, larger subtrees on two
//! threads.

/// Largest number of points in a leaf bucket.
const LEAF: usize = 8;

/// A KD-tree node, stored depth-first with the left child right after its parent.
#[derive(Clone, Copy, Debug)]
pub(super) enum Node {
    Leaf { start: u32, end: u32 },
    Split { dim: u16, value: f32, right: u32 },
}

/// Build the subtree over `ids` (reordered in place); nodes are stored depth-first, the
/// left child right after its parent. Large subtrees are built in parallel.
pub(super) fn build_node(ids: &mut [u32], proj: &[f32], d: usize, nodes: &mut Vec<Node>) {
    build_par(ids, 0, proj, d, nodes);
}

/// Subtrees of more points than this are built on two threads.
const PAR_POINTS: usize = 4096;

fn build_par(ids: &mut [u32], offset: usize, proj: &[f32], d: usize, nodes: &mut Vec<Node>) {
    if ids.len() <= PAR_POINTS {
        return build_range(ids, offset, proj, d, nodes);
    }
    let (me, mid) = push_split(ids, proj, d, nodes);
    let (left, right) = ids.split_at_mut(mid);
    let (mut l, mut r) = (Vec::new(), Vec::new());
    rayon::join(
        || build_par(left, offset, proj, d, &mut l),
        || build_par(right, offset + mid, proj, d, &mut r),
    );
    append_shifted(nodes, l);
    link_right(nodes, me);
    append_shifted(nodes, r);
}

/// Split `ids` at the median of their widest axis and push the split node (its right
/// child still unset); returns the node's index and the split position.
fn push_split(ids: &mut [u32], proj: &[f32], d: usize, nodes: &mut Vec<Node>) -> (usize, usize) {
    let me = nodes.len();
    let (dim, value, mid) = split(ids, proj, d);
    nodes.push(Node::Split {
        dim: dim as u16,
        value,
        right: 0,
    });
    (me, mid)
}

/// Point split node `me` at the next node to be pushed (its right subtree).
fn link_right(nodes: &mut [Node], me: usize) {
    let right_index = nodes.len() as u32;
    if let Node::Split { right, .. } = &mut nodes[me] {
        *right = right_index;
    }
}

/// Append a subtree built on its own (node indices from 0) to `nodes`.
fn append_shifted(nodes: &mut Vec<Node>, sub: Vec<Node>) {
    let base = nodes.len() as u32;
    nodes.extend(sub.into_iter().map(|n| match n {
        Node::Split { dim, value, right } => Node::Split {
            dim,
            value,
            right: right + base,
        },
        leaf => leaf,
    }));
}

/// Split `ids` at the median of their widest dimension (measured on at most ~64
/// points): returns (dimension, value, index of the median); `ids` is partitioned.
fn split(ids: &mut [u32], proj: &[f32], d: usize) -> (usize, f32, usize) {
    let stride = (ids.len() / 32).max(1);
    let mut dim = 0;
    let mut widest = -1.0f32;
    for j in 0..d {
        let (lo, hi) =
            ids.iter()
                .step_by(stride)
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &i| {
                    let v = proj[i as usize * d + j];
                    (lo.min(v), hi.max(v))
                });
        if hi - lo > widest {
            widest = hi - lo;
            dim = j;
        }
    }
    // select the median on packed (order-preserving key, id) pairs: one gather, then
    // integer comparisons on contiguous memory
    let mut packed: Vec<u64> = ids
        .iter()
        .map(|&i| ((sortable(proj[i as usize * d + dim]) as u64) << 32) | i as u64)
        .collect();
    let mid = ids.len() / 2;
    packed.select_nth_unstable(mid);
    for (dst, p) in ids.iter_mut().zip(&packed) {
        *dst = *p as u32;
    }
    (dim, proj[ids[mid] as usize * d + dim], mid)
}

/// A u32 whose unsigned order is the total order of the f32 `v`.
#[inline]
fn sortable(v: f32) -> u32 {
    let b = v.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

fn build_range(ids: &mut [u32], offset: usize, proj: &[f32], d: usize, nodes: &mut Vec<Node>) {
    if ids.len() <= LEAF {
        nodes.push(Node::Leaf {
            start: offset as u32,
            end: (offset + ids.len()) as u32,
        });
        return;
    }
    let (me, mid) = push_split(ids, proj, d, nodes);
    let (left, right) = ids.split_at_mut(mid);
    build_range(left, offset, proj, d, nodes);
    link_right(nodes, me);
    build_range(right, offset + mid, proj, d, nodes);
}

/// Mean and top-`d` principal axes of the kept points, transposed (k rows of 8, the
/// unit axes in the first d columns).
pub(super) fn principal_axes(
    points: &[f32],
    k: usize,
    keep: &[bool],
    d: usize,
) -> (Vec<f32>, Vec<f32>) {
    // a regular subsample of at most ~4096 points fixes the axes well enough (the tree
    // is exact in whatever space it is given)
    let kept = keep.iter().filter(|&&kp| kp).count();
    let stride = (kept / 4096).max(1);
    let sub: Vec<bool> = keep
        .iter()
        .enumerate()
        .map(|(i, &kp)| kp && i % stride == 0)
        .collect();
    let keep = if sub.iter().any(|&kp| kp) { &sub } else { keep };
    let mut mean = vec![0.0f64; k];
    let mut count = 0.0f64;
    for (i, _) in keep.iter().enumerate().filter(|(_, &kp)| kp) {
        for (m, v) in mean.iter_mut().zip(&points[i * k..(i + 1) * k]) {
            *m += *v as f64;
        }
        count += 1.0;
    }
    mean.iter_mut().for_each(|m| *m /= count.max(1.0));
    let mut cov = vec![0.0f64; k * k];
    let mut centred = vec![0.0f64; k];
    for (i, _) in keep.iter().enumerate().filter(|(_, &kp)| kp) {
        for ((c, v), m) in centred
            .iter_mut()
            .zip(&points[i * k..(i + 1) * k])
            .zip(&mean)
        {
            *c = *v as f64 - m;
        }
        for a in 0..k {
            for b in a..k {
                cov[a * k + b] += centred[a] * centred[b];
            }
        }
    }
    for a in 0..k {
        for b in 0..a {
            cov[a * k + b] = cov[b * k + a];
        }
    }
    let (values, vectors) = jacobi_eigen(cov, k);
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by(|&a, &b| values[b].total_cmp(&values[a]));
    let mut axes = vec![0.0f32; k * 8];
    for (col, &j) in order.iter().take(d).enumerate() {
        for r in 0..k {
            axes[r * 8 + col] = vectors[r * k + j] as f32;
        }
    }
    (mean.iter().map(|&m| m as f32).collect(), axes)
}

/// Eigen-decomposition of a symmetric k × k matrix by cyclic Jacobi rotations.
/// Returns (eigenvalues, eigenvectors as columns of a row-major k × k matrix).
pub(super) fn jacobi_eigen(mut a: Vec<f64>, k: usize) -> (Vec<f64>, Vec<f64>) {
    let mut v = vec![0.0f64; k * k];
    for i in 0..k {
        v[i * k + i] = 1.0;
    }
    let scale: f64 = a.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
    for _sweep in 0..60 {
        let off: f64 = (0..k)
            .flat_map(|i| (0..k).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * k + j] * a[i * k + j])
            .sum::<f64>()
            .sqrt();
        if off <= 1e-14 * scale {
            break;
        }
        for p in 0..k {
            for q in p + 1..k {
                let apq = a[p * k + q];
                if apq.abs() <= 1e-300 {
                    continue;
                }
                let theta = (a[q * k + q] - a[p * k + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for r in 0..k {
                    let (arp, arq) = (a[r * k + p], a[r * k + q]);
                    a[r * k + p] = c * arp - s * arq;
                    a[r * k + q] = s * arp + c * arq;
                }
                for col in 0..k {
                    let (apc, aqc) = (a[p * k + col], a[q * k + col]);
                    a[p * k + col] = c * apc - s * aqc;
                    a[q * k + col] = s * apc + c * aqc;
                }
                for r in 0..k {
                    let (vrp, vrq) = (v[r * k + p], v[r * k + q]);
                    v[r * k + p] = c * vrp - s * vrq;
                    v[r * k + q] = s * vrp + c * vrq;
                }
            }
        }
    }
    ((0..k).map(|i| a[i * k + i]).collect(), v)
}
