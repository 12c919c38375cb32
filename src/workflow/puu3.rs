//! `fts mechanism 3puu-track`: three-axis control of \[Tang17\]'s 3-PUU
//! stage (docs/mechanism.md "Three-axis control"). A task-space reference
//! `(x, y, z)` goes through the exact inverse kinematics (\[Tang17\] Eq.
//! 2-4) to the three slider references; each slider is a copy of the
//! \[Tang17\] joint plant (`fixtures/tang17-3puu.json`) under its PID, the
//! three simulated together; the measured sliders come back to task space
//! through the forward kinematics ([`Puu3::forward`], Newton).
//!
//! Two ways to close the loops:
//!
//! * `joint`: decoupled per-joint loops, `u_i = PID(q_ref,i - q_i)`;
//! * `task`: one PID per task axis on `e = p_ref - FK(q)`, its outputs
//!   mapped to the three joint commands by `J = dS/dp` at home (\[Tang17\]
//!   Eq. 5-7: the inverse of the forward Jacobian `dp/dS`, so this is the
//!   `J^-1` mapping of task-space control). For small motions
//!   `q_ref - q = J (p_ref - p)` to first order and the PID is linear, so
//!   both laws give the same commands.

use super::{StepError, Validate, positive};
use crate::runtime::{PidSpec, pid_step};
use crate::sim::virtual_fts::{VirtualFts, VirtualFtsParams};
use crate::synth::mechanism::Puu3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::fmt;

/// The \[Tang17\] joint plant, `fixtures/tang17-3puu.json`.
pub const TANG17_3PUU_JSON: &str = include_str!("../../fixtures/tang17-3puu.json");

/// Seconds before the profile: the sliders ramp from rest (0 um) to the
/// profile's first pose over the first half, then hold.
pub const LEAD_IN_S: f64 = 1.0;

/// Samples of a run at most (lead-in included): the trace keeps 16
/// numbers a sample.
pub const MAX_SAMPLES: usize = 2_000_000;

/// One `(x, y, z)` or slider triple per sample.
type Points = Vec<[f64; 3]>;

/// How the three loops are closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ControlMode {
    /// Decoupled per-joint PIDs on the slider errors.
    #[default]
    Joint,
    /// PIDs on the task-space errors, mapped to joint commands through `J`.
    Task,
}

/// What each joint is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum JointModel {
    /// The virtual FTS of `plant` under the PID.
    #[default]
    Plant,
    /// Ideal (unit) joint loops: each slider is where its reference is.
    Ideal,
}

/// Settings of a three-axis tracking run (lengths in um unless named).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Puu3Track {
    /// `joint` (default) or `task`.
    pub mode: ControlMode,
    /// `plant` (default) or `ideal` (unit joint loops, `joint` mode only).
    pub joints: JointModel,
    /// The joint plant; default the \[Tang17\] one (`fixtures/tang17-3puu.json`).
    pub plant: Option<VirtualFtsParams>,
    /// PID gains per sample, V/um; default \[Tang17\]'s printed
    /// `Kp 0.01, Ki 60 /s, Kd 1e-5 s` at 1 ms: 0.01, 0.06, 0.01.
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    /// Centre of the profile from home, um; default 0, 0, 0.
    pub center_um: [f64; 3],
    /// Amplitudes `(a_x, a_y, a_z)`: `x = c_x + a_x cos(w t)`,
    /// `y = c_y + a_y sin(w t)`, `z = c_z + a_z sin(w t)`; default 20, 20,
    /// 0 (a 20 um circle in the x-y plane).
    pub amplitude_um: [f64; 3],
    /// Profile frequency, Hz; default 1.
    pub freq: f64,
    /// Profile length, s; default 3.
    pub duration: f64,
    /// Errors are evaluated from this long into the profile, s; default 1.
    pub settle: f64,
    /// Slider displacement at home, um; default 65 (mid-range of the
    /// joint plant, which reaches about 11 to 121 um).
    pub home_um: f64,
    /// Slider travel allowed either side of home, um; default 50.
    pub travel_um: f64,
    /// Geometry, mm; default \[Tang17\]'s `L = 60`, `r = 70`, `r_a = 27`.
    pub rod_mm: f64,
    pub base_radius_mm: f64,
    pub platform_radius_mm: f64,
}

impl Default for Puu3Track {
    fn default() -> Self {
        let g = Puu3::default();
        Puu3Track {
            mode: ControlMode::Joint,
            joints: JointModel::Plant,
            plant: None,
            kp: 0.01,
            ki: 0.06,
            kd: 0.01,
            center_um: [0.0; 3],
            amplitude_um: [20.0, 20.0, 0.0],
            freq: 1.0,
            duration: 3.0,
            settle: 1.0,
            home_um: 65.0,
            travel_um: 50.0,
            rod_mm: g.rod,
            base_radius_mm: g.base_radius,
            platform_radius_mm: g.platform_radius,
        }
    }
}

fn finite(field: &'static str, x: f64) -> Result<(), StepError> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(StepError::setting(
            field,
            format!("expected a finite number, got {x}"),
        ))
    }
}

impl Validate for Puu3Track {
    fn validate(&self) -> Result<(), StepError> {
        for (f, v) in [("kp", self.kp), ("ki", self.ki), ("kd", self.kd)] {
            finite(f, v)?;
        }
        for v in self.center_um {
            finite("center_um", v)?;
        }
        for v in self.amplitude_um {
            finite("amplitude_um", v)?;
        }
        positive("freq", self.freq)?;
        positive("duration", self.duration)?;
        positive("travel_um", self.travel_um)?;
        positive("rod_mm", self.rod_mm)?;
        positive("base_radius_mm", self.base_radius_mm)?;
        positive("platform_radius_mm", self.platform_radius_mm)?;
        self.check_times()?;
        if let Some(p) = &self.plant {
            p.validate()
                .map_err(|e| StepError::setting("plant", e.to_string()))?;
        }
        if self.joints == JointModel::Ideal && self.mode == ControlMode::Task {
            return Err(StepError::setting(
                "joints",
                "ideal joint loops follow joint references: use them with `mode` joint",
            ));
        }
        Ok(())
    }
}

impl Puu3Track {
    fn check_times(&self) -> Result<(), StepError> {
        if self.duration > 600.0 {
            return Err(StepError::setting(
                "duration",
                format!("expected at most 600 s, got {}", self.duration),
            ));
        }
        if !(self.settle.is_finite() && self.settle >= 0.0 && self.settle < self.duration) {
            return Err(StepError::setting(
                "settle",
                format!(
                    "expected 0 or more s and less than `duration` ({} s), got {}",
                    self.duration, self.settle
                ),
            ));
        }
        if !(self.home_um.is_finite() && self.home_um >= 0.0) {
            return Err(StepError::setting(
                "home_um",
                format!("expected 0 or more um, got {}", self.home_um),
            ));
        }
        Ok(())
    }

    fn geometry(&self) -> Puu3 {
        Puu3 {
            rod: self.rod_mm,
            base_radius: self.base_radius_mm,
            platform_radius: self.platform_radius_mm,
        }
    }

    fn plant_params(&self) -> VirtualFtsParams {
        self.plant.clone().unwrap_or_else(tang17_joint_plant)
    }

    /// The task reference at `t`, um from home: the lead-in ramp from rest
    /// (every slider at 0, the pose `(0, 0, -home)`) to the profile's first
    /// pose, then the profile.
    pub fn reference(&self, t: f64) -> [f64; 3] {
        let profile = |tau: f64| {
            let (s, c) = (2.0 * PI * self.freq * tau).sin_cos();
            let [cx, cy, cz] = self.center_um;
            let [ax, ay, az] = self.amplitude_um;
            [cx + ax * c, cy + ay * s, cz + az * s]
        };
        if t >= LEAD_IN_S {
            return profile(t - LEAD_IN_S);
        }
        let ramp = 0.5 * (1.0 - (PI * (t / (0.5 * LEAD_IN_S)).min(1.0)).cos());
        let start = profile(0.0);
        let rest = [0.0, 0.0, -self.home_um];
        [0, 1, 2].map(|i| rest[i] + ramp * (start[i] - rest[i]))
    }
}

/// The \[Tang17\] joint plant (the embedded fixture).
pub fn tang17_joint_plant() -> VirtualFtsParams {
    serde_json::from_str(TANG17_3PUU_JSON).expect("the embedded fixture is valid")
}

/// Kinematics in the units of the run: poses and slider displacements in
/// um, the home pose at the origin with every slider at `home_um`.
#[derive(Debug, Clone, Copy)]
pub struct Kinematics {
    geometry: Puu3,
    home_mm: [f64; 3],
    home_um: f64,
}

impl Kinematics {
    /// `None` when the home pose is out of reach of the rods.
    pub fn new(geometry: Puu3, home_um: f64) -> Option<Self> {
        let home_mm = geometry.inverse(0.0, 0.0, 0.0)?;
        Some(Kinematics {
            geometry,
            home_mm,
            home_um,
        })
    }

    /// Slider displacements for pose `p` (um): \[Tang17\] Eq. 2-4.
    pub fn joints(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let s = self
            .geometry
            .inverse(p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3)?;
        Some([0, 1, 2].map(|i| (s[i] - self.home_mm[i]) * 1e3 + self.home_um))
    }

    /// The pose of slider displacements `q` (um), by Newton.
    pub fn pose(&self, q: [f64; 3]) -> Option<[f64; 3]> {
        let s = [0, 1, 2].map(|i| self.home_mm[i] + (q[i] - self.home_um) * 1e-3);
        Some(self.geometry.forward(s)?.map(|v| v * 1e3))
    }

    /// `J = dS/dp` at home (dimensionless).
    pub fn home_jacobian(&self) -> [[f64; 3]; 3] {
        self.geometry
            .jacobian(0.0, 0.0)
            .expect("the home pose is reachable")
    }
}

/// Per-axis error figures over the evaluated window, um.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AxisError {
    /// Commanded amplitude, um (0: not commanded, its error is cross-coupling).
    pub amplitude_um: f64,
    pub rms_um: f64,
    pub max_um: f64,
}

/// The simulated signals, one entry per sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Puu3Trace {
    pub t: Vec<f64>,
    /// Task reference and measured pose, um.
    pub reference: Vec<[f64; 3]>,
    pub pose: Vec<[f64; 3]>,
    /// Slider references and measurements, um; commands, V.
    pub joint_reference: Vec<[f64; 3]>,
    pub joint: Vec<[f64; 3]>,
    pub command: Vec<[f64; 3]>,
}

/// What [`Puu3Track`] reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Puu3TrackReport {
    /// The inputs (the plant as run).
    pub inputs: Puu3Track,
    /// Sample time, s.
    pub ts: f64,
    /// First evaluated sample's time, s, and the number evaluated.
    pub evaluated_from_s: f64,
    pub evaluated_samples: usize,
    /// Task-space errors x, y, z.
    pub task: [AxisError; 3],
    /// Slider errors (reference minus measurement), um: rms and max.
    pub joint_rms_um: [f64; 3],
    pub joint_max_um: [f64; 3],
    /// The largest error of an axis not commanded over the largest
    /// commanded amplitude, % (`None` when every axis is commanded).
    pub cross_coupling_percent: Option<f64>,
    /// Evaluated samples at which a joint command sat on its limit.
    pub saturated_samples: usize,
    /// The signals.
    #[serde(skip)]
    pub trace: Puu3Trace,
}

/// One sample's feedback: the joint commands from the references and the
/// measurements.
enum Law {
    /// Per-joint PID states: integral, previous measurement.
    Joint {
        spec: PidSpec,
        state: [(f64, Option<f64>); 3],
    },
    /// Task-space PID states and the map to the joints.
    Task {
        spec: PidSpec,
        integral: [f64; 3],
        previous: Option<[f64; 3]>,
        j: [[f64; 3]; 3],
    },
}

impl Law {
    /// The three joint commands, V.
    fn step(&mut self, q_ref: [f64; 3], q: [f64; 3], p_ref: [f64; 3], p: [f64; 3]) -> [f64; 3] {
        match self {
            Law::Joint { spec, state } => [0, 1, 2]
                .map(|i| pid_step(spec, &mut state[i].0, &mut state[i].1, q_ref[i], q[i], 0.0)),
            Law::Task {
                spec,
                integral,
                previous,
                j,
            } => {
                let e = [0, 1, 2].map(|i| p_ref[i] - p[i]);
                let last = previous.unwrap_or(p);
                *previous = Some(p);
                let candidate = [0, 1, 2].map(|i| integral[i] + spec.ki * e[i]);
                // The task-space PID's output v, then u = J v (Tang17 Eq. 5-7).
                let v =
                    [0, 1, 2].map(|i| spec.kp * e[i] + candidate[i] - spec.kd * (p[i] - last[i]));
                let u = j.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2]);
                let clamped = u.map(|x| x.clamp(spec.output_min, spec.output_max));
                // Conditional integration: hold the integrals while a joint saturates.
                if clamped == u {
                    *integral = candidate;
                }
                clamped
            }
        }
    }
}

impl Puu3Track {
    /// Runs the three loops together and evaluates the errors.
    pub fn run(&self) -> Result<Puu3TrackReport, StepError> {
        self.validate()?;
        let kin = Kinematics::new(self.geometry(), self.home_um).ok_or_else(|| {
            StepError::setting(
                "rod_mm",
                "the rods cannot reach the home pose: need L > r - r_a",
            )
        })?;
        let params = self.plant_params();
        let ts = params.ts;
        if self.freq > 0.5 / ts {
            return Err(StepError::setting(
                "freq",
                format!(
                    "{} Hz is above Nyquist ({} Hz at Ts {ts} s)",
                    self.freq,
                    0.5 / ts
                ),
            ));
        }
        let samples = (LEAD_IN_S + self.duration) / ts;
        if samples > MAX_SAMPLES as f64 {
            return Err(StepError::setting(
                "duration",
                format!(
                    "{} s is {samples:.0} samples at Ts {ts} s (with the 1 s lead-in): at most 2e6",
                    self.duration
                ),
            ));
        }
        let n = samples.round() as usize + 1;
        let (task, joints) = self.references(&kin, ts, n)?;
        let trace = self.simulate(&kin, &params, task, joints)?;
        Ok(self.report(trace, &params))
    }

    /// The task references and their slider references; a profile pose
    /// outside the workspace is refused.
    fn references(
        &self,
        kin: &Kinematics,
        ts: f64,
        n: usize,
    ) -> Result<(Points, Points), StepError> {
        let mut task = Vec::with_capacity(n);
        let mut joints = Vec::with_capacity(n);
        for k in 0..n {
            let t = k as f64 * ts;
            let p = self.reference(t);
            let q = kin.joints(p).filter(|q| {
                t < LEAD_IN_S || q.iter().all(|v| (v - self.home_um).abs() <= self.travel_um)
            });
            let Some(q) = q else {
                return Err(self.outside(kin, t, p));
            };
            task.push(p);
            joints.push(q);
        }
        Ok((task, joints))
    }

    /// The refusal of a pose outside the workspace.
    fn outside(&self, kin: &Kinematics, t: f64, p: [f64; 3]) -> StepError {
        let why = match kin.joints(p) {
            Some(q) => format!(
                "needs sliders at {:.3}, {:.3}, {:.3} um, beyond home {} +- `travel_um` {} um",
                q[0], q[1], q[2], self.home_um, self.travel_um
            ),
            None => "a rod cannot reach it".into(),
        };
        StepError::input(format!(
            "the reference leaves the workspace at t = {:.4} s: (x, y, z) = ({:.3}, {:.3}, {:.3}) um {why} (`center_um`, `amplitude_um`)",
            t - LEAD_IN_S,
            p[0],
            p[1],
            p[2]
        ))
    }

    fn law(&self, kin: &Kinematics, params: &VirtualFtsParams) -> Law {
        let spec = PidSpec {
            kp: self.kp,
            ki: self.ki,
            kd: self.kd,
            output_min: params.amplifier.input_min_v,
            output_max: params.amplifier.input_max_v,
        };
        match self.mode {
            ControlMode::Joint => Law::Joint {
                spec,
                state: [(0.0, None); 3],
            },
            ControlMode::Task => Law::Task {
                spec,
                integral: [0.0; 3],
                previous: None,
                j: kin.home_jacobian(),
            },
        }
    }

    /// The three joints under `law`, sample by sample.
    fn simulate(
        &self,
        kin: &Kinematics,
        params: &VirtualFtsParams,
        task: Vec<[f64; 3]>,
        joints: Vec<[f64; 3]>,
    ) -> Result<Puu3Trace, StepError> {
        let mut plants = (0..3u64)
            .map(|i| {
                let mut p = params.clone();
                p.seed = p.seed.wrapping_add(i);
                VirtualFts::new(p).map_err(|e| StepError::setting("plant", e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut law = self.law(kin, params);
        let mut trace = Puu3Trace::default();
        for (k, (p_ref, q_ref)) in task.into_iter().zip(joints).enumerate() {
            let t = k as f64 * params.ts;
            let q = match self.joints {
                JointModel::Ideal => q_ref,
                JointModel::Plant => [0, 1, 2].map(|i| plants[i].measure()),
            };
            let p = kin
                .pose(q)
                .filter(|p| p.iter().all(|v| v.abs() < 1e6))
                .ok_or_else(|| {
                    StepError::computation(format!(
                        "the loops diverged at t = {t:.4} s: sliders at {:.4e}, {:.4e}, {:.4e} um have no pose",
                        q[0], q[1], q[2]
                    ))
                })?;
            let u = match self.joints {
                JointModel::Ideal => [0.0; 3],
                JointModel::Plant => law.step(q_ref, q, p_ref, p),
            };
            for (plant, ui) in plants.iter_mut().zip(u) {
                plant.advance(ui);
            }
            trace.t.push(t);
            trace.reference.push(p_ref);
            trace.pose.push(p);
            trace.joint_reference.push(q_ref);
            trace.joint.push(q);
            trace.command.push(u);
        }
        Ok(trace)
    }

    fn report(&self, trace: Puu3Trace, params: &VirtualFtsParams) -> Puu3TrackReport {
        let from = LEAD_IN_S + self.settle;
        let k0 = trace.t.iter().position(|&t| t >= from - 1e-9).unwrap_or(0);
        let stats = |e: &dyn Fn(usize) -> f64| {
            let m = trace.t.len() - k0;
            let (mut sq, mut max) = (0.0, 0.0f64);
            for k in k0..trace.t.len() {
                let v = e(k);
                sq += v * v;
                max = max.max(v.abs());
            }
            ((sq / m as f64).sqrt(), max)
        };
        let task = [0, 1, 2].map(|i| {
            let (rms_um, max_um) = stats(&|k| trace.reference[k][i] - trace.pose[k][i]);
            AxisError {
                amplitude_um: self.amplitude_um[i],
                rms_um,
                max_um,
            }
        });
        let joint = [0, 1, 2].map(|i| stats(&|k| trace.joint_reference[k][i] - trace.joint[k][i]));
        let (lo, hi) = (params.amplifier.input_min_v, params.amplifier.input_max_v);
        let saturated_samples = match self.joints {
            JointModel::Ideal => 0,
            JointModel::Plant => trace.command[k0..]
                .iter()
                .filter(|u| u.iter().any(|&v| v <= lo || v >= hi))
                .count(),
        };
        let largest = self.amplitude_um.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        let cross = task
            .iter()
            .filter(|a| a.amplitude_um == 0.0)
            .map(|a| a.max_um)
            .reduce(f64::max)
            .filter(|_| largest > 0.0)
            .map(|m| 100.0 * m / largest);
        Puu3TrackReport {
            inputs: Puu3Track {
                plant: Some(params.clone()),
                ..self.clone()
            },
            ts: params.ts,
            evaluated_from_s: trace.t[k0] - LEAD_IN_S,
            evaluated_samples: trace.t.len() - k0,
            task,
            joint_rms_um: joint.map(|j| j.0),
            joint_max_um: joint.map(|j| j.1),
            cross_coupling_percent: cross,
            saturated_samples,
            trace,
        }
    }
}

impl Puu3TrackReport {
    /// The trace as CSV: `t` (s, from the profile's start), the task
    /// reference and pose (um), the slider references and measurements
    /// (um) and the commands (V).
    pub fn trace_csv(&self) -> String {
        let tr = &self.trace;
        let col = |v: &[[f64; 3]], i: usize| -> Vec<f64> { v.iter().map(|r| r[i]).collect() };
        let t: Vec<f64> = tr.t.iter().map(|t| t - LEAD_IN_S).collect();
        let mut columns = vec![t];
        for v in [
            &tr.reference,
            &tr.pose,
            &tr.joint_reference,
            &tr.joint,
            &tr.command,
        ] {
            for i in 0..3 {
                columns.push(col(v, i));
            }
        }
        let names = [
            "t", "x_ref", "y_ref", "z_ref", "x", "y", "z", "q1_ref", "q2_ref", "q3_ref", "q1",
            "q2", "q3", "u1", "u2", "u3",
        ];
        let refs: Vec<&[f64]> = columns.iter().map(Vec::as_slice).collect();
        crate::io::timeseries::write_csv(&names, &refs)
    }
}

impl fmt::Display for Puu3TrackReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let i = &self.inputs;
        let law = match (i.mode, i.joints) {
            (_, JointModel::Ideal) => "ideal (unit) joint loops",
            (ControlMode::Joint, _) => "joint space (a PID per slider, decoupled)",
            (ControlMode::Task, _) => "task space (a PID per axis, u = J v)",
        };
        writeln!(
            f,
            "[Tang17] 3-PUU, three axes: {law}; inverse kinematics to the sliders, Newton forward kinematics back"
        )?;
        let [cx, cy, cz] = i.center_um;
        let [ax, ay, az] = i.amplitude_um;
        writeln!(
            f,
            "  reference (um from home): x = {cx} + {ax} cos, y = {cy} + {ay} sin, z = {cz} + {az} sin at {} Hz, {} s; evaluated from t = {:.3} s ({} samples, Ts {} s)",
            i.freq, i.duration, self.evaluated_from_s, self.evaluated_samples, self.ts
        )?;
        writeln!(
            f,
            "  PID kp {}, ki {}, kd {} (V/um, per sample); sliders home {} um, travel +-{} um",
            i.kp, i.ki, i.kd, i.home_um, i.travel_um
        )?;
        for (name, a) in ["x", "y", "z"].iter().zip(&self.task) {
            let what = if a.amplitude_um == 0.0 {
                "not commanded: cross-coupling".to_string()
            } else {
                format!("amplitude {} um", a.amplitude_um)
            };
            writeln!(
                f,
                "  {name} error: rms {:.4} um, max {:.4} um ({what})",
                a.rms_um, a.max_um
            )?;
        }
        let j = |v: [f64; 3]| format!("{:.4}, {:.4}, {:.4}", v[0], v[1], v[2]);
        writeln!(
            f,
            "  slider errors: rms {} um; max {} um",
            j(self.joint_rms_um),
            j(self.joint_max_um)
        )?;
        if let Some(c) = self.cross_coupling_percent {
            writeln!(f, "  cross-coupling: {c:.4} % of the largest amplitude")?;
        }
        if self.saturated_samples > 0 {
            writeln!(
                f,
                "  warning: a joint command sat on its limits for {} samples",
                self.saturated_samples
            )?;
        }
        Ok(())
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn short(mode: ControlMode, amplitude_um: [f64; 3]) -> Puu3Track {
        Puu3Track {
            mode,
            amplitude_um,
            duration: 1.0,
            settle: 0.5,
            ..Puu3Track::default()
        }
    }

    /// Slider references from the inverse kinematics, poses back by Newton:
    /// with unit joint loops every task error is rounding.
    pub fn ideal_joint_loops_track_exactly() {
        let r = Puu3Track {
            joints: JointModel::Ideal,
            amplitude_um: [20.0, 15.0, 10.0],
            ..short(ControlMode::Joint, [0.0; 3])
        }
        .run()
        .unwrap();
        for a in &r.task {
            assert!(a.max_um < 1e-8, "{a:?}");
        }
        assert_eq!(r.saturated_samples, 0);
        // The references are the kinematics': joints(pose(q)) = q.
        let kin = Kinematics::new(Puu3::default(), 65.0).unwrap();
        let q = r.trace.joint_reference[1500];
        let back = kin.joints(kin.pose(q).unwrap()).unwrap();
        assert!(q.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-8));
    }

    /// For small motions the task-space law is the joint-space one: the
    /// poses of the two runs differ by far less than their errors.
    pub fn joint_and_task_control_agree_for_small_motions() {
        let amp = [1.0, 1.0, 0.5];
        let a = short(ControlMode::Joint, amp).run().unwrap();
        let b = short(ControlMode::Task, amp).run().unwrap();
        let err = a.task.iter().map(|e| e.max_um).fold(0.0, f64::max);
        assert!(err > 0.05, "the loops have errors to compare: {err}");
        let diff = a
            .trace
            .pose
            .iter()
            .zip(&b.trace.pose)
            .map(|(p, q)| (0..3).map(|i| (p[i] - q[i]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        assert!(
            diff < 0.01 * err,
            "poses differ by {diff} um, errors {err} um"
        );
    }

    /// A z-only command moves the three identical sliders together: x and
    /// y stay within the sensor noise, reported as cross-coupling.
    pub fn z_only_motion_barely_couples() {
        let r = short(ControlMode::Joint, [0.0, 0.0, 10.0]).run().unwrap();
        assert!(r.task[2].max_um > 1.0, "{:?}", r.task);
        assert!(
            r.task[0].max_um < 0.05 && r.task[1].max_um < 0.05,
            "{:?}",
            r.task
        );
        let c = r.cross_coupling_percent.unwrap();
        assert!(c < 0.5 && c > 0.0, "{c}");
    }

    /// A pose beyond the sliders' travel or the rods' reach is bad input.
    pub fn a_point_outside_the_workspace_is_refused() {
        for amp in [[0.0, 0.0, 60.0], [200.0, 0.0, 0.0]] {
            match short(ControlMode::Joint, amp).run() {
                Err(StepError::Input { message, .. }) => {
                    assert!(message.contains("leaves the workspace"), "{message}")
                }
                other => panic!("{other:?}"),
            }
        }
        let far = Puu3Track {
            center_um: [0.0, 0.0, 0.0],
            amplitude_um: [1e6, 0.0, 0.0],
            ..Puu3Track::default()
        };
        assert!(matches!(far.run(), Err(StepError::Input { .. })));
        let bad = Puu3Track {
            joints: JointModel::Ideal,
            mode: ControlMode::Task,
            ..Puu3Track::default()
        };
        assert!(matches!(
            bad.run(),
            Err(StepError::Input {
                field: Some("joints"),
                ..
            })
        ));
    }
}
