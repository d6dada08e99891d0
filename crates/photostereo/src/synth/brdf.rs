//! Reflectance models, evaluated as the radiance seen by an orthographic camera
//! (view direction v = +z) under one directional light of intensity 1.
//!
//! Scale: a Lambertian surface of albedo ρ gives I = ρ·max(n·l, 0), i.e. the radiance is
//! π·f_r·(n·l) for a BRDF f_r. With h = (l + v)/‖l + v‖ and everything zero when n·l ≤ 0
//! (attached shadow) or n·v ≤ 0:
//!
//! * **Lambertian**: I = ρ (n·l).
//! * **Blinn–Phong** (Blinn 1977, un-normalised lobe):
//!   I = k_d ρ (n·l) + k_s (n·h)^s. The highlight peaks at k_d ρ (n·l) + k_s.
//! * **GGX / Cook–Torrance** (Walter et al. 2007; Cook & Torrance 1982):
//!   I = k_d ρ (n·l) + π·D(h)·G·F / (4 (n·v)) with
//!   D = α² / (π ((n·h)²(α² − 1) + 1)²) (α = `roughness`),
//!   G = G₁(l) G₁(v), G₁(w) = 2 (n·w) / ((n·w) + √(α² + (1 − α²)(n·w)²)) (Smith, separable),
//!   F = F₀ + (1 − F₀)(1 − v·h)⁵ (Schlick) with F₀ = `ks`.
//!   The diffuse part is not reduced by (1 − F) (kept simple). A metal has k_d = 0.
//!
//! Speculars can exceed 1 (the peak of GGX is about F₀/α²/4 at normal view).

/// A reflectance model. All coefficients are dimensionless.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Ideal diffuse: I = albedo·(n·l).
    Lambertian {
        /// Diffuse albedo (0..1).
        albedo: f32,
    },
    /// I = kd·ρ·(n·l) + ks·(n·h)^shininess.
    BlinnPhong {
        /// Diffuse weight (multiplies the albedo texture ρ).
        kd: f32,
        /// Specular weight (peak height of the lobe).
        ks: f32,
        /// Phong exponent (larger = sharper highlight).
        shininess: f32,
    },
    /// Microfacet GGX (Trowbridge–Reitz) with Smith shadowing and Schlick Fresnel.
    Ggx {
        /// Diffuse weight (0 for a metal).
        kd: f32,
        /// Fresnel reflectance at normal incidence F₀ (≈0.04 dielectrics, 0.5–1 metals).
        ks: f32,
        /// GGX width α (0.05 near-mirror … 0.5 rough), > 0.
        roughness: f32,
    },
}

impl Default for Material {
    fn default() -> Self {
        Material::shiny_plastic()
    }
}

impl Material {
    /// Ideal diffuse surface of the given albedo.
    pub fn lambertian(albedo: f32) -> Self {
        Material::Lambertian { albedo }
    }

    /// Shiny plastic: GGX, kd 0.7, F₀ 0.04, α 0.1 (highlight peak ≈ 1 over the diffuse).
    pub fn shiny_plastic() -> Self {
        Material::Ggx {
            kd: 0.7,
            ks: 0.04,
            roughness: 0.1,
        }
    }

    /// Metal: GGX with no diffuse part, F₀ 0.9, α 0.2 (peak ≈ 5.6).
    pub fn metal() -> Self {
        Material::Ggx {
            kd: 0.0,
            ks: 0.9,
            roughness: 0.2,
        }
    }

    /// Blinn–Phong plastic: kd 0.7, ks 0.5, shininess 50.
    pub fn phong() -> Self {
        Material::BlinnPhong {
            kd: 0.7,
            ks: 0.5,
            shininess: 50.0,
        }
    }

    /// The diffuse coefficient (albedo of a Lambertian, kd otherwise).
    pub fn diffuse(&self) -> f32 {
        match *self {
            Material::Lambertian { albedo } => albedo,
            Material::BlinnPhong { kd, .. } | Material::Ggx { kd, .. } => kd,
        }
    }

    /// Check that every coefficient is finite and in range.
    pub fn validate(&self) -> crate::Result<()> {
        let ok = match *self {
            Material::Lambertian { albedo } => albedo.is_finite() && albedo >= 0.0,
            Material::BlinnPhong { kd, ks, shininess } => [kd, ks, shininess]
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0),
            Material::Ggx { kd, ks, roughness } => {
                [kd, ks].iter().all(|v| v.is_finite() && *v >= 0.0)
                    && roughness.is_finite()
                    && roughness > 0.0
            }
        };
        if ok {
            Ok(())
        } else {
            Err(crate::Error::invalid(
                format!("material {self:?}"),
                "coefficients must be finite and >= 0, GGX roughness > 0",
            ))
        }
    }
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Radiance of one surface point under one light of intensity 1, no cast shadow.
/// `n` and `l` are unit vectors (camera frame, l toward the light), the view is +z, and
/// `albedo` multiplies the diffuse coefficient (a spatial texture; 1 when uniform).
pub fn shade(material: &Material, n: [f32; 3], l: [f32; 3], albedo: f32) -> f32 {
    let nl = dot(n, l);
    let nv = n[2];
    if nl <= 0.0 || nv <= 0.0 {
        return 0.0;
    }
    let diffuse = material.diffuse() * albedo * nl;
    let h = crate::image::normalize([l[0], l[1], l[2] + 1.0]);
    let nh = dot(n, h).max(0.0);
    match *material {
        Material::Lambertian { .. } => diffuse,
        Material::BlinnPhong { ks, shininess, .. } => diffuse + ks * nh.powf(shininess),
        Material::Ggx { ks, roughness, .. } => {
            let a2 = roughness * roughness;
            let t = nh * nh * (a2 - 1.0) + 1.0;
            let d = a2 / (std::f32::consts::PI * t * t);
            let g1 = |c: f32| 2.0 * c / (c + (a2 + (1.0 - a2) * c * c).sqrt());
            let vh = h[2].clamp(0.0, 1.0);
            let f = ks + (1.0 - ks) * (1.0 - vh).powi(5);
            diffuse + std::f32::consts::PI * d * g1(nl) * g1(nv) * f / (4.0 * nv)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambertian_is_albedo_times_cosine() {
        let n = [0.0, 0.0, 1.0];
        let l = crate::image::normalize([0.3, 0.4, 0.8]);
        let v = shade(&Material::lambertian(0.6), n, l, 0.5);
        assert!((v - 0.3 * l[2]).abs() < 1e-7);
        assert_eq!(
            shade(&Material::lambertian(1.0), n, [0.0, 1.0, -0.1], 1.0),
            0.0
        );
    }

    #[test]
    fn ggx_peak_matches_closed_form() {
        // Mirror configuration n = h: D = 1/(π α²), so the specular is F·G/(4 α² (n·v)).
        let l = crate::image::normalize([0.0, 0.6, 0.8]);
        let n = crate::image::normalize([0.0, 0.6, 1.8]);
        let m = Material::Ggx {
            kd: 0.0,
            ks: 1.0,
            roughness: 0.2,
        };
        let nl = dot(n, l);
        let g1 = |c: f32| 2.0 * c / (c + (0.04 + 0.96 * c * c).sqrt());
        let expected = g1(nl) * g1(n[2]) / (4.0 * 0.04 * n[2]);
        let v = shade(&m, n, l, 1.0);
        assert!((v - expected).abs() < 1e-4 * expected, "{v} vs {expected}");
    }
}
