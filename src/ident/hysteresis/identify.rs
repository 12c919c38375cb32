//! Identification of PI, MPI-cbrt and MPI-deadzone models from input/output
//! records (docs/math.md §1.5).
//!
//! The model output is linear in its weights once the operator outputs are
//! known, so the regressor `Phi[k, :] = [1, cbrt(u(k)), F_{r_0}[u](k), ...]`
//! is built column by column and solved by QR (streaming, see [`super::lsq`]),
//! or by L-BFGS on the same cost ([`super::gd`]). MPI-deadzone is bilinear in
//! `(w, g)` and is identified by alternating least squares.

use super::gd::{GdInfo, GdParams, GdState, TriangularLeastSquares, gd_lstsq};
use super::lsq::{ColMajor, LsError, PartialSumConstraint, qr_of, solve_from_r};
use super::model::{DeadZoneStage, HysteresisModel, ModelKind, RateStage};
use super::operators::{
    PlayOperator, ThresholdError, check_thresholds, dead_zone, uniform_thresholds,
};
use crate::ident::ls::StreamingQr;
use argmin::core::observers::Observe;

/// How the weights are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Least squares by QR (optionally with the invertibility constraint).
    #[default]
    Ls,
    /// L-BFGS gradient descent on the same cost (\[Li21\]).
    Gd,
}

/// Settings of [`identify`]. Defaults: MPI-cbrt (\[Li21\] Eq. 4), 10 play
/// operators on the uniform grid, offset term on, least squares, no
/// invertibility constraint.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyParams {
    /// Model structure.
    pub kind: ModelKind,
    /// Play operator form; `None` picks the paper's: lower play for PI and
    /// MPI-cbrt (\[Li21\]), symmetric play for MPI-deadzone (\[Tang17\]).
    pub operator: Option<PlayOperator>,
    /// Number of play operators when `thresholds` is `None`. Default 10.
    pub operators: usize,
    /// Explicit play thresholds (strictly increasing, >= 0); `None` uses
    /// `r_i = i/N max|u|` (docs/math.md §1.1).
    pub thresholds: Option<Vec<f64>>,
    /// Dead-zone operators of MPI-deadzone, on `d_j = (j-1)/m max|v|`. Default 4.
    pub dead_zone_operators: usize,
    /// Identify a constant output offset (real sensors have one). Default true.
    pub offset: bool,
    /// Solver.
    pub method: Method,
    /// Constrain the partial sums of the play weights (and of the dead-zone
    /// weights) to be positive, which makes the model invertible (docs/math.md §1.5).
    /// Least squares only. Default false.
    pub invertible: bool,
    /// Lower bound of each partial sum under `invertible`, relative to
    /// `range(y) / range(u)` (the mean slope of the loop). Default 1e-6.
    pub min_partial_sum_rel: f64,
    /// Alternations of MPI-deadzone's two stages. Default 50.
    pub alternations: usize,
    /// Gradient solver settings (for `Method::Gd`).
    pub gd: GdParams,
    /// Rate-dependent weights `w_i + w1_i rho` (docs/math.md §1.7) with the
    /// record's sample time, s; `None` (default) for a rate-independent
    /// model. PI and MPI-cbrt, without the invertibility constraint.
    pub rate_ts: Option<f64>,
}

impl Default for IdentifyParams {
    fn default() -> Self {
        Self {
            kind: ModelKind::MpiCbrt,
            operator: None,
            operators: 10,
            thresholds: None,
            dead_zone_operators: 4,
            offset: true,
            method: Method::Ls,
            invertible: false,
            min_partial_sum_rel: 1e-6,
            alternations: 50,
            gd: GdParams::default(),
            rate_ts: None,
        }
    }
}

impl IdentifyParams {
    /// The solver as recorded in a model file: `ls`, `ls-invertible` or `gd`.
    pub fn method_name(&self) -> &'static str {
        match (self.method, self.invertible) {
            (Method::Gd, _) => "gd",
            (Method::Ls, true) => "ls-invertible",
            (Method::Ls, false) => "ls",
        }
    }

    /// The operator form actually used.
    pub fn operator_form(&self) -> PlayOperator {
        self.operator.unwrap_or(match self.kind {
            ModelKind::MpiDeadzone => PlayOperator::Symmetric,
            _ => PlayOperator::Lower,
        })
    }
}

/// The fit of a model to a record (docs/math.md §1.5), `e = y_model - y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// `100 rms(e) / (max y - min y)`.
    pub rms_percent: f64,
    /// `100 max|e| / (max y - min y)`.
    pub max_percent: f64,
    /// Samples compared.
    pub samples: usize,
}

impl Fit {
    /// Compares a model output with the measurement. `None` if the lengths
    /// differ, or are 0, or the measurement is constant.
    pub fn of(y_model: &[f64], y: &[f64]) -> Option<Fit> {
        if y.is_empty() || y.len() != y_model.len() {
            return None;
        }
        let (lo, hi) = min_max(y);
        let range = hi - lo;
        // Also rejects a NaN range.
        if range.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let (mut sum_sq, mut max_abs) = (0.0f64, 0.0f64);
        for (a, b) in y_model.iter().zip(y) {
            let e = a - b;
            sum_sq += e * e;
            max_abs = max_abs.max(e.abs());
        }
        Some(Fit {
            rms_percent: 100.0 * (sum_sq / y.len() as f64).sqrt() / range,
            max_percent: 100.0 * max_abs / range,
            samples: y.len(),
        })
    }
}

/// What identification did, besides the model.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyInfo {
    /// Fit of the identified model, simulated sample by sample on the record.
    pub fit: Fit,
    /// 2-norm condition number of the (play-stage) regression matrix.
    pub condition_number: f64,
    /// Final cost `1/(2N) ||y_model - y||^2`.
    pub cost: f64,
    /// Gradient iterations (0 for least squares).
    pub iterations: u64,
    /// Alternations used (MPI-deadzone; 1 otherwise).
    pub alternations: usize,
    /// Whether the invertibility constraint was active at the solution.
    pub constraint_active: bool,
}

/// An identified model with its report.
#[derive(Debug, Clone, PartialEq)]
pub struct Identified {
    /// The model.
    pub model: HysteresisModel,
    /// How it was found and how well it fits.
    pub info: IdentifyInfo,
}

/// Why identification failed. All but `Solver` are about the input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    /// Input and output lengths differ.
    #[error("input has {input} samples but output has {output}")]
    LengthMismatch {
        /// Input length.
        input: usize,
        /// Output length.
        output: usize,
    },
    /// Not enough samples for the number of unknowns.
    #[error("too few samples: {found}, at least {needed} needed for {unknowns} unknowns")]
    TooFewSamples {
        /// Samples given.
        found: usize,
        /// Minimum.
        needed: usize,
        /// Unknowns of the model.
        unknowns: usize,
    },
    /// A sample is NaN or infinite.
    #[error("{signal} sample {index} is {value}; samples must be finite")]
    NonFinite {
        /// `input` or `output`.
        signal: &'static str,
        /// 0-based sample index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The input never changes, so no operator is excited.
    #[error("the input is constant ({value}); hysteresis needs an input that moves")]
    ConstantInput {
        /// The constant.
        value: f64,
    },
    /// The output never changes, so the fit percentages are undefined.
    #[error("the output is constant ({value}); nothing to identify")]
    ConstantOutput {
        /// The constant.
        value: f64,
    },
    /// Bad thresholds.
    #[error("thresholds: {0}")]
    Thresholds(#[from] ThresholdError),
    /// Bad settings.
    #[error("{0}")]
    InvalidParams(String),
    /// The regression is rank deficient.
    #[error(transparent)]
    Ls(#[from] LsError),
    /// The gradient solver failed.
    #[error("gradient solver: {0}")]
    Solver(String),
}

fn min_max(x: &[f64]) -> (f64, f64) {
    x.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// Minimum samples: twice the number of unknowns, and at least 10.
pub fn min_samples(unknowns: usize) -> usize {
    (2 * unknowns).max(10)
}

/// Column layout of the linear regression.
#[derive(Debug, Clone, PartialEq)]
pub struct Regressor {
    /// Column of ones for the output offset.
    pub offset: bool,
    /// Column `cbrt(u)` (\[Li21\] Eq. 4).
    pub cbrt: bool,
    /// Play operator form.
    pub operator: PlayOperator,
    /// Play thresholds, one column each.
    pub thresholds: Vec<f64>,
    /// Rate columns `|s(k)| F_{r_i}[u](k)` after the play columns, then the
    /// velocity column `s(k)` (docs/math.md §1.7), with `(ts, rate_scale)`.
    pub rate: Option<(f64, f64)>,
}

impl Regressor {
    /// Unconstrained leading columns (offset, cube root).
    pub fn free(&self) -> usize {
        self.offset as usize + self.cbrt as usize
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        let n = self.thresholds.len();
        self.free() + if self.rate.is_some() { 2 * n + 1 } else { n }
    }

    /// Length of the state `fill` carries from block to block: one per
    /// play operator, and the previous input when there are rate columns.
    pub fn state_len(&self) -> usize {
        self.thresholds.len() + self.rate.is_some() as usize
    }

    /// Fills `columns[j][..u.len()]` with the regressor rows for `u`, continuing
    /// from `states` ([`Regressor::state_len`]: the play states, then the
    /// previous input under rate columns; updated).
    pub fn fill(&self, u: &[f64], states: &mut [f64], columns: &mut [&mut [f64]]) {
        let rows = u.len();
        assert!(columns.len() >= self.cols() && columns.iter().all(|c| c.len() >= rows));
        assert_eq!(states.len(), self.state_len());
        let n = self.thresholds.len();
        let mut j = 0;
        if self.offset {
            columns[j][..rows].fill(1.0);
            j += 1;
        }
        if self.cbrt {
            // [Li21] Eq. 4: real, sign-preserving cube root.
            for (o, x) in columns[j][..rows].iter_mut().zip(u) {
                *o = crate::runtime::cbrt(*x);
            }
            j += 1;
        }
        play_columns(
            self.operator,
            &self.thresholds,
            u,
            &mut states[..n],
            &mut columns[j..],
        );
        if let Some((ts, scale)) = self.rate {
            // §1.7: s(k) = (u(k) - u(k-1)) / (ts scale), columns |s| F_i and s.
            let (plays, rates) = columns[j..].split_at_mut(n);
            for (play, rate) in plays.iter().zip(rates.iter_mut()) {
                let mut previous = states[n];
                for ((o, f), &x) in rate[..rows].iter_mut().zip(&play[..rows]).zip(u) {
                    *o = ((x - previous) / (ts * scale)).abs() * f;
                    previous = x;
                }
            }
            let mut previous = states[n];
            for (o, &x) in rates[n][..rows].iter_mut().zip(u) {
                *o = (x - previous) / (ts * scale);
                previous = x;
            }
            if let Some(&last) = u.last() {
                states[n] = last;
            }
        }
    }

    /// The whole regressor as an `N x cols` column-major matrix.
    pub fn matrix(&self, u: &[f64]) -> ColMajor {
        let mut phi = ColMajor::zeros(u.len(), self.cols());
        let mut states = vec![PlayOperator::INITIAL_STATE; self.state_len()];
        self.fill(u, &mut states, &mut phi.cols_mut());
        phi
    }

    /// Streams `[Phi | y]` through a QR accumulator: the R factor of the
    /// regression, with O(cols^2) memory whatever the record length.
    pub fn qr(&self, u: &[f64], y: &[f64]) -> StreamingQr {
        let cols = self.cols();
        let mut acc = StreamingQr::new(cols + 1);
        let block_rows = acc.block_rows();
        let mut states = vec![PlayOperator::INITIAL_STATE; self.state_len()];
        for (ub, yb) in u.chunks(block_rows).zip(y.chunks(block_rows)) {
            let mut block = acc.block_cols_mut();
            self.fill(ub, &mut states, &mut block);
            block[cols][..yb.len()].copy_from_slice(yb);
            acc.fold_block(ub.len());
        }
        acc
    }
}

/// Play operator outputs for `u` into `columns[i][..u.len()]`, one column per
/// threshold, continuing from `states` (updated). Picks the AVX2 build of the
/// kernel when the CPU has it.
pub(crate) fn play_columns(
    op: PlayOperator,
    thresholds: &[f64],
    u: &[f64],
    states: &mut [f64],
    columns: &mut [&mut [f64]],
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports the features `plays_avx2` is compiled for.
            unsafe { plays_avx2(op, thresholds, u, states, columns) };
            return;
        }
    }
    plays_kernel(op, thresholds, u, states, columns);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn plays_avx2(
    op: PlayOperator,
    thresholds: &[f64],
    u: &[f64],
    states: &mut [f64],
    columns: &mut [&mut [f64]],
) {
    plays_kernel(op, thresholds, u, states, columns);
}

/// Play operator columns, eight operators at a time: each operator is a chain
/// of dependent min/max, and running independent chains side by side (in
/// SIMD lanes) hides their latency. \[Li21\] Eq. 3 / \[Tang17\] Eq. 38 with the
/// band's upper offset hoisted out of the loop.
#[inline(always)]
fn plays_kernel(
    op: PlayOperator,
    thresholds: &[f64],
    u: &[f64],
    states: &mut [f64],
    columns: &mut [&mut [f64]],
) {
    let rows = u.len();
    let n = thresholds.len();
    let mut i = 0;
    while i < n {
        let g = (n - i).min(8);
        let mut r = [0.0f64; 8];
        let mut up = [0.0f64; 8];
        let mut s = [0.0f64; 8];
        for t in 0..g {
            r[t] = thresholds[i + t];
            up[t] = op.band(r[t], 0.0).1;
            s[t] = states[i + t];
        }
        // Lanes beyond `g` run on r = 0 and are discarded.
        let mut buf = [[0.0f64; 8]; 64];
        let mut k0 = 0;
        while k0 < rows {
            let len = (rows - k0).min(64);
            for (row, &x) in buf.iter_mut().zip(&u[k0..k0 + len]) {
                for t in 0..8 {
                    let upper = x + up[t];
                    let clipped = if upper < s[t] { upper } else { s[t] };
                    let lower = x - r[t];
                    s[t] = if lower > clipped { lower } else { clipped };
                }
                *row = s;
            }
            // Transpose the small row-major buffer into the columns.
            for t in 0..g {
                let col = &mut columns[i + t][k0..k0 + len];
                for (o, row) in col.iter_mut().zip(&buf[..len]) {
                    *o = row[t];
                }
            }
            k0 += len;
        }
        states[i..i + g].copy_from_slice(&s[..g]);
        i += g;
    }
}

fn check_record(u: &[f64], y: &[f64], unknowns: usize) -> Result<(), IdentifyError> {
    if u.len() != y.len() {
        return Err(IdentifyError::LengthMismatch {
            input: u.len(),
            output: y.len(),
        });
    }
    let needed = min_samples(unknowns);
    if u.len() < needed {
        return Err(IdentifyError::TooFewSamples {
            found: u.len(),
            needed,
            unknowns,
        });
    }
    for (signal, x) in [("input", u), ("output", y)] {
        if let Some((index, &value)) = x.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(IdentifyError::NonFinite {
                signal,
                index,
                value,
            });
        }
    }
    let (lo, hi) = min_max(u);
    if lo == hi {
        return Err(IdentifyError::ConstantInput { value: lo });
    }
    let (lo, hi) = min_max(y);
    if lo == hi {
        return Err(IdentifyError::ConstantOutput { value: lo });
    }
    Ok(())
}

/// Identifies a model with no progress display. See [`identify_observed`].
pub fn identify(
    u: &[f64],
    y: &[f64],
    params: &IdentifyParams,
) -> Result<Identified, IdentifyError> {
    identify_observed(u, y, params, super::gd::Silent)
}

/// Identifies the model of `params` mapping `u` to `y`. For the inverse model
/// (\[Li21\], docs/math.md §1.6) swap the signals. `observer` sees every gradient
/// iteration (it is cloned for each gradient solve).
pub fn identify_observed<O>(
    u: &[f64],
    y: &[f64],
    params: &IdentifyParams,
    observer: O,
) -> Result<Identified, IdentifyError>
where
    O: Observe<GdState> + Clone + 'static,
{
    if params.invertible && params.method == Method::Gd {
        return Err(IdentifyError::InvalidParams(
            "the invertibility constraint needs --method ls (gradient descent here is unconstrained)"
                .into(),
        ));
    }
    if !(params.min_partial_sum_rel >= 0.0 && params.min_partial_sum_rel.is_finite()) {
        return Err(IdentifyError::InvalidParams(
            "the minimum partial sum must be finite and >= 0".into(),
        ));
    }
    let thresholds = match &params.thresholds {
        Some(t) => {
            check_thresholds(t)?;
            t.clone()
        }
        None => {
            if params.operators == 0 {
                return Err(IdentifyError::InvalidParams(
                    "operators: at least one play operator is needed, got 0".into(),
                ));
            }
            Vec::new()
        }
    };
    let n_ops = if thresholds.is_empty() {
        params.operators
    } else {
        thresholds.len()
    };
    check_rate(params)?;
    let dz_ops = params.dead_zone_operators;
    if params.kind == ModelKind::MpiDeadzone && dz_ops == 0 {
        return Err(IdentifyError::InvalidParams(
            "MPI-deadzone needs at least one dead-zone operator".into(),
        ));
    }
    // A model file holds at most this many (docs/formats.md bounds); the
    // regression's memory grows with samples times operators.
    let max = crate::io::hysteresis_json::MAX_OPERATORS;
    for (name, n) in [("operators", n_ops), ("dead_zone_operators", dz_ops)] {
        if n > max {
            return Err(IdentifyError::InvalidParams(format!(
                "{name}: {n} is beyond the largest accepted, {max}"
            )));
        }
    }
    let unknowns = params.offset as usize
        + (params.kind == ModelKind::MpiCbrt) as usize
        + if params.rate_ts.is_some() {
            2 * n_ops + 1
        } else {
            n_ops
        }
        + if params.kind == ModelKind::MpiDeadzone {
            dz_ops
        } else {
            0
        };
    check_record(u, y, unknowns)?;

    let max_abs_u = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let thresholds = if thresholds.is_empty() {
        uniform_thresholds(n_ops, max_abs_u)
    } else {
        thresholds
    };
    let regressor = Regressor {
        offset: params.offset,
        cbrt: params.kind == ModelKind::MpiCbrt,
        operator: params.operator_form(),
        thresholds,
        rate: params.rate_ts.map(|ts| (ts, rate_scale(u, ts))),
    };
    let (ylo, yhi) = min_max(y);
    let (ulo, uhi) = min_max(u);
    let constraint = params.invertible.then(|| PartialSumConstraint {
        min_partial_sum: params.min_partial_sum_rel * (yhi - ylo) / (uhi - ulo),
    });

    let mut identified = match params.kind {
        ModelKind::Pi | ModelKind::MpiCbrt => {
            identify_linear(u, y, &regressor, params, constraint, observer)?
        }
        ModelKind::MpiDeadzone => {
            identify_dead_zone(u, y, &regressor, params, constraint, observer)?
        }
    };
    let y_model = identified.model.simulate(u);
    identified.info.fit = Fit::of(&y_model, y).expect("checked: same length, y not constant");
    identified.info.cost = y_model
        .iter()
        .zip(y)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / (2.0 * y.len() as f64);
    Ok(identified)
}

/// The settings a rate-dependent fit needs (docs/math.md §1.7).
fn check_rate(params: &IdentifyParams) -> Result<(), IdentifyError> {
    let Some(ts) = params.rate_ts else {
        return Ok(());
    };
    let refuse = |m: &str| Err(IdentifyError::InvalidParams(m.into()));
    if !(ts.is_finite() && ts > 0.0) {
        return refuse("rate_dependent: the sample time must be a positive number of seconds");
    }
    if params.kind == ModelKind::MpiDeadzone {
        return refuse("rate_dependent: pi and mpi-cbrt only (mpi-deadzone is bilinear)");
    }
    if params.invertible {
        return refuse(
            "rate_dependent: the invertibility constraint covers rate-independent weights only",
        );
    }
    Ok(())
}

/// The normalising rate of §1.7: the largest `|u(k) - u(k-1)| / ts` of the
/// record (from `u(-1) = 0`), so that `rho` lies in `[0, 1]` on it.
fn rate_scale(u: &[f64], ts: f64) -> f64 {
    let mut previous = 0.0;
    let mut largest = 0.0f64;
    for &x in u {
        largest = largest.max((x - previous).abs());
        previous = x;
    }
    largest / ts
}

fn placeholder_fit() -> Fit {
    Fit {
        rms_percent: f64::NAN,
        max_percent: f64::NAN,
        samples: 0,
    }
}

/// Splits a solution vector `[offset?, c?, w...]` into a model.
fn linear_model(regressor: &Regressor, kind: ModelKind, x: &[f64]) -> HysteresisModel {
    let mut it = x.iter().copied();
    let offset = if regressor.offset {
        it.next().unwrap_or(0.0)
    } else {
        0.0
    };
    let cbrt_gain = if regressor.cbrt {
        it.next().unwrap_or(0.0)
    } else {
        0.0
    };
    let n = regressor.thresholds.len();
    let weights: Vec<f64> = it.by_ref().take(n).collect();
    HysteresisModel {
        kind,
        operator: regressor.operator,
        thresholds: regressor.thresholds.clone(),
        weights,
        cbrt_gain,
        offset,
        input_offset: 0.0,
        dead_zone: None,
        input_dead_zone: None,
        rate: regressor.rate.map(|(ts, rate_scale)| RateStage {
            ts,
            rate_scale,
            weights: it.by_ref().take(n).collect(),
            velocity_gain: it.next().unwrap_or(0.0),
        }),
    }
}

fn identify_linear<O>(
    u: &[f64],
    y: &[f64],
    regressor: &Regressor,
    params: &IdentifyParams,
    constraint: Option<PartialSumConstraint>,
    observer: O,
) -> Result<Identified, IdentifyError>
where
    O: Observe<GdState> + 'static,
{
    let cols = regressor.cols();
    // The QR gives the condition number, and it carries GD's cost.
    let acc = regressor.qr(u, y);
    let ls = solve_from_r(acc.r(), cols + 1, regressor.free(), constraint)?;
    let (x, iterations) = match params.method {
        Method::Ls => (ls.x.clone(), 0),
        Method::Gd => {
            let (w, info) = run_gd(acc.r(), u.len(), &params.gd, None, observer)?;
            (w, info.iterations)
        }
    };
    Ok(Identified {
        model: linear_model(regressor, params.kind, &x),
        info: IdentifyInfo {
            fit: placeholder_fit(),
            condition_number: ls.condition_number,
            cost: f64::NAN,
            iterations,
            alternations: 1,
            constraint_active: ls.constraint_active,
        },
    })
}

/// L-BFGS on the least-squares cost carried by `r_aug`, the factor of
/// `[Phi | y]` over `rows` samples.
fn run_gd<O>(
    r_aug: &[f64],
    rows: usize,
    gd: &GdParams,
    start: Option<&[f64]>,
    observer: O,
) -> Result<(Vec<f64>, GdInfo), IdentifyError>
where
    O: Observe<GdState> + 'static,
{
    let problem = TriangularLeastSquares::from_factor(r_aug, rows);
    gd_lstsq(&problem, gd, start, observer).map_err(|e| IdentifyError::Solver(e.to_string()))
}

/// Solves one linear stage `min ||A x - b||` (A materialised) by the chosen method.
fn solve_stage<O>(
    a: &ColMajor,
    b: &[f64],
    free: usize,
    params: &IdentifyParams,
    constraint: Option<PartialSumConstraint>,
    start: Option<&[f64]>,
    observer: O,
) -> Result<(Vec<f64>, f64, u64, bool), IdentifyError>
where
    O: Observe<GdState> + 'static,
{
    let cols = a.cols();
    let acc = qr_of(a, b);
    let ls = solve_from_r(acc.r(), cols + 1, free, constraint)?;
    match params.method {
        Method::Ls => Ok((ls.x, ls.condition_number, 0, ls.constraint_active)),
        Method::Gd => {
            let (x, info) = run_gd(acc.r(), a.rows(), &params.gd, start, observer)?;
            Ok((x, ls.condition_number, info.iterations, false))
        }
    }
}

/// The best MPI-deadzone iterate so far.
struct Candidate {
    cost: f64,
    w: Vec<f64>,
    d: Vec<f64>,
    g: Vec<f64>,
    offset: f64,
}

/// MPI-deadzone (\[Tang17\] Eq. 40-43) by alternating least squares.
///
/// * g-step: with the PI stage `v = Phi w` fixed, `y = off + sum_j g_j S_{d_j}[v]`
///   is linear in `(off, g)` (\[Tang17\] Eq. 43, solved by QR here, not by
///   `(S^T S)^-1`).
/// * w-step: with `g` fixed and the dead-zone pattern of the current `v`
///   frozen, `y(k) = off + a(k) v(k) - b(k)` with `a(k) = sum of active g_j`
///   and `b(k) = sum of active g_j d_j`, which is linear in `(off, w)`: a
///   Gauss–Newton step on the piecewise-linear stage.
///
/// The pair has a scale freedom (`(s w, g / s)` with `d_j` tied to
/// `max|v|` gives the same output); it needs no normalisation because each
/// stage is solved exactly for the other. Each alternation's cost is the true
/// cost of the model it yields; the best iterate is kept, and the loop stops
/// when an alternation improves the cost by less than 1e-12 (relative) or
/// after `params.alternations`. On data from an MPI-deadzone model the cost
/// falls linearly to round-off (tests/suite/hysteresis_identify.rs).
fn identify_dead_zone<O>(
    u: &[f64],
    y: &[f64],
    regressor: &Regressor,
    params: &IdentifyParams,
    constraint: Option<PartialSumConstraint>,
    observer: O,
) -> Result<Identified, IdentifyError>
where
    O: Observe<GdState> + Clone + 'static,
{
    let n = u.len();
    let play_only = Regressor {
        offset: false,
        cbrt: false,
        ..regressor.clone()
    };
    let phi = play_only.matrix(u);
    let n_ops = play_only.thresholds.len();
    let m = params.dead_zone_operators;
    let free = params.offset as usize;
    let mut aw = ColMajor::zeros(n, free + n_ops);
    let mut ag = ColMajor::zeros(n, free + m);
    if free == 1 {
        aw.col_mut(0).fill(1.0);
        ag.col_mut(0).fill(1.0);
    }
    let mut b = vec![0.0; n];
    let mut slope = vec![0.0; n];

    // Start: identity output stage, so the first w-step is a plain PI fit.
    let mut g = vec![0.0; m];
    g[0] = 1.0;
    let mut d = vec![0.0; m];
    let mut v = vec![0.0; n];
    let mut best: Option<Candidate> = None;
    let mut condition_number = f64::NAN;
    let mut iterations = 0;
    let mut alternations = 0;
    let mut previous_cost = f64::INFINITY;
    let mut constraint_active = false;
    let (mut start_w, mut start_g): (Option<Vec<f64>>, Option<Vec<f64>>) = (None, None);
    for _ in 0..params.alternations.max(1) {
        alternations += 1;
        // w-step: y(k) + b(k) = off + a(k) Phi[k, :] w with the frozen pattern.
        for k in 0..n {
            let (mut a_k, mut b_k) = (0.0, 0.0);
            for (&dj, &gj) in d.iter().zip(&g) {
                if dj == 0.0 || v[k] > dj {
                    a_k += gj;
                    b_k += gj * dj;
                }
            }
            slope[k] = a_k;
            b[k] = y[k] + b_k;
        }
        for i in 0..n_ops {
            for ((o, p), a_k) in aw.col_mut(free + i).iter_mut().zip(phi.col(i)).zip(&slope) {
                *o = a_k * p;
            }
        }
        let (x, cond, it, act_w) = solve_stage(
            &aw,
            &b,
            free,
            params,
            constraint,
            start_w.as_deref(),
            observer.clone(),
        )?;
        iterations += it;
        condition_number = cond;
        let w = &x[free..];
        // Gradient solves of the next alternation start where this one ended.
        start_w = Some(x.clone());
        // g-step on the new v = Phi w ([Tang17] Eq. 40), d_j = (j-1)/m max|v|.
        v.fill(0.0);
        for (i, wi) in w.iter().enumerate() {
            for (vk, p) in v.iter_mut().zip(phi.col(i)) {
                *vk += wi * p;
            }
        }
        let vmax = v.iter().fold(0.0f64, |acc, x| acc.max(x.abs()));
        d = uniform_thresholds(m, vmax);
        for (j, &dj) in d.iter().enumerate() {
            for (o, &vk) in ag.col_mut(free + j).iter_mut().zip(&v) {
                *o = dead_zone(dj, vk);
            }
        }
        let (xg, _, it, act_g) = solve_stage(
            &ag,
            y,
            free,
            params,
            constraint,
            start_g.as_deref(),
            observer.clone(),
        )?;
        iterations += it;
        g.copy_from_slice(&xg[free..]);
        start_g = Some(xg.clone());
        let offset = if free == 1 { xg[0] } else { 0.0 };
        let cost = {
            let mut sum = 0.0;
            for (k, &yk) in y.iter().enumerate() {
                let out: f64 = (0..m).map(|j| g[j] * ag.col(free + j)[k]).sum();
                sum += (offset + out - yk).powi(2);
            }
            sum / (2.0 * n as f64)
        };
        if best.as_ref().is_none_or(|bst| cost < bst.cost) {
            best = Some(Candidate {
                cost,
                w: w.to_vec(),
                d: d.clone(),
                g: g.clone(),
                offset,
            });
            constraint_active = act_w || act_g;
        }
        // Stop when an alternation no longer improves the cost (relative 1e-12).
        if previous_cost.is_finite() && previous_cost - cost <= 1e-12 * previous_cost {
            break;
        }
        previous_cost = cost;
    }
    let Candidate {
        cost,
        w,
        d,
        g,
        offset,
    } = best.expect("at least one alternation");
    Ok(Identified {
        model: HysteresisModel {
            kind: ModelKind::MpiDeadzone,
            operator: regressor.operator,
            thresholds: regressor.thresholds.clone(),
            weights: w,
            cbrt_gain: 0.0,
            offset,
            input_offset: 0.0,
            dead_zone: Some(DeadZoneStage {
                thresholds: d,
                weights: g,
            }),
            input_dead_zone: None,
            rate: None,
        },
        info: IdentifyInfo {
            fit: placeholder_fit(),
            condition_number,
            cost,
            iterations,
            alternations,
            constraint_active,
        },
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::ident::hysteresis::operators::play_into;

    pub fn regressor_columns_match_the_operators() {
        // Every column equals the operator run on its own (portable path of
        // `play_into`), whichever kernel `fill` dispatches to; 11 operators
        // exercise a full group of 8 and a partial one.
        let u: Vec<f64> = (0..700)
            .map(|k| 5.0 * (k as f64 * 0.031).sin() * (1.0 + k as f64 / 700.0))
            .collect();
        for op in [PlayOperator::Lower, PlayOperator::Symmetric] {
            let reg = Regressor {
                offset: true,
                cbrt: true,
                operator: op,
                thresholds: uniform_thresholds(11, 10.0),
                rate: None,
            };
            let phi = reg.matrix(&u);
            assert!(phi.col(0).iter().all(|&v| v == 1.0));
            assert!(
                phi.col(1)
                    .iter()
                    .zip(&u)
                    .all(|(a, b)| *a == fts_runtime::cbrt(*b))
            );
            let mut want = vec![0.0; u.len()];
            for (i, &r) in reg.thresholds.iter().enumerate() {
                play_into(op, r, &u, &mut want);
                assert_eq!(phi.col(2 + i), &want[..], "{op:?} operator {i}");
            }
        }
    }
}
