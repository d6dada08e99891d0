//! The shape as a set of Lambertian facets on a (possibly coarser) grid.
//!
//! Facet `f` covers a `block`×`block` square of pixels. Its centre is the mean camera
//! position (x, y, z) of its pixels inside the mask, its normal the normalised mean of their
//! normals, and its **true** area the sum of the pixels' true areas Σ 1/n_z (one pixel has
//! projected area 1). Quantities computed per facet (the irradiance from other facets) are
//! spread back to pixels by bilinear interpolation between facet centres, so that a coarse
//! grid still gives smooth per-pixel bounced light.

use crate::error::{Error, Result};
use crate::image::{dot3, normalize, pixel_to_xy, DepthMap, ImageStack, Mask, NormalMap};

/// Smallest n_z used for the true area 1/n_z of a pixel (limits the area of grazing pixels).
const MIN_NZ: f32 = 0.05;
/// Facets whose normal differs from a pixel's by more than this (degrees) do not take part
/// in interpolating that pixel's value.
pub const CREASE_DEG: f32 = 20.0;

/// Facets of a height field on a grid of `block`×`block` pixel cells.
#[derive(Clone, Debug)]
pub struct Facets {
    /// Pixel size of one cell.
    pub block: usize,
    /// Image size in pixels.
    pub width: usize,
    /// Image size in pixels.
    pub height: usize,
    /// Grid size in cells (columns).
    pub grid_w: usize,
    /// Grid size in cells (rows).
    pub grid_h: usize,
    /// Facets of each grid cell: none where the cell has no pixel inside the mask, two
    /// where its pixels straddle a crease (see [`split_at_crease`]).
    pub cell_facets: Vec<Vec<u32>>,
    /// Grid cell (row, col) of each facet.
    pub cell: Vec<(u32, u32)>,
    /// Camera-frame centre (x, y, z) of each facet, pixel units.
    pub pos: Vec<[f32; 3]>,
    /// Unit normal of each facet.
    pub normal: Vec<[f32; 3]>,
    /// True area of each facet (pixel² units).
    pub area: Vec<f32>,
    /// Pixels (flat indices) of each facet.
    pub pixels: Vec<Vec<u32>>,
    /// Height of each grid cell (mean depth of its pixels), NaN where the cell has no facet.
    pub heights: Vec<f32>,
    /// Largest cell height (pixels).
    pub max_height: f32,
    /// Normal of every pixel (copied from the input), used to keep [`Facets::spread`] from
    /// blending across creases.
    pub pixel_normals: Vec<[f32; 3]>,
}

/// Split the pixels of one cell in two by their normals (two-means on the unit sphere) when
/// some normal is more than half of [`CREASE_DEG`] away from their mean, so that a facet never
/// averages across a crease (a bowl's edge, a V-groove's apex).
pub fn split_at_crease(px: Vec<u32>, normals: &NormalMap) -> Vec<Vec<u32>> {
    let n = |p: u32| normals.data[p as usize];
    let mean = normalize(px.iter().fold([0.0f32; 3], |a, &p| {
        let v = n(p);
        [a[0] + v[0], a[1] + v[1], a[2] + v[2]]
    }));
    let cos_half = (CREASE_DEG / 2.0).to_radians().cos();
    let far = |from: [f32; 3]| {
        px.iter()
            .copied()
            .min_by(|&a, &b| dot3(n(a), from).total_cmp(&dot3(n(b), from)))
    };
    let Some(a) = far(mean) else {
        return vec![px];
    };
    if dot3(n(a), mean) >= cos_half {
        return vec![px];
    }
    let mut ca = n(a);
    let mut cb = far(ca).map_or(mean, n);
    let mut groups = (Vec::new(), Vec::new());
    for _ in 0..4 {
        groups = px.iter().partition(|&&p| dot3(n(p), ca) >= dot3(n(p), cb));
        let centre = |g: &Vec<u32>| {
            normalize(g.iter().fold([0.0f32; 3], |s, &p| {
                let v = n(p);
                [s[0] + v[0], s[1] + v[1], s[2] + v[2]]
            }))
        };
        if groups.0.is_empty() || groups.1.is_empty() {
            return vec![px];
        }
        ca = centre(&groups.0);
        cb = centre(&groups.1);
    }
    vec![groups.0, groups.1]
}

/// The smallest facet block ≥ 2 (pixels) whose `block`×`block` grid has at most
/// `max_cells` cells holding mask pixels (64 when none does). Bounced light is smooth, so
/// a coarser grid costs little accuracy, while the dense kernel grows as cells².
/// Crease splitting ([`Facets::build`]) can add facets beyond the cell count.
pub fn auto_block(mask: &Mask, max_cells: usize) -> usize {
    let (w, h) = (mask.width, mask.height);
    let inside = mask.data.iter().filter(|&&m| m).count();
    // Each cell holds at most b² pixels: no block below √(inside / max_cells) can fit.
    let start = ((inside as f64 / max_cells.max(1) as f64).sqrt().floor() as usize).max(2);
    (start..64)
        .find(|&b| {
            let gw = w.div_ceil(b);
            let mut cells = vec![false; gw * h.div_ceil(b)];
            for (i, _) in mask.data.iter().enumerate().filter(|(_, &m)| m) {
                cells[(i / w / b) * gw + (i % w) / b] = true;
            }
            cells.iter().filter(|&&c| c).count() <= max_cells
        })
        .unwrap_or(64)
}

impl Facets {
    /// Build facets from a depth map, unit normals and a mask of the same size.
    ///
    /// Pixels inside the mask with a non-finite depth or a normal with n_z ≤ 0 are skipped.
    pub fn build(depth: &DepthMap, normals: &NormalMap, mask: &Mask, block: usize) -> Result<Self> {
        let (w, h) = (depth.width, depth.height);
        mask.check_size(w, h, "interreflection mask")?;
        if !normals.same_size(depth) {
            return Err(Error::SizeMismatch {
                what: "normal map for the interreflection kernel".into(),
                expected_w: w,
                expected_h: h,
                found_w: normals.width,
                found_h: normals.height,
                fix: "use normals and depth of the same size".into(),
            });
        }
        if block == 0 {
            return Err(Error::invalid(
                "facet block size 0",
                "use a block of at least 1 pixel",
            ));
        }
        let (gw, gh) = (w.div_ceil(block), h.div_ceil(block));
        let mut cell_pixels: Vec<Vec<u32>> = vec![Vec::new(); gw * gh];
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                let n = normals.data[i];
                if mask.data[i] && depth.data[i].is_finite() && n[2] > 0.0 && n[2].is_finite() {
                    cell_pixels[(r / block) * gw + c / block].push(i as u32);
                }
            }
        }
        let mut f = Facets {
            block,
            width: w,
            height: h,
            grid_w: gw,
            grid_h: gh,
            cell_facets: vec![Vec::new(); gw * gh],
            cell: Vec::new(),
            pos: Vec::new(),
            normal: Vec::new(),
            area: Vec::new(),
            pixels: Vec::new(),
            heights: vec![f32::NAN; gw * gh],
            max_height: f32::NEG_INFINITY,
            pixel_normals: normals.data.clone(),
        };
        for (ci, px) in cell_pixels.into_iter().enumerate() {
            if px.is_empty() {
                continue;
            }
            let mean_z = px
                .iter()
                .map(|&p| depth.data[p as usize] as f64)
                .sum::<f64>();
            f.heights[ci] = (mean_z / px.len() as f64) as f32;
            f.max_height = f.max_height.max(f.heights[ci]);
            for group in split_at_crease(px, normals) {
                f.add_facet(ci, group, depth, normals);
            }
        }
        if f.pos.is_empty() {
            return Err(Error::EmptyMask {
                what: "interreflection facets".into(),
                fix: "give a mask with pixels of finite depth and normals facing the camera".into(),
            });
        }
        Ok(f)
    }

    fn add_facet(&mut self, ci: usize, px: Vec<u32>, depth: &DepthMap, normals: &NormalMap) {
        let (w, h) = (self.width, self.height);
        let mut s = [0.0f64; 3];
        let mut ns = [0.0f32; 3];
        let mut area = 0.0f32;
        for &p in &px {
            let p = p as usize;
            let (x, y) = pixel_to_xy(p / w, p % w, w, h);
            s[0] += x;
            s[1] += y;
            s[2] += depth.data[p] as f64;
            let n = normals.data[p];
            for a in 0..3 {
                ns[a] += n[a];
            }
            area += 1.0 / n[2].max(MIN_NZ);
        }
        let m = px.len() as f64;
        let idx = self.pos.len() as u32;
        self.cell_facets[ci].push(idx);
        self.cell
            .push(((ci / self.grid_w) as u32, (ci % self.grid_w) as u32));
        self.pos
            .push([(s[0] / m) as f32, (s[1] / m) as f32, (s[2] / m) as f32]);
        self.normal.push(normalize(ns));
        self.area.push(area);
        self.pixels.push(px);
    }

    /// Number of facets.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True when there is no facet.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Mean of each light's pixel values over each facet: facet-major `[f * k + light]`.
    pub fn pool(&self, stack: &ImageStack) -> Vec<f32> {
        let k = stack.k;
        let mut out = vec![0.0f32; self.len() * k];
        for (f, px) in self.pixels.iter().enumerate() {
            let acc = &mut out[f * k..(f + 1) * k];
            for &p in px {
                for (a, v) in acc.iter_mut().zip(stack.pixel_flat(p as usize)) {
                    *a += *v;
                }
            }
            let inv = 1.0 / px.len() as f32;
            acc.iter_mut().for_each(|a| *a *= inv);
        }
        out
    }

    /// Spread facet values (`[f * k + light]`) back to every facet pixel by bilinear
    /// interpolation between facet centres. A corner facet that is missing, or whose normal
    /// differs from the pixel's by more than [`CREASE_DEG`] (V-groove apex, rim), is replaced by
    /// linear extrapolation from the pixel's own facet through the facet mirrored about it
    /// (2·v_own − v_mirror, at least 0), or by v_own when that one is unusable too; so values
    /// never leak across a crease. Pixels outside the facets get 0.
    pub fn spread(&self, values: &[f32], k: usize) -> ImageStack {
        let mut out = ImageStack::zeros(self.width, self.height, k);
        let b = self.block as f32;
        let cos_crease = CREASE_DEG.to_radians().cos();
        for (own, px) in self.pixels.iter().enumerate() {
            let (orow, ocol) = (self.cell[own].0 as i64, self.cell[own].1 as i64);
            let vown = &values[own * k..(own + 1) * k];
            for &p in px {
                let p = p as usize;
                let (r, c) = (p / self.width, p % self.width);
                let u = (r as f32 + 0.5) / b - 0.5;
                let v = (c as f32 + 0.5) / b - 0.5;
                let (r0, c0) = (u.floor(), v.floor());
                let (fu, fv) = (u - r0, v - c0);
                let usable = |rr: i64, cc: i64| -> Option<usize> {
                    if rr < 0 || cc < 0 || rr >= self.grid_h as i64 || cc >= self.grid_w as i64 {
                        return None;
                    }
                    let cell = &self.cell_facets[rr as usize * self.grid_w + cc as usize];
                    if cell.contains(&(own as u32)) {
                        return Some(own);
                    }
                    let np = self.pixel_normals[p];
                    let (f, d) = cell
                        .iter()
                        .map(|&f| (f as usize, dot3(self.normal[f as usize], np)))
                        .max_by(|a, b| a.1.total_cmp(&b.1))?;
                    (d >= cos_crease).then_some(f)
                };
                let o = out.pixel_flat_mut(p);
                for (dr, dc, wgt) in [
                    (0, 0, (1.0 - fu) * (1.0 - fv)),
                    (0, 1, (1.0 - fu) * fv),
                    (1, 0, fu * (1.0 - fv)),
                    (1, 1, fu * fv),
                ] {
                    if wgt <= 0.0 {
                        continue;
                    }
                    let (rr, cc) = (r0 as i64 + dr, c0 as i64 + dc);
                    if let Some(f) = usable(rr, cc) {
                        for (a, v) in o.iter_mut().zip(&values[f * k..(f + 1) * k]) {
                            *a += wgt * v;
                        }
                    } else if let Some(m) = usable(2 * orow - rr, 2 * ocol - cc) {
                        let vm = &values[m * k..(m + 1) * k];
                        for ((a, vo), vmm) in o.iter_mut().zip(vown).zip(vm) {
                            *a += wgt * (2.0 * vo - vmm).max(0.0);
                        }
                    } else {
                        for (a, vo) in o.iter_mut().zip(vown) {
                            *a += wgt * vo;
                        }
                    }
                }
            }
        }
        out
    }

    /// Height of the grid at continuous cell coordinates (row, col), cell (R, C) centred at
    /// (R + 0.5, C + 0.5): bilinear between the finite corner heights; `None` where no
    /// neighbouring cell has a facet.
    #[inline]
    pub fn height_at(&self, row: f32, col: f32) -> Option<f32> {
        let (u, v) = (row - 0.5, col - 0.5);
        let (r0, c0) = (u.floor(), v.floor());
        let (fu, fv) = (u - r0, v - c0);
        let (r0, c0) = (r0 as i64, c0 as i64);
        let mut acc = 0.0f32;
        let mut wsum = 0.0f32;
        let mut hmax = f32::NEG_INFINITY;
        for (dr, dc, wgt) in [
            (0, 0, (1.0 - fu) * (1.0 - fv)),
            (0, 1, (1.0 - fu) * fv),
            (1, 0, fu * (1.0 - fv)),
            (1, 1, fu * fv),
        ] {
            let (rr, cc) = (r0 + dr, c0 + dc);
            if rr < 0 || cc < 0 || rr >= self.grid_h as i64 || cc >= self.grid_w as i64 {
                continue;
            }
            let hv = self.heights[rr as usize * self.grid_w + cc as usize];
            if hv.is_finite() {
                acc += wgt * hv;
                wsum += wgt;
                hmax = hmax.max(hv);
            }
        }
        if wsum <= 0.0 {
            return None;
        }
        // Near the mask border some corners are missing: renormalise over the present ones.
        Some((acc / wsum).min(hmax))
    }
}
