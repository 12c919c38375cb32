//! The real-time controller step of fts: the code a 10 kHz loop runs, and
//! the only code `fts simulate` runs, so simulation and hardware cannot
//! drift apart.
//!
//! `no_std`, dependency-free (even the cube root is its own, [`cbrt`]) and
//! allocation-free: every block keeps its
//! coefficients and state in fixed-capacity arrays filled once by
//! [`RuntimeController::new`] from borrowed slices ([`RuntimeSpec`]);
//! [`RuntimeController::step`] does no allocation, no I/O and no locking.
//! fts's C runtime (`fts_runtime.c`, written by `fts emit --format c`)
//! performs the same floating-point operations in the same order, so a C
//! loop compiled without contraction (`-ffp-contract=off`) gives the same
//! bits as this step on any IEEE-754 double target.
//!
//! Signal order (\[Li21\] Fig. 5), per sample `k`:
//! 1. ZPETC pre-filter: `r_f(k) = (num/den)[r](k + preview)`; the caller
//!    passes the reference `preview` samples ahead;
//! 2. inverse-hysteresis feedforward: `u_ff(k) = Y^-1(r_f(k))` (\[Li21\] Eq. 5);
//! 3. the feedback controller on `e = r_f - x`, added to `u_ff` and clamped:
//!    the PID (derivative on the measurement, conditional-integration
//!    anti-windup, \[Li21\] Eq. 5; optionally with a first-order derivative
//!    filter), or a discrete state-space controller
//!    `v = C x + D e; x <- A x + B e` (an H2 / H-infinity / mixsyn design,
//!    negative feedback `u = u_ff + K e` as for the PID), or none.
//!
//! Without a ZPETC block `r_f = r` and the preview is 0; without a hysteresis
//! block `u_ff = 0`. Without a feedback controller (a feedforward-only
//! controller) the command is the output of the last block present:
//! `u_ff` when there is a hysteresis block, else `r_f`, unclamped.

#![no_std]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

mod contour;
mod dob;
mod repetitive;
pub use contour::{CrossCoupledStep, contour_estimate};
use dob::DobBlock;
pub use dob::{DobSpec, MAX_DOB_DELAY, MAX_DOB_LEN};
use repetitive::RepetitiveBlock;
pub use repetitive::{MAX_LEAD, MAX_PERIOD, MAX_Q_HALF, MAX_RC_PREVIEW, RepetitiveSpec};

/// The cube root, self-contained so that every build of the Rust and the C
/// runtime computes the same bits: the platform's `cbrt` differs between C
/// libraries (and Rust's `f64::cbrt` may resolve to either). FreeBSD's
/// `s_cbrt.c` as in musl (error < 0.667 ulp): a bit-level first guess, a
/// polynomial step to 23 bits, rounding to 32 bits, one Newton step;
/// `fts_cbrt` in `fts_runtime.c` is the same sequence of operations.
pub fn cbrt(x: f64) -> f64 {
    // (1023 - 1023/3 - 0.03306235651) * 2^20, and with 54/3 for subnormals.
    const B1: u32 = 715_094_163;
    const B2: u32 = 696_219_795;
    // |1/cbrt(r) - polynomial| < 2^-23.5 on the guess's range.
    const P0: f64 = f64::from_bits(0x3ffe_03e6_0f61_e692); // 1.87595182427177009643
    const P1: f64 = f64::from_bits(0xbffe_28e0_92f0_2420); // -1.88497979543377169875
    const P2: f64 = f64::from_bits(0x3ff9_f160_4a49_d6c2); // 1.621429720105354466140
    const P3: f64 = f64::from_bits(0xbfe8_44cb_bee7_51d9); // -0.758397934778766047437
    const P4: f64 = f64::from_bits(0x3fc2_b000_d4e4_edd7); // 0.145996192886612446982
    let mut ui = x.to_bits();
    let mut hx = (ui >> 32) as u32 & 0x7fff_ffff;
    if hx >= 0x7ff0_0000 {
        return x + x; // NaN, infinities
    }
    if hx < 0x0010_0000 {
        ui = (x * f64::from_bits(0x4350_0000_0000_0000)).to_bits(); // x 2^54: subnormals
        hx = (ui >> 32) as u32 & 0x7fff_ffff;
        if hx == 0 {
            return x; // +-0
        }
        hx = hx / 3 + B2;
    } else {
        hx = hx / 3 + B1;
    }
    ui &= 1 << 63;
    ui |= u64::from(hx) << 32;
    let mut t = f64::from_bits(ui);
    let r = (t * t) * (t / x);
    t *= (P0 + r * (P1 + r * P2)) + ((r * r) * r) * (P3 + r * P4);
    ui = t.to_bits().wrapping_add(0x8000_0000) & 0xffff_ffff_c000_0000;
    t = f64::from_bits(ui);
    let s = t * t;
    let r = x / s;
    let w = t + t;
    let r = (r - t) / (w + r);
    t + t * r
}

/// Longest polynomial (coefficients) of a filter block.
pub const MAX_FILTER_LEN: usize = 512;
/// Most play operators in a hysteresis block.
pub const MAX_OPERATORS: usize = 64;
/// Most dead-zone operators in a hysteresis block's output stage.
pub const MAX_DEAD_ZONES: usize = 16;
/// Most states of a state-space feedback controller.
pub const MAX_SS_ORDER: usize = 16;

/// Why a specification cannot be loaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RuntimeError {
    /// A coefficient list is empty or longer than the block's capacity.
    BadLength {
        /// The list, e.g. `zpetc.num`.
        field: &'static str,
        /// Its length.
        len: usize,
        /// The capacity.
        max: usize,
    },
    /// A state-space controller has more states than [`MAX_SS_ORDER`].
    OrderTooHigh {
        /// The block, `state_space.a`.
        field: &'static str,
        /// Its order.
        order: usize,
        /// The capacity.
        max: usize,
    },
    /// Two lists that must match in length do not.
    LengthMismatch {
        /// The list that is off.
        field: &'static str,
    },
    /// A coefficient is NaN or infinite.
    NonFinite {
        /// The list or value.
        field: &'static str,
    },
    /// `den[0]` is zero, or limits are not ordered.
    Invalid {
        /// The field.
        field: &'static str,
    },
}

impl core::fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RuntimeError::BadLength { field, len, max } => {
                write!(
                    f,
                    "{field}: {len} coefficients, the runtime takes 1 to {max}"
                )
            }
            RuntimeError::OrderTooHigh { field, order, max } => {
                write!(
                    f,
                    "{field}: {order} states, the runtime takes at most {max} (MAX_SS_ORDER); reduce the controller first (balanced truncation)"
                )
            }
            RuntimeError::LengthMismatch { field } => {
                write!(f, "{field}: length does not match its partner list")
            }
            RuntimeError::NonFinite { field } => write!(f, "{field}: contains a non-finite number"),
            RuntimeError::Invalid { field } => write!(f, "{field}: invalid value"),
        }
    }
}

impl core::error::Error for RuntimeError {}

/// Play operator form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlayForm {
    /// `F(k) = max(u - r, min(u, F(k-1)))` (\[Li21\] Eq. 3).
    Lower,
    /// `F(k) = max(u - r, min(u + r, F(k-1)))` (\[Tang17\] Eq. 37-39).
    Symmetric,
}

/// ZPETC block coefficients (borrowed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZpetcSpec<'a> {
    /// Samples of reference look-ahead.
    pub preview: usize,
    /// Causal numerator, ascending `z^-1`.
    pub num: &'a [f64],
    /// Causal denominator, ascending `z^-1`, `den[0] != 0`.
    pub den: &'a [f64],
}

/// Hysteresis compensation block coefficients (borrowed): a model
/// `Y(u) = offset + c cbrt(x) + Out[sum_i (w_i + w1_i |s|) F_{r_i}[In[x]]] + g s`,
/// `x = u - input_offset`, `Out` and `In` dead-zone stages or the identity, `s(k) = (x(k) - x(k-1)) / (rate_ts rate_scale)`
/// (`x(-1) = 0`; `w1_i`, `g` and `s` absent without rate weights;
/// docs/math.md §1.7), used one of two ways:
/// * `solve: None`: the model is an inverse model, `u_ff = Y(r_f)`;
/// * `solve: Some((lo, hi))`: the model is the forward model and
///   `u_ff` is its root `Y(u_ff) = r_f` on `[lo, hi]` (`hysteresis_solve`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HysteresisSpec<'a> {
    /// Play operator form.
    pub form: PlayForm,
    /// Play thresholds.
    pub thresholds: &'a [f64],
    /// Play weights.
    pub weights: &'a [f64],
    /// Cube-root gain.
    pub cbrt_gain: f64,
    /// Output offset.
    pub offset: f64,
    /// Input offset.
    pub input_offset: f64,
    /// Dead-zone thresholds (empty: no output stage).
    pub dead_zone_thresholds: &'a [f64],
    /// Dead-zone weights.
    pub dead_zone_weights: &'a [f64],
    /// Input dead-zone thresholds (empty: no input stage; the analytic
    /// inverse of an MPI-deadzone model has one).
    pub input_dead_zone_thresholds: &'a [f64],
    /// Input dead-zone weights.
    pub input_dead_zone_weights: &'a [f64],
    /// Rate weights `w1_i`, one per play operator (empty: rate-independent).
    pub rate_weights: &'a [f64],
    /// Sample time of the rate stage, s (unused without rate weights).
    pub rate_ts: f64,
    /// Input rate at which `|s| = 1`, input units per second.
    pub rate_scale: f64,
    /// Velocity gain `g`, output units.
    pub velocity_gain: f64,
    /// `None`: evaluate the model (an inverse model). `Some((lo, hi))`:
    /// invert the (forward) model per sample on the command bracket
    /// `[lo, hi]`, finite with `lo < hi`.
    pub solve: Option<(f64, f64)>,
}

impl HysteresisSpec<'_> {
    /// A rate-independent, directly evaluated block with no operators:
    /// the base for struct-update syntax.
    pub const EMPTY: HysteresisSpec<'static> = HysteresisSpec {
        form: PlayForm::Lower,
        thresholds: &[],
        weights: &[],
        cbrt_gain: 0.0,
        offset: 0.0,
        input_offset: 0.0,
        dead_zone_thresholds: &[],
        dead_zone_weights: &[],
        input_dead_zone_thresholds: &[],
        input_dead_zone_weights: &[],
        rate_weights: &[],
        rate_ts: 0.0,
        rate_scale: 0.0,
        velocity_gain: 0.0,
        solve: None,
    };
}

/// PID block coefficients (\[Li21\] Eq. 5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidSpec {
    /// Proportional gain.
    pub kp: f64,
    /// Integral gain per sample.
    pub ki: f64,
    /// Derivative gain per sample, on the measurement.
    pub kd: f64,
    /// Lowest command.
    pub output_min: f64,
    /// Highest command.
    pub output_max: f64,
}

/// The PID with a first-order filter on its derivative term: the
/// continuous parallel form `C(s) = Kp + Ki/s + Kd N s/(s + N)` by backward
/// Euler, `s = (1 - z^-1)/Ts`, with the derivative on the measurement:
///
/// `d(k) = pole d(k-1) + kd (x(k) - x(k-1))`, `pole = 1/(1 + N Ts)`,
/// `kd = Kd N/(1 + N Ts)`; `I(k) = I(k-1) + ki e(k)`, `ki = Ki Ts`;
/// `u = clamp(u_ff + kp e + I(k) - d(k))` with conditional integration as
/// in [`PidSpec`] (docs/formats.md "PID forms").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidFilteredSpec {
    /// Proportional gain.
    pub kp: f64,
    /// Integral gain per sample (`Ki Ts`).
    pub ki: f64,
    /// Derivative gain per sample on the measurement (`Kd N/(1 + N Ts)`).
    pub kd: f64,
    /// Derivative filter pole `1/(1 + N Ts)`, in `[0, 1)`.
    pub derivative_pole: f64,
    /// Lowest command.
    pub output_min: f64,
    /// Highest command.
    pub output_max: f64,
}

/// What a state-space controller does with its states while the command
/// sits on a limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SsAntiWindup {
    /// Clamp the command only; the states evolve as in the linear
    /// controller (they may wind up while the command is saturated).
    None,
    /// Conditional update, the state-space analogue of conditional
    /// integration: the states are held (`x(k+1) = x(k)`) when the unclamped
    /// command is beyond a limit and the update would move the state part
    /// of the output `C x` further beyond it (`C (x+ - x)` has the sign of
    /// the violation); otherwise `x <- A x + B e`.
    ConditionalUpdate,
}

/// A discrete state-space feedback controller (borrowed), SISO, error in,
/// command out: `v(k) = C x(k) + D e(k)`, `x(k+1) = A x(k) + B e(k)`,
/// `u(k) = clamp(u_ff(k) + v(k), output_min, output_max)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateSpaceSpec<'a> {
    /// `A`, `n x n`, row-major (`n` = `b.len()`, at most [`MAX_SS_ORDER`]).
    pub a: &'a [f64],
    /// `B`, `n x 1`.
    pub b: &'a [f64],
    /// `C`, `1 x n`.
    pub c: &'a [f64],
    /// `D`, the feedthrough.
    pub d: f64,
    /// Lowest command (`-inf`: no lower limit).
    pub output_min: f64,
    /// Highest command (`+inf`: no upper limit).
    pub output_max: f64,
    /// State handling under saturation.
    pub anti_windup: SsAntiWindup,
}

/// The feedback stage: at most one controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FeedbackSpec<'a> {
    /// No feedback controller: a feedforward-only controller, whose command
    /// is the last block's output, unclamped.
    None,
    /// The \[Li21\] Eq. 5 PID.
    Pid(PidSpec),
    /// The PID with a filtered derivative (continuous parallel form,
    /// discretised).
    PidFiltered(PidFilteredSpec),
    /// A discrete state-space controller.
    StateSpace(StateSpaceSpec<'a>),
    /// The filtered PID with a disturbance observer and friction
    /// feedforward (\[Karagoz18\]'s adaptive robust controller, [`DobSpec`]).
    Dob(DobSpec<'a>),
}

impl FeedbackSpec<'_> {
    /// The command limits `(min, max)` (infinite when absent).
    pub fn limits(&self) -> (f64, f64) {
        match self {
            FeedbackSpec::None => (f64::NEG_INFINITY, f64::INFINITY),
            FeedbackSpec::Pid(p) => (p.output_min, p.output_max),
            FeedbackSpec::PidFiltered(p) => (p.output_min, p.output_max),
            FeedbackSpec::StateSpace(s) => (s.output_min, s.output_max),
            FeedbackSpec::Dob(d) => (d.outer.output_min, d.outer.output_max),
        }
    }
}

/// A whole controller (borrowed), blocks in signal order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RuntimeSpec<'a> {
    /// Optional ZPETC pre-filter.
    pub zpetc: Option<ZpetcSpec<'a>>,
    /// Optional inverse-hysteresis feedforward.
    pub hysteresis: Option<HysteresisSpec<'a>>,
    /// The feedback controller.
    pub feedback: FeedbackSpec<'a>,
    /// Optional plug-in repetitive compensator on the tracking error,
    /// added to the loop's reference ([`RepetitiveSpec`]).
    pub repetitive: Option<RepetitiveSpec<'a>>,
}

#[derive(Debug, Clone)]
struct ZpetcBlock {
    preview: usize,
    order: usize,
    b: [f64; MAX_FILTER_LEN],
    a: [f64; MAX_FILTER_LEN],
    state: [f64; MAX_FILTER_LEN],
}

#[derive(Debug, Clone)]
struct HysteresisBlock {
    form: PlayForm,
    n: usize,
    thresholds: [f64; MAX_OPERATORS],
    weights: [f64; MAX_OPERATORS],
    play: [f64; MAX_OPERATORS],
    cbrt_gain: f64,
    offset: f64,
    input_offset: f64,
    output_stage: DeadZoneBank,
    input_stage: DeadZoneBank,
    /// Whether the rate stage is present.
    rate: bool,
    rate_weights: [f64; MAX_OPERATORS],
    /// `rate_ts * rate_scale`, the denominator of `s`.
    rate_denominator: f64,
    velocity_gain: f64,
    /// `x(k-1)`, 0 at rest.
    previous_input: f64,
    /// The command bracket of the per-sample solve, if solving.
    solve: Option<(f64, f64)>,
}

/// A dead-zone stage `sum_j g_j S_{d_j}[v]`; `n == 0` is the identity.
#[derive(Debug, Clone)]
struct DeadZoneBank {
    n: usize,
    thresholds: [f64; MAX_DEAD_ZONES],
    weights: [f64; MAX_DEAD_ZONES],
}

impl DeadZoneBank {
    /// Copies a stage; both lists empty means no stage.
    fn new(
        fields: [&'static str; 2],
        thresholds: &[f64],
        weights: &[f64],
    ) -> Result<Self, RuntimeError> {
        let mut bank = DeadZoneBank {
            n: 0,
            thresholds: [0.0; MAX_DEAD_ZONES],
            weights: [0.0; MAX_DEAD_ZONES],
        };
        if thresholds.is_empty() && weights.is_empty() {
            return Ok(bank);
        }
        bank.n = copy_into(fields[0], thresholds, &mut bank.thresholds)?;
        if copy_into(fields[1], weights, &mut bank.weights)? != bank.n {
            return Err(RuntimeError::LengthMismatch { field: fields[1] });
        }
        Ok(bank)
    }

    /// The stage's output, the same sum as `ident::hysteresis::DeadZoneStage::apply`.
    #[inline]
    fn apply(&self, v: f64) -> f64 {
        if self.n == 0 {
            return v;
        }
        // -0.0 is the additive identity (as in `Iterator::sum`): the sum
        // of one term is that term, signed zero included.
        let mut acc = -0.0;
        for (&d, &g) in self.thresholds[..self.n]
            .iter()
            .zip(&self.weights[..self.n])
        {
            acc += g * dead_zone(d, v);
        }
        acc
    }
}

#[derive(Debug, Clone)]
struct PidBlock {
    spec: PidSpec,
    integral: f64,
    previous_measurement: f64,
    started: bool,
}

#[derive(Debug, Clone)]
struct PidFilteredBlock {
    spec: PidFilteredSpec,
    integral: f64,
    derivative: f64,
    previous_measurement: f64,
    started: bool,
}

#[derive(Debug, Clone)]
pub(crate) struct SsBlock {
    n: usize,
    a: [[f64; MAX_SS_ORDER]; MAX_SS_ORDER],
    b: [f64; MAX_SS_ORDER],
    c: [f64; MAX_SS_ORDER],
    d: f64,
    pub(crate) output_min: f64,
    pub(crate) output_max: f64,
    anti_windup: SsAntiWindup,
    pub(crate) x: [f64; MAX_SS_ORDER],
}

// Fixed capacity, no heap: the state-space variant is large on purpose.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
enum Feedback {
    None,
    Pid(PidBlock),
    PidFiltered(PidFilteredBlock),
    StateSpace(SsBlock),
    Dob(DobBlock),
}

impl PidFilteredBlock {
    /// Checks and loads the filtered PID, at rest.
    fn new(p: &PidFilteredSpec) -> Result<Self, RuntimeError> {
        check_pid([p.kp, p.ki, p.kd], p.output_min, p.output_max)?;
        finite("pid.derivative_pole", p.derivative_pole)?;
        if !(0.0..1.0).contains(&p.derivative_pole) {
            return Err(RuntimeError::Invalid {
                field: "pid.derivative_pole",
            });
        }
        Ok(Self {
            spec: *p,
            integral: 0.0,
            derivative: 0.0,
            previous_measurement: 0.0,
            started: false,
        })
    }

    /// Back to rest.
    fn reset(&mut self) {
        self.integral = 0.0;
        self.derivative = 0.0;
        self.previous_measurement = 0.0;
        self.started = false;
    }
}

impl Feedback {
    /// Checks and loads one feedback controller, at rest.
    fn new(spec: &FeedbackSpec<'_>) -> Result<Self, RuntimeError> {
        Ok(match spec {
            FeedbackSpec::None => Feedback::None,
            FeedbackSpec::Pid(p) => {
                check_pid([p.kp, p.ki, p.kd], p.output_min, p.output_max)?;
                Feedback::Pid(PidBlock {
                    spec: *p,
                    integral: 0.0,
                    previous_measurement: 0.0,
                    started: false,
                })
            }
            FeedbackSpec::PidFiltered(p) => Feedback::PidFiltered(PidFilteredBlock::new(p)?),
            FeedbackSpec::StateSpace(k) => Feedback::StateSpace(ss_block(k)?),
            FeedbackSpec::Dob(d) => Feedback::Dob(DobBlock::new(d)?),
        })
    }

    /// Back to rest: integrator, derivative and states cleared.
    fn reset(&mut self) {
        match self {
            Feedback::None => {}
            Feedback::Pid(p) => {
                p.integral = 0.0;
                p.previous_measurement = 0.0;
                p.started = false;
            }
            Feedback::PidFiltered(p) => p.reset(),
            Feedback::StateSpace(k) => k.x = [0.0; MAX_SS_ORDER],
            Feedback::Dob(d) => d.reset(),
        }
    }

    /// The command limits `(min, max)` (infinite when absent).
    fn limits(&self) -> (f64, f64) {
        match self {
            Feedback::None => (f64::NEG_INFINITY, f64::INFINITY),
            Feedback::Pid(p) => (p.spec.output_min, p.spec.output_max),
            Feedback::PidFiltered(p) => (p.spec.output_min, p.spec.output_max),
            Feedback::StateSpace(k) => (k.output_min, k.output_max),
            Feedback::Dob(d) => d.limits(),
        }
    }

    /// The command actually applied to the plant (a DOB's observer input;
    /// nothing for the other controllers).
    #[inline]
    fn applied(&mut self, command: f64) {
        if let Feedback::Dob(d) = self {
            d.applied(command);
        }
    }

    /// One clamped command `u_ff + K[reference - measurement]` (the PIDs'
    /// derivative on the measurement); `None` without a controller.
    #[inline]
    fn step(&mut self, reference: f64, measurement: f64, feedforward: f64) -> Option<f64> {
        Some(match self {
            Feedback::None => return None,
            Feedback::PidFiltered(p) => pid_filtered_step(p, reference, measurement, feedforward),
            Feedback::Pid(p) => {
                let mut previous = p.started.then_some(p.previous_measurement);
                let command = pid_step(
                    &p.spec,
                    &mut p.integral,
                    &mut previous,
                    reference,
                    measurement,
                    feedforward,
                );
                p.previous_measurement = measurement;
                p.started = true;
                command
            }
            Feedback::StateSpace(k) => ss_step(k, reference - measurement, feedforward),
            Feedback::Dob(d) => d.step(reference, measurement, feedforward),
        })
    }
}

/// A loaded controller with its state.
#[derive(Debug, Clone)]
pub struct RuntimeController {
    zpetc: Option<ZpetcBlock>,
    hysteresis: Option<HysteresisBlock>,
    feedback: Feedback,
    repetitive: Option<RepetitiveBlock>,
}

/// The signals of one step, for traces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepSignals {
    /// The ZPETC-filtered reference `r_f(k)` (the reference without ZPETC).
    pub filtered: f64,
    /// The learning correction added to it: the repetitive output `v(k)`
    /// plus the learned feedforward `f(k)` passed in.
    pub correction: f64,
    /// The inverse-hysteresis feedforward `u_ff(k)`.
    pub feedforward: f64,
    /// The command `u(k)`.
    pub command: f64,
}

fn copy_into<const N: usize>(
    field: &'static str,
    src: &[f64],
    dst: &mut [f64; N],
) -> Result<usize, RuntimeError> {
    if src.is_empty() || src.len() > N {
        return Err(RuntimeError::BadLength {
            field,
            len: src.len(),
            max: N,
        });
    }
    if src.iter().any(|v| !v.is_finite()) {
        return Err(RuntimeError::NonFinite { field });
    }
    dst[..src.len()].copy_from_slice(src);
    Ok(src.len())
}

/// The rate stage of a hysteresis spec: absent (no rate weights) or one
/// finite weight per play operator, positive `rate_ts` and `rate_scale`
/// and a finite velocity gain.
fn rate_stage(
    h: &HysteresisSpec<'_>,
    n: usize,
) -> Result<(bool, [f64; MAX_OPERATORS]), RuntimeError> {
    let mut w = [0.0; MAX_OPERATORS];
    if h.rate_weights.is_empty() {
        return Ok((false, w));
    }
    if copy_into("hysteresis.rate_weights", h.rate_weights, &mut w)? != n {
        return Err(RuntimeError::LengthMismatch {
            field: "hysteresis.rate_weights",
        });
    }
    finite("hysteresis.velocity_gain", h.velocity_gain)?;
    for (field, v) in [
        ("hysteresis.rate_ts", h.rate_ts),
        ("hysteresis.rate_scale", h.rate_scale),
    ] {
        finite(field, v)?;
        if v <= 0.0 {
            return Err(RuntimeError::Invalid { field });
        }
    }
    Ok((true, w))
}

/// A solve bracket must be finite and ordered.
fn solve_bracket(b: Option<(f64, f64)>) -> Result<Option<(f64, f64)>, RuntimeError> {
    match b {
        Some((lo, hi)) => {
            finite("hysteresis.solve", lo)?;
            finite("hysteresis.solve", hi)?;
            if lo < hi {
                Ok(b)
            } else {
                Err(RuntimeError::Invalid {
                    field: "hysteresis.solve",
                })
            }
        }
        None => Ok(None),
    }
}

fn finite(field: &'static str, v: f64) -> Result<(), RuntimeError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(RuntimeError::NonFinite { field })
    }
}

/// Gains `[kp, ki, kd]` finite, limits finite and ordered.
fn check_pid(gains: [f64; 3], output_min: f64, output_max: f64) -> Result<(), RuntimeError> {
    for (field, v) in ["pid.kp", "pid.ki", "pid.kd"].into_iter().zip(gains) {
        finite(field, v)?;
    }
    finite("pid.output_min", output_min)?;
    finite("pid.output_max", output_max)?;
    if output_min >= output_max {
        return Err(RuntimeError::Invalid {
            field: "pid.output_min",
        });
    }
    Ok(())
}

impl RuntimeController {
    /// Copies and checks the coefficients; the controller starts at rest.
    pub fn new(spec: &RuntimeSpec<'_>) -> Result<Self, RuntimeError> {
        let zpetc = match &spec.zpetc {
            None => None,
            Some(z) => {
                let mut num = [0.0; MAX_FILTER_LEN];
                let mut den = [0.0; MAX_FILTER_LEN];
                let nb = copy_into("zpetc.num", z.num, &mut num)?;
                let na = copy_into("zpetc.den", z.den, &mut den)?;
                if den[0] == 0.0 {
                    return Err(RuntimeError::Invalid { field: "zpetc.den" });
                }
                // Normalised by a0 exactly as lti::TdfFilter does.
                let a0 = den[0];
                let order = nb.max(na) - 1;
                let mut b = [0.0; MAX_FILTER_LEN];
                let mut a = [0.0; MAX_FILTER_LEN];
                for i in 0..nb {
                    b[i] = num[i] / a0;
                }
                for i in 0..na {
                    a[i] = den[i] / a0;
                }
                Some(ZpetcBlock {
                    preview: z.preview,
                    order,
                    b,
                    a,
                    state: [0.0; MAX_FILTER_LEN],
                })
            }
        };
        let hysteresis = match &spec.hysteresis {
            None => None,
            Some(h) => {
                let mut thresholds = [0.0; MAX_OPERATORS];
                let mut weights = [0.0; MAX_OPERATORS];
                let n = copy_into("hysteresis.thresholds", h.thresholds, &mut thresholds)?;
                if copy_into("hysteresis.weights", h.weights, &mut weights)? != n {
                    return Err(RuntimeError::LengthMismatch {
                        field: "hysteresis.weights",
                    });
                }
                finite("hysteresis.cbrt_gain", h.cbrt_gain)?;
                finite("hysteresis.offset", h.offset)?;
                finite("hysteresis.input_offset", h.input_offset)?;
                let output_stage = DeadZoneBank::new(
                    [
                        "hysteresis.dead_zone.thresholds",
                        "hysteresis.dead_zone.weights",
                    ],
                    h.dead_zone_thresholds,
                    h.dead_zone_weights,
                )?;
                let input_stage = DeadZoneBank::new(
                    [
                        "hysteresis.input_dead_zone.thresholds",
                        "hysteresis.input_dead_zone.weights",
                    ],
                    h.input_dead_zone_thresholds,
                    h.input_dead_zone_weights,
                )?;
                let (rate, rate_weights) = rate_stage(h, n)?;
                Some(HysteresisBlock {
                    form: h.form,
                    n,
                    thresholds,
                    weights,
                    play: [0.0; MAX_OPERATORS],
                    cbrt_gain: h.cbrt_gain,
                    offset: h.offset,
                    input_offset: h.input_offset,
                    output_stage,
                    input_stage,
                    rate,
                    rate_weights,
                    rate_denominator: h.rate_ts * h.rate_scale,
                    velocity_gain: h.velocity_gain,
                    previous_input: 0.0,
                    solve: solve_bracket(h.solve)?,
                })
            }
        };
        let feedback = Feedback::new(&spec.feedback)?;
        let preview = spec.zpetc.map_or(0, |z| z.preview);
        let repetitive = match &spec.repetitive {
            None => None,
            Some(r) => Some(RepetitiveBlock::new(r, preview)?),
        };
        Ok(Self {
            zpetc,
            hysteresis,
            feedback,
            repetitive,
        })
    }

    /// Samples of reference look-ahead the caller must supply.
    pub fn preview(&self) -> usize {
        self.zpetc.as_ref().map_or(0, |z| z.preview)
    }

    /// Back to rest (filter, operators and integrator cleared).
    pub fn reset(&mut self) {
        if let Some(z) = &mut self.zpetc {
            z.state = [0.0; MAX_FILTER_LEN];
        }
        if let Some(h) = &mut self.hysteresis {
            h.play = [0.0; MAX_OPERATORS];
            h.previous_input = 0.0;
        }
        self.feedback.reset();
        if let Some(r) = &mut self.repetitive {
            r.reset();
        }
    }

    /// The command limits `(min, max)` of the feedback stage (infinite when absent).
    pub fn limits(&self) -> (f64, f64) {
        self.feedback.limits()
    }

    /// One command. `reference_ahead` is `r(k + preview())`; `measurement`
    /// is `x(k)`. Returns the command `u(k)` within the feedback stage's
    /// limits (without a feedback stage: the last block's output).
    #[inline]
    pub fn step(&mut self, reference_ahead: f64, measurement: f64) -> f64 {
        self.step_traced(reference_ahead, measurement).2
    }

    /// One step with the intermediate signals, for traces: `(r_f + c, u_ff, u)`
    /// with `c` the repetitive correction (0 without that block).
    #[inline]
    pub fn step_traced(&mut self, reference_ahead: f64, measurement: f64) -> (f64, f64, f64) {
        let s = self.step_signals(reference_ahead, measurement, 0.0);
        (s.filtered + s.correction, s.feedforward, s.command)
    }

    /// One step with a learned feedforward sample `learned = f(k)` (an
    /// iterative-learning table played back by [`FeedforwardTable`]; 0
    /// without one) added, with the repetitive output, to the filtered
    /// reference ahead of the inverse hysteresis and the feedback
    /// controller: the loop follows `r_f(k) + v(k) + f(k)`.
    #[inline]
    pub fn step_signals(
        &mut self,
        reference_ahead: f64,
        measurement: f64,
        learned: f64,
    ) -> StepSignals {
        let filtered = match &mut self.zpetc {
            Some(z) => tdf2_step(z, reference_ahead),
            None => reference_ahead,
        };
        let preview = self.zpetc.as_ref().map_or(0, |z| z.preview);
        let repetitive = match &mut self.repetitive {
            Some(r) => {
                let reference = r.delayed_reference(reference_ahead, preview);
                r.step(reference - measurement)
            }
            None => 0.0,
        };
        let correction = repetitive + learned;
        let loop_reference = filtered + correction;
        let feedforward = match &mut self.hysteresis {
            Some(h) => hysteresis_step(h, loop_reference),
            None => 0.0,
        };
        let command = match self.feedback.step(loop_reference, measurement, feedforward) {
            Some(command) => command,
            None if self.hysteresis.is_some() => feedforward,
            None => loop_reference,
        };
        StepSignals {
            filtered,
            correction,
            feedforward,
            command,
        }
    }
}

/// A learned feedforward table played back one sample per step (an
/// iterative-learning result, `fts ilc`): `next()` returns `f(k)` for the
/// `k`-th call, then 0 past the end. The samples are the caller's (a
/// `static` array in flash on a target), so the table has no capacity limit
/// and the player neither copies nor allocates.
#[derive(Debug, Clone)]
pub struct FeedforwardTable<'a> {
    samples: &'a [f64],
    next: usize,
}

impl<'a> FeedforwardTable<'a> {
    /// A player at the table's start; refuses an empty or non-finite table.
    pub fn new(samples: &'a [f64]) -> Result<Self, RuntimeError> {
        if samples.is_empty() {
            return Err(RuntimeError::BadLength {
                field: "feedforward_table.samples",
                len: 0,
                max: usize::MAX,
            });
        }
        if samples.iter().any(|v| !v.is_finite()) {
            return Err(RuntimeError::NonFinite {
                field: "feedforward_table.samples",
            });
        }
        Ok(Self { samples, next: 0 })
    }

    /// The next sample, 0 once the table is exhausted.
    #[inline]
    pub fn next_sample(&mut self) -> f64 {
        match self.samples.get(self.next) {
            Some(&v) => {
                self.next += 1;
                v
            }
            None => 0.0,
        }
    }

    /// Back to the first sample.
    pub fn rewind(&mut self) {
        self.next = 0;
    }

    /// Samples in the table.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Never true: an empty table is refused by [`FeedforwardTable::new`].
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }
}

pub(crate) fn ss_block(k: &StateSpaceSpec<'_>) -> Result<SsBlock, RuntimeError> {
    let n = k.b.len();
    if n > MAX_SS_ORDER {
        return Err(RuntimeError::OrderTooHigh {
            field: "state_space.a",
            order: n,
            max: MAX_SS_ORDER,
        });
    }
    if k.a.len() != n * n {
        return Err(RuntimeError::LengthMismatch {
            field: "state_space.a",
        });
    }
    if k.c.len() != n {
        return Err(RuntimeError::LengthMismatch {
            field: "state_space.c",
        });
    }
    for (field, v) in [
        ("state_space.a", k.a),
        ("state_space.b", k.b),
        ("state_space.c", k.c),
        ("state_space.d", core::slice::from_ref(&k.d)),
    ] {
        if v.iter().any(|x| !x.is_finite()) {
            return Err(RuntimeError::NonFinite { field });
        }
    }
    // Infinite limits mean "no limit"; NaN is refused.
    if k.output_min.is_nan() || k.output_min == f64::INFINITY {
        return Err(RuntimeError::NonFinite {
            field: "state_space.output_min",
        });
    }
    if k.output_max.is_nan() || k.output_max == f64::NEG_INFINITY {
        return Err(RuntimeError::NonFinite {
            field: "state_space.output_max",
        });
    }
    if k.output_min >= k.output_max {
        return Err(RuntimeError::Invalid {
            field: "state_space.output_min",
        });
    }
    let mut block = SsBlock {
        n,
        a: [[0.0; MAX_SS_ORDER]; MAX_SS_ORDER],
        b: [0.0; MAX_SS_ORDER],
        c: [0.0; MAX_SS_ORDER],
        d: k.d,
        output_min: k.output_min,
        output_max: k.output_max,
        anti_windup: k.anti_windup,
        x: [0.0; MAX_SS_ORDER],
    };
    for i in 0..n {
        block.a[i][..n].copy_from_slice(&k.a[i * n..(i + 1) * n]);
    }
    block.b[..n].copy_from_slice(k.b);
    block.c[..n].copy_from_slice(k.c);
    Ok(block)
}

/// One state-space controller step: `v = C x + D e` from the states before
/// the update, then `x <- A x + B e` (unless held by the conditional
/// update). Sums run in index order, `C x` first and `D e` last, and
/// `A x` row by row with `B e` added last; [`ss_reference_step`] documents
/// the same order for independent implementations.
#[inline]
pub(crate) fn ss_step(k: &mut SsBlock, error: f64, feedforward: f64) -> f64 {
    let n = k.n;
    // The states before the update, copied whole (a fixed-size copy is
    // inlined; the update then writes `k.x` in place, and no freshly
    // written buffer is read back, which would stall store forwarding).
    let before = k.x;
    let x = &before[..n];
    let mut cx = 0.0;
    for (cj, xj) in k.c[..n].iter().zip(x) {
        cx += cj * xj;
    }
    let unclamped = feedforward + (cx + k.d * error);
    let command = unclamped.clamp(k.output_min, k.output_max);
    for ((xi, row), bi) in k.x[..n].iter_mut().zip(&k.a[..n]).zip(&k.b[..n]) {
        let mut acc = 0.0;
        for (aij, xj) in row[..n].iter().zip(x) {
            acc += aij * xj;
        }
        *xi = acc + bi * error;
    }
    // The held-state test costs a dot product only while saturated.
    let hold = k.anti_windup == SsAntiWindup::ConditionalUpdate
        && (unclamped > k.output_max || unclamped < k.output_min)
        && {
            let mut cnext = 0.0;
            for (ci, xi) in k.c[..n].iter().zip(&k.x[..n]) {
                cnext += ci * xi;
            }
            (unclamped > k.output_max && cnext > cx) || (unclamped < k.output_min && cnext < cx)
        };
    if hold {
        k.x = before;
    }
    command
}

/// The state-space step's arithmetic on plain slices (`a` row-major), for
/// tests and for anyone re-implementing the loop: returns the unclamped
/// `u_ff + (C x + D e)` and overwrites `x` with `A x + B e`, summing in the
/// same order as the runtime, so that the results are bit-identical to the
/// runtime's whenever the command is not saturated.
pub fn ss_reference_step(
    a: &[f64],
    b: &[f64],
    c: &[f64],
    d: f64,
    x: &mut [f64],
    error: f64,
    feedforward: f64,
) -> f64 {
    let n = b.len();
    assert!(n <= MAX_SS_ORDER && a.len() == n * n && c.len() == n && x.len() == n);
    let mut cx = 0.0;
    for (cj, xj) in c.iter().zip(x.iter()) {
        cx += cj * xj;
    }
    let v = feedforward + (cx + d * error);
    let mut next = [0.0; MAX_SS_ORDER];
    for (i, (xi, bi)) in next[..n].iter_mut().zip(b).enumerate() {
        let mut acc = 0.0;
        for (aij, xj) in a[i * n..(i + 1) * n].iter().zip(x.iter()) {
            acc += aij * xj;
        }
        *xi = acc + bi * error;
    }
    x.copy_from_slice(&next[..n]);
    v
}

/// Transposed direct form II, the same arithmetic as `lti::TdfFilter::step`.
#[inline]
fn tdf2_step(z: &mut ZpetcBlock, x: f64) -> f64 {
    tdf2(z.order, &z.b, &z.a, &mut z.state, x)
}

/// One sample of `B(z^-1)/A(z^-1)` (`a[0] = 1`, order `n`) in transposed
/// direct form II; the ZPETC block and the DOB's filters share it, so both
/// run the same arithmetic as the C twin.
#[inline]
pub(crate) fn tdf2(n: usize, b: &[f64], a: &[f64], state: &mut [f64], x: f64) -> f64 {
    if n == 0 {
        return b[0] * x;
    }
    let y = b[0] * x + state[0];
    for i in 0..n - 1 {
        state[i] = b[i + 1] * x + state[i + 1] - a[i + 1] * y;
    }
    state[n - 1] = b[n] * x - a[n] * y;
    y
}

/// The hysteresis block's step: the model evaluated at `u`
/// (`solve: None`) or inverted at `u` (`hysteresis_solve`); the play
/// states and `x(k-1)` advance to the input used.
#[inline]
fn hysteresis_step(h: &mut HysteresisBlock, u: f64) -> f64 {
    let mut next = [0.0; MAX_OPERATORS];
    let (input, output) = match h.solve {
        None => (u, hysteresis_eval(h, u, &mut next)),
        Some((lo, hi)) => {
            let root = hysteresis_solve(h, u, lo, hi);
            hysteresis_eval(h, root, &mut next);
            (root, root)
        }
    };
    let n = h.n;
    h.play[..n].copy_from_slice(&next[..n]);
    h.previous_input = input - h.input_offset;
    output
}

/// The model `Y(u)` from the block's current state, the same arithmetic as
/// `ident::hysteresis::HysteresisModel::step`; the play outputs at `u` go
/// to `next`, the block is not changed (a trial evaluation).
#[inline]
fn hysteresis_eval(h: &HysteresisBlock, u: f64, next: &mut [f64; MAX_OPERATORS]) -> f64 {
    let x = u - h.input_offset;
    let z = h.input_stage.apply(x);
    let mut v = 0.0;
    let n = h.n;
    // One loop per form keeps the branch out of the operator loop.
    match h.form {
        PlayForm::Lower => {
            for (((s, &p), &r), &w) in next[..n]
                .iter_mut()
                .zip(&h.play[..n])
                .zip(&h.thresholds[..n])
                .zip(&h.weights[..n])
            {
                *s = play(z + 0.0, z - r, p);
                v += w * *s;
            }
        }
        PlayForm::Symmetric => {
            for (((s, &p), &r), &w) in next[..n]
                .iter_mut()
                .zip(&h.play[..n])
                .zip(&h.thresholds[..n])
                .zip(&h.weights[..n])
            {
                *s = play(z + r, z - r, p);
                v += w * *s;
            }
        }
    }
    let mut sigma = 0.0;
    if h.rate {
        // docs/math.md §1.7: s(k) = (x(k) - x(k-1)) / (ts rate_scale); the
        // rate part of the weights, summed after the static part.
        sigma = (x - h.previous_input) / h.rate_denominator;
        let rho = fabs(sigma);
        for (s, &w1) in next[..n].iter().zip(&h.rate_weights[..n]) {
            v += w1 * rho * *s;
        }
    }
    let out = h.output_stage.apply(v);
    if h.rate {
        h.offset + h.cbrt_gain * cbrt(x) + out + h.velocity_gain * sigma
    } else {
        h.offset + h.cbrt_gain * cbrt(x) + out
    }
}

/// `|x|` by clearing the sign bit (`f64::abs` needs `std`; C `fabs`).
#[inline(always)]
fn fabs(x: f64) -> f64 {
    f64::from_bits(x.to_bits() & !(1u64 << 63))
}

/// Most steps of one `hysteresis_solve` after the evaluations at the
/// bracket ends. A bisection step halves the bracket, so about 60 of them
/// take a command range of ~100 V to the resolution of a double; the
/// Illinois steps converge superlinearly on the piecewise-smooth `Y`
/// (tens of steps at most in the tests). The bound keeps the step's
/// worst-case time fixed.
pub const MAX_SOLVE_ITERATIONS: usize = 100;

/// Per-sample inversion of the forward model (docs/math.md §1.6): the
/// command `u` in `[lo, hi]` with `Y(u; F(k-1), x(k-1)) = target`.
///
/// Every trial is `hysteresis_eval` from the committed state (each play's
/// trial output is `play(x ± r, F_i(k-1))`), so trials do not move the
/// state. For a PI on the lower or symmetric play with `r_0 = 0`,
/// `w_0 > 0` and positive partial sums `W_j = w_0 + .. + w_j`, `c >= 0`,
/// and (MPI-deadzone) positive dead-zone partial sums, `Y` is strictly
/// increasing in `u` from any state: the plays that move when `u` moves
/// away from `x(k-1)` are a prefix `0..=j` of the threshold order, so the
/// slope of the play sum is some `W_j >= w_0 > 0` (and the dead-zone
/// stage's slope a positive prefix sum of its weights), while `c cbrt` is
/// non-decreasing. The root is then unique. With rate weights the slope
/// gains `sign(s) w1_i F_i / (ts rate_scale) + g / (ts rate_scale)`,
/// which need not be positive; the solve still returns a root of the
/// bracket (docs/math.md §1.7 for what the identified models do).
///
/// Illinois regula falsi (the retained end's residual halved when the same
/// end is kept twice), a bisection whenever the secant point is not
/// strictly inside the bracket, at most [`MAX_SOLVE_ITERATIONS`] steps,
/// stopping when the residual is within `8 eps max(|Y(lo)|, |Y(hi)|)` or
/// the bracket is two adjacent doubles. When `target` is outside
/// `(Y(lo), Y(hi))` (or NaN) the result is the end that is closer: it
/// saturates at `lo` or `hi` and is never NaN.
fn hysteresis_solve(h: &HysteresisBlock, target: f64, lo: f64, hi: f64) -> f64 {
    let mut trial = [0.0; MAX_OPERATORS];
    let y_lo = hysteresis_eval(h, lo, &mut trial);
    let mut f_a = y_lo - target;
    // NaN compares as neither: saturate.
    if f_a.partial_cmp(&0.0) != Some(core::cmp::Ordering::Less) {
        return lo;
    }
    let y_hi = hysteresis_eval(h, hi, &mut trial);
    let mut f_b = y_hi - target;
    if f_b.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
        return hi;
    }
    let scale = if fabs(y_lo) > fabs(y_hi) {
        fabs(y_lo)
    } else {
        fabs(y_hi)
    };
    let tolerance = 8.0 * f64::EPSILON * scale;
    let (mut a, mut b) = (lo, hi);
    // -1: `a` was kept last time, 1: `b`, 0: neither yet.
    let mut kept = 0i32;
    for _ in 0..MAX_SOLVE_ITERATIONS {
        let mut x = (a * f_b - b * f_a) / (f_b - f_a);
        if !(x > a && x < b) {
            x = a + 0.5 * (b - a);
            if !(x > a && x < b) {
                break;
            }
        }
        let f_x = hysteresis_eval(h, x, &mut trial) - target;
        if fabs(f_x) <= tolerance {
            return x;
        }
        if f_x < 0.0 {
            a = x;
            f_a = f_x;
            if kept == 1 {
                f_b *= 0.5;
            }
            kept = 1;
        } else {
            b = x;
            f_b = f_x;
            if kept == -1 {
                f_a *= 0.5;
            }
            kept = -1;
        }
    }
    // Bracket exhausted: the end with the smaller (true) residual.
    let r_a = fabs(hysteresis_eval(h, a, &mut trial) - target);
    let r_b = fabs(hysteresis_eval(h, b, &mut trial) - target);
    if r_a <= r_b { a } else { b }
}

/// One play-operator update `max(lower, min(upper, previous))`, written with
/// the same comparisons as `ident::hysteresis::PlayOperator::step` so that
/// both give the same bits (signed zeros included).
#[inline(always)]
fn play(upper: f64, lower: f64, previous: f64) -> f64 {
    let clipped = if upper < previous { upper } else { previous };
    if lower > clipped { lower } else { clipped }
}

/// `S_d[v] = max(v - d, 0)` for `d != 0`, `S_0[v] = v` (\[Tang17\] Eq. 41);
/// `ident::hysteresis::dead_zone` is this function. A plain comparison
/// rather than `f64::max`, whose result for `max(-0.0, 0.0)` is not
/// specified: here it is `+0.0`, as in the C runtime.
#[inline]
pub fn dead_zone(d: f64, v: f64) -> f64 {
    if d == 0.0 {
        v
    } else {
        let t = v - d;
        if t > 0.0 { t } else { 0.0 }
    }
}

/// The filtered-derivative PID step ([`PidFilteredSpec`]): the same
/// operation order as [`pid_step`], the derivative term through its pole.
#[inline]
fn pid_filtered_step(
    p: &mut PidFilteredBlock,
    reference: f64,
    measurement: f64,
    feedforward: f64,
) -> f64 {
    let spec = &p.spec;
    let error = reference - measurement;
    let previous = if p.started {
        p.previous_measurement
    } else {
        measurement
    };
    let derivative = spec.derivative_pole * p.derivative + spec.kd * (measurement - previous);
    p.derivative = derivative;
    p.previous_measurement = measurement;
    p.started = true;
    let candidate = p.integral + spec.ki * error;
    let unclamped = feedforward + spec.kp * error + candidate - derivative;
    let command = unclamped.clamp(spec.output_min, spec.output_max);
    let winding_up = (unclamped > spec.output_max && error > 0.0)
        || (unclamped < spec.output_min && error < 0.0);
    if !winding_up {
        p.integral = candidate;
    }
    command
}

/// The \[Li21\] Eq. 5 PID step with conditional-integration anti-windup.
/// `synth::pid::Li21Pid` calls this same function.
#[inline]
pub fn pid_step(
    spec: &PidSpec,
    integral: &mut f64,
    previous_measurement: &mut Option<f64>,
    reference: f64,
    measurement: f64,
    feedforward: f64,
) -> f64 {
    let error = reference - measurement;
    // The first sample has no previous measurement: no derivative kick.
    let derivative = measurement - previous_measurement.unwrap_or(measurement);
    *previous_measurement = Some(measurement);
    let candidate = *integral + spec.ki * error;
    let unclamped = feedforward + spec.kp * error + candidate - spec.kd * derivative;
    let command = unclamped.clamp(spec.output_min, spec.output_max);
    // Keep the new integral unless saturated with the error pushing further out.
    let winding_up = (unclamped > spec.output_max && error > 0.0)
        || (unclamped < spec.output_min && error < 0.0);
    if !winding_up {
        *integral = candidate;
    }
    command
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;
    use std::vec;

    const PID: PidSpec = PidSpec {
        kp: 0.1,
        ki: 0.3,
        kd: 0.05,
        output_min: 0.0,
        output_max: 10.0,
    };

    #[test]
    fn cbrt_is_within_one_ulp_of_the_cube_root_and_exact_on_cubes() {
        let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..200_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            // Any finite double, subnormals included.
            let x = f64::from_bits(seed & !(0x7ff << 52) | ((seed >> 20) % 0x7ff) << 52);
            let c = cbrt(x);
            // c^3 rounds back near x: |c^3 - x| within 3 ulp of x (c within 1 ulp).
            let back = c * c * c;
            assert!(
                (back - x).abs() <= 4.0 * f64::EPSILON * x.abs() + f64::from_bits(1) * 8.0,
                "{x:e}: {c:e}"
            );
        }
        for k in -30..=30 {
            let v = f64::from(k);
            assert_eq!(cbrt(v * v * v), v);
        }
        assert!(cbrt(f64::NAN).is_nan());
        assert_eq!(cbrt(f64::NEG_INFINITY), f64::NEG_INFINITY);
        assert!(cbrt(-0.0).is_sign_negative() && cbrt(-0.0) == 0.0);
    }

    #[test]
    fn rejects_bad_specs() {
        let long = [1.0; MAX_FILTER_LEN + 1];
        let spec = RuntimeSpec {
            zpetc: Some(ZpetcSpec {
                preview: 1,
                num: &long,
                den: &[1.0],
            }),
            hysteresis: None,
            feedback: FeedbackSpec::Pid(PID),
            repetitive: None,
        };
        assert!(matches!(
            RuntimeController::new(&spec),
            Err(RuntimeError::BadLength {
                field: "zpetc.num",
                ..
            })
        ));
        let spec = RuntimeSpec {
            zpetc: Some(ZpetcSpec {
                preview: 1,
                num: &[1.0],
                den: &[0.0, 1.0],
            }),
            hysteresis: None,
            feedback: FeedbackSpec::Pid(PID),
            repetitive: None,
        };
        assert!(matches!(
            RuntimeController::new(&spec),
            Err(RuntimeError::Invalid { field: "zpetc.den" })
        ));
        let spec = RuntimeSpec {
            zpetc: None,
            hysteresis: Some(HysteresisSpec {
                form: PlayForm::Lower,
                thresholds: &[0.0, 1.0],
                weights: &[1.0],
                cbrt_gain: 0.0,
                offset: 0.0,
                input_offset: 0.0,
                dead_zone_thresholds: &[],
                dead_zone_weights: &[],
                ..HysteresisSpec::EMPTY
            }),
            feedback: FeedbackSpec::Pid(PID),
            repetitive: None,
        };
        assert!(matches!(
            RuntimeController::new(&spec),
            Err(RuntimeError::LengthMismatch {
                field: "hysteresis.weights"
            })
        ));
        let spec = RuntimeSpec {
            zpetc: None,
            hysteresis: None,
            feedback: FeedbackSpec::Pid(PidSpec {
                kp: f64::NAN,
                ..PID
            }),
            repetitive: None,
        };
        assert!(matches!(
            RuntimeController::new(&spec),
            Err(RuntimeError::NonFinite { field: "pid.kp" })
        ));
    }

    fn ss_spec<'a>(a: &'a [f64], b: &'a [f64], c: &'a [f64]) -> RuntimeSpec<'a> {
        RuntimeSpec {
            zpetc: None,
            hysteresis: None,
            feedback: FeedbackSpec::StateSpace(StateSpaceSpec {
                a,
                b,
                c,
                d: 0.5,
                output_min: f64::NEG_INFINITY,
                output_max: f64::INFINITY,
                anti_windup: SsAntiWindup::ConditionalUpdate,
            }),
            repetitive: None,
        }
    }

    #[test]
    fn state_space_rejects_bad_specs() {
        let big = vec![0.0; (MAX_SS_ORDER + 1) * (MAX_SS_ORDER + 1)];
        let b = vec![1.0; MAX_SS_ORDER + 1];
        let e = RuntimeController::new(&ss_spec(&big, &b, &b)).unwrap_err();
        assert!(matches!(e, RuntimeError::OrderTooHigh { order: 17, .. }));
        assert!(e.to_string().contains("MAX_SS_ORDER"), "{e}");
        let e = RuntimeController::new(&ss_spec(&[1.0, 0.0, 0.0], &[1.0, 1.0], &[1.0, 1.0]))
            .unwrap_err();
        assert_eq!(
            e,
            RuntimeError::LengthMismatch {
                field: "state_space.a"
            }
        );
        let e = RuntimeController::new(&ss_spec(&[0.5], &[1.0], &[f64::NAN])).unwrap_err();
        assert_eq!(
            e,
            RuntimeError::NonFinite {
                field: "state_space.c"
            }
        );
    }

    #[test]
    fn state_space_step_matches_reference_and_holds_states_when_saturated() {
        let a = [0.9, 0.1, -0.2, 0.7];
        let (b, c) = ([1.0, 0.5], [0.3, -0.1]);
        let mut rt = RuntimeController::new(&ss_spec(&a, &b, &c)).unwrap();
        let mut x = [0.0; 2];
        for k in 0..500 {
            let r = (k as f64 * 0.05).sin();
            let u = rt.step(r, 0.1);
            let v = ss_reference_step(&a, &b, &c, 0.5, &mut x, r - 0.1, 0.0);
            assert_eq!(u.to_bits(), v.to_bits());
        }
        // An integrator K = 1/(z - 1) saturating at 1: conditional update
        // holds the state at the limit, plain clamping winds it up.
        let run = |aw: SsAntiWindup| {
            let spec = RuntimeSpec {
                zpetc: None,
                hysteresis: None,
                feedback: FeedbackSpec::StateSpace(StateSpaceSpec {
                    a: &[1.0],
                    b: &[1.0],
                    c: &[1.0],
                    d: 0.0,
                    output_min: -1.0,
                    output_max: 1.0,
                    anti_windup: aw,
                }),
                repetitive: None,
            };
            let mut rt = RuntimeController::new(&spec).unwrap();
            for _ in 0..100 {
                assert!(rt.step(1.0, 0.0) <= 1.0);
            }
            // The error reverses: how long until the command leaves the limit?
            (0..1000).position(|_| rt.step(-1.0, 0.0) < 1.0).unwrap()
        };
        assert!(run(SsAntiWindup::ConditionalUpdate) <= 2);
        assert!(run(SsAntiWindup::None) >= 90);
    }
}
