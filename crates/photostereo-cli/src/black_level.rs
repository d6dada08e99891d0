//! `--black-level auto|none|LEVEL`, the camera's black level of a Lambertian solve: one
//! parser and one help text for `normals --lambertian` and `run --lambertian`, so that
//! both accept the same values and refuse the others with the same message. What is
//! done with the choice (and the rule that takes a measured level) is the library's
//! ([`photostereo::lambertian::BlackLevelChoice`]).

use anyhow::bail;
use photostereo::lambertian::{BlackLevelChoice, MAX_BLACK_LEVEL};

/// The flag's help text, shared by the subcommands that take it.
macro_rules! help_text {
    () => {
        "The camera's black level, taken off every sample before the Lambertian fit: `auto` \
         (the default: measured from the images and taken off when clearly above 0; a line \
         says what was found), `none`, or a level as a fraction of full scale (e.g. 0.03). A \
         dark offset reads as light no normal explains."
    };
}

/// The flag's help in `normals`.
pub const HELP: &str = help_text!();

/// The flag's help in `run`, which also removes interreflections.
pub const RUN_HELP: &str = concat!(
    help_text!(),
    " With --interreflections `auto` measures nothing (bounced light reads as an offset): \
     give the camera's level."
);

/// The choice of `--black-level TEXT` (`None`: the flag not given, i.e. `auto`).
///
/// Errors: a text that is neither `auto`, `none` nor a level in [0, 0.25): the message
/// names the flag, the value and what it takes.
pub fn parse(text: Option<&str>) -> anyhow::Result<BlackLevelChoice> {
    let choice = match text.unwrap_or("auto") {
        "auto" => BlackLevelChoice::Auto,
        "none" => BlackLevelChoice::None,
        level => match level.parse::<f32>() {
            Ok(v) if BlackLevelChoice::Given(v).check().is_ok() => BlackLevelChoice::Given(v),
            _ => bail!(
                "--black-level {level}: give auto, none, or a level in [0, {MAX_BLACK_LEVEL}) \
                 as a fraction of full scale (e.g. 0.03)"
            ),
        },
    };
    Ok(choice)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_auto_none_and_a_level_and_names_the_flag_otherwise() {
        assert_eq!(parse(None).unwrap(), BlackLevelChoice::Auto);
        assert_eq!(parse(Some("auto")).unwrap(), BlackLevelChoice::Auto);
        assert_eq!(parse(Some("none")).unwrap(), BlackLevelChoice::None);
        assert_eq!(parse(Some("0.03")).unwrap(), BlackLevelChoice::Given(0.03));
        for bad in ["bogus", "0.25", "-0.01", "NaN", "inf", ""] {
            let err = parse(Some(bad)).unwrap_err().to_string();
            assert!(
                err.starts_with(&format!("--black-level {bad}:")) && err.contains("auto, none"),
                "{bad}: {err}"
            );
        }
    }
}
