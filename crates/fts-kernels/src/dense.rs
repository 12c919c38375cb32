//! faer's dense decompositions for `f64` (and `c64` where fts needs them),
//! behind functions of concrete types (see the crate's documentation).
//! Each is the faer call of the same name; the results are faer's types.

use crate::c64;
use faer::linalg::evd::EvdError;
use faer::linalg::solvers::DenseSolveCore;
use faer::linalg::solvers::{ColPivQr, Eigen, SelfAdjointEigen, Svd};
use faer::linalg::svd::SvdError;
use faer::prelude::Solve;
use faer::{Mat, MatRef, Side};

/// Singular values of `m`, in faer's order (descending).
pub fn singular_values(m: MatRef<'_, f64>) -> Result<Vec<f64>, SvdError> {
    m.singular_values()
}

/// Singular values of a complex `m`, in faer's order (descending).
pub fn singular_values_c64(m: MatRef<'_, c64>) -> Result<Vec<f64>, SvdError> {
    m.singular_values()
}

/// The full SVD `m = U S V^T`.
pub fn svd(m: MatRef<'_, f64>) -> Result<Svd<f64>, SvdError> {
    m.svd()
}

/// Eigenvalues of a real square `m`.
pub fn eigenvalues(m: MatRef<'_, f64>) -> Result<Vec<c64>, EvdError> {
    m.eigenvalues()
}

/// Eigenvalues and eigenvectors of a real square `m`.
pub fn eigen(m: MatRef<'_, f64>) -> Result<Eigen<f64>, EvdError> {
    m.eigen()
}

/// Eigen-decomposition of a symmetric `m` read from its `side` triangle.
pub fn self_adjoint_eigen(
    m: MatRef<'_, f64>,
    side: Side,
) -> Result<SelfAdjointEigen<f64>, EvdError> {
    m.self_adjoint_eigen(side)
}

/// `m^-1` by LU with partial pivoting (non-finite where `m` is singular;
/// callers check).
pub fn lu_inverse(m: MatRef<'_, f64>) -> Mat<f64> {
    m.partial_piv_lu().inverse()
}

/// `X` with `m X = b`, by LU with partial pivoting.
pub fn lu_solve(m: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    m.partial_piv_lu().solve(b)
}

/// `X` with `m X = b` for complex `m`, `b`, by LU with partial pivoting.
pub fn lu_solve_c64(m: MatRef<'_, c64>, b: MatRef<'_, c64>) -> Mat<c64> {
    m.partial_piv_lu().solve(b)
}

/// A column-pivoted QR factorisation, kept for several solves.
pub struct ColPivQrSolver {
    qr: ColPivQr<f64>,
}

impl ColPivQrSolver {
    /// Factors `m`.
    pub fn new(m: MatRef<'_, f64>) -> Self {
        ColPivQrSolver { qr: m.col_piv_qr() }
    }

    /// The least-squares solution of `m X = rhs`.
    pub fn solve(&self, rhs: MatRef<'_, f64>) -> Mat<f64> {
        self.qr.solve(rhs)
    }
}

/// The LU factors (partial pivoting) of a complex matrix, for
/// [`lu_c64_solve`]: one factorisation, many right-hand sides.
pub fn lu_c64(m: MatRef<'_, c64>) -> faer::linalg::solvers::PartialPivLu<c64> {
    m.partial_piv_lu()
}

/// `M^-1 B` from [`lu_c64`]'s factors of `M`.
pub fn lu_c64_solve(lu: &faer::linalg::solvers::PartialPivLu<c64>, b: MatRef<'_, c64>) -> Mat<c64> {
    use faer::linalg::solvers::Solve;
    lu.solve(b)
}
