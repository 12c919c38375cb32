//! Piezo hysteresis: play operators, Prandtl–Ishlinskii models and their
//! modified forms, their identification and their inverses (docs/math.md §1).
//!
//! * [`operators`] — lower and symmetric play, dead zone, threshold grids.
//! * [`model`] — [`HysteresisModel`], evaluated sample by sample with explicit state.
//! * [`identify`](mod@identify) — least squares (QR), gradient descent, alternating LS.
//! * [`inverse`] — the analytic inverse of a classical PI model.
//! * [`lsq`], [`gd`] — the solvers underneath.

pub mod gd;
pub mod identify;
pub mod inverse;
pub mod lsq;
pub mod model;
pub mod operators;
pub mod solve;

pub use identify::{
    Fit, Identified, IdentifyError, IdentifyInfo, IdentifyParams, Method, identify,
    identify_observed,
};
pub use inverse::{InverseError, analytic_inverse};
pub use model::{DeadZoneStage, HysteresisModel, ModelError, ModelKind, ModelState, RateStage};
pub use operators::PlayOperator;
pub use solve::{check_solvable, solve_inverse};
