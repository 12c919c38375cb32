//! Model conversions as steps: `fts convert` (tf <-> ss), `fts zpk`,
//! `fts minreal`, `fts balred`, `fts d2c` (docs/responses.md §3).

use super::{StepError, Validate, complex_pairs, fmt_complex};
use crate::io::{ss_json, tf_json};
use crate::lti::convert::{self, ConvertError, Zpk};
use crate::lti::margins::LoopSystem;
use crate::lti::ss::{SsError, StateSpace};
use crate::lti::{TransferFunction, c64};
use serde::{Deserialize, Serialize, Serializer};
use serde_json::{Value, json};
use std::fmt;

fn conv_err(source: &str) -> impl Fn(ConvertError) -> StepError + '_ {
    move |e| match e {
        ConvertError::Refused(m) => StepError::input(format!("{source}: {m}")),
        ConvertError::Tf(e) => StepError::input(format!("{source}: {e}")),
        other => StepError::computation(format!("{source}: {other}")),
    }
}

fn ss_err(source: &str) -> impl Fn(SsError) -> StepError + '_ {
    move |e| match e {
        SsError::NoConvergence => StepError::computation(format!("{source}: {e}")),
        e => StepError::input(format!("{source}: {e}")),
    }
}

fn realise(model: &LoopSystem, source: &str) -> Result<StateSpace, StepError> {
    model.to_ss().map_err(ss_err(source))
}

/// The most states `fts balred` and `fts ss-info` take: their Gramians,
/// Hamiltonian bisections and zero pencils cost O(n^3) per step over many
/// steps, about 2 to 3 s at 64 states and over 25 s at 105
/// (docs/formats.md, Bounds).
pub const MAX_ANALYSED_STATES: usize = 64;

/// Refuses a system beyond [`MAX_ANALYSED_STATES`] before any work.
pub fn check_analysed_states(
    sys: &StateSpace,
    source: &str,
    command: &str,
) -> Result<(), StepError> {
    if sys.nx() > MAX_ANALYSED_STATES {
        return Err(StepError::input(format!(
            "{source}: {} states; `fts {command}` takes at most {MAX_ANALYSED_STATES} states (docs/formats.md, Bounds)",
            sys.nx()
        )));
    }
    Ok(())
}

/// A model in either file form.
pub type Model = LoopSystem;

// ------------------------------------------------------------- convert

/// Target form of [`Convert`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Form {
    /// `fts.ss/1`.
    #[default]
    Ss,
    /// `fts.tf/1`, one per channel.
    Tf,
}

impl crate::workflow::Choices for Form {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        (
            "ss",
            "State space (`fts.ss/1`): controllable canonical form of a transfer function",
        ),
        (
            "tf",
            "Transfer function (`fts.tf/1`), one per output/input channel",
        ),
    ];
}

/// `fts convert`: a model as state space or as transfer functions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Convert {
    /// Target form.
    pub to: Form,
}

impl Validate for Convert {
    fn validate(&self) -> Result<(), StepError> {
        Ok(())
    }
}

/// The converted model.
#[derive(Debug, Clone)]
pub enum ConvertReport {
    /// A state-space realisation (controllable canonical form of a tf).
    Ss(Box<StateSpace>),
    /// `tfs[i][j]` from input `j` to output `i`; `None` for a zero channel.
    Tf(Vec<Vec<Option<TransferFunction>>>),
}

impl Convert {
    /// Converts `model`.
    pub fn run(&self, model: &Model, source: &str) -> Result<ConvertReport, StepError> {
        Ok(match (self.to, model) {
            (Form::Ss, m) => ConvertReport::Ss(Box::new(realise(m, source)?)),
            (Form::Tf, LoopSystem::Tf(t)) => ConvertReport::Tf(vec![vec![Some(t.clone())]]),
            (Form::Tf, LoopSystem::Ss(s)) => {
                ConvertReport::Tf(convert::ss_to_tfs(s).map_err(conv_err(source))?)
            }
        })
    }
}

impl Serialize for ConvertReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            ConvertReport::Ss(sys) => json!({"system": ss_json::ss_to_value(sys)}),
            ConvertReport::Tf(tfs) => {
                let channels: Vec<Value> = tfs
                    .iter()
                    .enumerate()
                    .flat_map(|(i, row)| {
                        row.iter().enumerate().map(move |(j, t)| {
                            json!({"output": i + 1, "input": j + 1,
                                "tf": t.as_ref().map(tf_json::tf_to_value)})
                        })
                    })
                    .collect();
                json!({ "channels": channels })
            }
        }
        .serialize(s)
    }
}

fn describe_tf(t: &TransferFunction) -> String {
    match t {
        TransferFunction::Continuous(c) => format!(
            "num (s) {:?}, den (s) {:?}, input delay {} s",
            c.num(),
            c.den(),
            c.delay()
        ),
        TransferFunction::Discrete(d) => format!(
            "num (z^-1) {:?}, den (z^-1) {:?}, delay {}, ts {} s",
            d.num().coeffs(),
            d.den().coeffs(),
            d.delay(),
            d.ts()
        ),
    }
}

impl fmt::Display for ConvertReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConvertReport::Ss(sys) => writeln!(
                f,
                "state space: {} states, {} inputs, {} outputs, {}",
                sys.nx(),
                sys.nu(),
                sys.ny(),
                sys.ts
                    .map_or("continuous".into(), |t| format!("ts = {t} s"))
            ),
            ConvertReport::Tf(tfs) => {
                for (i, row) in tfs.iter().enumerate() {
                    for (j, t) in row.iter().enumerate() {
                        match t {
                            Some(t) => writeln!(
                                f,
                                "output {} <- input {}: {}",
                                i + 1,
                                j + 1,
                                describe_tf(t)
                            )?,
                            None => writeln!(f, "output {} <- input {}: 0", i + 1, j + 1)?,
                        }
                    }
                }
                Ok(())
            }
        }
    }
}

// ----------------------------------------------------------------- zpk

/// `fts zpk`: zeros, poles and gain of every channel.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ZpkStep {}

/// Zeros, poles and gains.
#[derive(Debug, Clone)]
pub struct ZpkReport {
    /// `(output, input, zpk)`, 1-based; `None` for a zero channel.
    pub channels: Vec<(usize, usize, Option<Zpk>)>,
}

impl ZpkStep {
    /// Computes the zpk form of every channel of `model`.
    pub fn run(&self, model: &Model, source: &str) -> Result<ZpkReport, StepError> {
        if let LoopSystem::Tf(TransferFunction::Continuous(c)) = model
            && c.delay() != 0.0
        {
            return Err(StepError::input(format!(
                "{source} field 'delay': zpk lists the zeros, poles and gain of a rational model; the {} s input delay has none (`fts tf info` reports the model with it)",
                c.delay()
            )));
        }
        let tfs = match model {
            LoopSystem::Tf(t) => vec![vec![Some(t.clone())]],
            LoopSystem::Ss(s) => convert::ss_to_tfs(s).map_err(conv_err(source))?,
        };
        let mut channels = Vec::new();
        for (i, row) in tfs.iter().enumerate() {
            for (j, t) in row.iter().enumerate() {
                let z = t
                    .as_ref()
                    .map(convert::zpk)
                    .transpose()
                    .map_err(conv_err(source))?;
                channels.push((i + 1, j + 1, z));
            }
        }
        Ok(ZpkReport { channels })
    }
}

impl Serialize for ZpkReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let v: Vec<Value> = self
            .channels
            .iter()
            .map(|(i, j, z)| match z {
                Some(z) => json!({"output": i, "input": j, "zeros": complex_pairs(&z.zeros),
                    "poles": complex_pairs(&z.poles), "gain": z.gain, "ts": z.ts}),
                None => json!({"output": i, "input": j, "zeros": [], "poles": [], "gain": 0.0}),
            })
            .collect();
        json!({ "channels": v }).serialize(s)
    }
}

fn list(v: &[c64]) -> String {
    if v.is_empty() {
        "none".into()
    } else {
        v.iter()
            .map(|z| fmt_complex(*z))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl fmt::Display for ZpkReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, j, z) in &self.channels {
            match z {
                None => writeln!(f, "output {i} <- input {j}: 0")?,
                Some(z) => {
                    let x = if z.ts.is_some() { "z" } else { "s" };
                    writeln!(
                        f,
                        "output {i} <- input {j}: k prod({x} - zeros) / prod({x} - poles){}",
                        z.ts.map_or(String::new(), |t| format!(", ts = {t} s"))
                    )?;
                    writeln!(f, "  zeros: {}", list(&z.zeros))?;
                    writeln!(f, "  poles: {}", list(&z.poles))?;
                    writeln!(f, "  gain k: {}", z.gain)?;
                }
            }
        }
        Ok(())
    }
}

// ------------------------------------------------------------- minreal

/// `fts minreal`: a minimal realisation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Minreal {
    /// Relative tolerance of the rank decisions (default `sqrt(eps)`).
    pub tol: f64,
}

impl Default for Minreal {
    fn default() -> Self {
        Self {
            tol: f64::EPSILON.sqrt(),
        }
    }
}

impl Validate for Minreal {
    fn validate(&self) -> Result<(), StepError> {
        if self.tol.is_finite() && self.tol > 0.0 && self.tol < 1.0 {
            Ok(())
        } else {
            Err(StepError::setting(
                "tol",
                format!("expected a number between 0 and 1, got {}", self.tol),
            ))
        }
    }
}

/// The minimal model.
#[derive(Debug, Clone)]
pub struct MinrealReport {
    /// States before.
    pub order_before: usize,
    /// The minimal realisation.
    pub system: StateSpace,
    /// Its transfer function when the input was one (SISO).
    pub tf: Option<TransferFunction>,
    /// Its poles.
    pub poles: Vec<c64>,
}

impl Minreal {
    /// Removes uncontrollable and unobservable states of `model`.
    pub fn run(&self, model: &Model, source: &str) -> Result<MinrealReport, StepError> {
        self.validate()?;
        let sys = realise(model, source)?;
        let system = convert::minreal(&sys, self.tol).map_err(ss_err(source))?;
        let poles = system.poles().map_err(ss_err(source))?;
        self.check(&sys, &poles, source)?;
        self.check_response(&sys, &system, source)?;
        let tf = match model {
            LoopSystem::Tf(_) => Some(convert::siso_tf(&system).map_err(conv_err(source))?),
            LoopSystem::Ss(_) => None,
        };
        Ok(MinrealReport {
            order_before: sys.nx(),
            system,
            tf,
            poles,
        })
    }
}

/// A pole of a minimal realisation may sit this far (times `1 + |p|`)
/// from a pole of the model: removing states moves no other pole, so
/// anything farther is a state that was reachable and observable.
pub const MINREAL_POLE_DRIFT: f64 = 1e-2;

impl Minreal {
    /// The self-check (docs/responses.md §3): every pole of the result is
    /// a pole of the model within [`MINREAL_POLE_DRIFT`], and a stable
    /// model stays stable. A failure is a computation failure: the
    /// tolerance removed more than uncontrollable or unobservable states.
    fn check(&self, sys: &StateSpace, poles: &[c64], source: &str) -> Result<(), StepError> {
        let before = sys.poles().map_err(ss_err(source))?;
        let fail = |what: String| {
            Err(StepError::computation(format!(
                "{source}: the minimal realisation fails its self-check: {what}; `tol` = {:e} removed states that are reachable and observable: use a smaller `tol`",
                self.tol
            )))
        };
        for p in poles {
            let nearest = before
                .iter()
                .map(|q| (q, (p - q).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let near = nearest.is_some_and(|(_, d)| d <= MINREAL_POLE_DRIFT * (1.0 + p.norm()));
            if !near {
                let nearest = nearest.map_or("none".into(), |(q, d)| {
                    format!("nearest {} at {d:.3e}", fmt_complex(*q))
                });
                return fail(format!(
                    "its pole {} is not a pole of the model ({nearest})",
                    fmt_complex(*p)
                ));
            }
        }
        let stable = |ps: &[c64]| match sys.ts {
            Some(_) => ps.iter().all(|p| p.norm() < 1.0),
            None => ps.iter().all(|p| p.re < 0.0),
        };
        if stable(&before) && !stable(poles) {
            return fail("the model is stable, its minimal realisation is not".into());
        }
        Ok(())
    }
}

impl Minreal {
    /// The second self-check: the result's frequency response keeps the
    /// model's at three frequencies (to half of its largest gain there): a
    /// tolerance that removes every state of a system with a response
    /// leaves a zero system, which no pole test sees.
    fn check_response(
        &self,
        sys: &StateSpace,
        reduced: &StateSpace,
        source: &str,
    ) -> Result<(), StepError> {
        let points: Vec<c64> = match sys.ts {
            Some(_) => [0.3, 1.3, 2.9]
                .iter()
                .map(|&w| c64::new(0.0, w).exp())
                .collect(),
            None => {
                let scale = 1.0
                    + sys
                        .poles()
                        .map_err(ss_err(source))?
                        .iter()
                        .fold(0.0f64, |m, p| m.max(p.norm()));
                [0.1, 1.0, 10.0]
                    .iter()
                    .map(|&w| c64::new(0.0, w * scale))
                    .collect()
            }
        };
        let (mut worst, mut largest) = (0.0f64, 0.0f64);
        for x in points {
            let (Ok(a), Ok(b)) = (sys.eval(x), reduced.eval(x)) else {
                continue;
            };
            for (u, v) in a
                .col_iter()
                .flat_map(|c| c.iter().copied().collect::<Vec<_>>())
                .zip(
                    b.col_iter()
                        .flat_map(|c| c.iter().copied().collect::<Vec<_>>()),
                )
            {
                worst = worst.max((u - v).norm());
                largest = largest.max(u.norm());
            }
        }
        if largest > 0.0 && worst > 0.5 * largest {
            return Err(StepError::computation(format!(
                "{source}: the minimal realisation fails its self-check: its frequency response differs from the model's by {:.3e} of the model's gain; `tol` = {:e} removed states that are reachable and observable: use a smaller `tol`",
                worst / largest,
                self.tol
            )));
        }
        Ok(())
    }
}

impl Serialize for MinrealReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        json!({"order_before": self.order_before, "order": self.system.nx(),
            "poles": complex_pairs(&self.poles),
            "system": ss_json::ss_to_value(&self.system),
            "tf": self.tf.as_ref().map(tf_json::tf_to_value)})
        .serialize(s)
    }
}

impl fmt::Display for MinrealReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "minimal realisation: {} states (from {}); poles: {}",
            self.system.nx(),
            self.order_before,
            list(&self.poles)
        )?;
        if let Some(t) = &self.tf {
            writeln!(f, "transfer function: {}", describe_tf(t))?;
        }
        Ok(())
    }
}

// -------------------------------------------------------------- balred

/// `fts balred`: balanced truncation to `order` states.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Balred {
    /// States to keep (required).
    pub order: Option<usize>,
    /// Accept a reduction whose error on a dense frequency grid exceeds
    /// the Hankel-singular-value bound (inaccurate Gramians); default false.
    pub allow_degradation: bool,
}

impl Validate for Balred {
    fn validate(&self) -> Result<(), StepError> {
        self.order
            .map(|_| ())
            .ok_or_else(|| StepError::setting("order", "missing: the number of states to keep"))
    }
}

/// The reduced model, the Hankel singular values and the error bound.
#[derive(Debug, Clone)]
pub struct BalredReport {
    /// The reduced system.
    pub system: StateSpace,
    /// States before.
    pub order_before: usize,
    /// Hankel singular values of the original (descending).
    pub hsv: Vec<f64>,
    /// `||G - G_r||_inf <= 2 sum of the discarded Hankel singular values`
    /// (or, for an accepted untrusted reduction, the larger error found on
    /// the frequency grid).
    pub bound: f64,
    /// Whether the error found on a dense frequency grid stayed within
    /// the Hankel-singular-value bound.
    pub trusted: bool,
}

impl Balred {
    /// Reduces `model` (stable, continuous or discrete).
    pub fn run(&self, model: &Model, source: &str) -> Result<BalredReport, StepError> {
        self.validate()?;
        let order = self.order.unwrap_or(0);
        let sys = realise(model, source)?;
        check_analysed_states(&sys, source, "balred")?;
        if order > sys.nx() {
            return Err(StepError::setting(
                "order",
                format!("{source} has {} states, cannot keep {order}", sys.nx()),
            ));
        }
        if !sys.is_stable().map_err(ss_err(source))? {
            return Err(StepError::input(format!(
                "{source}: the system is unstable; balanced truncation needs a stable one (split off the unstable part first)"
            )));
        }
        let red = convert::balred_any(&sys, order).map_err(ss_err(source))?;
        if !red.trusted && !self.allow_degradation {
            return Err(StepError::computation(format!(
                "{source}: the reduction to {order} states cannot be trusted: its error reaches {:.6e} on a frequency grid, beyond the bound 2 sum(discarded Hankel singular values) = {:.6e} (on this badly conditioned system the Hankel singular values or the projection lose accuracy); set `allow_degradation` to accept it",
                red.grid_error, red.bound
            )));
        }
        Ok(BalredReport {
            system: red.sys,
            order_before: sys.nx(),
            hsv: red.hsv,
            // Within round-off of the bound when trusted; otherwise the
            // bound is false and the error found is the honest figure.
            bound: if red.trusted {
                red.bound
            } else {
                red.bound.max(red.grid_error)
            },
            trusted: red.trusted,
        })
    }
}

impl Serialize for BalredReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        json!({"order_before": self.order_before, "order": self.system.nx(),
            "hankel_singular_values": self.hsv, "error_bound": self.bound,
            "system": ss_json::ss_to_value(&self.system)})
        .serialize(s)
    }
}

impl fmt::Display for BalredReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "balanced truncation: {} states (from {})",
            self.system.nx(),
            self.order_before
        )?;
        writeln!(f, "Hankel singular values:")?;
        for (k, s) in self.hsv.iter().enumerate() {
            let mark = if k < self.system.nx() {
                "kept"
            } else {
                "discarded"
            };
            writeln!(f, "  {:>3}  {s:.6e}  {mark}", k + 1)?;
        }
        if self.trusted {
            writeln!(
                f,
                "error bound ||G - Gr||_inf <= 2 sum(discarded) = {:.6e}",
                self.bound
            )
        } else {
            writeln!(
                f,
                "warning: untrusted reduction (inaccurate Gramians): ||G - Gr||_inf >= {:.6e} on a frequency grid, beyond 2 sum(discarded)",
                self.bound
            )
        }
    }
}

// ----------------------------------------------------------------- d2c

/// `fts d2c`: the continuous system whose ZOH discretisation is the input.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct D2c {}

/// The continuous system.
#[derive(Debug, Clone)]
pub struct D2cReport {
    /// The continuous system.
    pub system: StateSpace,
    /// Its poles.
    pub poles: Vec<c64>,
    /// The sample time of the input.
    pub ts: f64,
}

impl D2c {
    /// Inverts the ZOH discretisation of `model` (discrete).
    pub fn run(&self, model: &Model, source: &str) -> Result<D2cReport, StepError> {
        let sys = realise(model, source)?;
        let Some(ts) = sys.ts else {
            return Err(StepError::input(format!(
                "{source}: the system is already continuous"
            )));
        };
        let system = convert::d2c(&sys).map_err(conv_err(source))?;
        let poles = system.poles().map_err(ss_err(source))?;
        Ok(D2cReport { system, poles, ts })
    }
}

impl Serialize for D2cReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        json!({"system": ss_json::ss_to_value(&self.system), "poles": complex_pairs(&self.poles),
            "ts": self.ts})
        .serialize(s)
    }
}

impl fmt::Display for D2cReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "continuous system (inverse ZOH of ts = {} s): {} states; poles: {}",
            self.ts,
            self.system.nx(),
            list(&self.poles)
        )
    }
}
