//! The CLI's own advice on a library error: the flag that changes what the error is
//! about. The library says what is wrong and its fix in terms of the data and knows no
//! flags; its typed errors ([`Error::Setting`], [`Error::SphereNotFound`]) say which
//! setting is concerned, and this file names the flag for it.

use photostereo::error::Setting;
use photostereo::Error;

/// The flag advice for `err` (the first library error in its chain), if any.
pub fn advice(err: &anyhow::Error) -> Option<&'static str> {
    let lib = err.chain().find_map(|c| c.downcast_ref::<Error>())?;
    match lib.root() {
        Error::Setting { setting, .. } => setting_flag(*setting),
        Error::SphereNotFound { .. } => Some(
            "restrict the search with --sphere-region x,y,w,h or --sphere-mask FILE, or give the \
             circle with --circle cx,cy,r",
        ),
        _ => None,
    }
}

/// The flag of each setting the library names.
fn setting_flag(setting: Setting) -> Option<&'static str> {
    Some(match setting {
        Setting::Method => "give --sphere SPHERE_DIR (calibration-based) or --lambertian, one of them",
        Setting::Lambertian => "add --lambertian",
        Setting::LightsFile => {
            "--lights FILE: K lines `x y z`; leave --lights out to use the dataset's light_directions.txt"
        }
        Setting::Lights => "give --lights FILE or --chrome CHROME_DIR",
        Setting::ImageScale => "--image-scale F takes a finite factor > 0",
        Setting::Circle => "--circle cx,cy,r gives the circle by hand (pixels)",
        Setting::SphereSearch => {
            "give --sphere-region x,y,w,h around the sphere, its mask with --sphere-mask FILE, or \
             its circle with --circle cx,cy,r"
        }
        Setting::FacetBlock => "give a larger --block (pixels)",
        Setting::Memory => "set the budget with --memory SIZE (e.g. --memory 8G)",
        Setting::CurvatureScale => "--curvature-sigma PX takes pixels >= 0 (0 = no smoothing)",
        _ => return None,
    })
}

/// The advice printed after a sphere detection's warning (an uncertain circle).
pub const UNCERTAIN_CIRCLE: &str = "give the circle with --circle cx,cy,r";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_setting_error_gets_its_flag_through_context() {
        let lib = Error::setting(Setting::Circle, "circle", "outside the images");
        let err =
            anyhow::Error::new(lib.context("stage 'lookup table' failed")).context("calibrating");
        assert_eq!(
            advice(&err),
            Some("--circle cx,cy,r gives the circle by hand (pixels)")
        );
        let plain = anyhow::anyhow!("not a library error");
        assert_eq!(advice(&plain), None);
        let other = anyhow::Error::new(Error::invalid("x", "y"));
        assert_eq!(advice(&other), None);
    }
}
