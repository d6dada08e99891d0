//! `photostereo interreflect` (to be written).

use crate::Global;

/// Arguments of `photostereo interreflect`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Run the subcommand.
pub fn run(_args: Args, _global: Global) -> anyhow::Result<()> {
    anyhow::bail!("`photostereo interreflect` is not available yet")
}
