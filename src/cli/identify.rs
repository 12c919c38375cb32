//! `fts identify <model>`: identification subcommands. Each variant's code
//! lives in its own file (`identify_<variant>.rs`).

use super::{identify_ct, identify_hysteresis, identify_linear};
use clap::Subcommand;

#[derive(Debug, Subcommand)]
pub enum IdentifyCommand {
    /// Identify a PI / MPI hysteresis model (or its inverse) from voltage/displacement data.
    Hysteresis(identify_hysteresis::HysteresisArgs),
    /// Continuous transfer function `e^(-s delay) B(s)/A(s)` from an input/output record (SRIVC).
    Ct(identify_ct::CtArgs),
    /// Continuous transfer function from a frequency response (Levy, Sanathanan-Koerner, Levenberg-Marquardt).
    CtFrd(identify_ct::CtFrdArgs),
    /// Linear models: `arx`, `oe`, `iv`, `arx-struct`.
    #[command(flatten)]
    Linear(identify_linear::IdentifyLinear),
}

pub fn run(cmd: IdentifyCommand) -> anyhow::Result<()> {
    match cmd {
        IdentifyCommand::Hysteresis(args) => identify_hysteresis::run(args),
        IdentifyCommand::Ct(args) => identify_ct::run(args),
        IdentifyCommand::CtFrd(args) => identify_ct::run_frd(args),
        IdentifyCommand::Linear(cmd) => identify_linear::run(cmd),
    }
}
