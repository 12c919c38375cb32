//! Linear time-invariant systems: polynomials in `z^-1`, roots, transfer
//! functions, frequency response and filtering.

pub(crate) mod accurate;
pub mod balred;
pub mod c2d;
pub mod convert;
pub mod exact_response;
pub mod filter;
pub mod freqresp;
pub mod info;
pub mod lyapunov;
pub mod margins;
pub mod model_check;
pub mod norms;
pub mod poly;
pub mod response;
pub mod riccati;
pub mod roots;
/// Ordered (generalized) Schur forms (from the kernels crate, where they are
/// compiled once).
pub use fts_kernels::schur;
pub mod ss;
pub mod stability;
pub mod tf;
pub mod zeros;

/// Complex double, the same type faer uses (`faer::c64`); defined beside the
/// kernels that return it.
pub use fts_kernels::c64;

pub use filter::{TdfFilter, lsim};
pub use poly::Poly;
pub use roots::{RootsError, roots_descending};
pub use ss::{SsError, StateSpace};
pub use tf::{
    Bode, ContinuousTf, DiscreteTf, Minreal, TfError, TransferFunction, linspace, logspace,
};
pub use zeros::{Zeros, invariant_zeros};
