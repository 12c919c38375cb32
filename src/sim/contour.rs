//! Multi-axis contouring simulation with cross-coupled control
//! (\[Karagoz18\], docs/contouring.md): three axes, each a discrete plant
//! under its own feedback controller, following a [`Trajectory`]; a sum of
//! sines added at each plant output; the contour-error estimate
//! `eps = e - (e . t) t` through its own controller (one per component) and
//! added to each axis's command on top of the axis controller.
//!
//! Per sample `k` (the controller reads before it commands, so the plants
//! must be strictly proper):
//! `y_i = C_i x_i + d_i(kT)`, `e = R - y`, `eps = e - (e . t) t`,
//! `u_i = K_i[e_i] + K_cc[eps_i]`, `x_i <- A_i x_i + B_i u_i`. The
//! controllers run in the runtime's allocation-free
//! [`crate::runtime::CrossCoupledStep`], the code a real-time loop would run.
//!
//! With friction ([`Friction`]) the plant receives
//! `u_i - Fc sign(v_i) - Fv v_i`, `v_i` the backward difference of the
//! plant's own output over the last sample. A DOB axis ([`DobAxis`],
//! `synth::dob`) is the PID's Tustin block inside a disturbance observer.
//!
//! Nothing is stored per sample but a thinned trace for plots: the metrics
//! accumulate on the fly, so a 1 MHz loop over seconds needs little memory.

use super::disturbance::Sine;
use super::path::{Trajectory, Vec3, contour_estimate, length};
use crate::io::controller_file::{
    DobBlock, Feedback, MultiAxisControllerFile, Provenance, StateSpaceBlock, Units,
};
use crate::lti::c2d::{C2dMethod, c2d};
use crate::lti::ss::StateSpace;
use crate::runtime::{FeedbackSpec, SsAntiWindup};
use crate::synth::pid::{Discretization, ParallelPid};
use std::f64::consts::PI;

/// The three axes' names, in order.
pub const AXES: [&str; 3] = ["x", "y", "z"];

/// A discrete SISO state-space block stepped in place (no allocation per step).
#[derive(Debug, Clone)]
pub struct SisoBlock {
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    d: f64,
    x: Vec<f64>,
    next: Vec<f64>,
}

impl SisoBlock {
    /// A block at rest; `sys` must be discrete and SISO.
    pub fn new(sys: &StateSpace) -> Result<Self, String> {
        if sys.nu() != 1 || sys.ny() != 1 {
            return Err(format!(
                "expected one input and one output, got {} outputs x {} inputs",
                sys.ny(),
                sys.nu()
            ));
        }
        if !sys.is_discrete() {
            return Err("expected a discrete system".into());
        }
        let n = sys.nx();
        Ok(Self {
            a: (0..n * n).map(|k| sys.a[(k / n, k % n)]).collect(),
            b: (0..n).map(|i| sys.b[(i, 0)]).collect(),
            c: (0..n).map(|j| sys.c[(0, j)]).collect(),
            d: sys.d[(0, 0)],
            x: vec![0.0; n],
            next: vec![0.0; n],
        })
    }

    /// Its feedthrough `D`.
    pub fn feedthrough(&self) -> f64 {
        self.d
    }

    /// `y = C x + D u`.
    #[inline]
    pub fn output(&self, u: f64) -> f64 {
        self.c.iter().zip(&self.x).map(|(c, x)| c * x).sum::<f64>() + self.d * u
    }

    /// `x <- A x + B u`.
    #[inline]
    pub fn update(&mut self, u: f64) {
        let n = self.x.len();
        for i in 0..n {
            let row = &self.a[i * n..(i + 1) * n];
            self.next[i] = row.iter().zip(&self.x).map(|(a, x)| a * x).sum::<f64>() + self.b[i] * u;
        }
        std::mem::swap(&mut self.x, &mut self.next);
    }

    /// Output, then update: one sample.
    #[inline]
    pub fn step(&mut self, u: f64) -> f64 {
        let y = self.output(u);
        self.update(u);
        y
    }
}

/// Why a loop cannot be set up or run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContourError {
    /// A plant or controller does not fit the loop (the message says which).
    #[error("{0}")]
    Setup(String),
    /// An axis's own closed loop is unstable at this sample time.
    #[error(
        "axis {axis}: the closed loop of its plant and controller is unstable at ts = {ts} s (largest pole |z| = {radius:.9}); a shorter sample time or other gains are needed"
    )]
    Unstable {
        /// `x`, `y` or `z`.
        axis: &'static str,
        /// Sample time, s.
        ts: f64,
        /// Largest closed-loop pole modulus.
        radius: f64,
    },
    /// The run left the finite world (or grew past any sensible bound).
    #[error("the multi-axis loop diverged at t = {time_s:.6} s: axis {axis} output = {value:e}")]
    Diverged {
        /// Time, s.
        time_s: f64,
        /// Axis.
        axis: &'static str,
        /// Its output there.
        value: f64,
    },
}

/// A controller before discretisation.
#[derive(Debug, Clone, PartialEq)]
pub enum AxisController {
    /// `P + I/s + D N s/(s + N)` (\[Karagoz18\] Table 2), Tustin.
    Pid(ParallelPid),
    /// A state-space controller (`u = K e`); continuous ones by Tustin.
    StateSpace(Box<StateSpace>),
    /// The PID with a disturbance observer and friction feedforward
    /// (\[Karagoz18\]'s adaptive robust controller, `synth::dob`).
    Dob(Box<DobAxis>),
    /// A block of a controller file, discrete at `ts` (which must be the
    /// loop's) and run as written (limits included).
    Block {
        /// The block.
        feedback: Box<Feedback>,
        /// Its file's sample time, s.
        ts: f64,
    },
}

/// A DOB axis controller before discretisation.
#[derive(Debug, Clone, PartialEq)]
pub struct DobAxis {
    /// The outer PID `P + I/s + D N s/(s + N)` (backward Euler).
    pub pid: ParallelPid,
    /// The nominal plant (continuous: ZOH at the loop's `ts`).
    pub nominal: StateSpace,
    /// `Q` cut-off, Hz.
    pub q_hz: f64,
    /// `Q` order.
    pub q_order: usize,
    /// Coulomb friction feedforward, command units.
    pub coulomb: f64,
    /// Viscous friction feedforward, command per um/s.
    pub viscous: f64,
    /// Smoothing velocity of the sign, um/s.
    pub smoothing: f64,
}

/// Coulomb and viscous friction at a plant's input:
/// `u_eff = u - Fc sign(v) - Fv v`, `v` the axis velocity.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Friction {
    /// `Fc`, command units.
    pub coulomb: f64,
    /// `Fv`, command per um/s.
    pub viscous: f64,
}

/// The discrete DOB block of `d` at `ts`: the PID by Tustin (as a PID
/// axis runs it) inside the observer.
fn dob_block(
    d: &DobAxis,
    ts: f64,
    limits: CommandLimits,
    what: &str,
) -> Result<Feedback, ContourError> {
    let setup = |e: String| ContourError::Setup(format!("{what}: {e}"));
    let Feedback::StateSpace(outer) =
        controller_block(&AxisController::Pid(d.pid), ts, limits, what)?
    else {
        unreachable!("a PID axis is a state-space block");
    };
    let g = discrete(
        &d.nominal,
        ts,
        C2dMethod::Zoh,
        &format!("{what}: the nominal model"),
    )?;
    let f = crate::synth::dob::design(&g, d.q_hz, d.q_order, ts).map_err(setup)?;
    Ok(Feedback::Dob(DobBlock::from_filters(
        outer,
        f,
        (d.coulomb, d.viscous, d.smoothing),
        format!(
            "Q binomial order {} at {} Hz; nominal inverse of the ZOH model",
            d.q_order, d.q_hz
        ),
    )))
}

/// The \[Karagoz18\] Table 2 axis gains `(P, I, D, N)` for X, Y, Z.
pub const KARAGOZ18_AXIS_PID: [ParallelPid; 3] = [
    ParallelPid {
        p: 1.0,
        i: 0.01,
        d: 0.0005,
        n: 100.0,
    },
    ParallelPid {
        p: 1.5,
        i: 0.01,
        d: 0.0005,
        n: 100.0,
    },
    ParallelPid {
        p: 1.0,
        i: 0.01,
        d: 0.0005,
        n: 100.0,
    },
];

/// The \[Karagoz18\] Table 2 cross-coupling gains.
pub const KARAGOZ18_CC_PID: ParallelPid = ParallelPid {
    p: 0.4,
    i: 0.005,
    d: 0.0005,
    n: 100.0,
};

/// The \[Karagoz18\] Eq. 2-4 identified plants `(num, den)`, descending
/// powers of `s` (also `fixtures/karagoz18-g{xx,yy,zz}.json`).
pub const KARAGOZ18_PLANTS: [(&[f64], &[f64]); 3] = [
    (&[56930.0, 1389.0], &[1.0, 0.2268, 0.002058]),
    (&[548000.0, 13670.0], &[1.0, 1.644, 8.198, 0.06571]),
    (&[355600.0, 5468000.0], &[1.0, 607.5, 344.0, 2643.0]),
];

/// Command limits of the controllers fts builds (PIDs, state-space
/// systems); a controller file's block keeps its own. `None`: unlimited,
/// as \[Karagoz18\] simulates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CommandLimits {
    /// Lowest command.
    pub min: Option<f64>,
    /// Highest command.
    pub max: Option<f64>,
}

/// One axis before discretisation.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisSetup {
    /// Command to position; continuous (ZOH) or discrete at the loop's `ts`.
    pub plant: StateSpace,
    /// The feedback controller.
    pub controller: AxisController,
    /// Sines added to the plant output (position units, Hz, degrees).
    pub disturbance: Vec<Sine>,
    /// Friction at the plant input.
    pub friction: Friction,
}

/// The discretised loop, ready to run.
#[derive(Debug, Clone)]
pub struct MultiAxisLoop {
    ts: f64,
    plants: [SisoBlock; 3],
    controllers: crate::runtime::CrossCoupledStep,
    /// The controllers as the multi-axis file that the step runs.
    pub file: MultiAxisControllerFile,
    disturbances: [Vec<Sine>; 3],
    /// For each axis, the first axis with the same disturbance (itself if
    /// none before it): the sines of one disturbance are evaluated once a
    /// sample however many axes it is added to.
    disturbance_source: [usize; 3],
    /// Each axis's own closed loop, judged by its poles.
    pub axis_loops: [AxisLoop; 3],
    limits: CommandLimits,
    limited_samples: usize,
    friction: [Friction; 3],
    previous_position: Vec3,
}

/// An axis's own closed loop (plant and controller, unity feedback).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct AxisLoop {
    /// Largest closed-loop pole modulus (< 1: stable).
    pub pole_radius: f64,
    /// Damping ratio of its least damped pole (`s = ln(z)/ts`).
    pub least_damping: f64,
    /// Natural frequency of that pole, Hz.
    pub least_damped_hz: f64,
}

/// A continuous system by `method`, a discrete one checked against `ts`.
fn discrete(
    sys: &StateSpace,
    ts: f64,
    method: C2dMethod,
    what: &str,
) -> Result<StateSpace, ContourError> {
    match sys.ts {
        None => c2d(sys, ts, method).map_err(|e| ContourError::Setup(format!("{what}: {e}"))),
        Some(t) if (t - ts).abs() <= 1e-9 * ts => Ok(sys.clone()),
        Some(t) => Err(ContourError::Setup(format!(
            "{what} is discrete with ts = {t} s, but the loop runs at ts = {ts} s"
        ))),
    }
}

/// The discrete controller block of `c` at `ts`: a PID or a state-space
/// system by Tustin (a state-space block without limits), a file's block
/// as it is.
fn controller_block(
    c: &AxisController,
    ts: f64,
    limits: CommandLimits,
    what: &str,
) -> Result<Feedback, ContourError> {
    let setup = |e: String| ContourError::Setup(format!("{what}: {e}"));
    let (k, how) = match c {
        AxisController::Block { feedback, ts: t } => {
            if (t - ts).abs() > 1e-9 * ts {
                return Err(setup(format!(
                    "its file runs at ts = {t} s, but the loop runs at ts = {ts} s"
                )));
            }
            return Ok((**feedback).clone());
        }
        AxisController::Dob(d) => return dob_block(d, ts, limits, what),
        AxisController::Pid(pid) => {
            let tf = if pid.i == 0.0 {
                pd_tustin(pid, ts)
            } else {
                pid.discretize(ts, Discretization::Tustin)
                    .map_err(|e| e.to_string())
            }
            .map_err(setup)?;
            let k =
                crate::lti::margins::discrete_tf_to_ss(&tf).map_err(|e| setup(e.to_string()))?;
            let how = format!(
                "tustin of the PID {} + {}/s + {} {} s/(s + {})",
                pid.p, pid.i, pid.d, pid.n, pid.n
            );
            (k, how)
        }
        AxisController::StateSpace(k) => {
            let how = if k.ts.is_some() { "given" } else { "tustin" };
            let tustin = C2dMethod::Tustin { prewarp: None };
            (discrete(k, ts, tustin, what)?, how.to_owned())
        }
    };
    let mut block = StateSpaceBlock::from_discrete(&k, ts, &how).map_err(setup)?;
    block.output_min = limits.min;
    block.output_max = limits.max;
    // Clamped commands hold the states (the runtime's conditional update),
    // as a limited PID stops integrating.
    block.anti_windup = if limits == CommandLimits::default() {
        SsAntiWindup::None
    } else {
        SsAntiWindup::ConditionalUpdate
    };
    Ok(Feedback::StateSpace(block))
}

/// The linear controller a block runs (limits aside), for the closed-loop
/// poles: a state-space block as it is; the runtime's PIDs as
/// `kp + ki/(1 - z^-1) + kd (1 - z^-1)/(1 - pole z^-1)` (the derivative on
/// the measurement moves a zero, not a pole, of the loop).
fn linear_controller(f: &Feedback, ts: f64) -> Result<StateSpace, String> {
    let (kp, ki, kd, pole) = match f.runtime_spec(ts) {
        FeedbackSpec::StateSpace(_) => match f {
            Feedback::StateSpace(k) => return k.to_state_space(ts),
            _ => unreachable!("a state-space spec comes from a state-space block"),
        },
        FeedbackSpec::Pid(p) => (p.kp, p.ki, p.kd, 0.0),
        FeedbackSpec::PidFiltered(p) => (p.kp, p.ki, p.kd, p.derivative_pole),
        FeedbackSpec::Dob(d) => return crate::synth::dob::linear_controller(&d, ts),
        FeedbackSpec::None => return Err("an axis needs a feedback controller".into()),
    };
    pid_linear([kp, ki, kd, pole], ts)
}

/// The runtime PID `[kp, ki, kd, pole]` on the measurement as a system.
fn pid_linear([kp, ki, kd, pole]: [f64; 4], ts: f64) -> Result<StateSpace, String> {
    // Over the common denominator (1 - z^-1)(1 - pole z^-1).
    let num = [
        kp + ki + kd,
        -kp * (1.0 + pole) - ki * pole - 2.0 * kd,
        kp * pole + kd,
    ];
    let den = vec![1.0, -(1.0 + pole), pole];
    let tf = crate::lti::DiscreteTf::new(num.to_vec(), den, 0, ts).map_err(|e| e.to_string())?;
    crate::lti::margins::discrete_tf_to_ss(&tf).map_err(|e| e.to_string())
}

/// The multi-axis controller file of `axes` and `cross` at `ts`.
pub fn controller_file(
    axes: [&AxisController; 3],
    cross: Option<&AxisController>,
    ts: f64,
    limits: CommandLimits,
) -> Result<MultiAxisControllerFile, ContourError> {
    let mut blocks = Vec::with_capacity(3);
    for (i, c) in axes.iter().enumerate() {
        let what = format!("axis {} controller", AXES[i]);
        blocks.push(controller_block(c, ts, limits, &what)?);
    }
    let cross = cross
        .map(|c| controller_block(c, ts, limits, "cross-coupling controller"))
        .transpose()?;
    Ok(MultiAxisControllerFile {
        ts,
        units: Units {
            reference: "um".into(),
            measurement: "um".into(),
            command: "plant input".into(),
        },
        axes: blocks.try_into().expect("three axes"),
        cross_coupling: cross,
        provenance: Provenance {
            fts_version: env!("CARGO_PKG_VERSION").into(),
            inputs: Vec::new(),
        },
    })
}

/// `P + D N s/(s + N)` by Tustin, without the integrator's `(1 - z^-1)`
/// that [`ParallelPid::discretize`] puts in its common denominator (with
/// `I = 0` it would stay as a cancelled pole on the unit circle):
/// `(P (f0 + f1 z^-1) + D N k (1 - z^-1)) / (f0 + f1 z^-1)`, `k = 2/ts`,
/// `f0 = k + N`, `f1 = N - k`.
fn pd_tustin(pid: &ParallelPid, ts: f64) -> Result<crate::lti::DiscreteTf, String> {
    if ![pid.p, pid.d, pid.n].iter().all(|v| v.is_finite()) || pid.n <= 0.0 {
        return Err("P, D must be finite and N positive".into());
    }
    let k = 2.0 / ts;
    let (f0, f1) = (k + pid.n, pid.n - k);
    let dnk = pid.d * pid.n * k;
    let num = vec![pid.p * f0 + dnk, pid.p * f1 - dnk];
    crate::lti::DiscreteTf::new(num, vec![f0, f1], 0, ts).map_err(|e| e.to_string())
}

/// The poles of the unity-feedback loop of `k` and `g` (discrete, at `ts`).
fn axis_loop(
    g: &StateSpace,
    k: &StateSpace,
    ts: f64,
    axis: &str,
) -> Result<AxisLoop, ContourError> {
    let setup = |e: crate::lti::ss::SsError| ContourError::Setup(format!("axis {axis}: {e}"));
    let one = StateSpace::gain(faer::Mat::from_fn(1, 1, |_, _| 1.0), g.ts);
    let cl = k.series(g).and_then(|l| l.feedback(&one)).map_err(setup)?;
    let poles = cl.poles().map_err(setup)?;
    Ok(loop_info(&poles, ts))
}

/// The figures of closed-loop poles `poles` at `ts`.
fn loop_info(poles: &[crate::lti::c64], ts: f64) -> AxisLoop {
    let mut info = AxisLoop {
        pole_radius: poles.iter().map(|p| p.norm()).fold(0.0, f64::max),
        least_damping: f64::INFINITY,
        least_damped_hz: 0.0,
    };
    for z in poles.iter().filter(|z| z.norm() > 0.0) {
        let s = z.ln() / ts;
        let damping = -s.re / s.norm();
        if damping < info.least_damping {
            info.least_damping = damping;
            info.least_damped_hz = s.norm() / (2.0 * PI);
        }
    }
    info
}

/// The closed loop of a DOB axis. With the plant as the nominal model
/// (`(A, B, d)` of `g` equal to the block's to 1e-9), `1 - Q z^-d + (C + Q A/B) P`
/// times its denominators is `D_Q B (A D_c + N_c B z^-d)`: the poles are the
/// PID loop's, `Q`'s and the plant's zeros, each found where it is well
/// conditioned (the realisation of the whole, with poles and zeros within
/// 1e-6 of `z = 1` at fast sampling, is not). Otherwise the loop of the
/// block's linear part as a whole ([`crate::synth::dob::linear_controller`]).
fn dob_loop(g: &StateSpace, d: &DobBlock, ts: f64, axis: &str) -> Result<AxisLoop, ContourError> {
    let setup = |e: String| ContourError::Setup(format!("axis {axis} controller: {e}"));
    let spec = d.runtime_spec(ts);
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(x, y)| (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1e-300))
    };
    let nominal_is_plant = crate::synth::dob::nominal_inverse(g).is_ok_and(|(a, b, delay)| {
        delay == d.delay && same(&a, &d.inverse_num) && same(&b, &d.inverse_den)
    });
    if !nominal_is_plant {
        let k = crate::synth::dob::linear_controller(&spec, ts).map_err(setup)?;
        return axis_loop(g, &k, ts, axis);
    }
    let k = d.outer.to_state_space(ts).map_err(setup)?;
    let cl = k
        .series(g)
        .and_then(|l| {
            l.feedback(&StateSpace::gain(
                faer::Mat::from_fn(1, 1, |_, _| 1.0),
                g.ts,
            ))
        })
        .map_err(|e| setup(e.to_string()))?;
    let mut poles = cl.poles().map_err(|e| setup(e.to_string()))?;
    poles.extend(crate::lti::roots_descending(&d.q_den).map_err(|e| setup(e.to_string()))?);
    poles.extend(crate::lti::roots_descending(&d.inverse_den).map_err(|e| setup(e.to_string()))?);
    Ok(loop_info(&poles, ts))
}

impl MultiAxisLoop {
    /// Discretises every axis at `ts` (plants by ZOH, controllers by
    /// Tustin) and checks each axis's own loop; `cross` is the
    /// cross-coupling controller (`None`: the axes run uncoupled).
    pub fn new(
        axes: &[AxisSetup; 3],
        cross: Option<&AxisController>,
        ts: f64,
        limits: CommandLimits,
    ) -> Result<Self, ContourError> {
        let controllers = [0, 1, 2].map(|i| &axes[i].controller);
        let file = controller_file(controllers, cross, ts, limits)?;
        let plants = [0, 1, 2].map(|i| (axes[i].plant.clone(), axes[i].disturbance.clone()));
        let mut lp = Self::from_file(plants, file)?;
        lp.limits = limits;
        lp.friction = [0, 1, 2].map(|i| axes[i].friction);
        Ok(lp)
    }

    /// The loop of `plants` (each with its output disturbance) under the
    /// controllers of `file`, at the file's sample time; each axis's own
    /// loop is checked first.
    pub fn from_file(
        plants: [(StateSpace, Vec<Sine>); 3],
        file: MultiAxisControllerFile,
    ) -> Result<Self, ContourError> {
        let ts = file.ts;
        let mut blocks = Vec::with_capacity(3);
        let mut axis_loops = [AxisLoop::default(); 3];
        for (i, (plant, _)) in plants.iter().enumerate() {
            let name = AXES[i];
            let what = format!("axis {name} plant");
            let g = discrete(plant, ts, C2dMethod::Zoh, &what)?;
            axis_loops[i] = match &file.axes[i] {
                Feedback::Dob(d) => dob_loop(&g, d, ts, name)?,
                other => {
                    let k = linear_controller(other, ts)
                        .map_err(|e| ContourError::Setup(format!("axis {name} controller: {e}")))?;
                    axis_loop(&g, &k, ts, name)?
                }
            };
            let radius = axis_loops[i].pole_radius;
            if radius.is_nan() || radius >= 1.0 {
                return Err(ContourError::Unstable {
                    axis: name,
                    ts,
                    radius,
                });
            }
            let block =
                SisoBlock::new(&g).map_err(|e| ContourError::Setup(format!("{what}: {e}")))?;
            if block.feedthrough() != 0.0 {
                return Err(ContourError::Setup(format!(
                    "{what}: it must be strictly proper (D = 0): the controller reads the position before it commands"
                )));
            }
            blocks.push(block);
        }
        let step = file
            .runtime_step()
            .map_err(|e| ContourError::Setup(format!("runtime step: {e}")))?;
        let disturbances = plants.map(|(_, d)| d);
        let disturbance_source = std::array::from_fn(|i| {
            (0..i)
                .find(|&j| disturbances[j] == disturbances[i])
                .unwrap_or(i)
        });
        Ok(Self {
            ts,
            plants: blocks.try_into().expect("three axes"),
            controllers: step,
            file,
            disturbances,
            disturbance_source,
            axis_loops,
            limits: CommandLimits::default(),
            limited_samples: 0,
            friction: [Friction::default(); 3],
            previous_position: [0.0; 3],
        })
    }

    /// Sample time, s.
    pub fn ts(&self) -> f64 {
        self.ts
    }

    fn disturbance(&self, axis: usize, t: f64) -> f64 {
        self.disturbances[axis]
            .iter()
            .map(|s| s.amplitude * (2.0 * PI * s.freq_hz * t + s.phase_deg.to_radians()).sin())
            .sum()
    }

    /// One sample: the positions read now, and the commands applied.
    fn step(&mut self, k: usize, reference: Vec3, tangent: Vec3) -> (Vec3, Vec3, Vec3) {
        let sample = self.sample(k, reference, tangent);
        let e: Vec3 = std::array::from_fn(|i| reference[i] - sample.measurement[i]);
        (sample.measurement, e, contour_estimate(e, tangent))
    }

    /// The friction at axis `i`'s input, `Fc sign(v) + Fv v`, with `v` the
    /// backward difference of the plant's own output (the disturbance
    /// excluded) over the last sample.
    fn friction_force(&mut self, i: usize, position: f64) -> f64 {
        let f = self.friction[i];
        let v = (position - self.previous_position[i]) / self.ts;
        self.previous_position[i] = position;
        let sign = if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        };
        f.coulomb * sign + f.viscous * v
    }

    /// One sample `k`: read the positions, step the controllers, apply
    /// the commands (less any friction) to the plants.
    pub fn sample(&mut self, k: usize, reference: Vec3, tangent: Vec3) -> LoopSample {
        let t = k as f64 * self.ts;
        let position: Vec3 = std::array::from_fn(|i| self.plants[i].output(0.0));
        let mut disturbance = [0.0; 3];
        for i in 0..3 {
            let source = self.disturbance_source[i];
            disturbance[i] = if source < i {
                disturbance[source]
            } else {
                self.disturbance(i, t)
            };
        }
        let y: Vec3 = std::array::from_fn(|i| position[i] + disturbance[i]);
        let friction: Vec3 = std::array::from_fn(|i| self.friction_force(i, position[i]));
        let u = self.controllers.step(&reference, &tangent, &y);
        let (lo, hi) = (self.limits.min, self.limits.max);
        if u.iter()
            .any(|u| lo.is_some_and(|lo| *u <= lo) || hi.is_some_and(|hi| *u >= hi))
        {
            self.limited_samples += 1;
        }
        for ((plant, u), f) in self.plants.iter_mut().zip(u).zip(friction) {
            plant.update(u - f);
        }
        LoopSample {
            reference,
            tangent,
            measurement: y,
            command: u,
        }
    }
}

/// What the controllers saw and commanded at one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopSample {
    /// Reference point.
    pub reference: Vec3,
    /// Unit tangent of the path there.
    pub tangent: Vec3,
    /// Measured positions.
    pub measurement: Vec3,
    /// Commands applied.
    pub command: Vec3,
}

/// The first `samples` samples of `lp` (from rest) along `traj`, every
/// signal the runtime step saw and returned (for replaying the step
/// elsewhere, e.g. in the C runtime).
pub fn record(lp: &mut MultiAxisLoop, traj: &Trajectory, samples: usize) -> Vec<LoopSample> {
    (0..samples)
        .map(|k| {
            let r = traj.at(k as f64 * lp.ts);
            lp.sample(k, r.point, r.tangent)
        })
        .collect()
}

/// Figures of one run (in the path's length unit).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ContourMetrics {
    /// RMS tracking error per axis.
    pub rms_axis: [f64; 3],
    /// Largest absolute tracking error per axis.
    pub max_axis: [f64; 3],
    /// RMS of the exact contour error (distance to the path).
    pub rms_contour: f64,
    /// Largest exact contour error.
    pub max_contour: f64,
    /// RMS of the estimate `|e - (e . t) t|`.
    pub rms_estimate: f64,
    /// Largest estimate.
    pub max_estimate: f64,
    /// Samples evaluated.
    pub samples: usize,
    /// Samples at which an axis command was at or beyond a command limit
    /// (`CommandLimits`; 0 without limits).
    pub limited_samples: usize,
}

/// A thinned record of a run, for plots and CSV.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ContourTrace {
    /// Time, s.
    pub t: Vec<f64>,
    /// Reference per axis.
    pub reference: [Vec<f64>; 3],
    /// Position (plant output with its disturbance) per axis.
    pub position: [Vec<f64>; 3],
    /// Exact contour error.
    pub contour: Vec<f64>,
    /// Contour-error estimate `|eps|`.
    pub estimate: Vec<f64>,
}

/// A run: its figures and its thinned trace.
#[derive(Debug, Clone, PartialEq)]
pub struct ContourRun {
    /// Figures over every sample.
    pub metrics: ContourMetrics,
    /// Every `stride`-th sample.
    pub trace: ContourTrace,
    /// Samples between trace points.
    pub stride: usize,
}

#[derive(Default)]
struct Accumulator {
    sq_axis: [f64; 3],
    max_axis: [f64; 3],
    sq_contour: f64,
    max_contour: f64,
    sq_estimate: f64,
    max_estimate: f64,
    n: usize,
}

impl Accumulator {
    fn add(&mut self, e: Vec3, contour: f64, estimate: f64) {
        for ((sq, max), e) in self.sq_axis.iter_mut().zip(&mut self.max_axis).zip(e) {
            *sq += e * e;
            *max = max.max(e.abs());
        }
        self.sq_contour += contour * contour;
        self.max_contour = self.max_contour.max(contour);
        self.sq_estimate += estimate * estimate;
        self.max_estimate = self.max_estimate.max(estimate);
        self.n += 1;
    }

    fn metrics(&self) -> ContourMetrics {
        let n = self.n.max(1) as f64;
        ContourMetrics {
            rms_axis: self.sq_axis.map(|s| (s / n).sqrt()),
            max_axis: self.max_axis,
            rms_contour: (self.sq_contour / n).sqrt(),
            max_contour: self.max_contour,
            rms_estimate: (self.sq_estimate / n).sqrt(),
            max_estimate: self.max_estimate,
            samples: self.n,
            limited_samples: 0,
        }
    }
}

/// Runs `lp` (from rest) along `traj` for its duration plus `settle`
/// seconds, keeping about `trace_points` samples of the trace.
pub fn run(
    lp: &mut MultiAxisLoop,
    traj: &Trajectory,
    settle: f64,
    trace_points: usize,
) -> Result<ContourRun, ContourError> {
    let n = ((traj.duration() + settle.max(0.0)) / lp.ts).ceil() as usize + 1;
    let stride = n.div_ceil(trace_points.max(2)).max(1);
    let bound = 1e6 * (1.0 + traj.path.length());
    let mut acc = Accumulator::default();
    let mut trace = ContourTrace::default();
    for k in 0..n {
        let r = traj.at(k as f64 * lp.ts);
        let (y, e, eps) = lp.step(k, r.point, r.tangent);
        if let Some(i) = (0..3).find(|&i| !y[i].is_finite() || y[i].abs() > bound) {
            return Err(ContourError::Diverged {
                time_s: k as f64 * lp.ts,
                axis: AXES[i],
                value: y[i],
            });
        }
        let (contour, estimate) = (traj.path.distance(y), length(eps));
        acc.add(e, contour, estimate);
        if k % stride == 0 || k + 1 == n {
            trace.t.push(k as f64 * lp.ts);
            for (i, y) in y.iter().enumerate() {
                trace.reference[i].push(r.point[i]);
                trace.position[i].push(*y);
            }
            trace.contour.push(contour);
            trace.estimate.push(estimate);
        }
    }
    let mut metrics = acc.metrics();
    metrics.limited_samples = lp.limited_samples;
    Ok(ContourRun {
        metrics,
        trace,
        stride,
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::sim::path::{MotionLimits, Path, Shape};

    fn first_order(ts: Option<f64>, gain: f64, pole: f64) -> StateSpace {
        StateSpace::from_tf(&[gain], &[1.0, pole], ts).unwrap()
    }

    fn axes(gains: [f64; 3]) -> [AxisSetup; 3] {
        // Integrating plants 1/s with proportional control: e_ss = v / Kp on a ramp.
        gains.map(|p| AxisSetup {
            friction: Friction::default(),
            plant: first_order(None, 1.0, 0.0),
            controller: AxisController::Pid(ParallelPid {
                p,
                i: 0.0,
                d: 0.0,
                n: 100.0,
            }),
            disturbance: vec![],
        })
    }

    fn square_traj() -> Trajectory {
        let path = Path::new(Shape::Square { side: 1.0 }, 30.0).unwrap();
        let limits = MotionLimits {
            velocity: 0.5,
            acceleration: 5.0,
            jerk: 100.0,
        };
        Trajectory::plan(path, limits).unwrap()
    }

    pub fn a_discrete_block_steps_its_difference_equation() {
        // y(k) = 0.5 y(k-1) + u(k-1): x(k+1) = 0.5 x + u, y = x.
        let mut b = SisoBlock::new(&first_order(Some(0.1), 1.0, -0.5)).unwrap();
        let ys: Vec<f64> = (0..4).map(|_| b.step(1.0)).collect();
        assert_eq!(ys, vec![0.0, 1.0, 1.5, 1.75]);
        assert!(SisoBlock::new(&first_order(None, 1.0, 1.0)).is_err());
    }

    pub fn a_ramp_is_tracked_with_the_velocity_over_the_gain() {
        // One straight side at cruise: e = v / Kp along the path, and no
        // contour error with equal axes (the error is along the tangent).
        let traj = square_traj();
        let mut lp =
            MultiAxisLoop::new(&axes([20.0; 3]), None, 1e-4, CommandLimits::default()).unwrap();
        let run = run(&mut lp, &traj, 0.0, 1000).unwrap();
        let m = run.metrics;
        // At cruise on side 1 (along x): e_x = 0.5 / 20 = 0.025.
        assert!((m.max_axis[0] - 0.025).abs() < 1e-6, "{m:?}");
        // Equal axes lag along the path: only the corners (where the lag
        // left on the last side is normal to the next) show a contour error.
        assert!(m.rms_contour < 0.02 * m.rms_axis[0], "{m:?}");
        assert!(m.max_contour < 0.1 * m.max_axis[0], "{m:?}");
    }

    pub fn cross_coupling_lowers_the_contour_error_of_mismatched_axes() {
        // Unequal axis gains make the path bend away on the diagonal sides;
        // the coupling adds gain normal to the path only.
        let traj = square_traj();
        let cc = AxisController::Pid(ParallelPid {
            p: 40.0,
            i: 0.0,
            d: 0.0,
            n: 100.0,
        });
        let uncoupled = {
            let mut lp = MultiAxisLoop::new(
                &axes([10.0, 30.0, 10.0]),
                None,
                1e-4,
                CommandLimits::default(),
            )
            .unwrap();
            run(&mut lp, &traj, 0.0, 100).unwrap().metrics
        };
        let coupled = {
            let mut lp = MultiAxisLoop::new(
                &axes([10.0, 30.0, 10.0]),
                Some(&cc),
                1e-4,
                CommandLimits::default(),
            )
            .unwrap();
            run(&mut lp, &traj, 0.0, 100).unwrap().metrics
        };
        assert!(uncoupled.rms_contour > 1e-3, "{uncoupled:?}");
        assert!(
            coupled.rms_contour < 0.5 * uncoupled.rms_contour,
            "{coupled:?} vs {uncoupled:?}"
        );
    }

    pub fn the_linear_model_of_a_runtime_pid_is_what_the_runtime_runs() {
        // The poles are judged on `linear_controller`; the runtime steps the
        // block. Fed the same error (reference 0, measurement -e, so the
        // derivative on the measurement is on e), both give the same output.
        use crate::io::controller_file::ParallelPid as FilePid;
        use crate::runtime::PidSpec;
        let ts = 1e-3;
        let blocks = [
            Feedback::ParallelPid(FilePid {
                kp: 1.5,
                ki: 20.0,
                kd: 0.01,
                n: Some(300.0),
                output_min: -1e9,
                output_max: 1e9,
            }),
            Feedback::Pid(PidSpec {
                kp: 0.7,
                ki: 0.05,
                kd: 2.0,
                output_min: -1e9,
                output_max: 1e9,
            }),
        ];
        for f in blocks {
            let spec = f.runtime_spec(ts);
            let mut step = crate::runtime::CrossCoupledStep::new([&spec; 3], None).unwrap();
            let mut linear = SisoBlock::new(&linear_controller(&f, ts).unwrap()).unwrap();
            for k in 0..200 {
                let e = (0.37 * k as f64).sin() + 0.2 * ((k % 7) as f64);
                let u = step.step(&[0.0; 3], &[1.0, 0.0, 0.0], &[-e; 3])[0];
                let v = linear.step(e);
                assert!(
                    (u - v).abs() <= 1e-9 * (1.0 + u.abs()),
                    "{f:?} k {k}: {u} vs {v}"
                );
            }
        }
    }

    pub fn an_unstable_axis_is_refused_and_a_biproper_plant_too() {
        let mut a = axes([1.0; 3]);
        a[1].controller = AxisController::Pid(ParallelPid {
            p: -5.0,
            i: 0.0,
            d: 0.0,
            n: 100.0,
        });
        let e = MultiAxisLoop::new(&a, None, 1e-3, CommandLimits::default()).unwrap_err();
        assert!(matches!(e, ContourError::Unstable { axis: "y", .. }), "{e}");
        let mut a = axes([1.0; 3]);
        a[2].plant = StateSpace::from_tf(&[1.0, 2.0], &[1.0, 3.0], None).unwrap();
        let e = MultiAxisLoop::new(&a, None, 1e-3, CommandLimits::default()).unwrap_err();
        assert!(e.to_string().contains("strictly proper"), "{e}");
    }
}
