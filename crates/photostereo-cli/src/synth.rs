//! `photostereo synth` (to be written).

use crate::Global;

/// Arguments of `photostereo synth`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Run the subcommand.
pub fn run(_args: Args, _global: Global) -> anyhow::Result<()> {
    anyhow::bail!("`photostereo synth` is not available yet")
}
