//! Sylvester and Lyapunov equations by the Bartels–Stewart method
//! (Bartels & Stewart 1972, CACM 15(9)): reduce the coefficient matrices to
//! (complex) Schur form, solve the triangular equation column by column,
//! transform back. Each solver returns its relative residual.
//!
//! * continuous Sylvester `A X + X B + C = 0`, Lyapunov `A X + X A' + Q = 0`;
//! * discrete (Stein) `A X B - X + C = 0`, `A X A' - X + Q = 0`.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c64;
use super::schur::{SchurError, schur};
use super::ss::{fro, tr};
use faer::Mat;
use thiserror::Error;

/// Errors of the matrix-equation solvers.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MatEqError {
    /// Dimensions do not fit.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// The equation has no unique solution.
    #[error("no unique solution: {0}")]
    Singular(String),
    /// The Schur decomposition failed.
    #[error(transparent)]
    Schur(#[from] SchurError),
}

/// A solution and its relative residual (Frobenius norms).
#[derive(Debug, Clone)]
pub struct MatEqSolution {
    /// The solution.
    pub x: Mat<f64>,
    /// `||residual|| / (sum of the norms of the terms)`.
    pub residual: f64,
}

fn cplx(m: &Mat<f64>) -> Mat<c64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| c64::new(m[(i, j)], 0.0))
}

/// Solves the upper-triangular system `(T + shift I) y = rhs` in place, `T` scaled by `tscale`.
fn tri_solve(t: &Mat<c64>, tscale: c64, shift: c64, rhs: &mut [c64], tol: f64) -> Result<(), ()> {
    let n = rhs.len();
    for i in (0..n).rev() {
        let mut s = rhs[i];
        for j in i + 1..n {
            s -= tscale * t[(i, j)] * rhs[j];
        }
        let d = tscale * t[(i, i)] + shift;
        if d.norm() <= tol {
            return Err(());
        }
        rhs[i] = s / d;
    }
    Ok(())
}

fn check_sizes(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>) -> Result<(), MatEqError> {
    if a.nrows() != a.ncols() || b.nrows() != b.ncols() {
        return Err(MatEqError::Dimension("A and B must be square".into()));
    }
    if c.nrows() != a.nrows() || c.ncols() != b.nrows() {
        return Err(MatEqError::Dimension(format!(
            "C is {}x{}, expected {}x{}",
            c.nrows(),
            c.ncols(),
            a.nrows(),
            b.nrows()
        )));
    }
    Ok(())
}

/// Shared Bartels–Stewart core; `discrete` selects `A X B - X + C = 0`.
/// The triangular solve is followed by iterative refinement (Golub, Nash &
/// Van Loan 1979): the residual is recomputed from the original data in
/// real arithmetic and the equation solved again for the correction,
/// reusing the Schur forms, while that lowers the residual. Strongly
/// non-normal coefficients (`||A|| >> rho(A)`, as in the closed loops of
/// nearly unstabilisable Riccati problems) otherwise leave residuals of
/// 1e-9 and worse, which would stall the Newton refinement of CARE/DARE.
fn bartels_stewart(
    a: &Mat<f64>,
    b: &Mat<f64>,
    c: &Mat<f64>,
    discrete: bool,
) -> Result<Mat<f64>, MatEqError> {
    check_sizes(a, b, c)?;
    let (n, m) = (a.nrows(), b.nrows());
    if n == 0 || m == 0 {
        return Ok(Mat::zeros(n, m));
    }
    let (ua, ta) = schur(a)?;
    let (ub, tb) = schur(b)?;
    let scale = fro(a).max(fro(b)).max(1e-300);
    let tol = 1e-14 * scale.max(if discrete { 1.0 } else { 0.0 });
    let solve = |c: &Mat<f64>| -> Result<Mat<f64>, MatEqError> {
        let ct = ua.adjoint() * cplx(c) * &ub;
        triangular(&ta, &tb, &ct, discrete, tol).map(|y| {
            let x = &ua * &y * ub.adjoint();
            Mat::from_fn(n, m, |i, j| x[(i, j)].re)
        })
    };
    // Residual of the equation at X and the sum of the norms of its terms.
    let residual = |x: &Mat<f64>| -> (Mat<f64>, f64) {
        if discrete {
            let axb = a * x * b;
            let r = &(&axb - x) + c;
            let den = fro(&axb) + fro(x) + fro(c);
            (r, den)
        } else {
            let (ax, xb) = (a * x, x * b);
            let r = &(&ax + &xb) + c;
            let den = fro(&ax) + fro(&xb) + fro(c);
            (r, den)
        }
    };
    let mut x = solve(c)?;
    if !x.is_all_finite() {
        return Err(MatEqError::Singular("solution overflowed".into()));
    }
    let (mut r, den) = residual(&x);
    let mut err = fro(&r);
    for _ in 0..4 {
        if !(err > 8.0 * f64::EPSILON * den) {
            break;
        }
        let Ok(dx) = solve(&r) else { break };
        let xn = &x + &dx;
        let (rn, _) = residual(&xn);
        let errn = fro(&rn);
        if !(errn < 0.5 * err) {
            if errn < err {
                x = xn;
            }
            break;
        }
        (x, r, err) = (xn, rn, errn);
    }
    if !x.is_all_finite() {
        return Err(MatEqError::Singular("solution overflowed".into()));
    }
    Ok(x)
}

/// The triangular equation `Ta Y Tb - Y + C~ = 0` (discrete) or
/// `Ta Y + Y Tb + C~ = 0`, column by column.
fn triangular(
    ta: &Mat<c64>,
    tb: &Mat<c64>,
    ct: &Mat<c64>,
    discrete: bool,
    tol: f64,
) -> Result<Mat<c64>, MatEqError> {
    let (n, m) = (ta.nrows(), tb.nrows());
    let mut y = Mat::<c64>::zeros(n, m);
    let mut col = vec![c64::new(0.0, 0.0); n];
    for k in 0..m {
        // Column k of the triangular equation (Tb upper triangular).
        for (i, v) in col.iter_mut().enumerate() {
            *v = -ct[(i, k)];
        }
        if discrete {
            // Ta (sum_{j<k} y_j Tb_jk) moved to the right-hand side.
            let mut acc = vec![c64::new(0.0, 0.0); n];
            for j in 0..k {
                let t = tb[(j, k)];
                for (i, v) in acc.iter_mut().enumerate() {
                    *v += y[(i, j)] * t;
                }
            }
            for i in 0..n {
                let mut s = c64::new(0.0, 0.0);
                for (l, v) in acc.iter().enumerate().skip(i) {
                    s += ta[(i, l)] * v;
                }
                col[i] -= s;
            }
            tri_solve(ta, tb[(k, k)], c64::new(-1.0, 0.0), &mut col, tol).map_err(|_| {
                MatEqError::Singular(
                    "an eigenvalue of A times one of B equals 1 (reciprocal eigenvalues)".into(),
                )
            })?;
        } else {
            for j in 0..k {
                let t = tb[(j, k)];
                for (i, v) in col.iter_mut().enumerate() {
                    *v -= y[(i, j)] * t;
                }
            }
            tri_solve(ta, c64::new(1.0, 0.0), tb[(k, k)], &mut col, tol)
                .map_err(|_| MatEqError::Singular("A and -B have a common eigenvalue".into()))?;
        }
        for (i, v) in col.iter().enumerate() {
            y[(i, k)] = *v;
        }
    }
    Ok(y)
}

fn rel(res: &Mat<f64>, terms: &[f64]) -> f64 {
    let den: f64 = terms.iter().sum();
    if den == 0.0 { fro(res) } else { fro(res) / den }
}

/// `A X + X B + C = 0`.
pub fn sylvester(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>) -> Result<MatEqSolution, MatEqError> {
    let x = bartels_stewart(a, b, c, false)?;
    let (ax, xb) = (a * &x, &x * b);
    let residual = rel(&(&(&ax + &xb) + c), &[fro(&ax), fro(&xb), fro(c)]);
    Ok(MatEqSolution { x, residual })
}

/// `A X B - X + C = 0`.
pub fn dsylvester(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>) -> Result<MatEqSolution, MatEqError> {
    let x = bartels_stewart(a, b, c, true)?;
    let axb = a * &x * b;
    let residual = rel(&(&(&axb - &x) + c), &[fro(&axb), fro(&x), fro(c)]);
    Ok(MatEqSolution { x, residual })
}

fn symmetrise(x: &Mat<f64>) -> Mat<f64> {
    Mat::from_fn(x.nrows(), x.ncols(), |i, j| 0.5 * (x[(i, j)] + x[(j, i)]))
}

/// Continuous Lyapunov `A X + X A' + Q = 0` (solution symmetrised; `Q` must be symmetric).
pub fn lyap(a: &Mat<f64>, q: &Mat<f64>) -> Result<MatEqSolution, MatEqError> {
    let at = tr(a);
    let x = symmetrise(&bartels_stewart(a, &at, q, false)?);
    let (ax, xat) = (a * &x, &x * &at);
    let residual = rel(&(&(&ax + &xat) + q), &[fro(&ax), fro(&xat), fro(q)]);
    Ok(MatEqSolution { x, residual })
}

/// Discrete Lyapunov (Stein) `A X A' - X + Q = 0` (solution symmetrised).
pub fn dlyap(a: &Mat<f64>, q: &Mat<f64>) -> Result<MatEqSolution, MatEqError> {
    let at = tr(a);
    let x = symmetrise(&bartels_stewart(a, &at, q, true)?);
    let axa = a * &x * &at;
    let residual = rel(&(&(&axa - &x) + q), &[fro(&axa), fro(&x), fro(q)]);
    Ok(MatEqSolution { x, residual })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn m(rows: &[&[f64]]) -> Mat<f64> {
        Mat::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
    }

    pub fn lyapunov_scalar_and_matrix() {
        // -2 x + 1 = 0 for A = -1, Q = 1.
        let s = lyap(&m(&[&[-1.0]]), &m(&[&[1.0]])).unwrap();
        assert!((s.x[(0, 0)] - 0.5).abs() < 1e-15);
        let a = m(&[&[0.0, 1.0], &[-2.0, -3.0]]);
        let q = m(&[&[1.0, 0.0], &[0.0, 1.0]]);
        let s = lyap(&a, &q).unwrap();
        assert!(s.residual < 1e-14, "{}", s.residual);
        let s = dlyap(&(&a * 0.2), &q).unwrap();
        assert!(s.residual < 1e-14, "{}", s.residual);
    }

    pub fn sylvester_general_and_singular() {
        let a = m(&[&[1.0, 2.0, 0.0], &[0.5, -1.0, 3.0], &[0.0, 1.0, 2.5]]);
        let b = m(&[&[4.0, 1.0], &[-1.0, 3.0]]);
        let c = m(&[&[1.0, 2.0], &[3.0, 4.0], &[5.0, 6.0]]);
        let s = sylvester(&a, &b, &c).unwrap();
        assert!(s.residual < 1e-14, "{}", s.residual);
        let s = dsylvester(&a, &(&b * 0.1), &c).unwrap();
        assert!(s.residual < 1e-14, "{}", s.residual);
        // A = 1, B = -1: A + B singular.
        assert!(matches!(
            sylvester(&m(&[&[1.0]]), &m(&[&[-1.0]]), &m(&[&[1.0]])),
            Err(MatEqError::Singular(_))
        ));
    }
}
