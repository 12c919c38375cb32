//! Robust-control steps: weights, mixed-sensitivity, H-infinity and H2
//! synthesis, and discretisation of a continuous system.

use super::{StepError, Validate, positive};
use super::{complex_pairs, fmt_complex};
use crate::io::ss_json;
use crate::lti::balred::balred;
use crate::lti::c2d::{C2dMethod, c2d};
use crate::lti::c64;
use crate::lti::ss::{SsError, StateSpace};
use crate::synth::genplant::SynthError;
use crate::synth::h2::{H2Result, h2syn};
use crate::synth::hinf::{HinfOptions, HinfResult, closed_loop_hinf, fastest_pole, hinfsyn};
use crate::synth::mixsyn::mixsyn;
use crate::synth::weights;
use serde::{Deserialize, Serialize, Serializer};
use serde_json::{Value, json};
use std::fmt;

/// The six rightmost poles, for a one-line summary.
pub fn poles_summary(poles: &[c64]) -> String {
    let mut p: Vec<_> = poles.to_vec();
    p.sort_by(|a, b| b.re.total_cmp(&a.re));
    p.iter()
        .take(6)
        .map(|z| fmt_complex(*z))
        .collect::<Vec<_>>()
        .join(", ")
        + if p.len() > 6 { ", ..." } else { "" }
}

fn stability(stable: bool) -> &'static str {
    if stable { "stable" } else { "UNSTABLE" }
}

/// Reports are serialised through their JSON value, so the keys come out
/// sorted exactly as the commands always printed them.
macro_rules! serialize_via_value {
    ($t:ty) => {
        impl Serialize for $t {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                self.to_value().serialize(s)
            }
        }
    };
}

/// Synthesis errors: a numerical breakdown is the computation's fault,
/// everything else (dimensions, stabilisability, feasibility) the input's.
fn synth_err(source: &str, e: SynthError) -> StepError {
    match e {
        SynthError::Numerical(m) => {
            StepError::computation(format!("{source}: numerical failure: {m}"))
        }
        SynthError::BelowOptimum(m) => StepError::computation(format!("{source}: {m}")),
        other => StepError::input(format!("{source}: {other}")),
    }
}

fn computation(source: &str) -> impl Fn(crate::lti::ss::SsError) -> StepError + '_ {
    move |e| StepError::computation(format!("{source}: {e}"))
}

// ---------------------------------------------------------------- weight

/// The shape of a weight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WeightShape {
    /// `W_s = (s/M + w0)/(s + w0 A)` (Karagoz18 Eq. 7).
    Ws,
    /// `W_t = (s + w0/M)/(A s + w0)` (Karagoz18 Eq. 8).
    Wt,
    /// `makeweight(dc, [freq, mag], hf)`, first order.
    Makeweight,
}

impl crate::workflow::Choices for WeightShape {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("ws", "W_s = (s/M + w0)/(s + w0 A) (Karagoz18 Eq. 7)"),
        ("wt", "W_t = (s + w0/M)/(A s + w0) (Karagoz18 Eq. 8)"),
        (
            "makeweight",
            "makeweight(dcgain, [freq, mag], hfgain), first order",
        ),
    ];
}

impl WeightShape {
    fn name(self) -> &'static str {
        match self {
            WeightShape::Ws => "ws",
            WeightShape::Wt => "wt",
            WeightShape::Makeweight => "makeweight",
        }
    }
}

/// `fts weight`: a first-order performance weight (continuous `fts.ss/1`).
/// `shape` is required; `m`, `w0` (or `w0_rad`), `a` go with `ws`/`wt`,
/// `dc`, `freq` (or `freq_rad`), `mag`, `hf` with `makeweight`.
/// Frequencies are in Hz; the `_rad` forms take rad/s.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Weight {
    /// Which weight (no default).
    pub shape: Option<WeightShape>,
    /// Peak sensitivity / gain M (ws, wt).
    pub m: Option<f64>,
    /// Corner frequency, Hz (ws, wt).
    pub w0: Option<f64>,
    /// Corner frequency, rad/s (ws, wt), instead of `w0`.
    pub w0_rad: Option<f64>,
    /// Low/high-frequency gain parameter A (ws, wt).
    pub a: Option<f64>,
    /// makeweight: DC gain.
    pub dc: Option<f64>,
    /// makeweight: frequency, Hz, where the gain is `mag`.
    pub freq: Option<f64>,
    /// makeweight: that frequency in rad/s, instead of `freq`.
    pub freq_rad: Option<f64>,
    /// makeweight: gain at `freq`.
    pub mag: Option<f64>,
    /// makeweight: high-frequency gain.
    pub hf: Option<f64>,
}

impl Weight {
    fn shape(&self) -> Result<WeightShape, StepError> {
        self.shape.ok_or_else(|| {
            StepError::setting("shape", "missing: one of \"ws\", \"wt\", \"makeweight\"")
        })
    }

    /// A frequency given in Hz (`hz`) or rad/s (`rad`), in rad/s; which of
    /// the two settings was used, for messages.
    fn rad_per_s(
        hz: (&'static str, Option<f64>),
        rad: (&'static str, Option<f64>),
    ) -> Result<(&'static str, Option<f64>), StepError> {
        match (hz.1, rad.1) {
            (Some(_), Some(_)) => Err(StepError::setting(
                rad.0,
                format!("give {} (Hz) or {} (rad/s), not both", hz.0, rad.0),
            )),
            (Some(f), None) => Ok((hz.0, Some(positive(hz.0, f)? * std::f64::consts::TAU))),
            (None, Some(w)) => Ok((rad.0, Some(w))),
            (None, None) => Ok((hz.0, None)),
        }
    }

    /// The parameters the shape needs, in order, each checked positive
    /// (frequencies in rad/s, as the weight formulas take them).
    fn params(&self) -> Result<Vec<f64>, StepError> {
        let shape = self.shape()?;
        let needed: [(&'static str, Option<f64>); 4] = match shape {
            WeightShape::Ws | WeightShape::Wt => [
                ("m", self.m),
                Self::rad_per_s(("w0", self.w0), ("w0_rad", self.w0_rad))?,
                ("a", self.a),
                ("", None),
            ],
            WeightShape::Makeweight => [
                ("dc", self.dc),
                Self::rad_per_s(("freq", self.freq), ("freq_rad", self.freq_rad))?,
                ("mag", self.mag),
                ("hf", self.hf),
            ],
        };
        needed
            .iter()
            .filter(|(name, _)| !name.is_empty())
            .map(|&(name, value)| {
                let x = value.ok_or_else(|| {
                    StepError::setting(
                        name,
                        format!("missing: the {} weight needs it", shape.name()),
                    )
                })?;
                positive(name, x)
            })
            .collect()
    }

    /// Builds the weight.
    pub fn run(&self) -> Result<WeightReport, StepError> {
        let p = self.params()?;
        let weight = match self.shape()? {
            WeightShape::Ws => weights::ws(p[0], p[1], p[2]),
            WeightShape::Wt => weights::wt(p[0], p[1], p[2]),
            WeightShape::Makeweight => weights::makeweight(p[0], p[1], p[2], p[3]),
        }
        .map_err(|e| StepError::input(e.0))?;
        let (num, den) = weight.to_tf().map_err(computation("weight"))?;
        let dc_gain = weight.dc_gain().map_err(computation("weight"))?[(0, 0)];
        let hf_gain = weight.d[(0, 0)];
        Ok(WeightReport {
            weight,
            num,
            den,
            dc_gain,
            hf_gain,
        })
    }
}

impl Validate for Weight {
    fn validate(&self) -> Result<(), StepError> {
        self.params().map(|_| ())
    }
}

/// The weight and its gains.
#[derive(Debug, Clone)]
pub struct WeightReport {
    /// The weight (continuous, SISO).
    pub weight: StateSpace,
    /// Numerator, descending powers of s.
    pub num: Vec<f64>,
    /// Denominator, descending powers of s.
    pub den: Vec<f64>,
    /// Gain at s = 0.
    pub dc_gain: f64,
    /// Gain as s -> infinity.
    pub hf_gain: f64,
}

impl WeightReport {
    fn to_value(&self) -> Value {
        json!({"num": self.num, "den": self.den, "dc_gain": self.dc_gain,
            "hf_gain": self.hf_gain, "weight": ss_json::ss_to_value(&self.weight)})
    }
}
serialize_via_value!(WeightReport);

impl fmt::Display for WeightReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "W(s) = {:?} / {:?} (descending powers of s)\nDC gain {:.6e}, HF gain {:.6e}",
            self.num, self.den, self.dc_gain, self.hf_gain
        )
    }
}

// ---------------------------------------------------------------- hinf

/// `fts hinf`: H-infinity synthesis on a generalised plant (inputs [w; u],
/// outputs [z; y]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Hinf {
    /// Number of measurements (the last `nmeas` outputs); default 1.
    pub nmeas: usize,
    /// Number of controls (the last `ncon` inputs); default 1.
    pub ncon: usize,
    /// Smallest weight of the regularising channels added when D12 / D21
    /// lack full rank; default 1e-6.
    pub eps: f64,
    /// Relative tolerance of the gamma bisection; default 1e-6.
    pub tol: f64,
    /// Largest gamma tried before the problem is declared infeasible; default 1e8.
    pub gamma_max: f64,
    /// The controller is built for the bisection bound * (1 + backoff); default 1e-4.
    pub backoff: f64,
    /// Discrete plants: the smallest `1 - |z|` accepted for a closed-loop
    /// pole the controller moves; default 1e-4 (docs/robust.md, "Discrete
    /// H-infinity: the pole margin").
    pub pole_margin: f64,
    /// Design at exactly this gamma instead of searching for the optimum
    /// (`hinfsyn(P, ny, nu, gamTry)`); refused, naming the optimum, when
    /// below it. Default: none (search).
    pub gamma: Option<f64>,
}

impl Default for Hinf {
    fn default() -> Self {
        let o = HinfOptions::default();
        Self {
            nmeas: 1,
            ncon: 1,
            eps: o.eps,
            tol: o.rtol,
            gamma_max: o.gamma_max,
            backoff: o.backoff,
            pole_margin: o.pole_margin,
            gamma: o.gamma,
        }
    }
}

impl Hinf {
    fn options(&self) -> Result<HinfOptions, StepError> {
        self.validate()?;
        Ok(HinfOptions {
            rtol: self.tol,
            eps: self.eps,
            gamma_max: self.gamma_max,
            backoff: self.backoff,
            pole_margin: self.pole_margin,
            gamma: self.gamma,
        })
    }

    /// Synthesises the controller for the generalised plant `p` (`source`
    /// names it in messages).
    pub fn run(&self, p: &StateSpace, source: &str) -> Result<HinfReport, StepError> {
        check_synthesis_states(p.nx(), source, "hinf")?;
        let result =
            hinfsyn(p, self.nmeas, self.ncon, self.options()?).map_err(|e| synth_err(source, e))?;
        Ok(HinfReport {
            result,
            eps: self.eps,
            tol: self.tol,
            plant_fastest_pole: fastest_pole(p),
            pole_margin: self.pole_margin,
            chosen_gamma: self.gamma,
        })
    }
}

impl Validate for Hinf {
    fn validate(&self) -> Result<(), StepError> {
        let (eps, tol, gmax, backoff) = (self.eps, self.tol, self.gamma_max, self.backoff);
        if !(backoff.is_finite() && (0.0..1.0).contains(&backoff)) {
            return Err(StepError::setting(
                "backoff",
                format!("expected 0 <= backoff < 1, got {backoff}"),
            ));
        }
        positive("eps", eps)?;
        if !(tol.is_finite() && tol > 0.0 && tol < 0.5) {
            return Err(StepError::setting(
                "tol",
                format!("expected 0 < tol < 0.5, got {tol}"),
            ));
        }
        positive("gamma_max", gmax)?;
        if let Some(g) = self.gamma {
            positive("gamma", g)?;
        }
        let pm = self.pole_margin;
        if !(pm.is_finite() && (0.0..1.0).contains(&pm)) {
            return Err(StepError::setting(
                "pole_margin",
                format!("expected 0 <= pole_margin < 1, got {pm}"),
            ));
        }
        Ok(())
    }
}

/// What H2 and H-infinity reports share: the closed loop, the Riccati
/// residuals, the controller and the regularisation. (`serde_json` keeps
/// keys sorted, so the fields added after stay in the same place.)
fn synthesis_value(
    stable: bool,
    poles: &[c64],
    (x_residual, y_residual): (f64, f64),
    k: &StateSpace,
    ((d12, d21), eps_min): ((Option<f64>, Option<f64>), f64),
) -> Value {
    json!({
        "stable": stable,
        "closed_loop_poles": complex_pairs(poles),
        "riccati_residuals": {"x": x_residual, "y": y_residual},
        "controller": ss_json::ss_to_value(k),
        "controller_order": k.nx(),
        "regularised": {"d12": d12, "d21": d21, "eps_min": eps_min},
    })
}

/// An H-infinity controller and its closed loop.
#[derive(Debug, Clone)]
pub struct HinfReport {
    /// The synthesis result; `result.k` is the controller.
    pub result: HinfResult,
    /// The `eps` setting used.
    pub eps: f64,
    /// The `tol` setting used.
    pub tol: f64,
    /// Modulus of the generalised plant's fastest pole, rad/s.
    pub plant_fastest_pole: f64,
    /// The `pole_margin` setting used (discrete plants).
    pub pole_margin: f64,
    /// The `gamma` setting: the level the controller was designed at, when
    /// chosen rather than searched for.
    pub chosen_gamma: Option<f64>,
}

/// A controller pole this many times faster than the plant's fastest mode
/// is reported as a warning (it is beyond anything the plant model covers).
pub const FAST_POLE_RATIO: f64 = 100.0;

impl HinfReport {
    /// What the user should know about the controller: regularisation and
    /// controller poles far beyond the plant's modes.
    pub fn warnings(&self) -> Vec<String> {
        let r = &self.result;
        let mut w = Vec::new();
        if let Some(e) = r.regularised.0 {
            w.push(format!(
                "the control channel was regularised: a weight {e:.3e} on u was added to the \
                 performance outputs (D12 rank deficient, or its smallest singular value below \
                 the conditioning floor); gamma is the norm on the original plant"
            ));
        }
        if let Some(e) = r.regularised.1 {
            w.push(format!(
                "the measurement channel was regularised: a sensor-noise weight {e:.3e} was \
                 added (D21 rank deficient, or its smallest singular value below the \
                 conditioning floor); gamma is the norm on the original plant"
            ));
        }
        if let (Some(false), Some(m)) = (r.pole_margin_met, r.pole_margin) {
            let levels = match self.chosen_gamma {
                Some(g) => format!("at the chosen gamma {g}: raise it, "),
                None => "at every level up to 1.1 times the optimum: ".to_string(),
            };
            w.push(format!(
                "a closed-loop pole the controller moves lies {m:.3e} from the unit circle \
                 (|z| = {:.6}), less than the required pole margin {:.1e}, {levels}relax the \
                 weights or lower --pole-margin",
                1.0 - m,
                self.pole_margin
            ));
        }
        if let Some(g) = self.chosen_gamma
            && r.gamma > g * (1.0 + 1e-6)
        {
            w.push(format!(
                "the central controller at the chosen gamma {g} achieves {:.8}, {:.1e} above it \
                 (close to the optimum the central controller is ill-conditioned): choose a \
                 gamma further above the optimum for a controller that meets it",
                r.gamma,
                r.gamma / g - 1.0
            ));
        }
        let (fk, fp) = (r.controller_fastest_pole(), self.plant_fastest_pole);
        if fk > FAST_POLE_RATIO * fp.max(f64::MIN_POSITIVE) {
            w.push(format!(
                "the controller's fastest pole, {fk:.3e} rad/s, is {:.0} times the plant's \
                 fastest mode ({fp:.3e} rad/s): a cheap-control pole far beyond the model; \
                 reduce the controller's order or raise the control weight",
                fk / fp.max(f64::MIN_POSITIVE)
            ));
        }
        w
    }

    fn to_value(&self) -> Value {
        let r = &self.result;
        let mut v = synthesis_value(
            r.stable,
            &r.poles,
            (r.x_residual, r.y_residual),
            &r.k,
            (r.regularised, self.eps),
        );
        v["gamma"] = json!(r.gamma);
        v["gamma_omega"] = json!(r.peak_omega);
        v["gamma_freq_hz"] = json!(r.peak_omega / std::f64::consts::TAU);
        v["gamma_upper"] = json!(r.gamma_upper);
        v["bisection"] = match self.chosen_gamma {
            None => json!({"rtol": self.tol, "iterations": r.iterations,
                "bound": r.bisection_bound, "design_level": r.design_level}),
            // No search: the controller is built at the chosen level.
            Some(g) => json!({"chosen_gamma": g, "design_level": r.design_level}),
        };
        v["controller_fastest_pole_rad_s"] = json!(r.controller_fastest_pole());
        v["closed_loop_spectral_radius"] = json!(r.spectral_radius);
        v["pole_margin"] = json!({"achieved": r.pole_margin, "required": self.pole_margin,
            "met": r.pole_margin_met});
        v["controller_form"] = json!(r.form.name());
        v["plant_fastest_pole_rad_s"] = json!(self.plant_fastest_pole);
        v["warnings"] = json!(self.warnings());
        v
    }
}
serialize_via_value!(HinfReport);

impl fmt::Display for HinfReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.result;
        writeln!(
            f,
            "gamma            {:.8} (||Tzw||_inf of the returned controller, recomputed)\npeak             {}\nclosed loop      {} (poles: {})\ncontroller       {} states, fastest pole {:.3e} rad/s (plant {:.3e} rad/s)\n{}\nRiccati residual X {:.1e}, Y {:.1e}",
            r.gamma,
            peak_summary(r.peak_omega, r.gamma_upper),
            stability(r.stable),
            poles_summary(&r.poles),
            r.k.nx(),
            r.controller_fastest_pole(),
            self.plant_fastest_pole,
            match self.chosen_gamma {
                None => format!(
                    "bisection        bound {:.8}, controller built for {:.8} (diagnostics)",
                    r.bisection_bound, r.design_level
                ),
                Some(g) => format!("design level     {g} (chosen; no search for the optimum)"),
            },
            r.x_residual,
            r.y_residual
        )?;
        if let (Some(rho), Some(m)) = (r.spectral_radius, r.pole_margin) {
            writeln!(
                f,
                "discrete loop    spectral radius {rho:.6}; pole margin {m:.3e} (required {:.1e}); \
                 controller: {}",
                self.pole_margin,
                r.form.name()
            )?;
        }
        for w in self.warnings() {
            writeln!(f, "warning: {w}")?;
        }
        Ok(())
    }
}

/// Where the closed-loop norm is attained and its certified upper bound.
fn peak_summary(omega: f64, upper: f64) -> String {
    let at = if omega.is_nan() {
        "none (unstable)".to_string()
    } else if omega.is_infinite() {
        "at infinite frequency".to_string()
    } else {
        format!(
            "at {:.6} Hz ({:.6} rad/s)",
            omega / std::f64::consts::TAU,
            omega
        )
    };
    if upper.is_finite() {
        format!("{at}, certified ||Tzw||_inf <= {upper:.10}")
    } else {
        format!("{at}, upper bound not certified")
    }
}

// ---------------------------------------------------------------- h2

/// `fts h2`: H2-optimal synthesis on a generalised plant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct H2 {
    /// Number of measurements (the last `nmeas` outputs); default 1.
    pub nmeas: usize,
    /// Number of controls (the last `ncon` inputs); default 1.
    pub ncon: usize,
    /// Smallest weight of the regularising channels; default 1e-6.
    pub eps: f64,
}

impl Default for H2 {
    fn default() -> Self {
        let h = Hinf::default();
        Self {
            nmeas: h.nmeas,
            ncon: h.ncon,
            eps: h.eps,
        }
    }
}

impl H2 {
    /// Synthesises the controller for the generalised plant `p`.
    pub fn run(&self, p: &StateSpace, source: &str) -> Result<H2Report, StepError> {
        self.validate()?;
        check_synthesis_states(p.nx(), source, "h2")?;
        let result = h2syn(p, self.nmeas, self.ncon, self.eps).map_err(|e| synth_err(source, e))?;
        Ok(H2Report {
            result,
            eps: self.eps,
        })
    }
}

impl Validate for H2 {
    fn validate(&self) -> Result<(), StepError> {
        positive("eps", self.eps).map(|_| ())
    }
}

/// An H2 controller and its closed loop.
#[derive(Debug, Clone)]
pub struct H2Report {
    /// The synthesis result; `result.k` is the controller.
    pub result: H2Result,
    /// The `eps` setting used.
    pub eps: f64,
}

impl H2Report {
    fn to_value(&self) -> Value {
        let r = &self.result;
        let mut v = synthesis_value(
            r.stable,
            &r.poles,
            (r.x_residual, r.y_residual),
            &r.k,
            (r.regularised, self.eps),
        );
        v["h2_norm"] = json!(r.h2_norm);
        v["h2_optimum"] = json!(r.h2_optimum);
        v["closed_loop_spectral_radius"] = json!(r.spectral_radius());
        v
    }
}
serialize_via_value!(H2Report);

impl fmt::Display for H2Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.result;
        writeln!(
            f,
            "closed-loop H2 norm {:.12}\nclosed loop        {} (poles: {})\ncontroller         {} states\nRiccati residual   X {:.1e}, Y {:.1e}",
            r.h2_norm,
            stability(r.stable),
            poles_summary(&r.poles),
            r.k.nx(),
            r.x_residual,
            r.y_residual
        )?;
        if let (Some(rho), Some(opt)) = (r.spectral_radius(), r.h2_optimum) {
            writeln!(
                f,
                "discrete loop      spectral radius {rho:.6} (margin {:.3e}); optimum from the \
                 Riccati solutions {opt:.12}",
                1.0 - rho
            )?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------- mixsyn

/// `fts mixsyn`: mixed-sensitivity H-infinity design `mixsyn(G, Ws, Wu, Wt)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Mixsyn {
    /// Smallest weight of the regularising channels; default 1e-6.
    pub eps: f64,
    /// Relative tolerance of the gamma bisection; default 1e-6.
    pub tol: f64,
    /// Reduce the controller to this many states by balanced truncation
    /// (the closed loop is re-checked); default: no reduction.
    pub order: Option<usize>,
    /// Accept a reduced controller whose closed-loop norm exceeds the full
    /// controller's by more than [`MAX_DEGRADATION`]; default false.
    pub allow_degradation: bool,
    /// Design at exactly this gamma instead of searching for the optimum
    /// ([`Hinf::gamma`]); default: none (search).
    pub gamma: Option<f64>,
}

/// A reduced controller may raise the closed-loop H-infinity norm by at most
/// this factor over the full-order controller's, unless allowed.
pub const MAX_DEGRADATION: f64 = 1.1;

impl Default for Mixsyn {
    fn default() -> Self {
        let h = Hinf::default();
        Self {
            eps: h.eps,
            tol: h.tol,
            order: None,
            allow_degradation: false,
            gamma: None,
        }
    }
}

/// A system and its name (a file path) for messages.
#[derive(Debug, Clone, Copy)]
pub struct Named<'a> {
    /// The system.
    pub system: &'a StateSpace,
    /// Its name.
    pub source: &'a str,
}

impl<'a> From<&'a (StateSpace, String)> for Named<'a> {
    fn from((system, source): &'a (StateSpace, String)) -> Self {
        Named {
            system,
            source: source.as_str(),
        }
    }
}

/// The systems `mixsyn` combines; `source` names the plant in messages.
#[derive(Debug, Clone, Copy)]
pub struct MixsynInputs<'a> {
    /// The plant G.
    pub plant: &'a StateSpace,
    /// Sensitivity weight (on S).
    pub ws: Named<'a>,
    /// Control weight (on KS).
    pub wu: Option<Named<'a>>,
    /// Complementary sensitivity weight (on T).
    pub wt: Option<Named<'a>>,
    /// The plant's name (a file path), for messages.
    pub source: &'a str,
}

/// A mixed-sensitivity weight must be continuous, stable and square with
/// the plant's channel count (`ny` for ws and wt, `nu` for wu); refused
/// here, naming its file and setting, before the plant is blamed.
fn check_weight(key: &'static str, w: Named<'_>, size: usize) -> Result<(), StepError> {
    let (file, sys) = (w.source, w.system);
    let refuse = |m: String| {
        Err(StepError::setting(
            key,
            format!("{file}: the `{key}` weight {m}"),
        ))
    };
    if sys.is_discrete() {
        return refuse("is discrete; mixsyn weights are continuous (\"ts\": null)".into());
    }
    if sys.ny() != size || sys.nu() != size {
        return refuse(format!(
            "is {}x{} (outputs x inputs); the plant needs {size}x{size}",
            sys.ny(),
            sys.nu()
        ));
    }
    let poles = sys
        .poles()
        .map_err(|e| StepError::setting(key, format!("{file}: the `{key}` weight's poles: {e}")))?;
    match poles.iter().find(|p| p.re >= 0.0) {
        Some(p) => refuse(format!(
            "is unstable (pole at s = {}{:+}j); mixsyn weights must be stable",
            p.re, p.im
        )),
        None => Ok(()),
    }
}

impl Mixsyn {
    fn hinf(&self) -> Hinf {
        Hinf {
            eps: self.eps,
            tol: self.tol,
            gamma: self.gamma,
            ..Hinf::default()
        }
    }

    /// Designs the controller.
    pub fn run(&self, inputs: MixsynInputs<'_>) -> Result<MixsynReport, StepError> {
        let (ny, nu) = (inputs.plant.ny(), inputs.plant.nu());
        check_weight("ws", inputs.ws, ny)?;
        if let Some(wu) = inputs.wu {
            check_weight("wu", wu, nu)?;
        }
        if let Some(wt) = inputs.wt {
            check_weight("wt", wt, ny)?;
        }
        let weights = [Some(inputs.ws), inputs.wu, inputs.wt];
        let states = inputs.plant.nx()
            + weights
                .iter()
                .flatten()
                .map(|w| w.system.nx())
                .sum::<usize>();
        let what = format!("{} (with its weights, the augmented plant)", inputs.source);
        check_synthesis_states(states, &what, "mixsyn")?;
        let hinf = self.hinf();
        let (augmented, result) = mixsyn(
            inputs.plant,
            Some(inputs.ws.system),
            inputs.wu.map(|w| w.system),
            inputs.wt.map(|w| w.system),
            hinf.options()?,
        )
        .map_err(|e| synth_err(inputs.source, e))?;
        let plant_fastest_pole = fastest_pole(&augmented);
        let mut report = MixsynReport {
            augmented,
            hinf: HinfReport {
                result,
                eps: self.eps,
                tol: self.tol,
                plant_fastest_pole,
                pole_margin: hinf.pole_margin,
                chosen_gamma: self.gamma,
            },
            reduction: None,
        };
        if let Some(order) = self.order {
            report.reduce(order)?;
            report.check_degradation(self.allow_degradation)?;
        }
        Ok(report)
    }
}

/// The most states of a generalised plant `fts hinf`, `fts h2` and `fts
/// mixsyn` take: their Riccati solutions, gamma bisection and closed-loop
/// checks cost O(n^3) per step over many steps; measured on a random
/// plant in the test build, `hinf` takes 25 s at 64 states and 175 s at
/// 128, `h2` 3 s and 20 s (docs/formats.md, Bounds).
pub const MAX_SYNTHESIS_STATES: usize = 64;

/// Refuses a generalised plant beyond [`MAX_SYNTHESIS_STATES`] before any work.
fn check_synthesis_states(states: usize, source: &str, command: &str) -> Result<(), StepError> {
    if states > MAX_SYNTHESIS_STATES {
        return Err(StepError::input(format!(
            "{source}: {states} states; `fts {command}` takes at most {MAX_SYNTHESIS_STATES} states (docs/formats.md, Bounds)"
        )));
    }
    Ok(())
}

impl Validate for Mixsyn {
    fn validate(&self) -> Result<(), StepError> {
        self.hinf().validate()
    }
}

/// What balanced truncation did to the controller.
#[derive(Debug, Clone)]
pub struct Reduction {
    /// States of the full controller.
    pub full_order: usize,
    /// States kept.
    pub order: usize,
    /// Hankel singular values of the full controller.
    pub hankel_singular_values: Vec<f64>,
    /// Bound on `||K - Kr||_inf`.
    pub error_bound: f64,
    /// The closed-loop norm with the full-order controller.
    pub full_gamma: f64,
    /// `gamma (reduced) / full_gamma`; infinite when the reduced loop is unstable.
    pub degradation: f64,
}

/// A mixed-sensitivity controller, its closed loop and the augmented plant.
#[derive(Debug, Clone)]
pub struct MixsynReport {
    /// The augmented plant P = augw(G, Ws, Wu, Wt).
    pub augmented: StateSpace,
    /// The synthesis (with the reduced controller and its closed loop when
    /// reduced).
    pub hinf: HinfReport,
    /// The reduction, when `order` was set.
    pub reduction: Option<Reduction>,
}

/// Frequencies (Hz) at which the report gives the controller's gain.
const GAIN_FREQS_HZ: [f64; 5] = [0.0, 1.0, 10.0, 100.0, 1000.0];

impl MixsynReport {
    /// The controller.
    pub fn controller(&self) -> &StateSpace {
        &self.hinf.result.k
    }

    /// Replaces the controller by its balanced truncation and re-checks the
    /// loop: stability and the closed-loop norm, recomputed.
    fn reduce(&mut self, order: usize) -> Result<(), StepError> {
        let r = &mut self.hinf.result;
        let red = balred(&r.k, order).map_err(|e| StepError::setting("order", e.to_string()))?;
        let cl = self
            .augmented
            .lft(&red.sys)
            .map_err(computation("reduced closed loop"))?;
        let stable = cl.is_stable().map_err(computation("reduced closed loop"))?;
        let norm = if stable { closed_loop_hinf(&cl) } else { None };
        let gamma = norm.map_or(f64::INFINITY, |h| h.peak);
        self.reduction = Some(Reduction {
            full_order: r.k.nx(),
            order: red.sys.nx(),
            hankel_singular_values: red.hsv,
            error_bound: red.bound,
            full_gamma: r.gamma,
            degradation: gamma / r.gamma,
        });
        r.poles = cl.poles().map_err(computation("reduced closed loop"))?;
        r.k = red.sys;
        r.closed_loop = cl;
        r.stable = stable;
        r.gamma = gamma;
        r.peak_omega = norm.map_or(f64::NAN, |h| h.omega);
        r.gamma_upper = norm.map_or(f64::INFINITY, |h| h.upper);
        Ok(())
    }

    /// Refuses a reduced controller that destabilises the loop or raises its
    /// norm beyond [`MAX_DEGRADATION`] times the full controller's, unless allowed.
    fn check_degradation(&self, allow: bool) -> Result<(), StepError> {
        let Some(red) = &self.reduction else {
            return Ok(());
        };
        if allow || red.degradation <= MAX_DEGRADATION {
            return Ok(());
        }
        let what = if self.hinf.result.stable {
            format!(
                "raises the closed-loop H-inf norm from {:.6} to {:.6} ({:.3} times, more than \
                 the {MAX_DEGRADATION} allowed)",
                red.full_gamma, self.hinf.result.gamma, red.degradation
            )
        } else {
            "does not stabilise the loop".to_string()
        };
        Err(StepError::computation(format!(
            "the controller reduced from {} to {} states {what}; keep more states or allow the \
             degradation",
            red.full_order, red.order
        )))
    }

    /// One line about the reduction, if there was one.
    pub fn reduction_note(&self) -> Option<String> {
        let red = self.reduction.as_ref()?;
        let r = &self.hinf.result;
        Some(format!(
            "reduced controller: {} -> {} states (||K - Kr||_inf <= {:.3e}); closed loop {}, gamma {:.6} vs {:.6} at full order (degradation {:.4})",
            red.full_order,
            red.order,
            red.error_bound,
            stability(r.stable),
            r.gamma,
            red.full_gamma,
            red.degradation
        ))
    }

    fn to_value(&self) -> Value {
        let mut v = self.hinf.to_value();
        let k = self.controller();
        v["controller_gain"] = GAIN_FREQS_HZ
            .iter()
            .map(|f| json!({"freq_hz": f, "gain": k.sigma_at(std::f64::consts::TAU * f)}))
            .collect();
        v["reduction"] = self.reduction.as_ref().map_or(Value::Null, |red| {
            json!({"order": red.order, "hankel_singular_values": red.hankel_singular_values,
                "error_bound": red.error_bound, "full_order": red.full_order,
                "full_order_gamma": red.full_gamma,
                "degradation": if red.degradation.is_finite() { json!(red.degradation) } else { Value::Null },
                "max_degradation": MAX_DEGRADATION})
        });
        v
    }
}
serialize_via_value!(MixsynReport);

impl fmt::Display for MixsynReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.hinf)?;
        if let Some(note) = self.reduction_note() {
            writeln!(f, "{note}")?;
        }
        for hz in GAIN_FREQS_HZ {
            let gain = self.controller().sigma_at(std::f64::consts::TAU * hz);
            writeln!(f, "|K| at {hz} Hz = {gain:.6e}")?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------- c2d

/// Discretisation method of [`C2d`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum C2dMethodChoice {
    /// Zero-order hold (Van Loan block exponential).
    #[default]
    Zoh,
    /// Tustin / bilinear.
    Tustin,
}

impl crate::workflow::Choices for C2dMethodChoice {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("zoh", "Zero-order hold (Van Loan block exponential)"),
        ("tustin", "Tustin / bilinear"),
    ];
}

/// `fts c2d`: discretises a continuous system.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct C2d {
    /// Sample time in seconds (required).
    pub ts: Option<f64>,
    /// Method; default zoh.
    pub method: C2dMethodChoice,
    /// Tustin prewarp frequency in Hz; default none.
    pub prewarp: Option<f64>,
}

impl C2d {
    fn ts(&self) -> Result<f64, StepError> {
        match self.ts {
            None => Err(StepError::setting(
                "ts",
                "missing: the sample time in seconds",
            )),
            Some(ts) if ts.is_finite() && ts > 0.0 => Ok(ts),
            Some(ts) => Err(StepError::setting(
                "ts",
                format!("expected a positive number of seconds, got {ts}"),
            )),
        }
    }

    fn method(&self) -> Result<C2dMethod, StepError> {
        let ts = self.ts()?;
        match (self.method, self.prewarp) {
            (C2dMethodChoice::Zoh, None) => Ok(C2dMethod::Zoh),
            (C2dMethodChoice::Zoh, Some(_)) => Err(StepError::setting(
                "prewarp",
                "applies to the tustin method only",
            )),
            (C2dMethodChoice::Tustin, p) => Ok(C2dMethod::Tustin {
                prewarp: p.map(|f| prewarp_rad(f, ts)).transpose()?,
            }),
        }
    }

    /// Discretises the continuous system `sys` (`source` names it).
    pub fn run(&self, sys: &StateSpace, source: &str) -> Result<C2dReport, StepError> {
        let (ts, method) = (self.ts()?, self.method()?);
        if sys.is_discrete() {
            return Err(StepError::input(format!(
                "{source}: the system is already discrete"
            )));
        }
        let system = c2d(sys, ts, method).map_err(|e| match e {
            // The sample time chosen is the culprit, not the computation.
            SsError::TustinPole { .. } => StepError::setting("ts", format!("{source}: {e}")),
            e => computation(source)(e),
        })?;
        let poles = system.poles().map_err(computation(source))?;
        let stable = system.is_stable().map_err(computation(source))?;
        Ok(C2dReport {
            system,
            poles,
            stable,
            ts,
        })
    }
}

/// A Tustin prewarp frequency in Hz, checked below Nyquist, in rad/s.
pub(crate) fn prewarp_rad(hz: f64, ts: f64) -> Result<f64, StepError> {
    if hz.is_finite() && hz > 0.0 && hz < 0.5 / ts {
        Ok(2.0 * std::f64::consts::PI * hz)
    } else {
        Err(StepError::setting(
            "prewarp",
            format!("expected 0 < HZ < Nyquist ({} Hz), got {hz}", 0.5 / ts),
        ))
    }
}

impl Validate for C2d {
    fn validate(&self) -> Result<(), StepError> {
        self.method().map(|_| ())
    }
}

/// The discrete system.
#[derive(Debug, Clone)]
pub struct C2dReport {
    /// The discretised system.
    pub system: StateSpace,
    /// Its poles.
    pub poles: Vec<c64>,
    /// Whether they are inside the unit circle.
    pub stable: bool,
    /// The sample time used.
    pub ts: f64,
}

impl C2dReport {
    fn to_value(&self) -> Value {
        json!({"system": ss_json::ss_to_value(&self.system),
            "poles": complex_pairs(&self.poles), "stable": self.stable})
    }
}
serialize_via_value!(C2dReport);

impl fmt::Display for C2dReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "discrete system: {} states, ts = {} s, {} (poles: {})",
            self.system.nx(),
            self.ts,
            if self.stable { "stable" } else { "not stable" },
            poles_summary(&self.poles)
        )
    }
}
