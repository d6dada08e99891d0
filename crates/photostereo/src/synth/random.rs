//! A tiny deterministic random source: SplitMix64 (Steele, Lea & Flood 2014) for
//! uniform numbers and the Box–Muller transform for standard normal samples.
//!
//! Rendering seeds one generator per image row from (seed, row), so the output does
//! not depend on how rows are split across threads.

/// SplitMix64 generator.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// A generator for one stream (e.g. one image row) of a seeded experiment.
    pub fn for_stream(seed: u64, stream: u64) -> Self {
        let mut g = SplitMix64(seed ^ stream.wrapping_mul(0xD1B5_4A32_D192_ED03));
        g.next_u64();
        g
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1] (never 0, so its logarithm is finite).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }

    /// A standard normal sample (Box–Muller, one of the pair).
    pub fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// A smooth albedo multiplier in [0.4, 1] at camera point (x, y) of an image of size
/// `scale` (pixels): a product of two sinusoidal gratings with seeded phases plus a
/// Gaussian dark spot, so albedo varies by about 2.5x over the object.
pub fn albedo_texture(x: f64, y: f64, scale: f64, seed: u64) -> f64 {
    let mut g = SplitMix64::new(seed ^ 0xA1BE_D0A1_BE00);
    let (p1, p2) = (
        g.uniform() * std::f64::consts::TAU,
        g.uniform() * std::f64::consts::TAU,
    );
    let s = scale.max(1.0);
    let wave = (std::f64::consts::TAU * 2.0 * x / s + p1).sin()
        * (std::f64::consts::TAU * 1.5 * y / s + p2).cos();
    let (sx, sy) = ((g.uniform() - 0.5) * 0.4 * s, (g.uniform() - 0.5) * 0.4 * s);
    let spot = (-((x - sx).powi(2) + (y - sy).powi(2)) / (2.0 * (0.08 * s).powi(2))).exp();
    (0.8 + 0.2 * wave - 0.4 * spot).clamp(0.4, 1.0)
}
