//! `photostereo demo` (to be written).

use crate::Global;

/// Arguments of `photostereo demo`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Run the subcommand.
pub fn run(_args: Args, _global: Global) -> anyhow::Result<()> {
    anyhow::bail!("`photostereo demo` is not available yet")
}
