//! Least squares for tall, skinny regressions by a streaming Householder QR,
//! and Lawson–Hanson non-negative least squares on the compressed problem.
//!
//! The regressor `[Phi | y]` (N x p+1, N up to millions, p about 12) is never
//! needed whole: rows arrive in blocks, and each block is folded into the
//! `(p+1) x (p+1)` triangular factor by a QR of `[R; block]` (the "TSQR"
//! update). The result is the R factor of `[Phi | y]`:
//! `R = [[R11, z], [0, rho]]` with `Phi = Q R11`, `z = Q^T y` and `|rho|` the
//! residual norm of the least-squares solution. This is a QR factorisation
//! (backward stable); the normal equations `Phi^T Phi` are never formed.
//!
//! The QR itself is the crate's engine, [`crate::ident::ls::StreamingQr`],
//! fed column blocks as the play operators generate them ([`qr_of`] for a
//! materialised regressor); this module adds what is specific to hysteresis
//! identification: the solve with the partial-sum constraint and NNLS.

use crate::ident::ls::{LstsqParams, StreamingQr, lstsq};
use faer::{Mat, MatRef};

/// A dense column-major matrix that hands out its columns as disjoint slices
/// (regressors are filled column by column) and views as a faer matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct ColMajor {
    data: Vec<f64>,
    rows: usize,
    cols: usize,
}

impl ColMajor {
    /// A `rows x cols` matrix of zeros.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            data: vec![0.0; rows * cols],
            rows,
            cols,
        }
    }

    /// Rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Column `j`.
    pub fn col(&self, j: usize) -> &[f64] {
        &self.data[j * self.rows..(j + 1) * self.rows]
    }

    /// Column `j`, mutable.
    pub fn col_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.data[j * self.rows..(j + 1) * self.rows]
    }

    /// All columns at once, mutable and disjoint.
    pub fn cols_mut(&mut self) -> Vec<&mut [f64]> {
        if self.rows == 0 {
            return (0..self.cols).map(|_| <&mut [f64]>::default()).collect();
        }
        self.data.chunks_mut(self.rows).collect()
    }

    /// A faer view of the same data.
    pub fn as_faer(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.data, self.rows, self.cols)
    }
}

/// The R factor of `[a | b]` (`a.cols() + 1` columns), streamed through
/// [`StreamingQr`] in blocks.
pub fn qr_of(a: &ColMajor, b: &[f64]) -> StreamingQr {
    assert_eq!(a.rows(), b.len());
    let cols = a.cols();
    let mut acc = StreamingQr::new(cols + 1);
    acc.push_blocks(a.rows(), |j, s, out| {
        let src = if j < cols { a.col(j) } else { b };
        out.copy_from_slice(&src[s..s + out.len()]);
    });
    acc
}

/// Why a least-squares problem has no usable solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LsError {
    /// The regressor columns are (numerically) linearly dependent.
    #[error(
        "the regression is rank deficient (numerical rank {rank} of {cols} columns, condition number {condition_number:.3e}); the input does not excite every operator — use fewer operators or a richer input"
    )]
    RankDeficient {
        /// Numerical rank.
        rank: usize,
        /// Number of columns.
        cols: usize,
        /// `sigma_max / sigma_min` of the regressor.
        condition_number: f64,
    },
    /// The singular value decomposition of the small factor failed.
    #[error("SVD of the R factor did not converge")]
    Svd,
}

/// Partial-sum constraints (docs/math.md §1.5) on the last `p - free` unknowns:
/// `x_free + ... + x_i >= min_partial_sum` for every constrained `i`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartialSumConstraint {
    /// Lower bound for every partial sum (> 0 keeps the model strictly invertible).
    pub min_partial_sum: f64,
}

/// A least-squares solution from a compressed problem.
#[derive(Debug, Clone, PartialEq)]
pub struct LsSolution {
    /// The unknowns.
    pub x: Vec<f64>,
    /// `||Phi x - y||_2`.
    pub residual_norm: f64,
    /// 2-norm condition number of `Phi` (= that of `R11`).
    pub condition_number: f64,
    /// Whether a partial-sum constraint was active at the solution.
    pub constraint_active: bool,
}

/// Relative singular-value cut below which the regression counts as rank deficient.
pub const RANK_TOL: f64 = 1e-13;

/// Solves `min ||Phi x - y||` from the R factor of `[Phi | y]` (`p+1` columns,
/// column-major). The first `free` unknowns are unconstrained; with a
/// constraint the partial sums of the others are bounded below (see
/// [`nnls`] for how).
pub fn solve_from_r(
    r_full: &[f64],
    cols: usize,
    free: usize,
    constraint: Option<PartialSumConstraint>,
) -> Result<LsSolution, LsError> {
    let p = cols - 1;
    let r11 = Mat::from_fn(p, p, |i, j| if i <= j { r_full[j * cols + i] } else { 0.0 });
    let sv = fts_kernels::dense::singular_values(r11.as_ref()).map_err(|_| LsError::Svd)?;
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let smin = sv.iter().copied().fold(f64::INFINITY, f64::min);
    let condition_number = smax / smin;
    // `partial_cmp` so that a NaN singular value also counts as deficient.
    if smin.partial_cmp(&(RANK_TOL * smax * p as f64)) != Some(std::cmp::Ordering::Greater) {
        let rank = sv
            .iter()
            .filter(|&&s| s > RANK_TOL * smax * p as f64)
            .count();
        return Err(LsError::RankDeficient {
            rank,
            cols: p,
            condition_number,
        });
    }
    let z: Vec<f64> = (0..p).map(|i| r_full[p * cols + i]).collect();
    let rho = r_full[p * cols + p].abs();
    let r = |i: usize, j: usize| r_full[j * cols + i];

    let (x, constraint_active) = match constraint {
        None => (back_substitute(&r, p, &z), false),
        Some(c) => {
            // Reparametrise the constrained block by its partial sums,
            // w = T s with w_0 = s_0, w_i = s_i - s_{i-1}, and shift s = delta + q
            // so the constraint reads q >= 0 ([Li21]-style invertibility, docs/math.md §1.5).
            // The free unknowns can always zero their own rows of R, so only the
            // trailing block R22 (w) = z2 remains: a small NNLS problem.
            let m = p - free;
            let delta = c.min_partial_sum;
            // A = R22 T: column i of A is R22[:, i] - R22[:, i+1] (T's column i has
            // +1 at row i and -1 at row i+1), the last column is R22[:, m-1].
            let a = Mat::from_fn(m, m, |i, j| {
                let col = |jj: usize| r(free + i, free + jj);
                if j + 1 < m {
                    col(j) - col(j + 1)
                } else {
                    col(j)
                }
            });
            let mut b: Vec<f64> = (0..m).map(|i| z[free + i]).collect();
            for (i, bi) in b.iter_mut().enumerate() {
                let row_sum: f64 = (0..m).map(|j| a[(i, j)]).sum();
                *bi -= row_sum * delta;
            }
            let q = nnls(&a, &b);
            let active = q.contains(&0.0);
            let s: Vec<f64> = q.iter().map(|v| v + delta).collect();
            let mut w = vec![0.0; m];
            for i in 0..m {
                w[i] = if i == 0 { s[0] } else { s[i] - s[i - 1] };
            }
            // Free unknowns from the leading rows: R11f x_f = z_f - R12 w.
            let mut rhs: Vec<f64> = (0..free)
                .map(|i| z[i] - (0..m).map(|j| r(i, free + j) * w[j]).sum::<f64>())
                .collect();
            let xf = back_substitute(&r, free, &rhs);
            rhs.clear();
            let mut x = xf;
            x.extend_from_slice(&w);
            (x, active)
        }
    };
    // Residual: rho for the unconstrained optimum; recomputed from R otherwise
    // (||Phi x - y||^2 = ||R11 x - z||^2 + rho^2).
    let residual_norm = if constraint_active {
        let extra: f64 = (0..p)
            .map(|i| {
                let rx: f64 = (i..p).map(|j| r(i, j) * x[j]).sum();
                (rx - z[i]).powi(2)
            })
            .sum();
        (extra + rho * rho).sqrt()
    } else {
        rho
    };
    Ok(LsSolution {
        x,
        residual_norm,
        condition_number,
        constraint_active,
    })
}

/// Solves the leading `n x n` upper triangle `R x = z`.
fn back_substitute(r: &impl Fn(usize, usize) -> f64, n: usize, z: &[f64]) -> Vec<f64> {
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|j| r(i, j) * x[j]).sum();
        x[i] = (z[i] - s) / r(i, i);
    }
    x
}

/// Least squares on the columns `cols` of a small dense problem, by the
/// crate's QR solver ([`crate::ident::ls::lstsq`]). `None` when those columns
/// are dependent.
fn small_lstsq(a: &Mat<f64>, cols: &[usize], b: &[f64]) -> Option<Vec<f64>> {
    let sub = Mat::from_fn(a.nrows(), cols.len(), |i, j| a[(i, cols[j])]);
    lstsq(sub.as_ref(), b, &LstsqParams::default())
        .ok()
        .map(|s| s.theta)
}

/// Non-negative least squares `min ||A x - b||, x >= 0` by the active-set
/// method of Lawson & Hanson (Solving Least Squares Problems, 1974, ch. 23),
/// for the small compressed problems of this module. Subproblems are solved
/// by QR ([`crate::ident::ls::lstsq`]).
pub fn nnls(a: &Mat<f64>, b: &[f64]) -> Vec<f64> {
    let n = a.ncols();
    let m = a.nrows();
    let mut x = vec![0.0; n];
    let mut passive = vec![false; n];
    let scale = (0..n)
        .flat_map(|j| (0..m).map(move |i| (i, j)))
        .map(|(i, j)| a[(i, j)].abs())
        .fold(0.0, f64::max)
        * b.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let tol = 1e-12 * scale.max(f64::MIN_POSITIVE) * (m + n) as f64;
    let gradient = |x: &[f64]| -> Vec<f64> {
        // w = A^T (b - A x)
        let res: Vec<f64> = (0..m)
            .map(|i| b[i] - (0..n).map(|j| a[(i, j)] * x[j]).sum::<f64>())
            .collect();
        (0..n)
            .map(|j| (0..m).map(|i| a[(i, j)] * res[i]).sum())
            .collect()
    };
    for _outer in 0..3 * n + 10 {
        let w = gradient(&x);
        let candidate = (0..n)
            .filter(|&j| !passive[j] && w[j] > tol)
            .max_by(|&i, &j| w[i].total_cmp(&w[j]));
        let Some(t) = candidate else { break };
        passive[t] = true;
        loop {
            let cols: Vec<usize> = (0..n).filter(|&j| passive[j]).collect();
            let Some(zp) = small_lstsq(a, &cols, b) else {
                // Dependent columns: drop the newest and stop growing the set.
                passive[t] = false;
                return x;
            };
            let mut z = vec![0.0; n];
            for (k, &j) in cols.iter().enumerate() {
                z[j] = zp[k];
            }
            if cols.iter().all(|&j| z[j] > 0.0) {
                x = z;
                break;
            }
            // Step back towards x until the first passive unknown hits zero.
            let alpha = cols
                .iter()
                .filter(|&&j| z[j] <= 0.0)
                .map(|&j| x[j] / (x[j] - z[j]))
                .fold(f64::INFINITY, f64::min);
            for j in 0..n {
                x[j] += alpha * (z[j] - x[j]);
            }
            for &j in &cols {
                if x[j] <= 1e-15 * (1.0 + z[j].abs()) {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    x
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    pub fn streaming_qr_matches_known_solution() {
        // y = Phi x_true exactly, with rows spread over several blocks.
        let rows = 3 * crate::ident::ls::DEFAULT_BLOCK_ROWS + 17;
        let p = 4;
        let x_true = [1.5, -2.0, 0.25, 3.0];
        let mut seed = 7;
        let mut a = ColMajor::zeros(rows, p);
        let mut y = vec![0.0; rows];
        for (i, yi) in y.iter_mut().enumerate() {
            for (j, xj) in x_true.iter().enumerate() {
                let v = lcg(&mut seed);
                a.col_mut(j)[i] = v;
                *yi += v * xj;
            }
        }
        let acc = qr_of(&a, &y);
        let sol = solve_from_r(acc.r(), p + 1, p, None).unwrap();
        for (a, b) in sol.x.iter().zip(x_true) {
            assert!((a - b).abs() < 1e-13, "{a} vs {b}");
        }
        assert!(sol.residual_norm < 1e-12);
        // Condition number of a random +-1 uniform matrix is small.
        assert!(sol.condition_number > 1.0 && sol.condition_number < 5.0);
    }

    pub fn nnls_hand_example() {
        // min ||x - b|| with x >= 0 on an identity: clips negatives.
        let a = Mat::from_fn(3, 3, |i, j| if i == j { 1.0 } else { 0.0 });
        let x = nnls(&a, &[1.0, -2.0, 3.0]);
        assert_eq!(x, vec![1.0, 0.0, 3.0]);
        // A = [[1, 1], [0, 1]], b = [1, -1]: unconstrained x = [2, -1]. With
        // x2 = 0 the best x1 is 1 (residual [0, -1]) and the KKT multiplier of
        // x2, (A^T r)_2 = 0 - 1, is negative, so x = [1, 0] is the optimum.
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, 1.0], [0.0, 1.0]][i][j]);
        let x = nnls(&a, &[1.0, -1.0]);
        assert!((x[0] - 1.0).abs() < 1e-14 && x[1] == 0.0, "{x:?}");
    }

    pub fn rank_deficiency_is_reported() {
        let rows = 50;
        let mut a = ColMajor::zeros(rows, 2);
        for i in 0..rows {
            a.col_mut(0)[i] = i as f64;
            a.col_mut(1)[i] = 2.0 * i as f64;
        }
        let acc = qr_of(&a, &vec![1.0; rows]);
        assert!(matches!(
            solve_from_r(acc.r(), 3, 2, None),
            Err(LsError::RankDeficient {
                rank: 1,
                cols: 2,
                ..
            })
        ));
    }
}
