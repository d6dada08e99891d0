//! `photostereo bench` (to be written).

use crate::Global;

/// Arguments of `photostereo bench`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Run the subcommand.
pub fn run(_args: Args, _global: Global) -> anyhow::Result<()> {
    anyhow::bail!("`photostereo bench` is not available yet")
}
