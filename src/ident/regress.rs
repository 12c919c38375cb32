//! Streaming QR of a tall regression `[Phi | y]` for the linear-in-the-
//! parameters estimators (ARX, the initial-condition fit, the LM steps of OE).
//!
//! Why not one big QR: the regressors of a dynamic model are shifted copies of
//! two signals, so a 1e6-sample, 15-parameter problem would materialise a
//! 128 MB matrix only to reduce it to a 16 x 16 triangle. Instead the rows are
//! produced block by block (each column a contiguous, shifted, possibly negated
//! slice of a signal, written straight into a small column-major block) and
//! the factor is updated by the Householder QR of `[R; next block]`, with a
//! kernel that skips the known zeros of `R` and keeps the block in cache.
//! This is the same orthogonal reduction as the full QR, never
//! the normal equations `Phi^T Phi`, so the conditioning of the problem is not
//! squared: with `[Phi y] = Q [R11 r12; 0 r22]`, the least-squares solution is
//! `R11 theta = r12` and the residual norm is `|r22|`.

use faer::{Mat, MatRef};

/// Rows per block: the block (`rows x p` doubles) stays in L1/L2 cache
/// while the `p` reflections sweep it.
pub const DEFAULT_BLOCK_ROWS: usize = 256;

/// The upper-triangular factor `R` of an `m x p` matrix, as produced by
/// [`triangularize`], together with the number of rows reduced.
#[derive(Debug, Clone)]
pub struct Triangle {
    /// `p x p`, upper triangular (entries below the diagonal are zero).
    pub r: Mat<f64>,
    /// Number of rows of the original matrix.
    pub rows: usize,
}

/// QR-reduces the `rows x ncols` matrix whose column `j`, rows
/// `start .. start + out.len()`, is written by `fill(j, start, out)`.
///
/// `fill` is called once per column and block, with consecutive row ranges.
pub fn triangularize(
    ncols: usize,
    rows: usize,
    block_rows: usize,
    mut fill: impl FnMut(usize, usize, &mut [f64]),
) -> Triangle {
    let p = ncols;
    let block = block_rows.max(1).min(rows.max(1));
    let mut r = vec![0.0; p * p];
    let mut x = vec![0.0; p * block];
    let kernel = Kernel::detect();
    let mut start = 0;
    while start < rows {
        let len = block.min(rows - start);
        for j in 0..p {
            fill(j, start, &mut x[j * block..j * block + len]);
        }
        kernel.fold(&mut r, &mut x, p, block, len);
        start += len;
    }
    Triangle {
        r: Mat::from_fn(p, p, |i, j| if i <= j { r[i * p + j] } else { 0.0 }),
        rows,
    }
}

/// Which build of [`fold_block_body`] runs: the AVX2+FMA one when the CPU has
/// it (chosen at run time, so the binary stays portable), else the baseline.
#[derive(Clone, Copy)]
enum Kernel {
    Baseline,
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Kernel {
    fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return Kernel::Avx2;
            }
        }
        Kernel::Baseline
    }

    fn fold(self, r: &mut [f64], x: &mut [f64], p: usize, ld: usize, len: usize) {
        match self {
            Kernel::Baseline => fold_block_body(r, x, p, ld, len),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Kernel::Avx2` is only constructed after
            // `is_x86_feature_detected!` confirmed AVX2 and FMA.
            Kernel::Avx2 => unsafe { fold_block_avx2(r, x, p, ld, len) },
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn fold_block_avx2(r: &mut [f64], x: &mut [f64], p: usize, ld: usize, len: usize) {
    fold_block_body(r, x, p, ld, len)
}

/// Folds a block of rows into `R`: Householder QR of `[R; X]` exploiting
/// that `R` (row-major `p x p`) is already upper triangular, so reflector `j`
/// only touches row `j` of `R` and the block `X` (column-major, leading
/// dimension `ld`, `len` rows). With `alpha = R[j,j]`, `sigma = ||x_j||^2`,
/// `beta = -sign(alpha) sqrt(alpha^2 + sigma)` (no cancellation),
/// `v = [1; x_j / (alpha - beta)]`, `tau = (beta - alpha)/beta`, column `c`
/// becomes `[R[j,c]; x_c] - tau (v . [R[j,c]; x_c]) v` (Golub & Van Loan,
/// Alg. 5.1.1), written out so that `v` is never formed.
#[inline(always)]
fn fold_block_body(r: &mut [f64], x: &mut [f64], p: usize, ld: usize, len: usize) {
    for j in 0..p {
        let (head, tail) = x.split_at_mut((j + 1) * ld);
        let xj = &head[j * ld..j * ld + len];
        let sigma = dot(xj, xj);
        if sigma == 0.0 {
            continue;
        }
        let alpha = r[j * p + j];
        let norm = (alpha * alpha + sigma).sqrt();
        let beta = if alpha >= 0.0 { -norm } else { norm };
        let scale = 1.0 / (alpha - beta);
        let tau = (beta - alpha) / beta;
        r[j * p + j] = beta;
        for c in (j + 1)..p {
            let off = (c - j - 1) * ld;
            let xc = &mut tail[off..off + len];
            let w = r[j * p + c] + scale * dot(xj, xc);
            let tw = tau * w;
            r[j * p + c] -= tw;
            axpy(-tw * scale, xj, xc);
        }
    }
}

/// Dot product with eight independent accumulators (vectorisable, and no
/// single long dependency chain).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let ca = a.chunks_exact(8);
    let cb = b.chunks_exact(8);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for i in 0..8 {
            acc[i] += x[i] * y[i];
        }
    }
    let mut s: f64 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// `y += alpha x`.
#[inline(always)]
fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// The least-squares solution read off a triangle of `[Phi y]`.
#[derive(Debug, Clone)]
pub struct TriangleSolution {
    /// `theta = R11^-1 r12`.
    pub theta: Vec<f64>,
    /// Residual norm `|r22| = ||y - Phi theta||`.
    pub residual_norm: f64,
    /// Singular values of `Phi` (those of `R11`), decreasing.
    pub singular_values: Vec<f64>,
    /// `sigma_max / sigma_min` (infinite when singular).
    pub condition_number: f64,
    /// Condition number of `Phi` with unit-norm columns (decides rank).
    pub scaled_condition_number: f64,
    /// `R11^-1`, for the covariance `lambda R11^-1 R11^-T`.
    pub r_inv: Mat<f64>,
}

/// Solves `R11 theta = r12` from the factor of `[Phi y]` (last column `y`).
///
/// Rank is judged as in [`crate::ident::ls`]: on the singular values of `Phi`
/// with unit-norm columns (those of `R11 D^-1`, `D` the column norms), so that
/// units (volts vs micrometres) do not decide solvability; the regression is
/// singular when that scaled condition number exceeds `1 / rank_tol`
/// (`LstsqParams::default().rank_tol` = 1e-12). On failure returns the
/// numerical rank and the scaled condition number.
pub fn solve_triangle(tri: &Triangle) -> Result<TriangleSolution, (usize, f64)> {
    let rank_tol = crate::ident::ls::LstsqParams::default().rank_tol;
    let p = tri.r.ncols();
    let d = p - 1;
    let r11: MatRef<'_, f64> = tri.r.as_ref().submatrix(0, 0, d, d);
    let svd_of = |m: MatRef<'_, f64>| {
        if d == 0 {
            Vec::new()
        } else {
            m.singular_values().unwrap_or_else(|_| vec![0.0; d])
        }
    };
    let norms: Vec<f64> = (0..d)
        .map(|j| (0..=j).map(|i| r11[(i, j)].powi(2)).sum::<f64>().sqrt())
        .collect();
    if norms.iter().any(|&n| n == 0.0 || !n.is_finite()) {
        let rank = norms.iter().filter(|&&n| n > 0.0 && n.is_finite()).count();
        return Err((rank.min(d.saturating_sub(1)), f64::INFINITY));
    }
    let scaled = Mat::<f64>::from_fn(d, d, |i, j| r11[(i, j)] / norms[j]);
    let ssv = svd_of(scaled.as_ref());
    let smax_s = ssv.first().copied().unwrap_or(0.0);
    let rank = ssv.iter().filter(|&&s| s > rank_tol * smax_s).count();
    let scaled_cond = match ssv.last() {
        Some(&m) if m > 0.0 => smax_s / m,
        _ => f64::INFINITY,
    };
    if rank < d || !smax_s.is_finite() {
        return Err((rank, scaled_cond));
    }
    let sv = svd_of(r11);
    let smax = sv.first().copied().unwrap_or(0.0);
    let cond = match sv.last() {
        Some(&m) if m > 0.0 => smax / m,
        _ => f64::INFINITY,
    };
    // Back substitution on the small triangle; R11^-1 column by column.
    let mut r_inv = Mat::<f64>::zeros(d, d);
    for c in 0..d {
        for i in (0..=c).rev() {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for k in i + 1..=c {
                s -= tri.r[(i, k)] * r_inv[(k, c)];
            }
            r_inv[(i, c)] = s / tri.r[(i, i)];
        }
    }
    let theta = (0..d)
        .map(|i| (i..d).map(|k| r_inv[(i, k)] * tri.r[(k, d)]).sum())
        .collect();
    Ok(TriangleSolution {
        theta,
        residual_norm: tri.r[(d, d)].abs(),
        singular_values: sv,
        condition_number: cond,
        scaled_condition_number: scaled_cond,
        r_inv,
    })
}

/// Standard deviations `sqrt(diag(lambda R^-1 R^-T))`.
pub fn std_devs(r_inv: &Mat<f64>, lambda: f64) -> Vec<f64> {
    let d = r_inv.nrows();
    (0..d)
        .map(|i| {
            let s: f64 = (i..d).map(|k| r_inv[(i, k)].powi(2)).sum();
            (lambda * s).sqrt()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocked_equals_direct_least_squares() {
        // y = 2 x0 - 3 x1 + 0.5 x2 + small deterministic "noise"; 1000 rows in
        // blocks of 64 must give the same R (up to signs) and solution as one
        // QR of the whole matrix.
        let m = 1000;
        let col = |j: usize, i: usize| -> f64 {
            let t = i as f64;
            match j {
                0 => (0.37 * t).sin(),
                1 => (0.011 * t).cos(),
                2 => 1.0,
                _ => {
                    2.0 * (0.37 * t).sin() - 3.0 * (0.011 * t).cos() + 0.5 + 1e-3 * (1.7 * t).sin()
                }
            }
        };
        let tri = triangularize(4, m, 64, |j, s, out| {
            for (r, v) in out.iter_mut().enumerate() {
                *v = col(j, s + r);
            }
        });
        let sol = solve_triangle(&tri).unwrap();
        let full = Mat::<f64>::from_fn(m, 4, |i, j| col(j, i));
        let qr = full.qr();
        let r = qr.thin_R();
        for i in 0..4 {
            for j in i..4 {
                assert!(
                    (r[(i, j)].abs() - tri.r[(i, j)].abs()).abs() < 1e-10,
                    "R[{i},{j}]"
                );
            }
        }
        assert!((sol.theta[0] - 2.0).abs() < 1e-3);
        assert!((sol.theta[1] + 3.0).abs() < 1e-3);
        let resid: f64 = (0..m)
            .map(|i| (col(3, i) - (0..3).map(|j| sol.theta[j] * col(j, i)).sum::<f64>()).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!((resid - sol.residual_norm).abs() < 1e-10);
    }

    #[test]
    fn rank_deficiency_is_detected() {
        let tri = triangularize(3, 50, 16, |j, s, out| {
            for (r, v) in out.iter_mut().enumerate() {
                let t = (s + r) as f64;
                *v = if j < 2 { 1.0 } else { t };
            }
        });
        let (rank, cond) = solve_triangle(&tri).unwrap_err();
        assert_eq!(rank, 1);
        assert!(cond > 1e12);
    }
}
