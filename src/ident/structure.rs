//! ARX structure selection (MATLAB `arxstruc` / `selstruc` / `delayest`).
//!
//! Every candidate `[na nb nk]` of a grid is estimated by [`arx`] on the
//! estimation data and scored
//! * on validation data, when given, by the loss of its one-step predictor
//!   (what `arxstruc(ze, zv, NN)` returns) and its simulation fit;
//! * on the estimation data by AIC, FPE and MDL (penalised loss), which is
//!   what to use when no validation set exists.
//!
//! All candidates are fitted and scored on the same rows (from the largest
//! memory of the grid on), otherwise a model with a longer memory would be
//! scored on fewer, different samples.

use super::arx::{ArxParams, Orders, arx, arx_residuals};
use super::linear::{Criteria, IdentError, NoiseModel, check_excited, check_signals, fits};

/// The grid searched.
#[derive(Debug, Clone)]
pub struct StructParams {
    /// Candidate `na` values (default `1..=10`).
    pub na: Vec<usize>,
    /// Candidate `nb` values (default `1..=10`).
    pub nb: Vec<usize>,
    /// Candidate `nk` values (default `0..=10`).
    pub nk: Vec<usize>,
    /// Sample time stored in the models.
    pub ts: f64,
}

impl Default for StructParams {
    fn default() -> Self {
        StructParams {
            na: (1..=10).collect(),
            nb: (1..=10).collect(),
            nk: (0..=10).collect(),
            ts: 1.0,
        }
    }
}

/// One candidate's scores.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StructRow {
    /// `[na nb nk]`.
    pub orders: Orders,
    /// Loss and information criteria on the estimation data's common rows
    /// (`N` = those rows, as MATLAB's `selstruc` counts them).
    pub criteria: Criteria,
    /// Mean squared one-step prediction error on the validation data.
    pub validation_loss: Option<f64>,
    /// Simulation fit (%) on the validation data.
    pub validation_fit_percent: Option<f64>,
}

/// The table and the structures each rule picks.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StructSearch {
    /// Every candidate that could be estimated, in grid order.
    pub rows: Vec<StructRow>,
    /// First regression row every candidate was fitted and scored on (the
    /// largest memory of the grid); re-estimate the chosen structure with
    /// `ArxParams::start = Some(start)` to reproduce its table row.
    pub start: usize,
    /// Candidates skipped because their regression was singular or too short.
    pub skipped: Vec<(Orders, String)>,
    /// Minimum validation loss (when validation data were given).
    pub best_validation: Option<Orders>,
    /// Maximum simulation fit on the validation data (when given): the
    /// rule to prefer when the model is meant for simulation (ZPETC design),
    /// since a low one-step loss can come from modelling the noise.
    pub best_validation_fit: Option<Orders>,
    /// Minimum AIC (estimation data).
    pub best_aic: Orders,
    /// Minimum FPE (estimation data).
    pub best_fpe: Orders,
    /// Minimum MDL (estimation data).
    pub best_mdl: Orders,
}

/// How to pick one structure from the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SelectionRule {
    /// Validation loss when validation data exist, otherwise MDL (default).
    #[default]
    Auto,
    /// Minimum one-step prediction loss on validation data (MATLAB
    /// `selstruc(V, 0)` on `arxstruc(ze, zv, NN)`).
    ValidationLoss,
    /// Maximum simulation fit on validation data.
    ValidationFit,
    /// Minimum AIC on estimation data.
    Aic,
    /// Minimum FPE on estimation data.
    Fpe,
    /// Minimum MDL on estimation data.
    Mdl,
}

impl StructSearch {
    /// The recommended structure: best on validation data when available,
    /// otherwise MDL (the most parsimonious of the three criteria).
    pub fn recommended(&self) -> Orders {
        self.best_validation.unwrap_or(self.best_mdl)
    }

    /// The structure a rule picks; `None` for a validation rule without
    /// validation data.
    pub fn pick(&self, rule: SelectionRule) -> Option<Orders> {
        match rule {
            SelectionRule::Auto => Some(self.recommended()),
            SelectionRule::ValidationLoss => self.best_validation,
            SelectionRule::ValidationFit => self.best_validation_fit,
            SelectionRule::Aic => Some(self.best_aic),
            SelectionRule::Fpe => Some(self.best_fpe),
            SelectionRule::Mdl => Some(self.best_mdl),
        }
    }
}

/// Criteria of a candidate over the grid's common rows, `N = rows`: MATLAB's
/// `selstruc` penalises the `arxstruc` losses with the number of rows they
/// were computed on, the same for every candidate. (A single `arx` report
/// divides by all samples instead, [`super::arx::ArxEstimate::criteria`].)
fn common_rows_criteria(est: &super::arx::ArxEstimate, samples: usize, o: Orders) -> Criteria {
    let rows = samples - est.start;
    Criteria::new(est.residual_sum_squares / rows as f64, rows, o.params())
}

fn argmin(rows: &[StructRow], key: impl Fn(&StructRow) -> f64) -> Orders {
    rows.iter()
        .min_by(|a, b| key(a).total_cmp(&key(b)))
        .map(|r| r.orders)
        .unwrap_or(Orders::new(0, 1, 0))
}

/// The most candidates one structure search fits (the default grid has 1100).
pub const MAX_CANDIDATES: usize = 4096;

/// Searches the grid. `val` is the validation record, if any.
pub fn arx_struct(
    u: &[f64],
    y: &[f64],
    val: Option<(&[f64], &[f64])>,
    params: &StructParams,
) -> Result<StructSearch, IdentError> {
    arx_struct_observed(u, y, val, params, &mut |_, _| {})
}

/// [`arx_struct`], calling `observer(done, total)` after each candidate
/// (for a progress bar: a 1100-candidate grid on 1e6 samples takes a while).
pub fn arx_struct_observed(
    u: &[f64],
    y: &[f64],
    val: Option<(&[f64], &[f64])>,
    params: &StructParams,
    observer: &mut dyn FnMut(usize, usize),
) -> Result<StructSearch, IdentError> {
    check_signals(u, y)?;
    if let Some((uv, yv)) = val {
        check_signals(uv, yv)?;
    }
    if params.na.is_empty() || params.nb.is_empty() || params.nk.is_empty() {
        return Err(IdentError::BadStructure("empty order range".into()));
    }
    if params.nb.contains(&0) {
        return Err(IdentError::BadStructure("nb must be at least 1".into()));
    }
    let start = params
        .na
        .iter()
        .flat_map(|&na| {
            params.nb.iter().flat_map(move |&nb| {
                params
                    .nk
                    .iter()
                    .map(move |&nk| Orders::new(na, nb, nk).memory())
            })
        })
        .max()
        .unwrap_or(0);
    let total = params
        .na
        .len()
        .saturating_mul(params.nb.len())
        .saturating_mul(params.nk.len());
    if total > MAX_CANDIDATES {
        return Err(IdentError::BadStructure(format!(
            "the grid has {total} candidates (na x nb x nk); at most {MAX_CANDIDATES} are searched"
        )));
    }
    for &na in &params.na {
        for &nb in &params.nb {
            for &nk in &params.nk {
                Orders::new(na, nb, nk).check()?;
            }
        }
    }
    check_excited(u)?;
    let mut done = 0;
    let mut rows = Vec::new();
    let mut skipped = Vec::new();
    let mut first_err = None;
    for &na in &params.na {
        for &nb in &params.nb {
            for &nk in &params.nk {
                let o = Orders::new(na, nb, nk);
                let mut p = ArxParams::new(o);
                p.ts = params.ts;
                p.start = Some(start);
                match arx(u, y, &p) {
                    Ok(est) => {
                        let (validation_loss, validation_fit_percent) = match val {
                            Some((uv, yv)) => {
                                let s = start.min(yv.len());
                                let e = arx_residuals(&est.model, uv, yv, s);
                                let l =
                                    e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64;
                                let f = fits(&est.model, NoiseModel::Arx, uv, yv);
                                (Some(l), Some(f.simulation_percent))
                            }
                            None => (None, None),
                        };
                        rows.push(StructRow {
                            orders: o,
                            criteria: common_rows_criteria(&est, y.len(), o),
                            validation_loss,
                            validation_fit_percent,
                        });
                    }
                    Err(e) => {
                        skipped.push((o, e.to_string()));
                        first_err.get_or_insert(e);
                    }
                }
                done += 1;
                observer(done, total);
            }
        }
    }
    if rows.is_empty() {
        return Err(first_err.unwrap_or(IdentError::BadStructure("no candidate".into())));
    }
    let best_validation =
        val.map(|_| argmin(&rows, |r| r.validation_loss.unwrap_or(f64::INFINITY)));
    let best_validation_fit = val.map(|_| {
        argmin(&rows, |r| {
            -r.validation_fit_percent
                .filter(|f| f.is_finite())
                .unwrap_or(f64::NEG_INFINITY)
        })
    });
    Ok(StructSearch {
        best_aic: argmin(&rows, |r| r.criteria.naic),
        best_fpe: argmin(&rows, |r| r.criteria.fpe),
        best_mdl: argmin(&rows, |r| r.criteria.mdl),
        best_validation,
        best_validation_fit,
        start,
        rows,
        skipped,
    })
}

/// Delay estimate (MATLAB `delayest(data, na, nb, nkmin, nkmax)`): ARX
/// models `[na nb nk]` for every `nk` in `nk_range`, scored by their loss on
/// the same rows; the best `nk` is returned with the loss per delay.
pub fn delay_estimate(
    u: &[f64],
    y: &[f64],
    na: usize,
    nb: usize,
    nk_range: std::ops::RangeInclusive<usize>,
) -> Result<(usize, Vec<(usize, f64)>), IdentError> {
    let params = StructParams {
        na: vec![na],
        nb: vec![nb],
        nk: nk_range.collect(),
        ts: 1.0,
    };
    let s = arx_struct(u, y, None, &params)?;
    let losses: Vec<(usize, f64)> = s
        .rows
        .iter()
        .map(|r| (r.orders.nk, r.criteria.loss))
        .collect();
    let best = losses
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|r| r.0)
        .unwrap_or(0);
    Ok((best, losses))
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::ident::linear::filter_ab;
    use crate::ident::testutil::noise;

    pub fn constant_input_and_huge_grids_are_refused() {
        let u = vec![1.5; 200];
        let y = noise(200, 3);
        let params = StructParams::default();
        let e = arx_struct(&u, &y, None, &params).unwrap_err();
        assert!(matches!(e, IdentError::ConstantInput { .. }), "{e}");
        let u = noise(200, 4);
        let big = StructParams {
            na: (1..=20).collect(),
            nb: (1..=20).collect(),
            nk: (0..=20).collect(),
            ..StructParams::default()
        };
        let e = arx_struct(&u, &y, None, &big).unwrap_err();
        assert!(e.to_string().contains("8400 candidates"), "{e}");
    }

    pub fn finds_the_true_structure_and_delay() {
        // y = z^-3 (0.5 + 0.3 z^-1) / (1 - 1.2 z^-1 + 0.5 z^-2) u + small e.
        let n = 3000;
        let u = noise(n, 11);
        let e: Vec<f64> = noise(n, 12).iter().map(|v| 0.02 * v).collect();
        // Equation-error noise (the ARX structure is then the true one).
        let clean = filter_ab(&[0.5, 0.3], &[1.0, -1.2, 0.5], 3, &u);
        let ne = filter_ab(&[1.0], &[1.0, -1.2, 0.5], 0, &e);
        let y: Vec<f64> = clean.iter().zip(&ne).map(|(a, b)| a + b).collect();
        let (nk, losses) = delay_estimate(&u, &y, 2, 2, 0..=8).unwrap();
        assert_eq!(nk, 3, "{losses:?}");
        let half = n / 2;
        let p = StructParams {
            na: (1..=4).collect(),
            nb: (1..=4).collect(),
            nk: (1..=5).collect(),
            ts: 1.0,
        };
        let s = arx_struct(&u[..half], &y[..half], Some((&u[half..], &y[half..])), &p).unwrap();
        assert_eq!(s.best_mdl, Orders::new(2, 2, 3));
        // Validation loss alone cannot tell [2 2 3] from a superset such as
        // [2 4 1] (whose leading b's are ~0): the true structure is within
        // 1 % of the minimum, which is why MDL is reported too.
        let vl = |o: Orders| {
            s.rows
                .iter()
                .find(|r| r.orders == o)
                .unwrap()
                .validation_loss
                .unwrap()
        };
        let best = s.best_validation.unwrap();
        assert!(vl(Orders::new(2, 2, 3)) <= 1.01 * vl(best));
        assert_eq!(s.recommended(), best);
        assert_eq!(s.rows.len(), 80);
        // Every candidate is scored on the grid's common rows (from the
        // largest memory, max(na, nb + nk - 1) = 8), not on all samples as a
        // single `arx` report is.
        for r in &s.rows {
            assert_eq!(r.criteria.samples, half - 8, "{}", r.orders);
        }
        let single = arx(
            &u[..half],
            &y[..half],
            &ArxParams::new(Orders::new(2, 2, 3)),
        )
        .unwrap();
        assert_eq!(single.criteria.samples, half);
    }
}
