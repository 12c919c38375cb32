//! Ordered (generalized) Schur forms.
//!
//! faer 0.24 keeps its Schur drivers private but exposes the building
//! blocks of the QZ algorithm (`generalized_hessenberg`,
//! `qz_cplx::hessenberg_to_qz`). We compute the *complex* generalized Schur
//! form `M = Q S Z^H`, `L = Q T Z^H` (S, T upper triangular; Moler & Stewart
//! 1973) of real pencils and reorder it by adjacent swaps with unitary
//! rotations (Van Dooren 1981; the 1x1 case of LAPACK `ztgexc`/`ztgex2`,
//! Kågström 1993). Working in complex arithmetic means every diagonal block
//! is 1x1, so each swap is exact up to rounding and needs no 2x2 Sylvester
//! solve (the real Bai–Demmel swap). The invariant subspaces we extract are
//! those of real pencils, so their spans are real; callers take real parts
//! of the final results and refine them (Newton) in real arithmetic.
//!
//! The ordinary Schur form of `A` is the special case `L = I`.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c64;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::evd::ComputeEigenvectors;
use faer::linalg::gevd::{GeneralizedSchurParams, gen_hessenberg, qz_cplx};
use faer::{Mat, Par};
use thiserror::Error;

/// Errors of the Schur-form routines.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SchurError {
    /// Input has NaN or infinite entries.
    #[error("matrix has non-finite entries")]
    NonFinite,
    /// Input is not square or the two matrices differ in size.
    #[error("Schur form needs square matrices of equal size")]
    Dimension,
}

/// Complex generalized Schur form `M = Q S Z^H`, `L = Q T Z^H`.
#[derive(Debug, Clone)]
pub struct GenSchur {
    /// Upper triangular S.
    pub s: Mat<c64>,
    /// Upper triangular T.
    pub t: Mat<c64>,
    /// Unitary left factor.
    pub q: Mat<c64>,
    /// Unitary right factor.
    pub z: Mat<c64>,
}

fn cplx(m: &Mat<f64>) -> Mat<c64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| c64::new(m[(i, j)], 0.0))
}

/// Generalized Schur form of the real pencil `(M, L)` (QZ).
pub fn gen_schur(m: &Mat<f64>, l: &Mat<f64>) -> Result<GenSchur, SchurError> {
    let n = m.nrows();
    if m.ncols() != n || l.nrows() != n || l.ncols() != n {
        return Err(SchurError::Dimension);
    }
    if !(m.is_all_finite() && l.is_all_finite()) {
        return Err(SchurError::NonFinite);
    }
    if n == 0 {
        return Ok(GenSchur {
            s: Mat::zeros(0, 0),
            t: Mat::zeros(0, 0),
            q: Mat::zeros(0, 0),
            z: Mat::zeros(0, 0),
        });
    }
    // Step 1: L = Q0 R (Householder QR), M <- Q0^H M.
    let lc = cplx(l);
    let qr = lc.qr();
    let q0 = qr.compute_Q();
    let mut t = Mat::from_fn(n, n, |i, j| {
        if i <= j {
            qr.R()[(i, j)]
        } else {
            c64::new(0.0, 0.0)
        }
    });
    let mut s = q0.adjoint() * cplx(m);
    let mut q = q0;
    let mut z = Mat::<c64>::identity(n, n);
    // Step 2: Hessenberg-triangular reduction, then QZ iterations.
    let hparams: gen_hessenberg::GeneralizedHessenbergParams = faer::auto!(c64);
    let sparams: GeneralizedSchurParams = faer::auto!(c64);
    let req = StackReq::any_of(&[
        gen_hessenberg::generalized_hessenberg_scratch::<c64>(n, hparams),
        qz_cplx::hessenberg_to_qz_scratch::<c64>(n, Par::Seq, sparams),
    ]);
    let mut buf = MemBuffer::new(req);
    let stack = MemStack::new(&mut buf);
    gen_hessenberg::generalized_hessenberg(
        s.as_mut(),
        t.as_mut(),
        Some(q.as_mut()),
        Some(z.as_mut()),
        Par::Seq,
        stack,
        hparams,
    );
    let mut alpha = Mat::<c64>::zeros(n, 1);
    let mut beta = Mat::<c64>::zeros(n, 1);
    qz_cplx::hessenberg_to_qz(
        s.as_mut(),
        t.as_mut(),
        Some(q.as_mut()),
        Some(z.as_mut()),
        alpha.col_mut(0),
        beta.col_mut(0),
        ComputeEigenvectors::Yes,
        Par::Seq,
        sparams,
        stack,
    );
    for j in 0..n {
        for i in j + 1..n {
            s[(i, j)] = c64::new(0.0, 0.0);
            t[(i, j)] = c64::new(0.0, 0.0);
        }
    }
    if !(s.is_all_finite() && t.is_all_finite()) {
        return Err(SchurError::NonFinite);
    }
    Ok(GenSchur { s, t, q, z })
}

/// A unitary 2x2 rotation `[[c, -conj(s)], [s, conj(c)]]` whose first column is `v/|v|`.
fn rot_from(v0: c64, v1: c64) -> Option<(c64, c64)> {
    let nrm = (v0.norm_sqr() + v1.norm_sqr()).sqrt();
    (nrm > 0.0 && nrm.is_finite()).then(|| (v0 / nrm, v1 / nrm))
}

/// `X[:, k..k+2] <- X[:, k..k+2] G`, rows `r0..r1`.
fn rot_cols(x: &mut Mat<c64>, k: usize, c: c64, s: c64, r0: usize, r1: usize) {
    for i in r0..r1 {
        let a = x[(i, k)];
        let b = x[(i, k + 1)];
        x[(i, k)] = a * c + b * s;
        x[(i, k + 1)] = -a * s.conj() + b * c.conj();
    }
}

/// `X[k..k+2, :] <- G^H X[k..k+2, :]`, columns `c0..c1`.
fn rot_rows_h(x: &mut Mat<c64>, k: usize, c: c64, s: c64, c0: usize, c1: usize) {
    for j in c0..c1 {
        let a = x[(k, j)];
        let b = x[(k + 1, j)];
        x[(k, j)] = c.conj() * a + s.conj() * b;
        x[(k + 1, j)] = -s * a + c * b;
    }
}

impl GenSchur {
    /// Dimension.
    pub fn n(&self) -> usize {
        self.s.nrows()
    }

    /// Generalized eigenvalues as `(alpha_i, beta_i)` (`lambda = alpha/beta`).
    pub fn pairs(&self) -> Vec<(c64, c64)> {
        (0..self.n())
            .map(|i| (self.s[(i, i)], self.t[(i, i)]))
            .collect()
    }

    /// Swaps the adjacent 1x1 blocks `k` and `k+1` (Van Dooren 1981):
    /// a right rotation onto the eigenvector of the trailing eigenvalue,
    /// then a left rotation restoring triangularity.
    pub fn swap(&mut self, k: usize) {
        let n = self.n();
        let (a11, a12, a22) = (self.s[(k, k)], self.s[(k, k + 1)], self.s[(k + 1, k + 1)]);
        let (b11, b12, b22) = (self.t[(k, k)], self.t[(k, k + 1)], self.t[(k + 1, k + 1)]);
        // (b22 A - a22 B) x = 0 on the 2x2 block: the block is [[m11, m12], [0, 0]].
        let m11 = b22 * a11 - a22 * b11;
        let m12 = b22 * a12 - a22 * b12;
        let Some((c, s)) = rot_from(m12, -m11) else {
            return; // equal eigenvalues: nothing to swap
        };
        rot_cols(&mut self.s, k, c, s, 0, k + 2);
        rot_cols(&mut self.t, k, c, s, 0, k + 2);
        rot_cols(&mut self.z, k, c, s, 0, n);
        // A x and B x are parallel: use the larger for the left rotation.
        let (u0, u1) = (self.s[(k, k)], self.s[(k + 1, k)]);
        let (v0, v1) = (self.t[(k, k)], self.t[(k + 1, k)]);
        let (w0, w1) = if u0.norm_sqr() + u1.norm_sqr() >= v0.norm_sqr() + v1.norm_sqr() {
            (u0, u1)
        } else {
            (v0, v1)
        };
        if let Some((c, s)) = rot_from(w0, w1) {
            rot_rows_h(&mut self.s, k, c, s, k, n);
            rot_rows_h(&mut self.t, k, c, s, k, n);
            rot_cols(&mut self.q, k, c, s, 0, n);
        }
        self.s[(k + 1, k)] = c64::new(0.0, 0.0);
        self.t[(k + 1, k)] = c64::new(0.0, 0.0);
    }

    /// Moves every eigenvalue with `select(alpha, beta)` to the leading
    /// positions (keeping relative order) and returns how many were selected.
    pub fn reorder(&mut self, select: impl Fn(c64, c64) -> bool) -> usize {
        let mut ks = 0;
        for j in 0..self.n() {
            if select(self.s[(j, j)], self.t[(j, j)]) {
                let mut i = j;
                while i > ks {
                    self.swap(i - 1);
                    i -= 1;
                }
                ks += 1;
            }
        }
        ks
    }
}

/// Complex Schur form of a real matrix: `A = U R U^H`, `R` upper triangular.
pub fn schur(a: &Mat<f64>) -> Result<(Mat<c64>, Mat<c64>), SchurError> {
    let n = a.nrows();
    let gs = gen_schur(a, &Mat::identity(n, n))?;
    // L = I = Q T Z^H makes T = Q^H Z unitary and triangular, hence diagonal:
    // A = Q (S T^H) Q^H. Recompute R = Q^H A Q directly and drop round-off below the diagonal.
    let u = gs.q;
    let mut r = u.adjoint() * cplx(a) * &u;
    for j in 0..n {
        for i in j + 1..n {
            r[(i, j)] = c64::new(0.0, 0.0);
        }
    }
    Ok((u, r))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(a: &Mat<c64>, b: &Mat<c64>) -> f64 {
        (a - b).norm_l2()
    }

    #[test]
    fn pencil_reordering_keeps_the_factorisation() {
        let n = 7;
        let m = Mat::from_fn(n, n, |i, j| {
            ((i * 7 + j * 3) % 11) as f64 - 5.0 + (i == j) as u8 as f64
        });
        let l = Mat::from_fn(n, n, |i, j| {
            if i == j {
                2.0
            } else {
                ((i + 2 * j) % 5) as f64 * 0.1
            }
        });
        let mut gs = gen_schur(&m, &l).unwrap();
        let check = |gs: &GenSchur| {
            let e1 = dist(&(&gs.q * &gs.s * gs.z.adjoint()), &cplx(&m));
            let e2 = dist(&(&gs.q * &gs.t * gs.z.adjoint()), &cplx(&l));
            assert!(e1 < 1e-12 * 50.0 && e2 < 1e-12 * 50.0, "{e1} {e2}");
        };
        check(&gs);
        let k = gs.reorder(|a, b| (a / b).re < 0.0);
        check(&gs);
        for (i, (a, b)) in gs.pairs().into_iter().enumerate() {
            assert_eq!((a / b).re < 0.0, i < k);
        }
    }

    #[test]
    fn schur_of_rotation() {
        let a = Mat::from_fn(2, 2, |i, j| [[0.0, 1.0], [-1.0, 0.0]][i][j]);
        let (u, r) = schur(&a).unwrap();
        let back = &u * &r * u.adjoint();
        assert!(dist(&back, &cplx(&a)) < 1e-14);
        assert!((r[(0, 0)].norm() - 1.0).abs() < 1e-14);
    }
}
