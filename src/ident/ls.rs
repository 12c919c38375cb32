//! Linear least squares `min ||Phi theta - y||_2` by Householder QR (faer),
//! never by the normal equations (which square the condition number).
//!
//! Two entry points share one core:
//! * [`lstsq`] for a regressor already in memory;
//! * [`StreamingLstsq`] for long records: rows are pushed one at a time (no
//!   allocation per row) and folded into the triangular factor block by
//!   block, `R <- qr([R; block])`. Memory is `O(block * n)` and the work is
//!   linear in the number of rows.
//!
//! The QR is taken of the augmented matrix `[Phi | y]`: its last diagonal
//! entry is the residual norm and the solution comes from the leading
//! triangle. Conditioning is measured by the singular values of that triangle
//! (equal to those of `Phi`), both for `Phi` as given and for `Phi` with
//! unit-norm columns; rank deficiency is judged on the latter, because column
//! scaling (volts vs micrometres) must not decide whether a problem is solvable.

use faer::{Mat, MatRef};

/// Settings of the least-squares solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LstsqParams {
    /// The regression counts as rank deficient when the condition number of
    /// the column-equilibrated regressor exceeds `1 / rank_tol`.
    /// Default `1e-12` (about `4500 * f64::EPSILON`): beyond it the solution
    /// has no correct digits worth reporting.
    pub rank_tol: f64,
    /// Rows folded per QR in [`StreamingLstsq`]. Default 8192.
    pub block_rows: usize,
}

impl Default for LstsqParams {
    fn default() -> Self {
        Self {
            rank_tol: 1e-12,
            block_rows: 8192,
        }
    }
}

/// A least-squares solution with its diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct LstsqSolution {
    /// The minimiser `theta`.
    pub theta: Vec<f64>,
    /// `||Phi theta - y||_2`.
    pub residual_norm: f64,
    /// 2-norm condition number of `Phi` as given.
    pub condition_number: f64,
    /// 2-norm condition number of `Phi` with unit-norm columns (the one that
    /// decides rank deficiency).
    pub scaled_condition_number: f64,
    /// Rows used.
    pub rows: usize,
    /// The upper-triangular factor of `Phi` (n x n), useful for parameter
    /// covariances: `cov(theta) = sigma^2 (R^T R)^-1`.
    pub r: Mat<f64>,
}

/// Why a least-squares problem has no trustworthy solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LstsqError {
    /// Fewer rows than unknowns.
    #[error("too few samples: {rows} equations for {cols} unknowns")]
    TooFewRows {
        /// Equations available.
        rows: usize,
        /// Unknowns.
        cols: usize,
    },
    /// A regressor or target value is NaN or infinite.
    #[error("the regression contains a non-finite value (row {row})")]
    NonFinite {
        /// First offending row (0-based).
        row: usize,
    },
    /// The columns are (numerically) linearly dependent.
    #[error(
        "singular regression: the regressor columns are linearly dependent (condition number {condition:.3e} after column scaling{}); the data do not excite every parameter",
        match column { Some(c) => format!(", column {c} is the first dependent or all-zero one"), None => String::new() }
    )]
    RankDeficient {
        /// Condition number of the column-equilibrated regressor (may be infinite).
        condition: f64,
        /// A column that is zero or dependent, when one can be named (0-based).
        column: Option<usize>,
    },
    /// The SVD used for the condition number failed to converge.
    #[error("SVD of the triangular factor did not converge")]
    Svd,
}

/// Solves `min ||phi theta - y||` for a regressor in memory.
pub fn lstsq(
    phi: MatRef<'_, f64>,
    y: &[f64],
    params: &LstsqParams,
) -> Result<LstsqSolution, LstsqError> {
    assert_eq!(
        phi.nrows(),
        y.len(),
        "lstsq: phi and y must have the same number of rows"
    );
    let mut acc = StreamingLstsq::new(phi.ncols(), params);
    let mut row = vec![0.0; phi.ncols()];
    for (i, &target) in y.iter().enumerate() {
        for (j, r) in row.iter_mut().enumerate() {
            *r = phi[(i, j)];
        }
        acc.push_row(&row, target);
    }
    acc.finish()
}

/// Least squares over rows pushed one at a time.
#[derive(Debug, Clone)]
pub struct StreamingLstsq {
    cols: usize,
    params: LstsqParams,
    /// Current triangular factor of `[Phi | y]` ((n+1) x (n+1)), once any block was folded.
    r: Option<Mat<f64>>,
    /// Rows not yet folded, `[phi | y]`.
    block: Mat<f64>,
    filled: usize,
    rows: usize,
    column_sq_norms: Vec<f64>,
    first_non_finite: Option<usize>,
}

impl StreamingLstsq {
    /// An empty accumulator for `cols` unknowns.
    pub fn new(cols: usize, params: &LstsqParams) -> Self {
        let block_rows = params.block_rows.max(cols + 1);
        Self {
            cols,
            params: *params,
            r: None,
            block: Mat::zeros(block_rows, cols + 1),
            filled: 0,
            rows: 0,
            column_sq_norms: vec![0.0; cols],
            first_non_finite: None,
        }
    }

    /// Number of unknowns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Rows pushed so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Adds the equation `phi . theta = y`. Does not allocate.
    #[inline]
    pub fn push_row(&mut self, phi: &[f64], y: f64) {
        debug_assert_eq!(phi.len(), self.cols);
        let i = self.filled;
        for (j, &v) in phi.iter().enumerate() {
            self.block[(i, j)] = v;
            self.column_sq_norms[j] += v * v;
        }
        self.block[(i, self.cols)] = y;
        if self.first_non_finite.is_none() && !(y.is_finite() && phi.iter().all(|v| v.is_finite()))
        {
            self.first_non_finite = Some(self.rows);
        }
        self.filled += 1;
        self.rows += 1;
        if self.filled == self.block.nrows() {
            self.fold();
        }
    }

    /// Folds the buffered rows into the triangular factor.
    fn fold(&mut self) {
        if self.filled == 0 || self.first_non_finite.is_some() {
            self.filled = 0;
            return;
        }
        let n1 = self.cols + 1;
        let rows = self.filled;
        let stacked = match &self.r {
            None => self.block.as_ref().subrows(0, rows).to_owned(),
            Some(r) => {
                let mut s = Mat::<f64>::zeros(n1 + rows, n1);
                s.as_mut().subrows_mut(0, n1).copy_from(r);
                s.as_mut()
                    .subrows_mut(n1, rows)
                    .copy_from(self.block.as_ref().subrows(0, rows));
                s
            }
        };
        let qr = stacked.qr();
        let thin = qr.thin_R();
        let mut r = Mat::<f64>::zeros(n1, n1);
        let k = thin.nrows().min(n1);
        r.as_mut().subrows_mut(0, k).copy_from(thin.subrows(0, k));
        self.r = Some(r);
        self.filled = 0;
    }

    /// Solves the accumulated problem.
    pub fn finish(mut self) -> Result<LstsqSolution, LstsqError> {
        let n = self.cols;
        if self.rows < n {
            return Err(LstsqError::TooFewRows {
                rows: self.rows,
                cols: n,
            });
        }
        if let Some(row) = self.first_non_finite {
            return Err(LstsqError::NonFinite { row });
        }
        if let Some(column) = self.column_sq_norms.iter().position(|&s| s == 0.0) {
            return Err(LstsqError::RankDeficient {
                condition: f64::INFINITY,
                column: Some(column),
            });
        }
        self.fold();
        let r_aug = self.r.take().expect("at least one row was folded");
        let r11 = r_aug.as_ref().submatrix(0, 0, n, n).to_owned();
        let qty: Vec<f64> = (0..n).map(|i| r_aug[(i, n)]).collect();
        let residual_norm = r_aug[(n, n)].abs();

        let condition_number = condition(r11.as_ref())?;
        // Equilibrate: R D^-1 has the singular values of Phi D^-1.
        let mut scaled = r11.clone();
        for j in 0..n {
            let norm = self.column_sq_norms[j].sqrt();
            for i in 0..n {
                scaled[(i, j)] /= norm;
            }
        }
        let scaled_condition_number = condition(scaled.as_ref())?;
        if !(scaled_condition_number.is_finite()
            && scaled_condition_number * self.params.rank_tol < 1.0)
        {
            // The smallest |R_jj| of the scaled factor marks a dependent column.
            let column =
                (0..n).min_by(|&a, &b| scaled[(a, a)].abs().total_cmp(&scaled[(b, b)].abs()));
            return Err(LstsqError::RankDeficient {
                condition: scaled_condition_number,
                column,
            });
        }
        // Back substitution R11 theta = Q^T y.
        let mut theta = qty;
        for i in (0..n).rev() {
            let mut s = theta[i];
            for j in i + 1..n {
                s -= r11[(i, j)] * theta[j];
            }
            theta[i] = s / r11[(i, i)];
        }
        Ok(LstsqSolution {
            theta,
            residual_norm,
            condition_number,
            scaled_condition_number,
            rows: self.rows,
            r: r11,
        })
    }
}

fn condition(m: MatRef<'_, f64>) -> Result<f64, LstsqError> {
    let s = m.singular_values().map_err(|_| LstsqError::Svd)?;
    let max = s.first().copied().unwrap_or(0.0);
    let min = s.last().copied().unwrap_or(0.0);
    Ok(if min == 0.0 { f64::INFINITY } else { max / min })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_closed_form() {
        // y = 2 + 3 x exactly; plus a perpendicular residual check.
        let x = [0.0, 1.0, 2.0, 3.0, 4.0];
        let phi = Mat::from_fn(5, 2, |i, j| if j == 0 { 1.0 } else { x[i] });
        let y: Vec<f64> = x.iter().map(|v| 2.0 + 3.0 * v).collect();
        let s = lstsq(phi.as_ref(), &y, &LstsqParams::default()).unwrap();
        assert!((s.theta[0] - 2.0).abs() < 1e-14 && (s.theta[1] - 3.0).abs() < 1e-14);
        assert!(s.residual_norm < 1e-13);
        // Residual of a known inconsistent system: y = [0, 1, 0] on a constant
        // column gives theta = 1/3 and residual sqrt(2/3).
        let phi = Mat::from_fn(3, 1, |_, _| 1.0);
        let s = lstsq(phi.as_ref(), &[0.0, 1.0, 0.0], &LstsqParams::default()).unwrap();
        assert!((s.theta[0] - 1.0 / 3.0).abs() < 1e-15);
        assert!((s.residual_norm - (2.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert!((s.condition_number - 1.0).abs() < 1e-14);
    }

    #[test]
    fn streaming_equals_dense_across_blocks() {
        let n = 1000;
        let phi = Mat::from_fn(n, 3, |i, j| ((i * (j + 3)) as f64 * 0.37).sin());
        let y: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        let dense = lstsq(
            phi.as_ref(),
            &y,
            &LstsqParams {
                block_rows: 100_000,
                ..Default::default()
            },
        )
        .unwrap();
        let small = lstsq(
            phi.as_ref(),
            &y,
            &LstsqParams {
                block_rows: 7,
                ..Default::default()
            },
        )
        .unwrap();
        for (a, b) in dense.theta.iter().zip(&small.theta) {
            assert!((a - b).abs() < 1e-12 * (1.0 + a.abs()), "{a} vs {b}");
        }
        assert!((dense.residual_norm - small.residual_norm).abs() < 1e-12 * dense.residual_norm);
    }

    #[test]
    fn errors() {
        let p = LstsqParams::default();
        let phi = Mat::from_fn(3, 2, |i, _| i as f64);
        assert!(matches!(
            lstsq(phi.as_ref(), &[1.0, 2.0, 3.0], &p),
            Err(LstsqError::RankDeficient { .. })
        ));
        let phi = Mat::from_fn(1, 2, |_, _| 1.0);
        assert!(matches!(
            lstsq(phi.as_ref(), &[1.0], &p),
            Err(LstsqError::TooFewRows { .. })
        ));
        let phi = Mat::from_fn(3, 1, |i, _| i as f64 + 1.0);
        assert!(matches!(
            lstsq(phi.as_ref(), &[1.0, f64::NAN, 3.0], &p),
            Err(LstsqError::NonFinite { row: 1 })
        ));
        let phi = Mat::from_fn(3, 2, |i, j| if j == 0 { i as f64 } else { 0.0 });
        assert!(matches!(
            lstsq(phi.as_ref(), &[1.0, 2.0, 3.0], &p),
            Err(LstsqError::RankDeficient {
                column: Some(1),
                ..
            })
        ));
    }
}
