//! # fts — identification and control of piezo-driven fast tool servos
//!
//! The library is the product; the `fts` binary is a thin shell over [`cli`].
//! Modules follow the engineer's pipeline:
//!
//! * [`lti`] — polynomials in `z^-1`, discrete and continuous transfer functions,
//!   polynomial roots, filtering.
//! * [`ident`] — identification from measured data (fit metrics, least squares, models).
//! * [`synth`] — controller and feedforward synthesis (ZPETC, ...).
//! * [`io`] — the file contracts of `docs/formats.md` (CSV time series,
//!   `fts.tf/1`, ...), parsed from text so that callers decide where bytes come from.
//! * [`pipeline`] — pipeline manifests (`fts.toml`) and `fts build`: steps in
//!   dependency order, rebuilt when the content hash of an input or setting
//!   changes, atomic writes, the lock file.
//! * [`cli`] — the command line: the only module that knows about paths,
//!   exit codes and `anyhow`.
//!
//! Conventions: discrete polynomials are stored in ascending powers of `z^-1`
//! and a pure delay is always a separate integer field.

pub mod cli;
pub mod ident;
pub mod io;
pub mod lti;
pub mod pipeline;
/// The controller step: the `fts-runtime` crate (`crates/fts-runtime`),
/// re-exported so that `fts::runtime::...` paths keep working.
pub use fts_runtime as runtime;
pub mod sim;
pub mod synth;
pub mod workflow;
