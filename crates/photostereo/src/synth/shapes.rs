//! Analytic height fields z(x, y) with exact normals.
//!
//! Every shape is a function of the camera coordinates (x right, y up, origin at the
//! image centre, pixel units). Where a shape is defined it returns its height z (larger =
//! closer) and the unit normal n ∝ (−∂z/∂x, −∂z/∂y, 1), computed from the closed-form
//! gradient, never by finite differences.
//!
//! * **Sphere** (radius R): z = √(R² − x² − y²), mask = the open disc.
//! * **Blob**: a rotated ellipsoid z = h·√u, u = 1 − x'²/a² − y'²/b² (x', y' the
//!   coordinates rotated by `angle_deg`), mask = u > 0. Convex everywhere. The normal is
//!   taken as (h·x'/a², h·y'/b², √u) rotated back, which stays finite at the rim.
//! * **Vase**: an ellipsoidal body (as the blob, unrotated) plus Gaussian bumps
//!   a·exp(−|x − x_i|²/(2σ²)); negative amplitudes make concave dimples, so the shape has
//!   convex and concave regions and bumps cast shadows on the body.
//! * **Bowl** (rim radius a, depth d): a concave spherical cap of radius R = (a² + d²)/(2d)
//!   cut into the plane z = 0: z = (R − d) − √(R² − r²) for r < a, else 0. Requires d ≤ a.
//!   Mask = whole image.
//! * **VGroove** (opening angle θ, depth d): a groove along y, z = −d + |x|/tan(θ/2) for
//!   |x| < d·tan(θ/2), else 0. At x = 0 exactly (odd widths) the normal is taken as +z.
//!   Mask = whole image.

use crate::error::{Error, Result};
use crate::image::{pixel_to_xy, DepthMap, Mask, NormalMap};

/// One Gaussian bump of a [`Shape::Vase`]; all lengths in pixels, centre relative to the
/// image centre (x right, y up).
#[derive(Clone, Debug, PartialEq)]
pub struct Bump {
    /// Centre, x (pixels right of the image centre).
    pub x: f64,
    /// Centre, y (pixels above the image centre).
    pub y: f64,
    /// Height at the centre (pixels); negative = a dimple (concave).
    pub amplitude: f64,
    /// Standard deviation of the Gaussian (pixels, > 0).
    pub sigma: f64,
}

/// A synthetic surface, all lengths in pixel units, centred in the image.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Hemisphere of radius `radius`; mask = disc.
    Sphere {
        /// Radius (pixels).
        radius: f64,
    },
    /// Convex ellipsoidal bump with semi-axes `rx`, `ry` (before rotation) and height `height`.
    Blob {
        /// Semi-axis along x' (pixels).
        rx: f64,
        /// Semi-axis along y' (pixels).
        ry: f64,
        /// Height of the top (pixels).
        height: f64,
        /// Rotation of the (x', y') axes, counter-clockwise from x (degrees).
        angle_deg: f64,
    },
    /// Ellipsoidal body (semi-axes `rx`, `ry`, height `height`) plus Gaussian bumps/dimples.
    Vase {
        /// Semi-axis of the elliptical outline along x (pixels).
        rx: f64,
        /// Semi-axis of the elliptical outline along y (pixels).
        ry: f64,
        /// Height of the body (pixels); 0 gives a flat elliptical plate.
        height: f64,
        /// Bumps (positive amplitude) and dimples (negative) added to the body.
        bumps: Vec<Bump>,
    },
    /// Concave spherical cap of rim radius `radius` and depth `depth` in the plane z = 0.
    Bowl {
        /// Rim radius (pixels).
        radius: f64,
        /// Depth of the bottom below the rim plane (pixels, ≤ radius).
        depth: f64,
    },
    /// Groove along the image vertical with opening angle `angle_deg` and depth `depth`.
    VGroove {
        /// Full opening angle between the two walls (degrees, 0 < θ < 180).
        angle_deg: f64,
        /// Depth of the crease below the rims (pixels).
        depth: f64,
    },
}

/// The kind of a [`Shape`], for choosing a preset by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeKind {
    /// [`Shape::Sphere`].
    Sphere,
    /// [`Shape::Blob`].
    Blob,
    /// [`Shape::Vase`].
    Vase,
    /// [`Shape::Bowl`].
    Bowl,
    /// [`Shape::VGroove`].
    VGroove,
}

impl std::str::FromStr for ShapeKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "sphere" => Ok(ShapeKind::Sphere),
            "blob" => Ok(ShapeKind::Blob),
            "vase" | "bottle" => Ok(ShapeKind::Vase),
            "bowl" => Ok(ShapeKind::Bowl),
            "vgroove" | "v-groove" | "groove" => Ok(ShapeKind::VGroove),
            _ => Err(Error::invalid(
                format!("shape `{s}`"),
                "use one of sphere, blob, vase, bowl, vgroove",
            )),
        }
    }
}

impl Shape {
    /// A shape of the given kind scaled to fill a `width` x `height` image
    /// (s = min(width, height)): sphere radius 0.45 s; blob 0.42 s x 0.3 s, height 0.3 s,
    /// rotated 30°; vase 0.4 x 0.46 of the image, body height 0.25 s, one bump and two
    /// dimples; bowl rim 0.4 s, depth 0.2 s; V-groove 90°, depth 0.2 s.
    pub fn preset(kind: ShapeKind, width: usize, height: usize) -> Shape {
        let s = width.min(height).max(1) as f64;
        match kind {
            ShapeKind::Sphere => Shape::Sphere { radius: 0.45 * s },
            ShapeKind::Blob => Shape::Blob {
                rx: 0.42 * s,
                ry: 0.30 * s,
                height: 0.30 * s,
                angle_deg: 30.0,
            },
            ShapeKind::Vase => Shape::Vase {
                rx: 0.40 * width.max(1) as f64,
                ry: 0.46 * height.max(1) as f64,
                height: 0.25 * s,
                bumps: vec![
                    Bump {
                        x: -0.10 * s,
                        y: 0.18 * s,
                        amplitude: 0.10 * s,
                        sigma: 0.07 * s,
                    },
                    Bump {
                        x: 0.12 * s,
                        y: -0.05 * s,
                        amplitude: -0.08 * s,
                        sigma: 0.06 * s,
                    },
                    Bump {
                        x: -0.08 * s,
                        y: -0.25 * s,
                        amplitude: -0.05 * s,
                        sigma: 0.05 * s,
                    },
                ],
            },
            ShapeKind::Bowl => Shape::Bowl {
                radius: 0.40 * s,
                depth: 0.20 * s,
            },
            ShapeKind::VGroove => Shape::VGroove {
                angle_deg: 90.0,
                depth: 0.20 * s,
            },
        }
    }

    /// Check that every parameter is finite and in range.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str, fix: &str| Err(Error::invalid(format!("shape {what}"), fix));
        let pos = |v: f64| v.is_finite() && v > 0.0;
        match self {
            Shape::Sphere { radius } if !pos(*radius) => bad("sphere radius", "must be > 0"),
            Shape::Blob {
                rx,
                ry,
                height,
                angle_deg,
            } if !(pos(*rx)
                && pos(*ry)
                && height.is_finite()
                && *height >= 0.0
                && angle_deg.is_finite()) =>
            {
                bad("blob", "semi-axes must be > 0, height >= 0, angle finite")
            }
            Shape::Vase {
                rx,
                ry,
                height,
                bumps,
            } => {
                if !(pos(*rx) && pos(*ry) && height.is_finite() && *height >= 0.0) {
                    return bad("vase", "semi-axes must be > 0 and height >= 0");
                }
                if bumps.iter().any(|b| {
                    !(b.x.is_finite() && b.y.is_finite() && b.amplitude.is_finite() && pos(b.sigma))
                }) {
                    return bad(
                        "vase bump",
                        "centres and amplitudes must be finite, sigma > 0",
                    );
                }
                Ok(())
            }
            Shape::Bowl { radius, depth } if !(pos(*radius) && pos(*depth) && depth <= radius) => {
                bad(
                    "bowl",
                    "radius and depth must be > 0 with depth <= radius (at most a hemisphere)",
                )
            }
            Shape::VGroove { angle_deg, depth }
                if !(pos(*depth)
                    && angle_deg.is_finite()
                    && *angle_deg > 0.0
                    && *angle_deg < 180.0) =>
            {
                bad(
                    "v-groove",
                    "depth must be > 0 and the opening angle within (0, 180) degrees",
                )
            }
            _ => Ok(()),
        }
    }

    /// Height and unit normal at camera point (x, y), or `None` outside the shape.
    pub fn eval(&self, x: f64, y: f64) -> Option<(f64, [f64; 3])> {
        match self {
            Shape::Sphere { radius } => ellipsoid(x, y, *radius, *radius, *radius),
            Shape::Blob {
                rx,
                ry,
                height,
                angle_deg,
            } => {
                let (s, c) = angle_deg.to_radians().sin_cos();
                let (xr, yr) = (c * x + s * y, -s * x + c * y);
                let (z, n) = ellipsoid(xr, yr, *rx, *ry, *height)?;
                Some((z, [c * n[0] - s * n[1], s * n[0] + c * n[1], n[2]]))
            }
            Shape::Vase {
                rx,
                ry,
                height,
                bumps,
            } => vase(x, y, *rx, *ry, *height, bumps),
            Shape::Bowl { radius, depth } => Some(bowl(x, y, *radius, *depth)),
            Shape::VGroove { angle_deg, depth } => Some(vgroove(x, y, *angle_deg, *depth)),
        }
    }

    /// Height z(x, y) only (−∞ outside the shape): the cheap form for shadow rays.
    pub fn height(&self, x: f64, y: f64) -> f64 {
        let ell = |x: f64, y: f64, a: f64, b: f64, h: f64| {
            let u = 1.0 - (x / a).powi(2) - (y / b).powi(2);
            if u > 0.0 {
                h * u.sqrt()
            } else {
                f64::NEG_INFINITY
            }
        };
        match self {
            Shape::Sphere { radius } => ell(x, y, *radius, *radius, *radius),
            Shape::Blob {
                rx,
                ry,
                height,
                angle_deg,
            } => {
                let (s, c) = angle_deg.to_radians().sin_cos();
                ell(c * x + s * y, -s * x + c * y, *rx, *ry, *height)
            }
            Shape::Vase {
                rx,
                ry,
                height,
                bumps,
            } => {
                let base = ell(x, y, *rx, *ry, *height);
                if base == f64::NEG_INFINITY {
                    return base;
                }
                base + bumps
                    .iter()
                    .map(|b| {
                        let d2 = (x - b.x).powi(2) + (y - b.y).powi(2);
                        b.amplitude * (-d2 / (2.0 * b.sigma * b.sigma)).exp()
                    })
                    .sum::<f64>()
            }
            Shape::Bowl { .. } | Shape::VGroove { .. } => {
                self.eval(x, y).map_or(f64::NEG_INFINITY, |e| e.0)
            }
        }
    }

    /// True when z is a concave function (a convex bump): such a surface cannot cast a
    /// shadow on itself — a ray leaving a lit point stays above its tangent plane, which
    /// lies above the whole surface — so shadow rays can be skipped.
    pub fn casts_no_shadow(&self) -> bool {
        matches!(self, Shape::Sphere { .. } | Shape::Blob { .. })
    }

    /// Largest height the shape reaches (an upper bound used to stop shadow rays).
    pub fn max_height(&self) -> f64 {
        match self {
            Shape::Sphere { radius } => *radius,
            Shape::Blob { height, .. } => *height,
            Shape::Vase { height, bumps, .. } => {
                height + bumps.iter().map(|b| b.amplitude.max(0.0)).sum::<f64>()
            }
            Shape::Bowl { .. } | Shape::VGroove { .. } => 0.0,
        }
    }
}

/// Unit vector from a (possibly unnormalised) 3-vector.
fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// z = h·√u with u = 1 − x²/a² − y²/b²; normal ∝ (h·x/a², h·y/b², √u).
fn ellipsoid(x: f64, y: f64, a: f64, b: f64, h: f64) -> Option<(f64, [f64; 3])> {
    let u = 1.0 - (x / a).powi(2) - (y / b).powi(2);
    if u <= 0.0 {
        return None;
    }
    let s = u.sqrt();
    Some((h * s, unit([h * x / (a * a), h * y / (b * b), s])))
}

fn vase(x: f64, y: f64, a: f64, b: f64, h: f64, bumps: &[Bump]) -> Option<(f64, [f64; 3])> {
    let u = 1.0 - (x / a).powi(2) - (y / b).powi(2);
    if u <= 0.0 {
        return None;
    }
    let s = u.sqrt();
    let (mut z, mut gx, mut gy) = (h * s, 0.0, 0.0);
    for bump in bumps {
        let (dx, dy) = (x - bump.x, y - bump.y);
        let g = bump.amplitude * (-(dx * dx + dy * dy) / (2.0 * bump.sigma * bump.sigma)).exp();
        z += g;
        gx -= g * dx / (bump.sigma * bump.sigma);
        gy -= g * dy / (bump.sigma * bump.sigma);
    }
    // n ∝ (−p, −q, 1)·s with p = −h·x/(a²s) + gx.
    Some((
        z,
        unit([h * x / (a * a) - gx * s, h * y / (b * b) - gy * s, s]),
    ))
}

fn bowl(x: f64, y: f64, a: f64, d: f64) -> (f64, [f64; 3]) {
    let r2 = x * x + y * y;
    if r2 >= a * a {
        return (0.0, [0.0, 0.0, 1.0]);
    }
    let big_r = (a * a + d * d) / (2.0 * d);
    let w = (big_r * big_r - r2).sqrt();
    // z = (R − d) − w, ∂z/∂x = x / w, so n ∝ (−x, −y, w).
    (big_r - d - w, unit([-x, -y, w]))
}

fn vgroove(x: f64, _y: f64, angle_deg: f64, d: f64) -> (f64, [f64; 3]) {
    let t = (0.5 * angle_deg).to_radians().tan();
    let half = d * t;
    if x.abs() >= half {
        return (0.0, [0.0, 0.0, 1.0]);
    }
    let slope = 1.0 / t;
    let z = -d + x.abs() * slope;
    let p = if x > 0.0 {
        slope
    } else if x < 0.0 {
        -slope
    } else {
        0.0
    };
    (z, unit([-p, 0.0, 1.0]))
}

/// Sample a shape at the pixel centres of a `width` x `height` image: depth (NaN
/// outside), mask and exact unit normals (`[0, 0, 0]` outside).
pub fn shape_geometry(shape: &Shape, width: usize, height: usize) -> (DepthMap, Mask, NormalMap) {
    let mut depth = DepthMap::filled(width, height, f32::NAN);
    let mut mask = Mask::filled(width, height, false);
    let mut normals = NormalMap::filled(width, height, [0.0; 3]);
    for r in 0..height {
        for c in 0..width {
            let (x, y) = pixel_to_xy(r, c, width, height);
            if let Some((z, n)) = shape.eval(x, y) {
                let i = r * width + c;
                depth.data[i] = z as f32;
                mask.data[i] = true;
                normals.data[i] = [n[0] as f32, n[1] as f32, n[2] as f32];
            }
        }
    }
    (depth, mask, normals)
}
