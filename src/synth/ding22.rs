//! The \[Ding22\] workflow (docs/math.md §5): a lumped two-mass fast tool servo,
//! white-noise disturbances shaped by `W1..W3` inside a generalised plant,
//! the H2-optimal controller, a PID baseline tuned for the same cost, the
//! error budget, and the structural sweep over the flexure `(k2, c2)`.
//!
//! ## Mechanics (topology chosen here; docs/math.md does not fix it)
//!
//! ```text
//!   x_b (base)          x1                  x4 (tool)
//!   ///|----k2----[ m12 = m1+m2 ]----k4----[ m4 ]
//!      |----c2----[             ]----c4----[    ]
//!      |==F==>  (actuator force on m12, reacting on the base)
//! ```
//!
//! The flexure `(k2, c2)` guides the moving body `m12` (piezo end and
//! flexure) on the base; the tool holder `m4` sits on it through the
//! interface stiffness `(k4, c4)`. The actuator pushes `m12` against the
//! base. Positions are absolute (in the frame that carries the workpiece):
//! the sensed body's displacement is the tracking error when the reference
//! is zero, and the displacement sensor measures it. By default that body
//! is `m12` (`x1`): \[Ding22\] puts the sensor on `m2`, "the mass of the
//! movable body, including the coil assembly and sensor", and `m4` is a
//! flexible mass that decouples at high frequency. [`SensedBody::ToolMass`]
//! senses `x4` instead (non-collocated). Base vibration
//! `x_b` enters through the flexure's spring and damper.
//! Equations: `m12 x1'' = F - k2 (x1 - xb) - c2 (x1' - xb') - k4 (x1 - x4) - c4 (x1' - x4')`,
//! `m4 x4'' = -k4 (x4 - x1) - c4 (x4' - x1')`.
//! The base enters as a *displacement*; the damper's `c2 xb'` term is
//! absorbed by the state `w1 = x1' - (c2/m12) xb` so no derivative of the
//! input is needed (states `[x1, x4, w1, x4']`).
//!
//! ## Disturbances, weights, units
//!
//! Every exogenous input is a unit-intensity continuous white noise
//! (`E w(t) w(s) = delta(t - s)`, two-sided PSD 1). SI units throughout:
//! `u` and the current-loop noise are forces in N (the current-to-force
//! constant is taken as 1 N/A: the model is in force), displacements in m.
//! * `W1 = 1.36e-6` sensor noise (m), added to the measurement.
//! * `W2 = 1.64e-7 (s^2 + 0.1 w s + w^2)/(s^2 + 0.005 w s + w^2) (s - 200 pi)/(s + d)`,
//!   `w = 2 pi 7748`, a force added to `u`.
//! * `W3 = 2.83e-9 (s - 2000 pi)/(s + d)` base displacement (m).
//!
//! The integrators `1/s` of \[Ding22\] are shifted to `1/(s + d)`,
//! `d = 2 pi 0.1 rad/s` by default (otherwise the disturbances have infinite
//! power and the H2 problem is ill posed).
//! * `W_e = (s/M_s + w_b)/(s + w_b eps)`, `M_s = 1.2721`, `eps = 1e-7`,
//!   `w_b = 2 pi 1100 rad/s` (docs/math.md gives no `w_b`: the paper's bandwidth).
//! * `W_u = (s + w_bu/M_u)/(eps_1 s + w_bu)`, `M_u = w_bu = 1e8`. docs/math.md
//!   gives no `eps_1`; `eps_1 = 1` puts the weight's pole at `w_bu/eps_1 = 1e8`
//!   rad/s. Below that pole `W_u ~ (s + 1)/1e8` for any `eps_1`, so the value
//!   only matters above 16 MHz, but it must be nonzero (W_u proper,
//!   `D12 = 1/eps_1` full rank) and not tiny (with `eps_1 = 1e-7` the pole
//!   would sit at 1e15 rad/s, 1e19 times the slowest mode, beyond what the
//!   Riccati solvers resolve in double precision).
//!
//! Generalised plant: inputs `[w1, w2, w3, u]`, outputs
//! `[W_e e, W_u u, y]`, `e = x_s`, `y = x_s + W1 w1` (`x_s` the sensed
//! body's displacement); `u = K y` (the lft
//! convention of [`StateSpace::lft`]).

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::budget::{ErrorBudget, error_budget, exact_rms_per_source};
use super::genplant::SynthError;
use super::h2::{H2Result, h2syn};
use crate::lti::norms::h2_norm;
use crate::lti::ss::StateSpace;
use crate::lti::{c64, logspace};
use faer::Mat;
use std::f64::consts::PI;
use thiserror::Error;

/// Errors of the Ding22 workflow.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Ding22Error {
    /// A parameter is out of range (bad input).
    #[error("{0}")]
    Param(String),
    /// The synthesis failed.
    #[error(transparent)]
    Synth(#[from] SynthError),
    /// A numerical step (norm, frequency response) failed.
    #[error("{0}")]
    Numerical(String),
}

fn num<E: std::fmt::Display>(e: E) -> Ding22Error {
    Ding22Error::Numerical(e.to_string())
}

/// Which body the displacement sensor (and the tool, whose error is the
/// performance output) sits on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum SensedBody {
    /// The moving body `m12 = m1 + m2`, displacement `x1`: \[Ding22\] says
    /// `m2` "is the mass of the movable body, including the coil assembly
    /// and sensor". Collocated with the actuator force.
    #[default]
    MovingBody,
    /// The flexible mass `m4`, displacement `x4` (fts's reading before the
    /// paper's text was checked): non-collocated, the phase of `x4/F`
    /// heads for -360 deg above the 445 Hz mode.
    ToolMass,
}

/// Lumped mechanics of \[Ding22\] Table 1 (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoMassParams {
    /// `m1 + m2` (kg), the moving body driven by the actuator.
    pub m12: f64,
    /// Flexure stiffness to the base (N/m).
    pub k2: f64,
    /// Flexure damping to the base (N s/m).
    pub c2: f64,
    /// Tool (holder) mass (kg).
    pub m4: f64,
    /// Tool interface stiffness (N/m).
    pub k4: f64,
    /// Tool interface damping (N s/m).
    pub c4: f64,
    /// The body sensed (and whose displacement is the tool error).
    pub sensor: SensedBody,
}

impl Default for TwoMassParams {
    /// \[Ding22\] Table 1: `m12 = 0.074`, `k2 = 21965`, `c2 = 2.28`,
    /// `m4 = 0.008`, `k4 = 56285`, `c4 = 6.18`.
    fn default() -> Self {
        Self {
            m12: 0.074,
            k2: 21965.0,
            c2: 2.28,
            m4: 0.008,
            k4: 56285.0,
            c4: 6.18,
            sensor: SensedBody::MovingBody,
        }
    }
}

fn positive(x: f64, name: &str) -> Result<(), Ding22Error> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(Ding22Error::Param(format!(
            "{name} must be a positive finite number, got {x}"
        )))
    }
}

fn nonneg(x: f64, name: &str) -> Result<(), Ding22Error> {
    if x.is_finite() && x >= 0.0 {
        Ok(())
    } else {
        Err(Ding22Error::Param(format!(
            "{name} must be a finite number >= 0, got {x}"
        )))
    }
}

impl TwoMassParams {
    /// Masses and stiffnesses positive, dampings nonnegative, all finite.
    pub fn validate(&self) -> Result<(), Ding22Error> {
        positive(self.m12, "m12")?;
        positive(self.k2, "k2")?;
        nonneg(self.c2, "c2")?;
        positive(self.m4, "m4")?;
        positive(self.k4, "k4")?;
        nonneg(self.c4, "c4")
    }

    /// Continuous plant, inputs `[F (N), x_b (m)]`, output the sensed
    /// body's displacement (`x1` or `x4`, m), states
    /// `[x1, x4, x1' - (c2/m12) x_b, x4']` (module docs).
    pub fn plant(&self) -> Result<StateSpace, Ding22Error> {
        self.validate()?;
        let Self {
            m12,
            k2,
            c2,
            m4,
            k4,
            c4,
            sensor,
        } = *self;
        let a2 = c2 / m12; // x1' = w1 + a2 xb
        let a = Mat::from_fn(4, 4, |i, j| match (i, j) {
            (0, 2) | (1, 3) => 1.0,
            (2, 0) => -(k2 + k4) / m12,
            (2, 1) => k4 / m12,
            (2, 2) => -(c2 + c4) / m12,
            (2, 3) => c4 / m12,
            (3, 0) => k4 / m4,
            (3, 1) => -k4 / m4,
            (3, 2) => c4 / m4,
            (3, 3) => -c4 / m4,
            _ => 0.0,
        });
        let b = Mat::from_fn(4, 2, |i, j| match (i, j) {
            (0, 1) => a2,
            (2, 0) => 1.0 / m12,
            (2, 1) => (k2 - (c2 + c4) * a2) / m12,
            (3, 1) => c4 * a2 / m4,
            _ => 0.0,
        });
        let sensed = match sensor {
            SensedBody::MovingBody => 0,
            SensedBody::ToolMass => 1,
        };
        let c = Mat::from_fn(1, 4, |_, j| if j == sensed { 1.0 } else { 0.0 });
        StateSpace::new(a, b, c, Mat::zeros(1, 2), None).map_err(num)
    }

    /// Undamped natural frequencies (rad/s, ascending): the square roots of
    /// the eigenvalues of `M^-1 K`, `M = diag(m12, m4)`,
    /// `K = [k2 + k4, -k4; -k4, k4]`, in closed form.
    pub fn natural_frequencies(&self) -> [f64; 2] {
        let (p, q) = ((self.k2 + self.k4) / self.m12, self.k4 / self.m4);
        let det = self.k2 * self.k4 / (self.m12 * self.m4);
        let half = 0.5 * (p + q);
        let disc = (half * half - det).max(0.0).sqrt();
        // Smaller root by det / larger: no cancellation.
        let hi = half + disc;
        [(det / hi).sqrt(), hi.sqrt()]
    }
}

/// Disturbance filters and performance weights (module docs for the forms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ding22Weights {
    /// `W1` sensor noise gain (m).
    pub sensor_noise: f64,
    /// `W2` current-loop (force) noise gain (N).
    pub current_noise: f64,
    /// `W2` resonance frequency `w` (rad/s).
    pub current_w: f64,
    /// `W3` base-vibration gain (m).
    pub base_noise: f64,
    /// Shift `d` (rad/s) of the integrators of `W2`, `W3` into the left half plane.
    pub shift: f64,
    /// `M_s` of `W_e`.
    pub ms: f64,
    /// `w_b` of `W_e` (rad/s).
    pub wb: f64,
    /// `eps` of `W_e`.
    pub eps: f64,
    /// `M_u` of `W_u`.
    pub mu: f64,
    /// `w_bu` of `W_u` (rad/s).
    pub wbu: f64,
    /// `eps_1` of `W_u`.
    pub eps1: f64,
}

impl Default for Ding22Weights {
    fn default() -> Self {
        Self {
            sensor_noise: 1.36e-6,
            current_noise: 1.64e-7,
            current_w: 2.0 * PI * 7748.0,
            base_noise: 2.83e-9,
            shift: 2.0 * PI * 0.1,
            ms: 1.2721,
            wb: 2.0 * PI * 1100.0,
            eps: 1e-7,
            mu: 1e8,
            wbu: 1e8,
            eps1: 1.0,
        }
    }
}

/// Names of the three sources, in input order.
pub const SOURCES: [&str; 3] = [
    "sensor noise (W1)",
    "current-loop noise (W2)",
    "base vibration (W3)",
];

fn tf1(num: &[f64], den: &[f64]) -> Result<StateSpace, Ding22Error> {
    StateSpace::from_tf(num, den, None).map_err(num_err)
}

fn num_err(e: crate::lti::SsError) -> Ding22Error {
    Ding22Error::Numerical(e.to_string())
}

impl Ding22Weights {
    /// All gains and frequencies positive and finite.
    pub fn validate(&self) -> Result<(), Ding22Error> {
        positive(self.sensor_noise, "sensor noise W1")?;
        nonneg(self.current_noise, "current noise W2")?;
        positive(self.current_w, "W2 resonance")?;
        nonneg(self.base_noise, "base vibration W3")?;
        positive(self.shift, "integrator shift")?;
        positive(self.ms, "M_s")?;
        positive(self.wb, "w_b")?;
        positive(self.eps, "eps")?;
        positive(self.mu, "M_u")?;
        positive(self.wbu, "w_bu")?;
        positive(self.eps1, "eps_1")
    }

    /// `W2` (SISO, 3 states, the resonant pair in a modal realisation).
    pub fn w2(&self) -> Result<StateSpace, Ding22Error> {
        let w = self.current_w;
        let (zn, zd) = (0.05, 0.0025); // 0.1 w s = 2 zn w s, 0.005 w s = 2 zd w s
        let res = StateSpace::new(
            Mat::from_fn(2, 2, |i, j| match (i, j) {
                (0, 1) => w,
                (1, 0) => -w,
                (1, 1) => -2.0 * zd * w,
                _ => 0.0,
            }),
            Mat::from_fn(2, 1, |i, _| if i == 1 { 1.0 } else { 0.0 }),
            Mat::from_fn(1, 2, |_, j| if j == 1 { 2.0 * (zn - zd) * w } else { 0.0 }),
            Mat::from_fn(1, 1, |_, _| 1.0),
            None,
        )
        .map_err(num_err)?;
        let lag = tf1(
            &[self.current_noise, -self.current_noise * 200.0 * PI],
            &[1.0, self.shift],
        )?;
        res.series(&lag).map_err(num_err)
    }

    /// `W3` (SISO, 1 state).
    pub fn w3(&self) -> Result<StateSpace, Ding22Error> {
        tf1(
            &[self.base_noise, -self.base_noise * 2000.0 * PI],
            &[1.0, self.shift],
        )
    }

    /// `W_e` (\[Ding22\] Eq. 3, docs/math.md §5).
    pub fn we(&self) -> Result<StateSpace, Ding22Error> {
        tf1(&[1.0 / self.ms, self.wb], &[1.0, self.wb * self.eps])
    }

    /// `W_u` (\[Ding22\] Eq. 4, docs/math.md §5), proper since `eps_1 > 0`.
    pub fn wu(&self) -> Result<StateSpace, Ding22Error> {
        tf1(&[1.0, self.wbu / self.mu], &[self.eps1, self.wbu])
    }
}

/// One design problem: mechanics and weights.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ding22Problem {
    pub mech: TwoMassParams,
    pub weights: Ding22Weights,
}

fn put(m: &mut Mat<f64>, r0: usize, c0: usize, block: &Mat<f64>) {
    for i in 0..block.nrows() {
        for j in 0..block.ncols() {
            m[(r0 + i, c0 + j)] = block[(i, j)];
        }
    }
}

impl Ding22Problem {
    /// Validated problem.
    pub fn new(mech: TwoMassParams, weights: Ding22Weights) -> Result<Self, Ding22Error> {
        mech.validate()?;
        weights.validate()?;
        Ok(Self { mech, weights })
    }

    /// Inputs `[w1, w2, w3, u]`; outputs `[W_e e, W_u u, y]` when `weighted`,
    /// `[e, u, y]` otherwise (the analysis plant of the budget).
    fn assemble(&self, weighted: bool) -> Result<StateSpace, Ding22Error> {
        self.mech.validate()?;
        self.weights.validate()?;
        let g = self.mech.plant()?;
        let w2 = self.weights.w2()?;
        let w3 = self.weights.w3()?;
        let (we, wu) = if weighted {
            (self.weights.we()?, self.weights.wu()?)
        } else {
            let one = StateSpace::gain(Mat::from_fn(1, 1, |_, _| 1.0), None);
            (one.clone(), one)
        };
        let (ng, n2, n3, ne, nu) = (g.nx(), w2.nx(), w3.nx(), we.nx(), wu.nx());
        let (o2, o3, oe, ou) = (ng, ng + n2, ng + n2 + n3, ng + n2 + n3 + ne);
        let n = ou + nu;
        let bf = crate::lti::ss::sub(&g.b, 0, ng, 0, 1);
        let bb = crate::lti::ss::sub(&g.b, 0, ng, 1, 2);
        let mut a = Mat::<f64>::zeros(n, n);
        put(&mut a, 0, 0, &g.a);
        put(&mut a, 0, o2, &(&bf * &w2.c));
        put(&mut a, 0, o3, &(&bb * &w3.c));
        put(&mut a, o2, o2, &w2.a);
        put(&mut a, o3, o3, &w3.a);
        put(&mut a, oe, oe, &we.a);
        put(&mut a, oe, 0, &(&we.b * &g.c));
        put(&mut a, ou, ou, &wu.a);
        let mut b = Mat::<f64>::zeros(n, 4);
        put(&mut b, 0, 1, &(&bf * &w2.d));
        put(&mut b, 0, 2, &(&bb * &w3.d));
        put(&mut b, 0, 3, &bf);
        put(&mut b, o2, 1, &w2.b);
        put(&mut b, o3, 2, &w3.b);
        put(&mut b, ou, 3, &wu.b);
        let mut c = Mat::<f64>::zeros(3, n);
        put(&mut c, 0, 0, &(&we.d * &g.c));
        put(&mut c, 0, oe, &we.c);
        put(&mut c, 1, ou, &wu.c);
        put(&mut c, 2, 0, &g.c);
        let mut d = Mat::<f64>::zeros(3, 4);
        d[(1, 3)] = wu.d[(0, 0)];
        d[(2, 0)] = self.weights.sensor_noise;
        StateSpace::new(a, b, c, d, None).map_err(num_err)
    }

    /// The generalised plant `[w1 w2 w3 u] -> [W_e e, W_u u, y]`.
    pub fn generalized_plant(&self) -> Result<StateSpace, Ding22Error> {
        self.assemble(true)
    }

    /// The same interconnection without the performance weights:
    /// `[w1 w2 w3 u] -> [e, u, y]`.
    pub fn analysis_plant(&self) -> Result<StateSpace, Ding22Error> {
        self.assemble(false)
    }

    /// Mechanics with one structural parameter replaced.
    pub fn with_flexure(&self, k2: f64, c2: f64) -> Self {
        let mut p = *self;
        p.mech.k2 = k2;
        p.mech.c2 = c2;
        p
    }

    /// H2-optimal controller of [`Self::generalized_plant`] (`u = K y`).
    ///
    /// The measurement is synthesised in units of the sensor noise
    /// (`y' = y / W1`, so `D21 = [1 0 0]`) and the controller is scaled
    /// back (`K = K' / W1`): the optimal controller is invariant under this
    /// output scaling, but the filter Riccati equation is not equally well
    /// conditioned (with `W1 = 1.36e-12` its `R2 = W1^2` is 1.8e-24 in SI
    /// and the Hamiltonian solver fails). The closed loop reported in the
    /// result (`w -> z`) is the same either way.
    pub fn synthesise(&self) -> Result<H2Result, Ding22Error> {
        let mut p = self.generalized_plant()?;
        let s = 1.0 / self.weights.sensor_noise;
        let (n, m) = (p.nx(), p.nu());
        for j in 0..n {
            p.c[(2, j)] *= s;
        }
        for j in 0..m {
            p.d[(2, j)] *= s;
        }
        let mut r = h2syn(&p, 1, 1, 1e-6)?;
        for i in 0..r.k.nx() {
            r.k.b[(i, 0)] *= s;
        }
        for i in 0..r.k.ny() {
            r.k.d[(i, 0)] *= s;
        }
        Ok(r)
    }

    /// Closed-loop figures of any controller `K` (`u = K y`) on this problem.
    pub fn evaluate(&self, k: &StateSpace) -> Result<Evaluation, Ding22Error> {
        let pw = self.generalized_plant()?;
        let pa = self.analysis_plant()?;
        let clw = pw.lft(k).map_err(num_err)?.balanced();
        let cla = pa.lft(k).map_err(num_err)?.balanced();
        let stable = cla.is_stable().map_err(num_err)?;
        if !stable {
            return Ok(Evaluation::unstable(cla));
        }
        let cost = h2_norm(&clw).map_err(num)?;
        // Error channel (row 0) and control channel (row 1), all sources.
        let err = row(&cla, 0)?;
        let rms_per_source = exact_rms_per_source(&err, 0).map_err(num)?;
        let rms = h2_norm(&err).map_err(num)?;
        let u_rms = h2_norm(&row(&cla, 1)?).map_err(num)?;
        let bandwidth_hz = bandwidth_hz(&self.mech.plant()?, k)?;
        Ok(Evaluation {
            stable,
            cost,
            rms,
            rms_per_source,
            u_rms,
            bandwidth_hz,
            error_loop: err,
        })
    }
}

/// One output row of a system.
fn row(sys: &StateSpace, i: usize) -> Result<StateSpace, Ding22Error> {
    StateSpace::new(
        sys.a.clone(),
        sys.b.clone(),
        crate::lti::ss::sub(&sys.c, i, i + 1, 0, sys.nx()),
        crate::lti::ss::sub(&sys.d, i, i + 1, 0, sys.nu()),
        None,
    )
    .map_err(num_err)
}

/// Closed-loop figures of one controller.
#[derive(Debug, Clone)]
pub struct Evaluation {
    pub stable: bool,
    /// The H2 cost `||[W_e e; W_u u]||_2` (what the H2 design minimises).
    pub cost: f64,
    /// RMS of the tool error `e` (m): `||T_ew||_2`.
    pub rms: f64,
    /// Per-source RMS (m), `sum rms_i^2 = rms^2`.
    pub rms_per_source: Vec<f64>,
    /// RMS of the actuator force (N).
    pub u_rms: f64,
    /// Closed-loop bandwidth (Hz): first frequency where `|T| = |G K/(1 - G K)|`
    /// falls below `1/sqrt 2`.
    pub bandwidth_hz: f64,
    /// Closed loop `[w1 w2 w3] -> e` (balanced).
    pub error_loop: StateSpace,
}

impl Evaluation {
    fn unstable(cl: StateSpace) -> Self {
        Self {
            stable: false,
            cost: f64::INFINITY,
            rms: f64::INFINITY,
            rms_per_source: vec![f64::INFINITY; 3],
            u_rms: f64::INFINITY,
            bandwidth_hz: f64::NAN,
            error_loop: cl,
        }
    }
}

/// `-3 dB` frequency of the complementary sensitivity `T = L/(1 + L)`,
/// `L = -G_F K` (force-to-tool plant, `u = K y`), found on a log grid and
/// refined by bisection.
pub fn bandwidth_hz(plant: &StateSpace, k: &StateSpace) -> Result<f64, Ding22Error> {
    let t = |f: f64| -> Result<f64, Ding22Error> {
        let w = 2.0 * PI * f;
        let g = plant.freq_response(w).map_err(num_err)?[(0, 0)];
        let kk = k.freq_response(w).map_err(num_err)?[(0, 0)];
        let l = -g * kk;
        Ok((l / (c64::new(1.0, 0.0) + l)).norm())
    };
    let lim = 0.5f64.sqrt();
    let grid = logspace(1e-2, 1e7, 1801);
    let mut prev = grid[0];
    if t(prev)? < lim {
        return Ok(0.0);
    }
    for &f in &grid[1..] {
        if t(f)? < lim {
            let (mut lo, mut hi) = (prev, f);
            for _ in 0..60 {
                let mid = (lo * hi).sqrt();
                if t(mid)? < lim {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return Ok((lo * hi).sqrt());
        }
        prev = f;
    }
    Ok(f64::INFINITY)
}

/// Parallel PID with a filtered derivative and a first-order roll-off,
/// `C(s) = (kp + ki/s + kd s/(tau s + 1)) / (tau s + 1)`, acting on `r - y`;
/// as a controller of the generalised plant `K = -C`. The roll-off makes `C`
/// strictly proper: with white sensor noise a biproper controller would
/// give the force (and so `W_u u`, whose `W_u` is biproper) infinite
/// variance, i.e. an infinite H2 cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidBaseline {
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    pub tau: f64,
}

impl PidBaseline {
    /// `K = -C` in state space (states: integrator, derivative filter, roll-off).
    pub fn controller(&self) -> Result<StateSpace, Ding22Error> {
        let (kp, ki, kd, tau) = (self.kp, self.ki, self.kd, self.tau);
        let pid = StateSpace::new(
            Mat::from_fn(2, 2, |i, j| if i == 1 && j == 1 { -1.0 / tau } else { 0.0 }),
            Mat::from_fn(2, 1, |i, _| if i == 0 { 1.0 } else { 1.0 / tau }),
            Mat::from_fn(1, 2, |_, j| if j == 0 { -ki } else { kd / tau }),
            Mat::from_fn(1, 1, |_, _| -(kp + kd / tau)),
            None,
        )
        .map_err(num_err)?;
        let roll = tf1(&[1.0], &[tau, 1.0])?;
        pid.series(&roll).map_err(num_err)
    }
}

/// Nelder–Mead on `f` from `x0` with initial steps `step` (minimisation).
fn nelder_mead(f: &mut dyn FnMut(&[f64]) -> f64, x0: &[f64], step: f64, iters: usize) -> Vec<f64> {
    let n = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = (0..=n)
        .map(|i| {
            let mut x = x0.to_vec();
            if i > 0 {
                x[i - 1] += step;
            }
            let v = f(&x);
            (x, v)
        })
        .collect();
    let key = |v: f64| if v.is_nan() { f64::INFINITY } else { v };
    for _ in 0..iters {
        simplex.sort_by(|a, b| key(a.1).total_cmp(&key(b.1)));
        let spread = key(simplex[n].1) - key(simplex[0].1);
        if spread.is_finite() && spread <= 1e-10 * key(simplex[0].1).abs() {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|j| simplex[..n].iter().map(|s| s.0[j]).sum::<f64>() / n as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            (0..n)
                .map(|j| centroid[j] + t * (simplex[n].0[j] - centroid[j]))
                .collect()
        };
        let xr = along(-1.0);
        let fr = key(f(&xr));
        if fr < key(simplex[0].1) {
            let xe = along(-2.0);
            let fe = key(f(&xe));
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < key(simplex[n - 1].1) {
            simplex[n] = (xr, fr);
        } else {
            let xc = along(0.5);
            let fc = key(f(&xc));
            if fc < key(simplex[n].1) {
                simplex[n] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    let x: Vec<f64> = (0..n).map(|j| 0.5 * (best[j] + s.0[j])).collect();
                    let v = key(f(&x));
                    *s = (x, v);
                }
            }
        }
    }
    simplex.sort_by(|a, b| key(a.1).total_cmp(&key(b.1)));
    simplex[0].0.clone()
}

/// PID baseline tuned for the *same* H2 cost as the optimal design: a grid
/// of loop-shaping seeds (integral crossover at a fraction of the first
/// mode, proportional/derivative gains fractions of `k2`, filter and
/// roll-off at 10x the second mode), then Nelder–Mead on
/// `log(kp, ki, kd, tau)` minimising `||[W_e e; W_u u]||_2` (unstable loops
/// cost infinity). Several seeds; the best result is kept.
pub fn tune_pid(problem: &Ding22Problem) -> Result<(PidBaseline, Evaluation), Ding22Error> {
    let pw = problem.generalized_plant()?;
    let [w1, w2] = problem.mech.natural_frequencies();
    let k2 = problem.mech.k2;
    let mut cost = |x: &[f64]| -> f64 {
        let pid = PidBaseline {
            kp: x[0].exp(),
            ki: x[1].exp(),
            kd: x[2].exp(),
            tau: x[3].exp(),
        };
        let Ok(k) = pid.controller() else {
            return f64::INFINITY;
        };
        match pw.lft(&k).map(|c| c.balanced()) {
            Ok(cl) if cl.is_stable().unwrap_or(false) => h2_norm(&cl).unwrap_or(f64::INFINITY),
            _ => f64::INFINITY,
        }
    };
    // Seeds: integral crossover at frac * w1 on the compliance 1/k2,
    // proportional and derivative gains a fraction of k2; the two best
    // stabilising seeds are refined.
    let mut seeds: Vec<(Vec<f64>, f64)> = Vec::new();
    for frac in [0.01, 0.03, 0.1, 0.3] {
        for kpf in [1e-3, 1e-2, 1e-1, 1.0] {
            let x0 = vec![
                (kpf * k2).ln(),
                (frac * w1 * k2).ln(),
                (kpf * k2 / w2).ln(),
                (1.0 / (10.0 * w2)).ln(),
            ];
            let v = cost(&x0);
            if v.is_finite() {
                seeds.push((x0, v));
            }
        }
    }
    seeds.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut best: Option<(Vec<f64>, f64)> = None;
    for (x0, _) in seeds.into_iter().take(2) {
        let mut x = nelder_mead(&mut cost, &x0, 1.0, 800);
        x = nelder_mead(&mut cost, &x, 0.2, 800);
        let v = cost(&x);
        if best.as_ref().is_none_or(|b| v < b.1) {
            best = Some((x, v));
        }
    }
    let (x, _) = best
        .ok_or_else(|| Ding22Error::Numerical("no stabilising PID seed for this plant".into()))?;
    let pid = PidBaseline {
        kp: x[0].exp(),
        ki: x[1].exp(),
        kd: x[2].exp(),
        tau: x[3].exp(),
    };
    let ev = problem.evaluate(&pid.controller()?)?;
    Ok((pid, ev))
}

/// Frequency grid of the budget (Hz): `0`, a log grid from `1e-3` Hz to
/// `fmax`, and 81 extra points across each lightly damped pole of `cl`
/// (`|Im| +- 10 |Re|`), sorted and deduplicated.
pub fn budget_grid(cl: &StateSpace, fmax: f64, points: usize) -> Result<Vec<f64>, Ding22Error> {
    let mut f = vec![0.0];
    f.extend(logspace(1e-3, fmax, points.max(2)));
    for p in cl.poles().map_err(num_err)? {
        let (wr, wi) = (p.re.abs(), p.im.abs());
        if wi > 0.0 && wr < 0.2 * wi {
            for k in -40..=40 {
                let w = wi + 0.25 * k as f64 * wr;
                let fh = w / (2.0 * PI);
                if fh > 0.0 && fh < fmax {
                    f.push(fh);
                }
            }
        }
    }
    f.sort_by(f64::total_cmp);
    f.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs().max(1e-300));
    Ok(f)
}

/// Budget of the error channel on [`budget_grid`].
pub fn budget(ev: &Evaluation, fmax: f64, points: usize) -> Result<ErrorBudget, Ding22Error> {
    let grid = budget_grid(&ev.error_loop, fmax, points)?;
    error_budget(&ev.error_loop, 0, &grid)
        .ok_or_else(|| Ding22Error::Numerical("frequency response failed".into()))
}

/// The optimal design and its baseline.
#[derive(Debug, Clone)]
pub struct Design {
    pub problem: Ding22Problem,
    pub h2: H2Result,
    pub optimal: Evaluation,
}

/// Synthesises and evaluates.
pub fn design(problem: &Ding22Problem) -> Result<Design, Ding22Error> {
    let h2 = problem.synthesise()?;
    if !h2.stable {
        return Err(Ding22Error::Numerical(
            "the H2 controller does not stabilise the plant (numerical failure)".into(),
        ));
    }
    let optimal = problem.evaluate(&h2.k)?;
    Ok(Design {
        problem: *problem,
        h2,
        optimal,
    })
}

/// Result of the structural sweep.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub k2: Vec<f64>,
    pub c2: Vec<f64>,
    /// `rms[i][j]` at `(k2[i], c2[j])` (m; infinity where the synthesis failed).
    pub rms: Vec<Vec<f64>>,
    /// H2 cost at each point.
    pub cost: Vec<Vec<f64>>,
    /// Index of the smallest RMS.
    pub best: (usize, usize),
    /// Whether the best point is strictly inside the grid in both directions
    /// (a direction with fewer than 3 points is never interior).
    pub interior: bool,
}

/// Re-synthesises the H2 controller at every `(k2, c2)` and records the
/// error RMS; `progress(done, total)` after each point.
pub fn sweep(
    problem: &Ding22Problem,
    k2: &[f64],
    c2: &[f64],
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Sweep, Ding22Error> {
    if k2.is_empty() || c2.is_empty() {
        return Err(Ding22Error::Param("the sweep grid is empty".into()));
    }
    let total = k2.len() * c2.len();
    let mut rms = vec![vec![f64::INFINITY; c2.len()]; k2.len()];
    let mut cost = rms.clone();
    for (i, &k) in k2.iter().enumerate() {
        for (j, &c) in c2.iter().enumerate() {
            let p = problem.with_flexure(k, c);
            p.mech.validate()?;
            if let Ok(d) = design(&p) {
                rms[i][j] = d.optimal.rms;
                cost[i][j] = d.optimal.cost;
            }
            progress(i * c2.len() + j + 1, total);
        }
    }
    let mut best = (0, 0);
    for i in 0..k2.len() {
        for j in 0..c2.len() {
            if rms[i][j] < rms[best.0][best.1] {
                best = (i, j);
            }
        }
    }
    if !rms[best.0][best.1].is_finite() {
        return Err(Ding22Error::Numerical(
            "the synthesis failed at every grid point".into(),
        ));
    }
    let inside = |i: usize, n: usize| n >= 3 && i > 0 && i + 1 < n;
    Ok(Sweep {
        interior: inside(best.0, k2.len()) && inside(best.1, c2.len()),
        k2: k2.to_vec(),
        c2: c2.to_vec(),
        rms,
        cost,
        best,
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn dc_compliance_and_transmissibility() {
        let g = TwoMassParams::default().plant().unwrap();
        let dc = g.dc_gain().unwrap();
        assert!((dc[(0, 0)] * 21965.0 - 1.0).abs() < 1e-12);
        assert!((dc[(0, 1)] - 1.0).abs() < 1e-12);
    }

    pub fn weights_have_their_corner_gains() {
        let w = Ding22Weights::default();
        let we = w.we().unwrap();
        assert!((we.dc_gain().unwrap()[(0, 0)] - 1e7).abs() < 1e-3);
        let wu = w.wu().unwrap();
        // The canonical realisation forms 1 - (1e8 - 1)/1e8: ~1e-16 absolute.
        assert!((wu.dc_gain().unwrap()[(0, 0)] - 1e-8).abs() < 1e-15);
        assert!((wu.d[(0, 0)] - 1.0).abs() < 1e-15);
        // |W3(j w)| = 2.83e-9 |jw - 2000 pi| / |jw + d|.
        let w3 = w.w3().unwrap();
        let om = 100.0;
        let want = 2.83e-9 * (om * om + (2000.0 * PI).powi(2)).sqrt()
            / (om * om + w.shift * w.shift).sqrt();
        assert!((w3.sigma_at(om) / want - 1.0).abs() < 1e-12);
        // W2 peaks by 20x (0.1/0.005) at its resonance, times the lag factor.
        let w2 = w.w2().unwrap();
        let wr = w.current_w;
        let lag = (wr * wr + (200.0 * PI).powi(2)).sqrt() / (wr * wr + w.shift.powi(2)).sqrt();
        assert!((w2.sigma_at(wr) / (1.64e-7 * 20.0 * lag) - 1.0).abs() < 1e-9);
    }

    pub fn bad_parameters_are_rejected() {
        let mut m = TwoMassParams {
            m12: -1.0,
            ..TwoMassParams::default()
        };
        assert!(matches!(m.plant(), Err(Ding22Error::Param(_))));
        m.m12 = 0.074;
        m.c4 = f64::NAN;
        assert!(m.validate().is_err());
    }
}
