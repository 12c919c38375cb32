//! Sylvester and Lyapunov equations by the Bartels–Stewart method
//! (Bartels & Stewart 1972, CACM 15(9)): reduce the coefficient matrices to
//! real Schur form, solve the quasi-triangular equation block by block in
//! real arithmetic, transform back. A Lyapunov equation takes one Schur
//! form, its transpose read off by reversal. Each solver returns its
//! relative residual.
//!
//! * continuous Sylvester `A X + X B + C = 0`, Lyapunov `A X + X A' + Q = 0`;
//! * discrete (Stein) `A X B - X + C = 0`, `A X A' - X + Q = 0`.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c64;
use super::schur::{SchurError, cplx, real_schur, schur_by_real_form};
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
/// `A = Ua Ta Ua'` and `B = Ub Tb Ub'` come in real Schur form.
/// The quasi-triangular solve is followed by iterative refinement (Golub,
/// Nash & Van Loan 1979): the residual is recomputed from the original
/// data and the equation solved again for the correction, reusing the
/// Schur forms, while that lowers the residual. Strongly non-normal
/// coefficients (`||A|| >> rho(A)`, as in the closed loops of nearly
/// unstabilisable Riccati problems) otherwise leave residuals of 1e-9 and
/// worse, which would stall the Newton refinement of CARE/DARE.
fn bartels_stewart(
    (a, sa): (&Mat<f64>, &QuasiTriangular),
    (b, sb): (&Mat<f64>, &QuasiTriangular),
    c: &Mat<f64>,
    discrete: bool,
) -> Result<Mat<f64>, MatEqError> {
    let scale = fro(a).max(fro(b)).max(1e-300);
    let tol = 1e-14 * scale.max(if discrete { 1.0 } else { 0.0 });
    let solve = |c: &Mat<f64>| -> Result<Mat<f64>, MatEqError> {
        let rhs = -(sa.u.transpose() * c * &sb.u);
        let y = quasi_triangular(sa, sb, rhs, discrete, tol)?;
        Ok(&sa.u * y * sb.u.transpose())
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

/// A coefficient in real Schur form `M = U T U'`: `T` upper
/// quasi-triangular, its diagonal blocks (1x1, or 2x2 for a complex pair)
/// listed as `(first index, size)`.
struct QuasiTriangular {
    u: Mat<f64>,
    t: Mat<f64>,
    blocks: Vec<(usize, usize)>,
}

impl QuasiTriangular {
    fn new(u: Mat<f64>, t: Mat<f64>) -> Self {
        let n = t.nrows();
        let mut blocks = Vec::with_capacity(n);
        let mut i = 0;
        while i < n {
            let size = if i + 1 < n && t[(i + 1, i)] != 0.0 {
                2
            } else {
                1
            };
            blocks.push((i, size));
            i += size;
        }
        Self { u, t, blocks }
    }

    fn of(m: &Mat<f64>) -> Result<Self, MatEqError> {
        let rs = real_schur(m)?;
        Ok(Self::new(rs.q, rs.t))
    }

    /// The form of `M'` from that of `M`: with `P` the reversal
    /// permutation, `M' = U T' U' = (U P) (P T' P) (U P)'`, and `P T' P`
    /// is again upper quasi-triangular. One Schur form serves both
    /// coefficients of a Lyapunov equation.
    fn transposed(&self) -> Self {
        let n = self.t.nrows();
        let t = Mat::from_fn(n, n, |i, j| self.t[(n - 1 - j, n - 1 - i)]);
        let u = Mat::from_fn(n, n, |i, j| self.u[(i, n - 1 - j)]);
        Self::new(u, t)
    }
}

/// Solves the `(p q) x (p q)` system (at most 4x4) of one pair of
/// diagonal blocks by Gaussian elimination with complete pivoting
/// (as LAPACK `dlasy2`); a pivot at or below `tol` means the two blocks'
/// eigenvalues make the equation singular.
#[allow(clippy::needless_range_loop)] // a dense 4x4 kernel reads best with indices
fn small_solve(mut m: [[f64; 4]; 4], mut rhs: [f64; 4], size: usize, tol: f64) -> Option<[f64; 4]> {
    let mut perm = [0, 1, 2, 3];
    for k in 0..size {
        let (mut pi, mut pj, mut big) = (k, k, -1.0);
        for (i, row) in m.iter().enumerate().take(size).skip(k) {
            for (j, v) in row.iter().enumerate().take(size).skip(k) {
                if v.abs() > big {
                    (pi, pj, big) = (i, j, v.abs());
                }
            }
        }
        if !(big > tol) {
            return None;
        }
        m.swap(k, pi);
        rhs.swap(k, pi);
        for row in m.iter_mut() {
            row.swap(k, pj);
        }
        perm.swap(k, pj);
        for i in k + 1..size {
            let f = m[i][k] / m[k][k];
            for j in k..size {
                m[i][j] -= f * m[k][j];
            }
            rhs[i] -= f * rhs[k];
        }
    }
    let mut x = [0.0; 4];
    for k in (0..size).rev() {
        let mut s = rhs[k];
        for j in k + 1..size {
            s -= m[k][j] * x[j];
        }
        x[k] = s / m[k][k];
    }
    let mut out = [0.0; 4];
    for k in 0..size {
        out[perm[k]] = x[k];
    }
    Some(out)
}

/// The block equation `Ta_ii Y + Y S = R` (continuous) or
/// `Ta_ii Y S - Y = R` (discrete) for a `p x q` block `Y`, unknowns
/// ordered column by column (the Kronecker form).
fn block_solve(
    ta: &Mat<f64>,
    (i0, p): (usize, usize),
    tb: &Mat<f64>,
    (k0, q): (usize, usize),
    rhs: &Mat<f64>,
    discrete: bool,
    tol: f64,
) -> Option<[[f64; 2]; 2]> {
    let mut m = [[0.0; 4]; 4];
    let mut r = [0.0; 4];
    for c in 0..q {
        for l in 0..p {
            let row = l + p * c;
            r[row] = rhs[(i0 + l, k0 + c)];
            for c2 in 0..q {
                for l2 in 0..p {
                    let (a, s) = (ta[(i0 + l, i0 + l2)], tb[(k0 + c2, k0 + c)]);
                    let same = (l == l2) as u8 as f64;
                    let same_c = (c == c2) as u8 as f64;
                    m[row][l2 + p * c2] = if discrete {
                        a * s - same * same_c
                    } else {
                        a * same_c + s * same
                    };
                }
            }
        }
    }
    let x = small_solve(m, r, p * q, tol)?;
    let mut y = [[0.0; 2]; 2];
    for c in 0..q {
        for l in 0..p {
            y[l][c] = x[l + p * c];
        }
    }
    Some(y)
}

/// `col[..rows] -= t[..rows, j] * v` (a column of a column-major matrix).
fn axpy_col(col: &mut [f64], t: &Mat<f64>, j: usize, v: f64) {
    if v != 0.0 {
        for (c, a) in col.iter_mut().zip(t.col_as_slice(j)) {
            *c -= a * v;
        }
    }
}

/// The quasi-triangular equation `Ta Y + Y Tb = R` (continuous) or
/// `Ta Y Tb - Y = R` (discrete), in real arithmetic (LAPACK `dtrsyl`,
/// SLICOT `SB04PY`): column blocks of `Tb` forward, each solved by row
/// blocks of `Ta` backward; what a solved block contributes to the
/// blocks still to come is subtracted from their right-hand side at once.
fn quasi_triangular(
    a: &QuasiTriangular,
    b: &QuasiTriangular,
    mut r: Mat<f64>,
    discrete: bool,
    tol: f64,
) -> Result<Mat<f64>, MatEqError> {
    let (n, m) = (a.t.nrows(), b.t.nrows());
    let mut y = Mat::<f64>::zeros(n, m);
    // Discrete: Sum_{j<k} Y_j Tb_jk, kept apart because Ta multiplies it.
    let mut w = Mat::<f64>::zeros(n, if discrete { m } else { 0 });
    for &(k0, q) in &b.blocks {
        if discrete {
            // [Ta Y Tb]_k = Ta (W_k + Y_k S): move Ta W_k to the right.
            for c in k0..k0 + q {
                let rc = r.col_as_slice_mut(c);
                for (l, v) in w.col_as_slice(c).iter().enumerate() {
                    axpy_col(&mut rc[..=(l + 1).min(n - 1)], &a.t, l, *v);
                }
            }
        }
        for &(i0, p) in a.blocks.iter().rev() {
            let blk =
                block_solve(&a.t, (i0, p), &b.t, (k0, q), &r, discrete, tol).ok_or_else(|| {
                    MatEqError::Singular(if discrete {
                        "an eigenvalue of A times one of B equals 1 (reciprocal eigenvalues)".into()
                    } else {
                        "A and -B have a common eigenvalue".into()
                    })
                })?;
            for c in 0..q {
                // What the rows above see of this block: Y_ik, or Y_ik S.
                let mut seen = [0.0; 2];
                for l in 0..p {
                    y[(i0 + l, k0 + c)] = blk[l][c];
                    seen[l] = if discrete {
                        (0..q).map(|c2| blk[l][c2] * b.t[(k0 + c2, k0 + c)]).sum()
                    } else {
                        blk[l][c]
                    };
                }
                let rc = r.col_as_slice_mut(k0 + c);
                for (l, v) in seen.iter().enumerate().take(p) {
                    axpy_col(&mut rc[..i0], &a.t, i0 + l, *v);
                }
            }
        }
        // Right-looking update of the later columns: Y_k Tb[k, j].
        let target = if discrete { &mut w } else { &mut r };
        for j in k0 + q..m {
            for c in k0..k0 + q {
                let t = b.t[(c, j)];
                let sign = if discrete { -1.0 } else { 1.0 };
                axpy_col(target.col_as_slice_mut(j), &y, c, sign * t);
            }
        }
    }
    Ok(y)
}

/// Sylvester/Stein with two independent coefficients: two Schur forms.
fn general(
    a: &Mat<f64>,
    b: &Mat<f64>,
    c: &Mat<f64>,
    discrete: bool,
) -> Result<Mat<f64>, MatEqError> {
    check_sizes(a, b, c)?;
    if a.nrows() == 0 || b.nrows() == 0 {
        return Ok(Mat::zeros(a.nrows(), b.nrows()));
    }
    let (sa, sb) = (QuasiTriangular::of(a)?, QuasiTriangular::of(b)?);
    bartels_stewart((a, &sa), (b, &sb), c, discrete)
}

/// Lyapunov/Stein, `B = A'`: one Schur form serves both coefficients.
fn lyapunov(
    a: &Mat<f64>,
    at: &Mat<f64>,
    q: &Mat<f64>,
    discrete: bool,
) -> Result<Mat<f64>, MatEqError> {
    check_sizes(a, at, q)?;
    if a.nrows() == 0 {
        return Ok(Mat::zeros(0, 0));
    }
    let sa = QuasiTriangular::of(a)?;
    let sb = sa.transposed();
    bartels_stewart((a, &sa), (at, &sb), q, discrete)
}

fn rel(res: &Mat<f64>, terms: &[f64]) -> f64 {
    let den: f64 = terms.iter().sum();
    if den == 0.0 { fro(res) } else { fro(res) / den }
}

/// `A X + X B + C = 0`.
pub fn sylvester(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>) -> Result<MatEqSolution, MatEqError> {
    let x = general(a, b, c, false)?;
    let (ax, xb) = (a * &x, &x * b);
    let residual = rel(&(&(&ax + &xb) + c), &[fro(&ax), fro(&xb), fro(c)]);
    Ok(MatEqSolution { x, residual })
}

/// `A X B - X + C = 0`.
pub fn dsylvester(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>) -> Result<MatEqSolution, MatEqError> {
    let x = general(a, b, c, true)?;
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
    let x = symmetrise(&lyapunov(a, &at, q, false)?);
    let residual = lyapunov_residual(a, &at, &x, q, false);
    Ok(MatEqSolution { x, residual })
}

/// Discrete Lyapunov (Stein) `A X A' - X + Q = 0` (solution symmetrised).
pub fn dlyap(a: &Mat<f64>, q: &Mat<f64>) -> Result<MatEqSolution, MatEqError> {
    let at = tr(a);
    let x = symmetrise(&lyapunov(a, &at, q, true)?);
    let residual = lyapunov_residual(a, &at, &x, q, true);
    Ok(MatEqSolution { x, residual })
}

/// Relative residual of `A X + X A' + Q = 0`, or of `A X A' - X + Q = 0`
/// (`discrete`), at `X` (`at` is `A'`).
fn lyapunov_residual(
    a: &Mat<f64>,
    at: &Mat<f64>,
    x: &Mat<f64>,
    q: &Mat<f64>,
    discrete: bool,
) -> f64 {
    if discrete {
        let axa = a * x * at;
        rel(&(&(&axa - x) + q), &[fro(&axa), fro(x), fro(q)])
    } else {
        let (ax, xat) = (a * x, x * at);
        rel(&(&(&ax + &xat) + q), &[fro(&ax), fro(&xat), fro(q)])
    }
}

/// A Gramian in factored form, `X = L L^H` (`L` complex, `X` real), from
/// Hammarling's method, with the relative residual of `X` in its equation.
#[derive(Debug, Clone)]
pub struct GramianFactor {
    /// The factor: `Q U`, `Q` the Schur vectors of `A`, `U` upper triangular.
    pub l: Mat<c64>,
    /// Relative residual of `X = Re(L L^H)` (Frobenius norms, as [`MatEqSolution`]).
    pub residual: f64,
}

/// Continuous Gramian `A X + X A' + B B' = 0` as `X = L L^H`, for a stable
/// `A` (Hammarling 1982, IMA J. Numer. Anal. 2). A norm taken through the
/// factor, `||C L||_F`, has an absolute error of order `eps ||C|| ||L||`
/// where `trace(C X C')` has one of order `eps ||C||^2 ||X||`: a norm that
/// is zero by cancellation comes out at rounding, not at its square root.
pub fn lyap_factor(a: &Mat<f64>, b: &Mat<f64>) -> Result<GramianFactor, MatEqError> {
    gramian_factor(a, b, false)
}

/// Discrete Gramian `A X A' - X + B B' = 0` as `X = L L^H` (see [`lyap_factor`]).
pub fn dlyap_factor(a: &Mat<f64>, b: &Mat<f64>) -> Result<GramianFactor, MatEqError> {
    gramian_factor(a, b, true)
}

fn gramian_factor(a: &Mat<f64>, b: &Mat<f64>, discrete: bool) -> Result<GramianFactor, MatEqError> {
    let n = a.nrows();
    if a.ncols() != n || b.nrows() != n {
        return Err(MatEqError::Dimension(format!(
            "A is {}x{} and B has {} rows",
            n,
            a.ncols(),
            b.nrows()
        )));
    }
    let (q, s) = schur_by_real_form(a)?;
    let qb = q.adjoint() * cplx(b);
    let l = &q * hammarling(&s, qb, discrete)?;
    let llh = &l * l.adjoint();
    let x = Mat::from_fn(n, n, |i, j| llh[(i, j)].re);
    let residual = lyapunov_residual(a, &tr(a), &x, &(b * tr(b)), discrete);
    Ok(GramianFactor { l, residual })
}

/// Hammarling's recursion on the complex Schur form `S` (upper
/// triangular) with `B~ = Q^H B`: `U` upper triangular with `X = U U^H`,
/// its columns from the last to the first. With `S = [S11 s; 0 lambda]`,
/// `U = [U11 u; 0 v]` and `e` the last row of `B~` conjugated and
/// normalised (norm `beta`), `g^2 = -2 Re(lambda)` (continuous) or
/// `1 - |lambda|^2` (discrete) and `v = beta / g`:
/// * continuous: `(S11 + conj(lambda) I) u = -(s v + g B1 e)`, and the
///   leading equation has `B1 - g u e^H` in place of `B~`'s first rows `B1`;
/// * discrete: `(conj(lambda) S11 - I) u = -(conj(lambda) s v + g B1 e)`,
///   `w = S11 u + s v`, and `B1 + (g w - (1 + lambda) B1 e) e^H`.
///
/// Both follow from the equation's last column and its leading block.
fn hammarling(s: &Mat<c64>, mut b: Mat<c64>, discrete: bool) -> Result<Mat<c64>, MatEqError> {
    let (n, m) = (s.nrows(), b.ncols());
    let mut u = Mat::<c64>::zeros(n, n);
    let mut b1e = vec![c64::new(0.0, 0.0); n];
    let mut col = vec![c64::new(0.0, 0.0); n];
    for k in (0..n).rev() {
        let lambda = s[(k, k)];
        let g2 = if discrete {
            1.0 - lambda.norm_sqr()
        } else {
            -2.0 * lambda.re
        };
        if !(g2 > 0.0) {
            return Err(MatEqError::Singular(
                "A is not stable: the Gramian has no factor".into(),
            ));
        }
        let g = g2.sqrt();
        let beta = (0..m).map(|j| b[(k, j)].norm_sqr()).sum::<f64>().sqrt();
        u[(k, k)] = c64::new(beta / g, 0.0);
        if beta == 0.0 {
            continue; // u = 0 and B1 unchanged
        }
        let v = beta / g;
        // e_j = conj(b[k, j]) / beta; B1 e.
        for (i, x) in b1e.iter_mut().enumerate().take(k) {
            *x = (0..m).map(|j| b[(i, j)] * b[(k, j)].conj()).sum::<c64>() / beta;
        }
        let lc = lambda.conj();
        for i in 0..k {
            let sv = s[(i, k)] * v;
            col[i] = -(if discrete { sv * lc } else { sv } + b1e[i] * g);
        }
        // Back substitution with S11 shifted (continuous) or scaled (discrete).
        for i in (0..k).rev() {
            let d = if discrete {
                lc * s[(i, i)] - 1.0
            } else {
                s[(i, i)] + lc
            };
            let xi = col[i] / d;
            col[i] = xi;
            let f = if discrete { lc * xi } else { xi };
            for r in 0..i {
                col[r] -= s[(r, i)] * f;
            }
        }
        for i in 0..k {
            u[(i, k)] = col[i];
        }
        // The row vector of the rank-one update, times e^H = b[k, :] / beta.
        let mut rank_one = vec![c64::new(0.0, 0.0); k];
        for i in 0..k {
            rank_one[i] = if discrete {
                let w = (i..k).map(|r| s[(i, r)] * col[r]).sum::<c64>() + s[(i, k)] * v;
                w * g - (lambda + 1.0) * b1e[i]
            } else {
                -col[i] * g
            };
        }
        for j in 0..m {
            let ej = b[(k, j)] / beta;
            for i in 0..k {
                b[(i, j)] += rank_one[i] * ej;
            }
        }
    }
    Ok(u)
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

    /// Random 40-state equations, most eigenvalues in complex pairs (the
    /// 2x2 blocks of the real Schur form), continuous and discrete: each
    /// residual at rounding, and Hammarling's factor reproducing the
    /// Bartels–Stewart Gramian, two independent routes.
    pub fn real_blocks_and_factors_agree() {
        let mut u = crate::internal_checks::unit_uniform(20261129);
        let n = 40;
        let mut draw = |rows: usize, cols: usize| Mat::from_fn(rows, cols, |_, _| u() - 0.5);
        let a0 = draw(n, n);
        let b = draw(n, 3);
        let bbt = &b * tr(&b);
        let shift = Mat::<f64>::identity(n, n) * 3.0;
        let (a, ad) = (&a0 - &shift, &a0 * 0.3);
        let pairs = crate::lti::ss::eigvals(&a)
            .unwrap()
            .iter()
            .filter(|z| z.im != 0.0)
            .count();
        assert!(pairs >= n / 2, "{pairs} complex eigenvalues");
        for (x, l, discrete) in [
            (lyap(&a, &bbt).unwrap(), lyap_factor(&a, &b).unwrap(), false),
            (
                dlyap(&ad, &bbt).unwrap(),
                dlyap_factor(&ad, &b).unwrap(),
                true,
            ),
        ] {
            assert!(x.residual < 1e-14, "{discrete}: {}", x.residual);
            assert!(l.residual < 1e-13, "{discrete}: {}", l.residual);
            let llh = &l.l * l.l.adjoint();
            let diff = Mat::from_fn(n, n, |i, j| llh[(i, j)].re - x.x[(i, j)]);
            assert!(
                fro(&diff) <= 1e-12 * fro(&x.x),
                "{discrete}: {:e}",
                fro(&diff) / fro(&x.x)
            );
        }
        let c = draw(n, 5);
        let bm = draw(5, 5) - Mat::<f64>::identity(5, 5) * 0.2;
        let s = sylvester(&a, &(Mat::<f64>::identity(5, 5) * 4.0 - &bm), &c).unwrap();
        assert!(s.residual < 1e-14, "{}", s.residual);
        let s = dsylvester(&ad, &(&bm * 0.3), &c).unwrap();
        assert!(s.residual < 1e-14, "{}", s.residual);
    }
}
