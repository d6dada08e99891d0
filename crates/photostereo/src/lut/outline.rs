//! The mask's outline: pixels that are partly background.
//!
//! A camera pixel integrates the radiance over its footprint. On the object's silhouette
//! only a share c of the footprint sees the object (the rest sees the dark background),
//! so the pixel's tuple is about c·I(n̄), n̄ the mean normal over the covered part: the
//! same shape as a fully covered pixel's, dimmer by an unknown c. Matched with c = 1, such
//! a tuple lands on a normal whose tuple is dimmer — on a rough metal, 5–12° off at the
//! silhouette of an area-averaged render. A mask drawn at half coverage (Mitsuba's, the
//! usual thresholded mask) puts c in [0.5, 1] on its outline.
//!
//! So an outline pixel (a mask pixel with one of its 4 neighbours inside the image and
//! outside the mask) is matched also with a free brightness (normalised matching,
//! c = ⟨t, I⟩/⟨I, I⟩); where that fits clearly better than the plain match
//! ([`RESIDUAL_RATIO`]), its tuple's light above each light's floor f (the camera's black
//! level, `Table::floors`: the background shows f, not 0) is divided by c clamped to
//! [`MIN_COVERAGE`, 1], t' = f + (t − f)/c, and matched again
//! ([`super::Options::outline_coverage`]). Measured 2026-12-05, default pipeline:
//! `synth` GGX metal α 0.2 rendered at 4× and averaged over 4 × 4 sub-pixels (mask =
//! coverage ≥ ½, table from a sphere made the same way): outline pixels 4.85° → 0.46°,
//! whole mask 0.112° → 0.020°; Mitsuba `target_diffuse` (table on the circle found)
//! outline 2.36° → 0.03°, whole mask 0.061° → 0.012°; `target_roughplastic` 1.92° →
//! 1.06°, 0.069° → 0.051° (`tests/lut_shared.rs`). Real masks drawn inside the
//! silhouette keep their figures: the DiLiGenT ball at 0.75× 0.0735° either way (with a
//! ratio of 1.5 instead of 3 it went to 0.0835°). A mask through that ball's rim (every
//! pixel whose centre is inside the circle) lost: its 230 outline pixels 1.22° → 2.25°,
//! because there the tuple is not c·I(n̄) (docs/accuracy.md, "The DiLiGenT ball at 0.75×
//! by resampler").
//!
//! **Checked on the sphere first** (2026-12-08). Nothing in a target's tuples tells the
//! two cases apart, but the calibration sphere's own silhouette, photographed with the
//! same camera, is made the same way and its normals are known. So the table keeps the
//! sphere's outline pixels (centre inside the circle, a 4-neighbour's outside) with
//! the mean normal of their covered part (`table::OutlineSample`), and
//! [`super::Lookup`] solves them as target outline pixels, plain and corrected; the
//! correction is applied to targets only where it brings them closer to their normals
//! ([`super::OutlineCheck`]). Mitsuba's diffuse sphere 2.42° → 0.05° and its rough
//! plastic 1.96° → 1.07° keep it; DiLiGenT's ball (1.02° → 1.05°) does not, and its
//! whole disc at 0.75× (default pipeline) went from 0.121° to 0.095°; `synth`'s spheres,
//! whose silhouette pixels are sampled at their centres, show no change (0.407° both)
//! and skip the brightness-free search, which made the prepared lookup of
//! `benches/sklearn_lookup.py` 8–14% faster in alternated runs, with the same normals.

use crate::image::Mask;

/// Smallest coverage an outline pixel's brightness is corrected for: the mask holds
/// pixels at least half covered.
pub const MIN_COVERAGE: f32 = 0.5;

/// The brightness-free match is taken only where its RMS residual is below the plain
/// match's divided by this: a noisy, fully covered pixel's free brightness lowers the
/// residual a little, a dimmed silhouette's by far more.
pub const RESIDUAL_RATIO: f32 = 3.0;

/// Whether mask pixel (r, c) has a 4-neighbour inside the image that is outside the mask.
pub(crate) fn on_outline(mask: &Mask, r: usize, c: usize) -> bool {
    let (w, h) = (mask.width, mask.height);
    let out = |rr: usize, cc: usize| !*mask.get(rr, cc);
    (r > 0 && out(r - 1, c))
        || (r + 1 < h && out(r + 1, c))
        || (c > 0 && out(r, c - 1))
        || (c + 1 < w && out(r, c + 1))
}

/// Whether the pixel at row-major index `i` of the mask is on its outline (`on_outline`).
pub fn on_outline_at(mask: &Mask, i: usize) -> bool {
    on_outline(mask, i / mask.width.max(1), i % mask.width.max(1))
}

/// The coverage a normalised match's brightness `c` stands for, in [`MIN_COVERAGE`, 1]
/// (1 where it is not finite).
pub(crate) fn coverage(c: f32) -> f32 {
    if c.is_finite() {
        c.clamp(MIN_COVERAGE, 1.0)
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    #[test]
    fn outline_is_the_mask_pixels_next_to_background_inside_the_image() {
        // a 4×3 mask: columns 0–2 set, column 3 clear
        let mut data = vec![true; 12];
        for r in 0..3 {
            data[r * 4 + 3] = false;
        }
        let mask: Mask = Image {
            width: 4,
            height: 3,
            data,
        };
        // column 2 touches the background; columns 0–1 only the image's border
        for r in 0..3 {
            assert!(on_outline(&mask, r, 2));
            assert!(!on_outline(&mask, r, 0) && !on_outline(&mask, r, 1));
        }
    }

    #[test]
    fn coverage_is_clamped() {
        assert_eq!(coverage(0.2), MIN_COVERAGE);
        assert_eq!(coverage(1.3), 1.0);
        assert_eq!(coverage(0.7), 0.7);
        assert_eq!(coverage(f32::NAN), 1.0);
    }
}
