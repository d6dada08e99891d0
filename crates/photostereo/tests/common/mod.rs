//! Helpers shared by the library's end-to-end tests. Each test file includes this with
//! `mod common;` and uses only part of it; the scenes and scores of one area are in
//! submodules.
//!
//! * [`angle_deg`]: the angle between normals by the accurate formula;
//! * [`Rng`]: the one deterministic random source (uniform and Gaussian);
//! * [`temp_dir`]: a fresh scratch folder per test;
//! * [`solve3`]: a 3 × 3 linear solve for fitting truths.
#![allow(dead_code)]

pub mod camera_case;
pub mod fuzz;
pub mod interreflect_scene;
pub mod lut_scene;
pub mod lut_score;
pub mod resample;
pub mod shared;
pub mod sphere_measure;
pub mod sphere_scene;
pub mod surfaces;

use std::path::PathBuf;

/// Angle between two directions (need not be unit), degrees, as atan2(‖a × b‖, a · b)
/// (`photostereo::eval::angle_deg`): accurate near 0°, where acos of the dot product
/// loses half the digits.
pub fn angle_deg(a: [f32; 3], b: [f32; 3]) -> f64 {
    photostereo::eval::angle_deg(&a, &b)
}

/// Deterministic random numbers: SplitMix64 (Steele, Lea & Flood 2014) for uniforms,
/// Box–Muller for Gaussian deviates.
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A standard normal deviate.
    pub fn gauss64(&mut self) -> f64 {
        let u1 = self.next_f64().max(1e-300);
        let u2 = self.next_f64();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// A standard normal deviate as f32.
    pub fn gauss(&mut self) -> f32 {
        self.gauss64() as f32
    }
}

/// A fresh, empty directory `group/name` under Cargo's scratch space for integration
/// tests (removed first if an earlier run left it).
pub fn temp_dir(group: &str, name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create the test's scratch directory");
    d
}

/// Solve a 3 × 3 system by Cramer's rule.
pub fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> [f64; 3] {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    std::array::from_fn(|k| {
        let mut m = a;
        for row in m.iter_mut().zip(b) {
            row.0[k] = row.1;
        }
        det(m) / d
    })
}
