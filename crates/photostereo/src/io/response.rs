//! The camera response: how the stored values of a light image relate to the light
//! that made them. Photometric stereo needs values proportional to the light
//! (Lambertian least squares, light calibration); camera JPEGs are sRGB-encoded, so
//! they are linearised on reading.

use crate::error::{Error, Result};
use image::ImageFormat;
use std::fmt;
use std::str::FromStr;

/// The response curve of the light images (see the [module docs](self)).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Response {
    /// sRGB for JPEG files, linear for everything else (PNG, TIFF, float TIFF).
    #[default]
    Auto,
    /// Values are proportional to the light (raw-converted 16-bit PNG/TIFF, renders).
    Linear,
    /// sRGB encoding (IEC 61966-2-1): v ≤ 0.04045 → v/12.92, else ((v+0.055)/1.055)^2.4.
    Srgb,
    /// A pure power law: linear = v^G (G = 2.2 for many cameras' "gamma" setting).
    Gamma(f32),
}

impl Response {
    /// The curve for a file of `format`: [`Response::Auto`] resolved (sRGB for JPEG).
    pub fn resolve(self, format: Option<ImageFormat>) -> Response {
        match self {
            Response::Auto if format == Some(ImageFormat::Jpeg) => Response::Srgb,
            Response::Auto => Response::Linear,
            r => r,
        }
    }

    /// Linear value of an encoded value `v` in [0, 1].
    #[inline]
    pub fn linearize(self, v: f32) -> f32 {
        match self {
            Response::Auto | Response::Linear => v,
            Response::Srgb => {
                if v <= 0.04045 {
                    v / 12.92
                } else {
                    ((v + 0.055) / 1.055).powf(2.4)
                }
            }
            Response::Gamma(g) => v.max(0.0).powf(g),
        }
    }

    /// The linear value of each integer code 0..=`full` (a lookup table).
    pub(crate) fn table(self, full: u32) -> Vec<f32> {
        let f = full as f32;
        (0..=full).map(|k| self.linearize(k as f32 / f)).collect()
    }

    /// Check a [`Response::Gamma`] exponent: finite, in (0, 10].
    pub fn check(self) -> Result<Self> {
        match self {
            Response::Gamma(g) if !(g.is_finite() && g > 0.0 && g <= 10.0) => Err(Error::invalid(
                format!("response gamma {g}"),
                "use an exponent in (0, 10], e.g. 2.2",
            )),
            r => Ok(r),
        }
    }
}

impl fmt::Display for Response {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Response::Auto => write!(f, "auto"),
            Response::Linear => write!(f, "linear"),
            Response::Srgb => write!(f, "srgb"),
            Response::Gamma(g) => write!(f, "gamma={g}"),
        }
    }
}

impl FromStr for Response {
    type Err = Error;

    /// `auto`, `linear`, `srgb` or `gamma=G`.
    fn from_str(s: &str) -> Result<Self> {
        let lower = s.trim().to_ascii_lowercase();
        let r = match lower.as_str() {
            "auto" => Response::Auto,
            "linear" => Response::Linear,
            "srgb" => Response::Srgb,
            other => match other.strip_prefix("gamma=").map(str::parse::<f32>) {
                Some(Ok(g)) => Response::Gamma(g),
                _ => {
                    return Err(Error::invalid(
                        format!("response `{s}`"),
                        "use linear, srgb, gamma=G (e.g. gamma=2.2) or auto",
                    ))
                }
            },
        };
        r.check()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_the_standard_encoding() {
        for k in 0..=255u32 {
            let lin = Response::Srgb.linearize(k as f32 / 255.0);
            // the standard encoder
            let enc = if lin <= 0.0031308 {
                12.92 * lin
            } else {
                1.055 * lin.powf(1.0 / 2.4) - 0.055
            };
            assert!((enc * 255.0 - k as f32).abs() < 1e-3, "{k}: {enc}");
        }
        assert_eq!(Response::Srgb.linearize(1.0), 1.0);
        assert_eq!(Response::Gamma(2.2).linearize(0.5), 0.5f32.powf(2.2));
    }

    #[test]
    fn parsing_and_printing_agree() {
        for s in ["auto", "linear", "srgb", "gamma=2.2"] {
            assert_eq!(s.parse::<Response>().unwrap().to_string(), s);
        }
        assert_eq!("SRGB".parse::<Response>().unwrap(), Response::Srgb);
        for bad in ["gamma=0", "gamma=x", "log", "gamma=-1"] {
            assert!(bad.parse::<Response>().is_err(), "{bad}");
        }
        assert_eq!(
            Response::Auto.resolve(Some(ImageFormat::Jpeg)),
            Response::Srgb
        );
        assert_eq!(
            Response::Auto.resolve(Some(ImageFormat::Png)),
            Response::Linear
        );
        assert_eq!(
            Response::Gamma(2.0).resolve(Some(ImageFormat::Png)),
            Response::Gamma(2.0)
        );
    }
}
