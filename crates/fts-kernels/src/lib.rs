//! fts's dense numerical kernels, behind functions of concrete types.
//!
//! faer's decompositions and rustfft's planner are generic: every crate
//! that calls them compiles its own copy. fts calls them only through this
//! crate, so they are compiled once, optimised, whichever profile builds
//! fts, and not again whenever fts's own code changes. The numerical content is
//! fts's: the ordered Schur forms ([`schur`]), thin wrappers of faer's
//! decompositions ([`dense`]) and of a planned real FFT ([`fft`]). One
//! module is faer's own code: its multishift QR algorithm for the real
//! Schur form (`multishift_qr`, private in faer; provenance and licence in
//! that file and `LICENSE-faer`).

pub mod dense;
pub mod fft;
mod multishift_qr;
pub mod schur;

/// Complex double, the same type faer uses (`faer::c64`).
#[allow(non_camel_case_types)]
pub type c64 = num_complex::Complex<f64>;
