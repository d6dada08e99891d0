//! The fast (horizon) visibility against the brute-force reference (48×48 here to keep the
//! tests quick; the bench `interreflect` prints the 64×64 figures), coarse facets against
//! per-pixel facets, and physical checks of the kernel.

mod common;
use common::interreflect_scene::{albedo, bowl, direct, sample, trough};
use photostereo::image::{ImageStack, Mask};
use photostereo::interreflect::{Model, RadiosityOptions, Visibility};
use photostereo::progress::NoProgress;

const LIGHTS: [[f32; 3]; 3] = [[0.0, 0.0, 1.0], [0.5, 0.0, 0.866], [-0.3, 0.4, 0.866]];

/// Bounced light (one bounce of the direct images) with a given visibility.
fn bounced(
    depth_normals: &(photostereo::DepthMap, photostereo::NormalMap),
    vis: Visibility,
    block: usize,
) -> (ImageStack, u64) {
    let (z, n) = depth_normals;
    let mask = Mask::full(z.width, z.height);
    let opts = RadiosityOptions {
        block,
        visibility: vis,
        ..Default::default()
    };
    let model = Model::new(z, n, &mask, &opts, &NoProgress).unwrap();
    let rho = albedo(z.width, z.height, 0.8);
    let d = direct(n, 0.8, &LIGHTS);
    (model.bounce(&d, &rho).unwrap(), model.kernel.occluded_pairs)
}

/// Σ|a − b| / Σ|b| over all pixels and lights.
fn rel_l1(a: &ImageStack, b: &ImageStack) -> f64 {
    let num: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs() as f64)
        .sum();
    let den: f64 = b.data.iter().map(|y| y.abs() as f64).sum();
    num / den
}

#[test]
fn horizon_matches_brute_force_on_a_trough_with_occlusion() {
    // Ring trough around a hill: many facet pairs are hidden from each other.
    let shape = sample(48, 48, trough(12.0, 4.0, 6.0));
    let (brute, occ_b) = bounced(&shape, Visibility::BruteForce, 1);
    let (fast, occ_h) = bounced(&shape, Visibility::Horizon { azimuths: 64 }, 1);
    let (none, _) = bounced(&shape, Visibility::None, 1);
    let err = rel_l1(&fast, &brute);
    let ignore = rel_l1(&none, &brute);
    println!("trough 48x48: horizon vs brute force {err:.4} (occluded pairs {occ_h} vs {occ_b}); no visibility {ignore:.4}");
    assert!(
        occ_b > 1000,
        "the trough must have occluded pairs, found {occ_b}"
    );
    assert!(ignore > 0.05, "visibility should matter here ({ignore})");
    // measured 0.0066 (no visibility: 0.1199)
    assert!(
        err < 0.02,
        "horizon bounced light differs by {err} from brute force"
    );
}

#[test]
fn horizon_matches_brute_force_on_a_bowl() {
    let shape = sample(48, 48, bowl(20.0, 8.0));
    let (brute, _) = bounced(&shape, Visibility::BruteForce, 1);
    let (fast, _) = bounced(&shape, Visibility::Horizon { azimuths: 64 }, 1);
    let err = rel_l1(&fast, &brute);
    println!("bowl 48x48: horizon vs brute force {err:.5}");
    // measured < 0.000005: nothing in a bowl is hidden, both find every pair visible
    assert!(
        err < 1e-4,
        "horizon bounced light differs by {err} from brute force"
    );
}

#[test]
fn coarse_facets_match_per_pixel_facets_on_a_bowl() {
    let shape = sample(64, 64, bowl(28.0, 11.2));
    let (fine, _) = bounced(&shape, Visibility::Horizon { azimuths: 64 }, 1);
    let (coarse, _) = bounced(&shape, Visibility::Horizon { azimuths: 64 }, 2);
    let err = rel_l1(&coarse, &fine);
    println!("bowl 64x64: block 2 vs block 1 bounced light {err:.4}");
    // measured 0.0017
    assert!(
        err < 0.005,
        "block-2 bounced light differs by {err} from block 1"
    );
}

#[test]
fn a_convex_shape_has_no_bounced_light() {
    // A sphere of radius 60 px seen from outside, covering the whole image.
    let shape = sample(48, 48, |x, y| {
        let s = (3600.0 - x * x - y * y).sqrt();
        (s, -x / s, -y / s)
    });
    let (b, _) = bounced(&shape, Visibility::Horizon { azimuths: 32 }, 1);
    let max = b.data.iter().fold(0.0f32, |a, v| a.max(*v));
    assert!(
        max < 1e-6,
        "a convex cap must not receive bounced light, got {max}"
    );
}

#[test]
fn a_spherical_cavity_receives_uniform_first_bounce() {
    // Inside a sphere K_ij = A_j / (4π R²) for every pair: under overhead light the first
    // bounce is ρ·ρ·(Σ projected area)/(4π R²), the same at every point of the cap.
    let (radius, depth) = (28.0f64, 11.2f64);
    let rs = (radius * radius + depth * depth) / (2.0 * depth);
    let shape = sample(64, 64, bowl(radius, depth));
    let mask = Mask::from_fn(64, 64, |r, c| {
        let (x, y) = photostereo::image::pixel_to_xy(r, c, 64, 64);
        x * x + y * y < radius * radius
    });
    let inside = mask.count() as f64;
    let expected = 0.8 * 0.8 * inside / (4.0 * std::f64::consts::PI * rs * rs);
    for block in [1, 2] {
        let opts = RadiosityOptions {
            block,
            ..Default::default()
        };
        let model = Model::new(&shape.0, &shape.1, &mask, &opts, &NoProgress).unwrap();
        let d = direct(&shape.1, 0.8, &[[0.0, 0.0, 1.0]]);
        let b = model.bounce(&d, &albedo(64, 64, 0.8)).unwrap();
        let mut worst = 0.0f64;
        for (p, &m) in mask.data.iter().enumerate() {
            if m {
                worst = worst.max((b.data[p] as f64 - expected).abs() / expected);
            }
        }
        println!(
            "spherical cavity, block {block}: worst relative error of the first bounce {worst:.4}"
        );
        // measured 0.0008 (block 1), 0.0028 (block 2)
        let bound = if block == 1 { 0.0025 } else { 0.008 };
        assert!(worst < bound, "block {block}: first bounce off by {worst}");
    }
}
