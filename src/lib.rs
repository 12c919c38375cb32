//! # fts — identification and control of piezo-driven fast tool servos
//!
//! Every workflow of the `fts` command is a typed step in [`workflow`]:
//! settings that deserialise from a manifest (`fts.toml`) with documented
//! defaults, `validate()`, and `run(inputs) -> Result<Report, StepError>`
//! whose report serialises (the `--json` output) and displays (the summary).
//! A Rust user calls the same steps the command line and `fts build` call:
//!
//! ```
//! use fts::{DesignZpetc, DiscreteTf};
//! // \[Li21\] Eq. 11, the closed loop of PID + hysteresis compensation.
//! let closed_loop = DiscreteTf::new(
//!     vec![4.154, -9.631, 10.23, -5.511, 1.154],
//!     vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
//!     5,
//!     1e-4,
//! )?;
//! let report = DesignZpetc::default().design(&closed_loop, "Li21 Eq. 11")?;
//! assert!(report.check.max_phase_error_rad < 1e-9);
//! println!("{report}"); // zero map, preview, coefficients, self-check
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The steps, by stage of the engineer's pipeline:
//!
//! | stage | steps |
//! |---|---|
//! | hysteresis | [`IdentifyHysteresis`] (PI, MPI cube-root and dead-zone; least squares or gradient descent; the inverse) |
//! | linear models | [`IdentifyArx`], [`IdentifyOe`], [`IdentifyIv`], [`ArxStruct`] (records prepared, fit %, delay and order selection) |
//! | feedforward | [`DesignZpetc`] |
//! | feedback | [`Weight`], [`Mixsyn`], [`Hinf`], [`H2`], [`C2d`]; margins and sensitivities in [`lti::margins`] |
//! | studies | [`Ding22Study`] (the \[Ding22\] two-mass FTS: H2 design against a PID tuned for the same cost, error budget, structural sweep) |
//! | judging a design | [`workflow::response::Response`] (step/impulse, `stepinfo`), [`workflow::convert`] (tf/ss/zpk, minreal, balred, d2c) |
//! | virtual records | [`VirtualTriangles`], [`VirtualSweep`] (the \[Li21\] open-loop triangles and closed-loop sweep on the embedded virtual FTS) |
//! | simulation | [`Simulate`] (a tracking run: the runtime's controller from a coefficient file or stages, on the virtual FTS or a linear model; tracking and step figures, divergence named), [`sim::closed_loop`] (any plant, the runtime's controller), [`sim::virtual_fts`] (the embedded virtual FTS), [`sim::experiment`] (the \[Li21\] study) |
//! | deployment | [`BuildController`] (the coefficient file: PID, [`SsController`] or no feedback, after ZPETC and inverse hysteresis), [`io::controller_file::ControllerFile`] (the `fts.controller/1` file and C header), [`runtime`] (the allocation-free step, `no_std`) |
//!
//! Underneath: [`lti`] (polynomials in `z^-1`, transfer functions, state
//! space, Riccati and Lyapunov solvers, norms), [`ident`] (the estimators),
//! [`synth`] (the synthesis algorithms), [`io`] (the file contracts of
//! `docs/formats.md`, parsed from text) and [`pipeline`] (`fts build`:
//! manifests, content hashes, the lock file).
//!
//! Conventions: discrete polynomials are stored in ascending powers of
//! `z^-1` and a pure delay is always a separate integer field; frequencies
//! are in Hz unless a name says rad/s.

/// The command line (`fts ...`): flags into steps, reports rendered, exit
/// codes. Not part of the library's API.
#[doc(hidden)]
pub mod cli;
pub mod ident;
/// The checks of the library's private parts, run by the integration suite
/// (`tests/suite/checks.rs`); compiled only with the `checks` feature.
#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod internal_checks;
pub mod io;
pub mod lti;
pub mod pipeline;
/// The controller step: the `fts-runtime` crate (`crates/fts-runtime`),
/// re-exported so that `fts::runtime::...` paths keep working.
pub use fts_runtime as runtime;
pub mod sim;
pub mod synth;
pub mod workflow;

pub use io::InputError;
pub use io::controller_file::ControllerFile;
pub use lti::{ContinuousTf, DiscreteTf, Poly, StateSpace, TransferFunction};
pub use runtime::RuntimeController;
pub use workflow::{
    ArxStruct, BuildController, C2d, DesignZpetc, Ding22Study, H2, Hinf, IdentifyArx,
    IdentifyHysteresis, IdentifyIv, IdentifyOe, Mixsyn, Simulate, SsController, StepError,
    Validate, VirtualSweep, VirtualTriangles, Weight,
};
