//! Linear least squares `min ||Phi theta - y||_2` by Householder QR, never by
//! the normal equations (which square the condition number). This module is
//! the crate's one QR engine: ARX/IV/OE, the initial-condition fits and the
//! hysteresis identification all reduce their regressions here.
//!
//! * [`StreamingQr`] reduces a tall matrix (`N` up to millions, a few dozen
//!   columns) to its `p x p` triangular factor with `O(block * p)` memory.
//!   Rows arrive either as column-major blocks ([`StreamingQr::push_blocks`],
//!   [`StreamingQr::block_cols_mut`] + [`StreamingQr::fold_block`]) — the
//!   natural form for shifted signal copies and play-operator outputs — or one
//!   at a time ([`StreamingQr::push_row`], buffered into the block, no
//!   allocation per row). Each full block is folded by `R <- qr([R; block])`
//!   with a Householder kernel that skips the known zeros of `R` and applies
//!   reflectors in pairs (one read pass and one write pass over the block per
//!   pair of reflectors); an AVX2+FMA build of the same kernel is picked at run
//!   time on x86-64.
//! * [`solve_triangle`] reads the least-squares solution off the factor of
//!   `[Phi | y]`: with `[Phi y] = Q [R11 r12; 0 r22]`, `R11 theta = r12` and the
//!   residual norm is `|r22|`. [`std_devs`] gives parameter standard deviations
//!   from `R11^-1`.
//! * [`StreamingLstsq`] (rows pushed one at a time) and [`lstsq`] (regressor in
//!   memory) wrap the two with input checks.
//!
//! Conditioning is measured by the singular values of `R11` (equal to those of
//! `Phi`), both for `Phi` as given and for `Phi` with unit-norm columns; rank
//! deficiency is judged on the latter, because column scaling (volts vs
//! micrometres) must not decide whether a problem is solvable.

use faer::{Mat, MatRef};

/// Rows per block: the block (`rows x p` doubles, 26 KiB for p = 13) stays in
/// L1/L2 cache while the reflectors sweep it.
pub const DEFAULT_BLOCK_ROWS: usize = 256;

/// Settings of the least-squares solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LstsqParams {
    /// The regression counts as rank deficient when the condition number of
    /// the column-equilibrated regressor exceeds `1 / rank_tol`.
    /// Default `1e-12` (about `4500 * f64::EPSILON`): beyond it the solution
    /// has no correct digits worth reporting.
    pub rank_tol: f64,
    /// Rows folded per block in [`StreamingLstsq`]. Default
    /// [`DEFAULT_BLOCK_ROWS`].
    pub block_rows: usize,
}

impl Default for LstsqParams {
    fn default() -> Self {
        Self {
            rank_tol: 1e-12,
            block_rows: DEFAULT_BLOCK_ROWS,
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
    /// Singular values of `Phi` (those of `R11`), decreasing.
    pub singular_values: Vec<f64>,
    /// Rows used.
    pub rows: usize,
    /// The upper-triangular factor `R11` of `Phi` (n x n), useful for
    /// parameter covariances: `cov(theta) = sigma^2 (R^T R)^-1`.
    pub r: Mat<f64>,
    /// `R11^-1`, for the covariance `sigma^2 R11^-1 R11^-T` ([`std_devs`]).
    pub r_inv: Mat<f64>,
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
        /// First offending row (0-based). Exact for rows pushed one at a
        /// time; for rows fed as blocks, the first row of the block in which
        /// the factor became non-finite.
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
        /// Numerical rank: singular values of the column-equilibrated
        /// regressor above `rank_tol` times the largest.
        rank: usize,
    },
    /// The SVD used for the condition number failed to converge.
    #[error("SVD of the triangular factor did not converge")]
    Svd,
}

impl LstsqError {
    /// `(numerical rank, scaled condition number)` for a report on a
    /// regression of `cols` unknowns (rank 0 and an infinite condition number
    /// unless the error is [`LstsqError::RankDeficient`]).
    pub fn rank_and_condition(&self) -> (usize, f64) {
        match self {
            LstsqError::RankDeficient {
                rank, condition, ..
            } => (*rank, *condition),
            _ => (0, f64::INFINITY),
        }
    }
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

/// Least squares over rows pushed one at a time: a [`StreamingQr`] of
/// `[phi | y]` plus the checks of [`StreamingLstsq::finish`].
#[derive(Debug, Clone)]
pub struct StreamingLstsq {
    qr: StreamingQr,
    params: LstsqParams,
}

impl StreamingLstsq {
    /// An empty accumulator for `cols` unknowns.
    pub fn new(cols: usize, params: &LstsqParams) -> Self {
        Self {
            qr: StreamingQr::with_block_rows(cols + 1, params.block_rows),
            params: *params,
        }
    }

    /// Number of unknowns.
    pub fn cols(&self) -> usize {
        self.qr.cols() - 1
    }

    /// Rows pushed so far.
    pub fn rows(&self) -> usize {
        self.qr.rows()
    }

    /// Adds the equation `phi . theta = y`. Does not allocate.
    #[inline]
    pub fn push_row(&mut self, phi: &[f64], y: f64) {
        self.qr.push_row_parts(phi, y);
    }

    /// Solves the accumulated problem.
    pub fn finish(self) -> Result<LstsqSolution, LstsqError> {
        let n = self.cols();
        if self.rows() < n {
            return Err(LstsqError::TooFewRows {
                rows: self.rows(),
                cols: n,
            });
        }
        let tri = self.qr.into_triangle();
        if let Some(row) = tri.first_non_finite {
            return Err(LstsqError::NonFinite { row });
        }
        solve_triangle_with(&tri, self.params.rank_tol)
    }
}

/// The upper-triangular factor `R` of an `m x p` matrix, as produced by
/// [`StreamingQr::into_triangle`] or [`triangularize`], together with the
/// number of rows reduced.
#[derive(Debug, Clone)]
pub struct Triangle {
    /// `p x p`, upper triangular (entries below the diagonal are zero).
    pub r: Mat<f64>,
    /// Number of rows of the original matrix.
    pub rows: usize,
    /// First row (see [`LstsqError::NonFinite`]) at which a NaN or infinity
    /// entered the factor, if any.
    pub first_non_finite: Option<usize>,
}

/// QR-reduces the `rows x ncols` matrix whose column `j`, rows
/// `start .. start + out.len()`, is written by `fill(j, start, out)`
/// (see [`StreamingQr::push_blocks`]), in blocks of at most `block_rows` rows.
pub fn triangularize(
    ncols: usize,
    rows: usize,
    block_rows: usize,
    fill: impl FnMut(usize, usize, &mut [f64]),
) -> Triangle {
    let block = block_rows.max(1).min(rows.max(1));
    let mut qr = StreamingQr::with_block_rows(ncols, block);
    qr.push_blocks(rows, fill);
    qr.into_triangle()
}

/// [`triangularize`] of a long matrix (at least `PARALLEL_SAMPLES` rows)
/// as two halves of rows, reduced on two threads where the machine has
/// them, the second factor then folded into the first (`[R1; R2] = Q R`,
/// the factor of the whole). The cut depends on the rows alone, not on the
/// machine, and so does the factor. `fill` as in [`triangularize`].
pub fn triangularize_halves(
    ncols: usize,
    rows: usize,
    block_rows: usize,
    fill: impl Fn(usize, usize, &mut [f64]) + Sync,
) -> Triangle {
    if rows < super::fork::PARALLEL_SAMPLES {
        return triangularize(ncols, rows, block_rows, fill);
    }
    let block = block_rows.max(1).min(rows.max(1));
    let reduce = |from: usize, count: usize| {
        let mut qr = StreamingQr::with_block_rows(ncols, block);
        qr.push_blocks(count, |j, start, out| fill(j, from + start, out));
        qr
    };
    let half = rows / 2;
    let (second, first) = super::fork::join(rows, || reduce(half, rows - half), || reduce(0, half));
    first.absorb(second)
}

/// Streaming Householder QR of a tall matrix: keeps only the `p x p`
/// triangular factor and one block of rows.
#[derive(Debug, Clone)]
pub struct StreamingQr {
    cols: usize,
    /// Block rows (the leading dimension of `block`).
    ld: usize,
    /// Upper-triangular factor, column-major `cols x cols`.
    r: Vec<f64>,
    /// Rows not yet folded, column-major with leading dimension `ld`.
    block: Vec<f64>,
    /// Rows buffered in `block` by `push_row`.
    filled: usize,
    /// Rows pushed so far (folded or buffered).
    rows: usize,
    first_non_finite: Option<usize>,
    kernel: Kernel,
}

impl StreamingQr {
    /// An empty factor of a matrix with `cols` columns, blocks of
    /// [`DEFAULT_BLOCK_ROWS`] rows.
    pub fn new(cols: usize) -> Self {
        Self::with_block_rows(cols, DEFAULT_BLOCK_ROWS)
    }

    /// An empty factor with blocks of `block_rows` rows (at least 1).
    pub fn with_block_rows(cols: usize, block_rows: usize) -> Self {
        let ld = block_rows.max(1);
        Self {
            cols,
            ld,
            r: vec![0.0; cols * cols],
            block: vec![0.0; ld * cols],
            filled: 0,
            rows: 0,
            first_non_finite: None,
            kernel: Kernel::detect(),
        }
    }

    /// Uses the portable kernel even where the AVX2+FMA one is available
    /// (to test one against the other).
    #[cfg(feature = "checks")]
    pub(crate) fn portable(mut self) -> Self {
        self.kernel = Kernel::Portable;
        self
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Rows pushed so far (folded or still buffered).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Rows per block.
    pub fn block_rows(&self) -> usize {
        self.ld
    }

    /// Appends one row (`cols` values). Buffered; folded when the block is
    /// full. Does not allocate.
    #[inline]
    pub fn push_row(&mut self, row: &[f64]) {
        assert_eq!(row.len(), self.cols, "StreamingQr::push_row: row length");
        let i = self.filled;
        for (j, &v) in row.iter().enumerate() {
            self.block[j * self.ld + i] = v;
        }
        self.after_row(row.iter().all(|v| v.is_finite()));
    }

    /// Appends the row `[phi, y]`.
    #[inline]
    fn push_row_parts(&mut self, phi: &[f64], y: f64) {
        assert_eq!(phi.len() + 1, self.cols, "push_row: row length");
        let i = self.filled;
        for (j, &v) in phi.iter().enumerate() {
            self.block[j * self.ld + i] = v;
        }
        self.block[phi.len() * self.ld + i] = y;
        self.after_row(y.is_finite() && phi.iter().all(|v| v.is_finite()));
    }

    #[inline]
    fn after_row(&mut self, finite: bool) {
        if !finite && self.first_non_finite.is_none() {
            self.first_non_finite = Some(self.rows);
        }
        self.filled += 1;
        self.rows += 1;
        if self.filled == self.ld {
            self.flush();
        }
    }

    /// Folds the rows buffered by [`StreamingQr::push_row`] into the factor.
    pub fn flush(&mut self) {
        if self.filled > 0 {
            let len = self.filled;
            self.filled = 0;
            self.fold(len);
        }
    }

    /// Every column of the block buffer ([`StreamingQr::block_rows`] long
    /// each), disjoint, to be filled and then folded by
    /// [`StreamingQr::fold_block`]. Buffered rows are folded first.
    pub fn block_cols_mut(&mut self) -> Vec<&mut [f64]> {
        self.flush();
        self.block.chunks_mut(self.ld).collect()
    }

    /// Folds the first `rows` rows of the block buffer (as filled through
    /// [`StreamingQr::block_cols_mut`]) into the factor.
    pub fn fold_block(&mut self, rows: usize) {
        assert!(
            rows <= self.ld,
            "fold_block: more rows than the block holds"
        );
        assert_eq!(
            self.filled, 0,
            "fold_block: rows pushed one at a time are pending"
        );
        self.rows += rows;
        self.fold(rows);
    }

    /// Appends `rows` rows given column by column: `fill(j, start, out)` writes
    /// rows `start .. start + out.len()` (counted from the first row of this
    /// call) of column `j`. Called once per column and block, with
    /// consecutive row ranges.
    pub fn push_blocks(&mut self, rows: usize, mut fill: impl FnMut(usize, usize, &mut [f64])) {
        self.flush();
        let mut start = 0;
        while start < rows {
            let len = self.ld.min(rows - start);
            for j in 0..self.cols {
                fill(j, start, &mut self.block[j * self.ld..j * self.ld + len]);
            }
            self.rows += len;
            self.fold(len);
            start += len;
        }
    }

    /// The triangular factor, column-major `cols x cols` (entries below the
    /// diagonal are zero). Panics if rows pushed one at a time are still
    /// buffered: call [`StreamingQr::flush`] first.
    pub fn r(&self) -> &[f64] {
        assert_eq!(self.filled, 0, "StreamingQr::r: call flush() first");
        &self.r
    }

    /// Folds what is buffered and returns the factor.
    pub fn into_triangle(mut self) -> Triangle {
        self.flush();
        let p = self.cols;
        Triangle {
            r: Mat::from_fn(p, p, |i, j| if i <= j { self.r[j * p + i] } else { 0.0 }),
            rows: self.rows,
            first_non_finite: self.first_non_finite,
        }
    }

    /// The factor of this matrix with the rows of `other` below it: the
    /// rows of `other`'s factor folded into this one.
    pub fn absorb(mut self, other: StreamingQr) -> Triangle {
        assert_eq!(self.cols, other.cols, "StreamingQr::absorb: columns");
        let below = other.into_triangle();
        let first_non_finite = self
            .first_non_finite
            .or(below.first_non_finite.map(|row| self.rows + row));
        let rows = self.rows + below.rows;
        let mut row = vec![0.0; self.cols];
        for i in 0..self.cols {
            for (j, v) in row.iter_mut().enumerate() {
                *v = below.r[(i, j)];
            }
            self.push_row(&row);
        }
        let mut tri = self.into_triangle();
        tri.rows = rows;
        tri.first_non_finite = first_non_finite.or(tri.first_non_finite);
        tri
    }

    /// Folds the first `len` rows of the block into the factor.
    fn fold(&mut self, len: usize) {
        if len == 0 {
            return;
        }
        self.kernel
            .fold(self.cols, self.ld, &mut self.r, &mut self.block, len);
        if self.first_non_finite.is_none() {
            let p = self.cols;
            let bad = (0..p).any(|j| !self.r[j * p + j].is_finite())
                || (0..p).any(|j| !self.r[(p - 1) * p + j].is_finite());
            if bad {
                self.first_non_finite = Some(self.rows - len);
            }
        }
    }
}

/// Solves `R11 theta = r12` from the factor of `[Phi y]` (last column `y`),
/// with the default rank tolerance ([`LstsqParams::default`]).
pub fn solve_triangle(tri: &Triangle) -> Result<LstsqSolution, LstsqError> {
    solve_triangle_with(tri, LstsqParams::default().rank_tol)
}

/// Solves `R11 theta = r12` from the factor of `[Phi y]` (last column `y`).
///
/// Rank is judged on the singular values of `Phi` with unit-norm columns
/// (those of `R11 D^-1`, `D` the column norms, which `R11` preserves), so that
/// units do not decide solvability: the regression is singular when that
/// scaled condition number exceeds `1 / rank_tol`. The error names the zero
/// column, else the column with the smallest scaled diagonal entry.
pub fn solve_triangle_with(tri: &Triangle, rank_tol: f64) -> Result<LstsqSolution, LstsqError> {
    let p = tri.r.ncols();
    let d = p - 1;
    let r11: MatRef<'_, f64> = tri.r.as_ref().submatrix(0, 0, d, d);
    let svd_of = |m: MatRef<'_, f64>| -> Result<Vec<f64>, LstsqError> {
        if d == 0 {
            Ok(Vec::new())
        } else {
            fts_kernels::dense::singular_values(m.as_ref()).map_err(|_| LstsqError::Svd)
        }
    };
    let norms: Vec<f64> = (0..d)
        .map(|j| (0..=j).map(|i| r11[(i, j)].powi(2)).sum::<f64>().sqrt())
        .collect();
    if let Some(column) = norms.iter().position(|&n| n == 0.0 || !n.is_finite()) {
        let rank = norms.iter().filter(|&&n| n > 0.0 && n.is_finite()).count();
        return Err(LstsqError::RankDeficient {
            condition: f64::INFINITY,
            column: Some(column),
            rank: rank.min(d.saturating_sub(1)),
        });
    }
    let scaled = Mat::<f64>::from_fn(d, d, |i, j| r11[(i, j)] / norms[j]);
    let ssv = svd_of(scaled.as_ref())?;
    let smax_s = ssv.first().copied().unwrap_or(0.0);
    let rank = ssv.iter().filter(|&&s| s > rank_tol * smax_s).count();
    let scaled_condition_number = match ssv.last() {
        Some(&m) if m > 0.0 => smax_s / m,
        _ => f64::INFINITY,
    };
    // `partial_cmp` so that a NaN condition number also counts as deficient.
    let too_ill =
        (scaled_condition_number * rank_tol).partial_cmp(&1.0) != Some(std::cmp::Ordering::Less);
    if rank < d || !smax_s.is_finite() || (d > 0 && too_ill) {
        // The smallest |R_jj| of the scaled factor marks a dependent column.
        let column = (0..d).min_by(|&a, &b| scaled[(a, a)].abs().total_cmp(&scaled[(b, b)].abs()));
        return Err(LstsqError::RankDeficient {
            condition: scaled_condition_number,
            column,
            rank: rank.min(d.saturating_sub(1)),
        });
    }
    let sv = svd_of(r11)?;
    let smax = sv.first().copied().unwrap_or(0.0);
    let condition_number = match sv.last() {
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
    // R11 theta = r12 by back substitution (not via R11^-1: more accurate).
    let mut theta: Vec<f64> = (0..d).map(|i| tri.r[(i, d)]).collect();
    for i in (0..d).rev() {
        let s: f64 = (i + 1..d).map(|j| tri.r[(i, j)] * theta[j]).sum();
        theta[i] = (theta[i] - s) / tri.r[(i, i)];
    }
    Ok(LstsqSolution {
        theta,
        residual_norm: tri.r[(d, d)].abs(),
        condition_number,
        scaled_condition_number,
        singular_values: sv,
        rows: tri.rows,
        r: r11.to_owned(),
        r_inv,
    })
}

/// Standard deviations `sqrt(diag(lambda R^-1 R^-T))` from `R^-1`
/// ([`LstsqSolution::r_inv`]) and the noise variance `lambda`.
pub fn std_devs(r_inv: &Mat<f64>, lambda: f64) -> Vec<f64> {
    let d = r_inv.nrows();
    (0..d)
        .map(|i| {
            let s: f64 = (i..d).map(|k| r_inv[(i, k)].powi(2)).sum();
            (lambda * s).sqrt()
        })
        .collect()
}

/// Which build of [`fold_kernel`] runs: the AVX2+FMA one when the CPU has it
/// (chosen at run time, so the binary stays portable), else the portable one.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Kernel {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2Fma,
}

impl Kernel {
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return Kernel::Avx2Fma;
            }
        }
        Kernel::Portable
    }

    fn fold(self, n: usize, ld: usize, r: &mut [f64], block: &mut [f64], rows: usize) {
        assert!(rows <= ld && r.len() == n * n && block.len() >= n * ld);
        match self {
            Kernel::Portable => fold_kernel::<false>(n, ld, r, block, rows),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Kernel::Avx2Fma` is only constructed by `detect` after
            // `is_x86_feature_detected!` confirmed AVX2 and FMA on this CPU;
            // `fold_avx2` has no other precondition (all accesses are
            // bounds-checked slices).
            Kernel::Avx2Fma => unsafe { fold_avx2(n, ld, r, block, rows) },
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn fold_avx2(n: usize, ld: usize, r: &mut [f64], block: &mut [f64], rows: usize) {
    fold_kernel::<true>(n, ld, r, block, rows);
}

/// Folds a block into `R`: Householder QR of `[R; B]` exploiting that `R`
/// (column-major `n x n`) is already upper triangular, so reflector `j` only
/// touches row `j` of `R` and the block `B` (column-major, leading dimension
/// `ld`, `rows` rows). With `x = R[j,j]`, `sigma = ||b_j||^2`,
/// `alpha = -sign(x) sqrt(x^2 + sigma)` (no cancellation, Golub & Van Loan
/// 5.1.3), `v = [x - alpha; b_j]`, `H = I - beta v v^T`; `v` is never formed.
/// `FMA` selects fused multiply-adds (only where the CPU has them:
/// `f64::mul_add` is a slow library call otherwise).
///
/// Reflectors are applied two at a time: for the pair `(j, k = j+1)` each
/// trailing column needs both dot products (one pass over the block) and one
/// combined update (a second pass), instead of two passes per reflector. With
/// the R parts of `v_j`, `v_k` on different rows,
/// `v_k^T (H_j c) = v_k^T c - s_j (b_k . b_j)`.
#[inline(always)]
fn fold_kernel<const FMA: bool>(
    n: usize,
    ld: usize,
    r: &mut [f64],
    block: &mut [f64],
    rows: usize,
) {
    let mut j = 0;
    while j < n {
        let (head, tail) = block.split_at_mut((j + 1) * ld);
        let bj = &head[j * ld..j * ld + rows];
        let Some((v0j, beta_j)) = reflector::<FMA>(n, r, bj, j) else {
            j += 1;
            continue;
        };
        if j + 1 == n {
            break;
        }
        // Column k = j + 1 gets H_j alone, then yields the second reflector.
        let k = j + 1;
        let (bk_all, rest) = tail.split_at_mut(ld);
        let bk = &mut bk_all[..rows];
        let s = beta_j * (v0j * r[k * n + j] + dot::<FMA>(bj, bk));
        r[k * n + j] -= s * v0j;
        axpy::<FMA>(-s, bj, bk);
        let bk = &bk_all[..rows];
        match reflector::<FMA>(n, r, bk, k) {
            Some((v0k, beta_k)) => {
                let cross = dot::<FMA>(bk, bj);
                for l in k + 1..n {
                    let bl = &mut rest[(l - k - 1) * ld..(l - k - 1) * ld + rows];
                    let (dj, dk) = dot2::<FMA>(bj, bk, bl);
                    let s_j = beta_j * (v0j * r[l * n + j] + dj);
                    let s_k = beta_k * (v0k * r[l * n + k] + dk - s_j * cross);
                    r[l * n + j] -= s_j * v0j;
                    r[l * n + k] -= s_k * v0k;
                    axpy2::<FMA>(-s_j, bj, -s_k, bk, bl);
                }
            }
            None => {
                for l in k + 1..n {
                    let bl = &mut rest[(l - k - 1) * ld..(l - k - 1) * ld + rows];
                    let s = beta_j * (v0j * r[l * n + j] + dot::<FMA>(bj, bl));
                    r[l * n + j] -= s * v0j;
                    axpy::<FMA>(-s, bj, bl);
                }
            }
        }
        j += 2;
    }
}

/// Makes the reflector of column `j` (`R[j, j]` becomes alpha): `(v0,
/// beta)`, or `None` if the block column is already zero. A function, not a
/// closure, so that it is inlined into the caller's target features (a
/// closure is compiled for the baseline CPU, where `mul_add` is a library
/// call).
#[inline(always)]
fn reflector<const FMA: bool>(n: usize, r: &mut [f64], bj: &[f64], j: usize) -> Option<(f64, f64)> {
    let sigma = dot::<FMA>(bj, bj);
    if sigma == 0.0 {
        return None;
    }
    let x = r[j * n + j];
    let norm = (x * x + sigma).sqrt();
    let alpha = if x > 0.0 { -norm } else { norm };
    let v0 = x - alpha;
    r[j * n + j] = alpha;
    Some((v0, 2.0 / (v0 * v0 + sigma)))
}

/// `(a . c, b . c)` in one pass.
#[inline(always)]
fn dot2<const FMA: bool>(a: &[f64], b: &[f64], c: &[f64]) -> (f64, f64) {
    let n = a.len().min(b.len()).min(c.len());
    let (a, b, c) = (&a[..n], &b[..n], &c[..n]);
    let mut acc_a = [0.0f64; 4];
    let mut acc_b = [0.0f64; 4];
    let chunks = n / 4;
    for q in 0..chunks {
        let (xa, xb, xc) = (
            &a[4 * q..4 * q + 4],
            &b[4 * q..4 * q + 4],
            &c[4 * q..4 * q + 4],
        );
        for t in 0..4 {
            acc_a[t] = madd::<FMA>(xa[t], xc[t], acc_a[t]);
            acc_b[t] = madd::<FMA>(xb[t], xc[t], acc_b[t]);
        }
    }
    let (mut sa, mut sb) = (
        (acc_a[0] + acc_a[1]) + (acc_a[2] + acc_a[3]),
        (acc_b[0] + acc_b[1]) + (acc_b[2] + acc_b[3]),
    );
    for i in 4 * chunks..n {
        sa += a[i] * c[i];
        sb += b[i] * c[i];
    }
    (sa, sb)
}

/// `c += alpha a + beta b` in one pass.
#[inline(always)]
fn axpy2<const FMA: bool>(alpha: f64, a: &[f64], beta: f64, b: &[f64], c: &mut [f64]) {
    for ((ci, ai), bi) in c.iter_mut().zip(a).zip(b) {
        *ci = madd::<FMA>(beta, *bi, madd::<FMA>(alpha, *ai, *ci));
    }
}

#[inline(always)]
pub(crate) fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA { a.mul_add(b, c) } else { a * b + c }
}

/// Dot product with eight accumulators so the compiler can vectorise it
/// without reassociating a single sum (`FMA`: fused multiply-adds, only
/// where the CPU has them). Shared by the QR fold, the residual tests'
/// correlations and the gradient identification.
#[inline(always)]
pub(crate) fn dot<const FMA: bool>(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for t in 0..8 {
            acc[t] = madd::<FMA>(x[t], y[t], acc[t]);
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])) + tail
}

#[inline(always)]
fn axpy<const FMA: bool>(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi = madd::<FMA>(alpha, *xi, *yi);
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn line_fit_closed_form() {
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

    pub fn streaming_equals_dense_across_blocks() {
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

    /// The factor of two halves folded together is the factor of the
    /// whole: `R^T R` (the Gram matrix, free of the rows' signs), the
    /// solution and the residual norm agree with one pass to round-off, and
    /// a NaN in the second half is placed in the block that held it.
    pub fn halves_equal_one_pass() {
        let (rows, cols) = (3 * super::super::fork::PARALLEL_SAMPLES / 2 + 17, 6);
        let value =
            |j: usize, k: usize| ((k * (j + 3) + j * j) as f64 * 0.37).sin() + 0.1 * j as f64;
        let fill = |j: usize, start: usize, out: &mut [f64]| {
            for (r, o) in out.iter_mut().enumerate() {
                *o = value(j, start + r);
            }
        };
        let whole = triangularize(cols, rows, DEFAULT_BLOCK_ROWS, fill);
        let halves = triangularize_halves(cols, rows, DEFAULT_BLOCK_ROWS, fill);
        assert_eq!(halves.rows, rows);
        assert_eq!(halves.first_non_finite, None);
        let gram = |r: &Mat<f64>| r.transpose() * r;
        let (g1, g2) = (gram(&whole.r), gram(&halves.r));
        let scale = (0..cols).map(|j| g1[(j, j)]).fold(0.0, f64::max);
        for i in 0..cols {
            for j in 0..cols {
                let d = (g1[(i, j)] - g2[(i, j)]).abs();
                assert!(
                    d < 64.0 * f64::EPSILON * scale,
                    "Gram ({i},{j}) differs by {d:e}"
                );
            }
        }
        let (a, b) = (
            solve_triangle(&whole).unwrap(),
            solve_triangle(&halves).unwrap(),
        );
        for (x, y) in a.theta.iter().zip(&b.theta) {
            assert!((x - y).abs() < 1e-12 * (1.0 + x.abs()), "{x} vs {y}");
        }
        assert!((a.residual_norm - b.residual_norm).abs() < 1e-12 * a.residual_norm);
        let nan_row = rows - 100;
        let with_nan = triangularize_halves(cols, rows, DEFAULT_BLOCK_ROWS, |j, start, out| {
            fill(j, start, out);
            if (start..start + out.len()).contains(&nan_row) {
                out[nan_row - start] = f64::NAN;
            }
        });
        let row = with_nan.first_non_finite.expect("NaN found");
        assert!(
            row <= nan_row && nan_row < row + DEFAULT_BLOCK_ROWS,
            "{row}"
        );
        // Below the threshold the factor is the one-pass factor itself.
        let short = triangularize_halves(cols, 1000, DEFAULT_BLOCK_ROWS, fill);
        assert_eq!(
            short.r,
            triangularize(cols, 1000, DEFAULT_BLOCK_ROWS, fill).r
        );
    }

    pub fn errors() {
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

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    pub fn blocked_equals_direct_least_squares() {
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

    pub fn rank_deficiency_is_detected() {
        let tri = triangularize(3, 50, 16, |j, s, out| {
            for (r, v) in out.iter_mut().enumerate() {
                let t = (s + r) as f64;
                *v = if j < 2 { 1.0 } else { t };
            }
        });
        let (rank, cond) = solve_triangle(&tri).unwrap_err().rank_and_condition();
        assert_eq!(rank, 1);
        assert!(cond > 1e12);
    }

    /// Solution, residual and condition number of both kernel builds (when the
    /// CPU has AVX2+FMA; else the portable one twice) against faer's dense QR
    /// on a random well-conditioned problem, with rows fed as blocks, one at a
    /// time, and mixed.
    pub fn kernels_match_faer_qr() {
        let (m, n) = (3 * DEFAULT_BLOCK_ROWS + 37, 9);
        let mut seed = 11;
        let phi = Mat::<f64>::from_fn(m, n, |_, _| lcg(&mut seed));
        let y: Vec<f64> = (0..m).map(|_| lcg(&mut seed)).collect();
        // Reference: faer Householder QR of [phi y].
        let aug = Mat::<f64>::from_fn(m, n + 1, |i, j| if j < n { phi[(i, j)] } else { y[i] });
        let qr = aug.qr();
        let rf = qr.thin_R().to_owned();
        let mut theta_ref: Vec<f64> = (0..n).map(|i| rf[(i, n)]).collect();
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|j| rf[(i, j)] * theta_ref[j]).sum();
            theta_ref[i] = (theta_ref[i] - s) / rf[(i, i)];
        }
        let resid_ref = rf[(n, n)].abs();
        let fill = |j: usize, s: usize, out: &mut [f64]| {
            for (r, o) in out.iter_mut().enumerate() {
                *o = if j < n { phi[(s + r, j)] } else { y[s + r] };
            }
        };
        let check = |tri: Triangle, what: &str| {
            let sol = solve_triangle(&tri).unwrap();
            let scale = theta_ref.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for (a, b) in sol.theta.iter().zip(&theta_ref) {
                assert!((a - b).abs() <= 1e-12 * scale, "{what}: {a} vs {b}");
            }
            assert!(
                (sol.residual_norm - resid_ref).abs() <= 1e-12 * resid_ref,
                "{what}"
            );
            for i in 0..=n {
                for j in i..=n {
                    assert!(
                        (tri.r[(i, j)].abs() - rf[(i, j)].abs()).abs()
                            <= 1e-12 * rf[(j, j)].abs().max(1.0) * 10.0,
                        "{what}: R[{i},{j}]"
                    );
                }
            }
            assert!(sol.condition_number > 1.0 && sol.condition_number < 10.0);
            assert_eq!(tri.rows, m);
        };
        for portable in [false, true] {
            let make = || {
                let q = StreamingQr::new(n + 1);
                if portable { q.portable() } else { q }
            };
            let mut q = make();
            q.push_blocks(m, fill);
            check(q.into_triangle(), &format!("blocks, portable={portable}"));
            let mut q = make();
            let mut row = vec![0.0; n + 1];
            for i in 0..m {
                for (j, v) in row.iter_mut().enumerate() {
                    *v = if j < n { phi[(i, j)] } else { y[i] };
                }
                q.push_row(&row);
                if i == 100 {
                    // Mixed: a block after some single rows.
                    q.push_blocks(0, fill);
                }
            }
            check(q.into_triangle(), &format!("rows, portable={portable}"));
        }
    }

    pub fn portable_and_dispatched_fold_agree() {
        // The run-time dispatch may pick the AVX2+FMA build; the portable
        // kernel must give the same R to rounding.
        let n = 5;
        let mut seed = 3;
        let mut fast = StreamingQr::new(n);
        let mut slow = StreamingQr::new(n).portable();
        for _ in 0..3 {
            let block: Vec<f64> = (0..DEFAULT_BLOCK_ROWS * n)
                .map(|_| lcg(&mut seed))
                .collect();
            for q in [&mut fast, &mut slow] {
                for (c, src) in q
                    .block_cols_mut()
                    .into_iter()
                    .zip(block.chunks(DEFAULT_BLOCK_ROWS))
                {
                    c.copy_from_slice(src);
                }
                q.fold_block(DEFAULT_BLOCK_ROWS - 7);
            }
        }
        assert_eq!(fast.rows(), 3 * (DEFAULT_BLOCK_ROWS - 7));
        for (a, b) in fast.r().iter().zip(slow.r()) {
            assert!((a - b).abs() < 1e-12 * (1.0 + b.abs()), "{a} vs {b}");
        }
    }

    pub fn non_finite_block_is_reported() {
        let mut q = StreamingLstsq::new(
            2,
            &LstsqParams {
                block_rows: 4,
                ..Default::default()
            },
        );
        for i in 0..10 {
            let v = if i == 6 { f64::INFINITY } else { i as f64 };
            q.push_row(&[1.0, v], 1.0);
        }
        assert_eq!(q.finish(), Err(LstsqError::NonFinite { row: 6 }));
        let tri = triangularize(2, 10, 4, |_, s, out| {
            for (r, o) in out.iter_mut().enumerate() {
                *o = if s + r == 6 {
                    f64::NAN
                } else {
                    1.0 + (s + r) as f64
                };
            }
        });
        assert_eq!(tri.first_non_finite, Some(4));
    }
}
