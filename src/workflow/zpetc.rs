//! The ZPETC feedforward of a discrete closed-loop model: what
//! `fts zpetc --tf closed_loop.json` and a `kind = "zpetc"` manifest step do.

use super::convert::Minreal;
use super::{StepError, Validate, complex_pairs, fmt_complex};
use crate::io::zpetc_json::zpetc_to_value;
use crate::lti::TransferFunction;
use crate::lti::c64;
use crate::lti::margins::LoopSystem;
use crate::lti::model_check;
use crate::lti::tf::DiscreteTf;
use crate::synth::zpetc::{
    self, CheckFailure, StableInversion, ZeroStatus, Zpetc, ZpetcCheck, ZpetcError, ZpetcParams,
};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Frequencies of the self-check (uniform, 0 to Nyquist).
pub const CHECK_POINTS: usize = 2001;

/// Settings of a ZPETC design (docs/math.md §3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DesignZpetc {
    /// Zeros with `|z| >= rho` are not cancelled; in `(0, 1]`, default 0.95.
    pub rho: f64,
    /// Zeros whose cancelling pole would be damped less than this are not
    /// cancelled; in `[0, 1]`, default 0.1.
    pub min_damping: f64,
    /// Invert zeros with `|z| >=` this radius exactly by an anticausal
    /// series; default none (classical ZPETC, \[Li21\] Eq. 8).
    pub stable_inversion: Option<f64>,
    /// Relative truncation tolerance of that series; default 1e-4.
    pub series_tol: f64,
    /// Cancel pole/zero pairs closer than this (relative) before the design;
    /// default none.
    pub minreal: Option<f64>,
}

impl Default for DesignZpetc {
    fn default() -> Self {
        let d = ZpetcParams::default();
        Self {
            rho: d.rho,
            min_damping: d.min_damping,
            stable_inversion: None,
            series_tol: StableInversion::default().tolerance,
            minreal: None,
        }
    }
}

impl Validate for DesignZpetc {
    fn validate(&self) -> Result<(), StepError> {
        if !(self.rho > 0.0 && self.rho <= 1.0) {
            return Err(StepError::setting(
                "rho",
                format!("expected a radius in (0, 1], got {}", self.rho),
            ));
        }
        if !(0.0..=1.0).contains(&self.min_damping) {
            return Err(StepError::setting(
                "min_damping",
                format!(
                    "expected a damping ratio in [0, 1], got {}",
                    self.min_damping
                ),
            ));
        }
        if let Some(r) = self.stable_inversion
            && !(r > 1.0 && r.is_finite())
        {
            return Err(StepError::setting(
                "stable_inversion",
                format!("expected a radius above 1, got {r}"),
            ));
        }
        if !(self.series_tol > 0.0 && self.series_tol < 1.0) {
            return Err(StepError::setting(
                "series_tol",
                format!("expected a tolerance in (0, 1), got {}", self.series_tol),
            ));
        }
        if let Some(tol) = self.minreal
            && !(tol > 0.0 && tol < 1.0)
        {
            return Err(StepError::setting(
                "minreal",
                format!("expected a tolerance in (0, 1), got {tol}"),
            ));
        }
        Ok(())
    }
}

/// A designed filter with the model it was designed for and its self-check.
#[derive(Debug, Clone)]
pub struct ZpetcReport {
    /// The closed-loop model's name (a file path), for the summary.
    pub source: String,
    /// The model the filter inverts (after `minreal`, if asked).
    pub plant: DiscreteTf,
    /// The `(zero, pole)` pairs `minreal` removed.
    pub removed_pairs: Vec<(c64, c64)>,
    /// The filter.
    pub filter: Zpetc,
    /// `G_z G_c` over `0..Nyquist`.
    pub check: ZpetcCheck,
}

impl DesignZpetc {
    /// The library's settings.
    pub fn params(&self) -> ZpetcParams {
        ZpetcParams {
            rho: self.rho,
            min_damping: self.min_damping,
            stable_inversion: self.stable_inversion.map(|min_radius| StableInversion {
                min_radius,
                tolerance: self.series_tol,
                ..StableInversion::default()
            }),
        }
    }

    /// Designs the filter of the model read from `source`, which must be a
    /// discrete closed loop.
    pub fn run(&self, model: &TransferFunction, source: &str) -> Result<ZpetcReport, StepError> {
        match model {
            TransferFunction::Discrete(g) => self.design(g, source),
            TransferFunction::Continuous(_) => Err(StepError::input(format!(
                "{source} field 'var': ZPETC needs a discrete closed loop (\"var\": \"z^-1\"), found a continuous one; discretise it first"
            ))),
        }
    }

    /// Designs the filter of `plant` (named `source` in messages) and
    /// refuses it, as a computation failure, when it fails its self-check
    /// ([`ZpetcCheck::failures`]; docs/formats.md "Exit codes"). The
    /// message names every near pole-zero cancellation on the unit circle
    /// of the model with the `fts minreal` command that removes it, found
    /// by running that command's step and this design on its result.
    pub fn design(&self, plant: &DiscreteTf, source: &str) -> Result<ZpetcReport, StepError> {
        let report = self.design_unchecked(plant, source)?;
        let failures = report.check.failures();
        if failures.is_empty() {
            return Ok(report);
        }
        Err(StepError::computation(
            self.failure_message(plant, &report, &failures, source),
        ))
    }

    /// What failed, why, and what removes the cause.
    fn failure_message(
        &self,
        plant: &DiscreteTf,
        report: &ZpetcReport,
        failures: &[CheckFailure],
        source: &str,
    ) -> String {
        let what: Vec<String> = failures.iter().map(|f| f.to_string()).collect();
        let mut message = format!(
            "{source}: the ZPETC fails its self-check: {}",
            what.join("; ")
        );
        let pairs = model_check::unit_circle_pairs(&report.plant).unwrap_or_default();
        if !pairs.is_empty() {
            let named: Vec<String> = pairs.iter().map(|p| p.to_string()).collect();
            message.push_str(&format!(
                "; the model has a near pole-zero cancellation on the unit circle: {}",
                named.join(", ")
            ));
            message.push_str(&match self.minreal_remedy(plant, source) {
                Some((tol, out)) => format!(
                    "; remove it first: fts minreal {} --tol {tol:e} -o {}, then design on {}",
                    shell_word(source),
                    shell_word(&out),
                    shell_word(&out)
                ),
                None => format!(
                    "; fts minreal removes it at no tolerance up to {:e} without failing a check: re-identify the loop (lower orders)",
                    MINREAL_LADDER[MINREAL_LADDER.len() - 1]
                ),
            });
        } else if let Some(z) = self.cancellable_kept_zero(report) {
            message.push_str(&format!(
                "; the kept zero {} (|z| = {:.6}) sits near z = 1: cancel it with `rho` above {:.6}",
                fmt_complex(z),
                z.norm(),
                z.norm()
            ));
        }
        message
    }

    /// The smallest tolerance of [`MINREAL_LADDER`] at which `fts minreal`
    /// (the [`Minreal`] step) removes the unit-circle pairs of `plant` and
    /// this design on its result passes its self-check, with the file the
    /// command would write.
    fn minreal_remedy(&self, plant: &DiscreteTf, source: &str) -> Option<(f64, String)> {
        let model = LoopSystem::Tf(TransferFunction::Discrete(plant.clone()));
        MINREAL_LADDER.iter().find_map(|&tol| {
            let reduced = Minreal { tol }.run(&model, source).ok()?;
            let Some(TransferFunction::Discrete(g)) = reduced.tf else {
                return None;
            };
            if !model_check::unit_circle_pairs(&g).ok()?.is_empty() {
                return None;
            }
            let r = self.design_unchecked(&g, source).ok()?;
            r.check
                .failures()
                .is_empty()
                .then(|| (tol, minreal_output(source)))
        })
    }

    /// A kept zero near `z = 1` that raising `rho` would cancel.
    fn cancellable_kept_zero(&self, report: &ZpetcReport) -> Option<c64> {
        report
            .filter
            .uncancelled_zeros()
            .filter(|z| {
                z.zero.re > 0.0 && z.magnitude < zpetc::MAX_CANCELLED_MAGNITUDE && z.damping > 0.9
            })
            .map(|z| z.zero)
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
    }

    /// The design without the verdict on its self-check.
    fn design_unchecked(&self, plant: &DiscreteTf, source: &str) -> Result<ZpetcReport, StepError> {
        self.validate()?;
        let (plant, removed_pairs) = match self.minreal {
            Some(tol) => {
                let m = plant
                    .minreal(tol)
                    .map_err(|e| StepError::computation(format!("{source}: minreal: {e}")))?;
                (m.tf, m.removed)
            }
            None => (plant.clone(), Vec::new()),
        };
        let filter = zpetc::design(&plant, &self.params()).map_err(|e| match e {
            // Settings were validated; what is left is about the model.
            ZpetcError::InvalidParams(m) => StepError::input(m),
            e @ (ZpetcError::ZeroAtDc
            | ZpetcError::SeriesTooLong { .. }
            | ZpetcError::UnstablePlant { .. }) => StepError::input(format!("{source}: {e}")),
            e @ ZpetcError::CancelsNearUnitCircle { .. } => {
                StepError::setting("rho", e.to_string())
            }
            e @ ZpetcError::Roots(_) => StepError::computation(format!("{source}: {e}")),
        })?;
        let check = filter
            .check(&plant, CHECK_POINTS)
            .map_err(|e| StepError::computation(format!("{source}: self-check: {e}")))?;
        Ok(ZpetcReport {
            source: source.to_owned(),
            plant,
            removed_pairs,
            filter,
            check,
        })
    }
}

/// The `fts minreal --tol` values tried for the remedy, smallest first.
const MINREAL_LADDER: [f64; 6] = [1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3];

/// The file `fts minreal` is told to write: `CL.json` -> `CL-minreal.json`.
fn minreal_output(source: &str) -> String {
    let path = std::path::Path::new(source);
    let stem = path
        .file_stem()
        .map_or_else(|| "model".into(), |s| s.to_string_lossy().to_string());
    let ext = path
        .extension()
        .map_or_else(|| "json".into(), |s| s.to_string_lossy().to_string());
    path.with_file_name(format!("{stem}-minreal.{ext}"))
        .display()
        .to_string()
}

/// `word` as one shell word: quoted when it holds anything but plain path
/// characters.
fn shell_word(word: &str) -> String {
    if !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./+=,:@%".contains(c))
    {
        word.to_owned()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
}

/// One zero in the JSON report.
#[derive(Serialize)]
struct ZeroEntry {
    zero: serde_json::Value,
    magnitude: f64,
    damping: f64,
    cancelled: bool,
    status: &'static str,
}

/// The JSON report: the `fts.zpetc/1` document plus `check` and `zeros`.
#[derive(Serialize)]
struct ReportDoc {
    #[serde(flatten)]
    file: serde_json::Value,
    check: CheckDoc,
    zeros: Vec<ZeroEntry>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    minreal_removed: Vec<serde_json::Value>,
}

#[derive(Serialize)]
struct CheckDoc {
    points: usize,
    max_phase_error_rad: f64,
    dc_gain: f64,
    max_magnitude_error: f64,
    filter_stable: bool,
    max_gain: f64,
    max_gain_hz: f64,
    rounding_bound: f64,
}

impl Serialize for ZpetcReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let c = &self.check;
        ReportDoc {
            file: zpetc_to_value(&self.filter),
            check: CheckDoc {
                points: c.points,
                max_phase_error_rad: c.max_phase_error_rad,
                dc_gain: c.dc_gain,
                max_magnitude_error: c.max_magnitude_error,
                filter_stable: c.filter_stable,
                max_gain: c.max_gain,
                max_gain_hz: c.max_gain_hz,
                rounding_bound: c.rounding_bound,
            },
            zeros: self
                .filter
                .zeros
                .iter()
                .map(|z| ZeroEntry {
                    zero: complex_pairs([&z.zero])[0].clone(),
                    magnitude: z.magnitude,
                    damping: z.damping,
                    cancelled: z.status == ZeroStatus::Cancelled,
                    status: z.status.label(),
                })
                .collect(),
            minreal_removed: self
                .removed_pairs
                .iter()
                .map(|(z, p)| serde_json::json!({"zero": [z.re, z.im], "pole": [p.re, p.im]}))
                .collect(),
        }
        .serialize(s)
    }
}

impl fmt::Display for ZpetcReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (plant, filter, source) = (&self.plant, &self.filter, &self.source);
        let d = plant.delay();
        writeln!(
            f,
            "closed loop {source}: z^-{d} B_c/A_c, ts = {} s, {} zeros, {} poles, DC gain {:.6}",
            plant.ts(),
            filter.zeros.len(),
            plant.den().trimmed(0.0).degree(),
            plant.dc_gain()
        )?;
        for (z, p) in &self.removed_pairs {
            writeln!(
                f,
                "minreal removed zero {} with pole {}",
                fmt_complex(*z),
                fmt_complex(*p)
            )?;
        }
        self.fmt_zero_map(f)?;
        self.fmt_preview(f)?;
        writeln!(f, "G_z = z^{} num(z^-1)/den(z^-1)", filter.preview)?;
        writeln!(f, "  num = {:?}", filter.num.coeffs())?;
        writeln!(f, "  den = {:?}", filter.den.coeffs())?;
        let c = &self.check;
        writeln!(
            f,
            "self-check over 0..{} Hz ({} points): max |phase(G_z G_c)| = {:.3e} rad, DC gain of G_z G_c = {:.12}, filter {}",
            plant.nyquist_hz(),
            c.points,
            c.max_phase_error_rad,
            c.dc_gain,
            if c.filter_stable {
                "stable"
            } else {
                "UNSTABLE"
            }
        )?;
        writeln!(
            f,
            "  max |G_z G_c| = {:.6} at {:.1} Hz, coefficient rounding bound {:.1e} (limits: DC within {:e} of 1, gain {:e}, rounding {:e})",
            c.max_gain,
            c.max_gain_hz,
            c.rounding_bound,
            zpetc::DC_GAIN_TOLERANCE,
            zpetc::MAX_PRODUCT_GAIN,
            zpetc::ROUNDING_LIMIT
        )
    }
}

impl ZpetcReport {
    fn fmt_zero_map(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.filter.params;
        match p.stable_inversion {
            Some(si) => writeln!(
                f,
                "zero map (invert by series if |z| >= {}; else cancel if |z| < rho = {} and damping >= {}):",
                si.min_radius, p.rho, p.min_damping
            )?,
            None => writeln!(
                f,
                "zero map (cancel if |z| < rho = {} and damping >= {}):",
                p.rho, p.min_damping
            )?,
        }
        writeln!(f, "  {:<26} {:>8} {:>8}  status", "zero", "|z|", "damping")?;
        for z in &self.filter.zeros {
            writeln!(
                f,
                "  {:<26} {:>8.4} {:>8.3}  {}",
                fmt_complex(z.zero),
                z.magnitude,
                z.damping,
                z.status.label()
            )?;
        }
        Ok(())
    }

    fn fmt_preview(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let filter = &self.filter;
        let d = self.plant.delay();
        let s = filter.uncancelled_zeros().count();
        let m = filter.series_inverted_zeros().count();
        let ms = filter.preview as f64 * self.plant.ts() * 1e3;
        if m > 0 {
            writeln!(
                f,
                "preview: {} samples (delay d = {d}, uncancelled zeros s = {s}, series-inverted zeros m = {m}, series terms N = {}) = {ms:.3} ms",
                filter.preview, filter.series_terms
            )
        } else {
            writeln!(
                f,
                "preview: {} samples (delay d = {d}, uncancelled zeros s = {s}) = {ms:.3} ms",
                filter.preview
            )
        }
    }

    /// `G_c` and `G_z G_c` at `f_hz` (for a Bode plot).
    pub fn with_filter_at(&self, f_hz: f64) -> (c64, c64) {
        let w = 2.0 * std::f64::consts::PI * f_hz * self.plant.ts();
        let g = self.plant.response_at_omega(w);
        (g, self.filter.response_at_omega(w) * g)
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn plant() -> DiscreteTf {
        // [Li21]-like closed loop with one zero outside the unit circle.
        DiscreteTf::new(vec![0.2, 0.3], vec![1.0, -0.5], 1, 1e-4).unwrap()
    }

    pub fn defaults_are_the_library_defaults() {
        let s = DesignZpetc::default();
        assert_eq!(s.params(), ZpetcParams::default());
        assert!(s.validate().is_ok());
    }

    pub fn each_bad_setting_is_named() {
        let cases = [
            (
                DesignZpetc {
                    rho: 0.0,
                    ..Default::default()
                },
                "rho",
            ),
            (
                DesignZpetc {
                    min_damping: 2.0,
                    ..Default::default()
                },
                "min_damping",
            ),
            (
                DesignZpetc {
                    stable_inversion: Some(1.0),
                    ..Default::default()
                },
                "stable_inversion",
            ),
            (
                DesignZpetc {
                    series_tol: 1.0,
                    ..Default::default()
                },
                "series_tol",
            ),
            (
                DesignZpetc {
                    minreal: Some(0.0),
                    ..Default::default()
                },
                "minreal",
            ),
        ];
        for (s, field) in cases {
            match s.validate() {
                Err(StepError::Input { field: Some(f), .. }) => assert_eq!(f, field),
                other => panic!("{field}: {other:?}"),
            }
        }
    }

    pub fn the_filter_times_the_plant_has_zero_phase_and_unit_dc() {
        let r = DesignZpetc::default().design(&plant(), "p").unwrap();
        assert!(r.check.max_phase_error_rad < 1e-9);
        assert!((r.check.dc_gain - 1.0).abs() < 1e-12);
        let text = r.to_string();
        assert!(text.contains("kept: |z| >= rho"), "{text}");
    }

    pub fn a_zero_at_dc_is_the_models_fault() {
        let g = DiscreteTf::new(vec![1.0, -1.0], vec![1.0, -0.5], 1, 1e-4).unwrap();
        assert!(matches!(
            DesignZpetc::default().design(&g, "p"),
            Err(StepError::Input { field: None, .. })
        ));
    }
}
