//! The embedded virtual fast tool servo (docs/virtual-fts.md).
//!
//! Signal chain, integrated on `substeps` internal steps per controller sample:
//!
//! 1. command `u` (V), clipped to the amplifier's input range, held for one
//!    sample after `delay_samples` samples of computation and transport delay;
//! 2. power amplifier: gain `G`, first-order bandwidth `f_a`:
//!    `dv/dt = 2 pi f_a (G u - v)` (solved exactly per substep);
//! 3. piezo stack: Bouc–Wen hysteresis in the voltage domain plus an
//!    asymmetric quadratic term,
//!    `x_free = d v + q v^2 - h`, `dh = alpha d dv - beta |dv| h - gamma dv |h|`
//!    (Heun's method per substep). This is deliberately *not* a play-operator
//!    model, so identifying PI/MPI models from it is honest. Rate independent
//!    by default; with `piezo.rate_dependence` the loop widens with the
//!    voltage rate, `alpha(v') = alpha (1 + c |v'| / v'_ref)`
//!    (docs/virtual-fts.md);
//! 4. flexure: stiffness loss `k_p/(k_p + k)` (\[Li21\] Eq. 1) and the first
//!    mode, `x'' = w_n^2 (kappa x_free - x) - 2 zeta w_n x'` (exact ZOH
//!    discretisation of the mode by the matrix exponential);
//! 5. capacitive sensor: `y = x + n`, `n` white Gaussian with the given RMS,
//!    from a seeded ChaCha8 generator (deterministic for a seed).

use nalgebra::{Matrix3, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// The format tag of the parameter file.
pub const VIRTUAL_FTS_FORMAT: &str = "fts.virtual-fts/1";

/// The default plant, the documented fixture `fixtures/virtual-fts.json`.
pub const DEFAULT_VIRTUAL_FTS_JSON: &str = include_str!("../../fixtures/virtual-fts.json");

/// Power amplifier.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmplifierParams {
    /// Lowest command accepted, V (the input is clipped).
    pub input_min_v: f64,
    /// Highest command accepted, V.
    pub input_max_v: f64,
    /// Voltage gain.
    pub gain: f64,
    /// First-order bandwidth, Hz.
    pub bandwidth_hz: f64,
}

/// Piezo stack hysteresis (Bouc–Wen plus an asymmetric static term).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PiezoParams {
    /// Free displacement per volt, um/V.
    pub d_um_per_v: f64,
    /// Quadratic (asymmetric) term, um/V^2.
    pub quadratic_um_per_v2: f64,
    /// Bouc–Wen `alpha` (dimensionless).
    pub alpha: f64,
    /// Bouc–Wen `beta`, 1/V.
    pub beta: f64,
    /// Bouc–Wen `gamma`, 1/V.
    pub gamma: f64,
    /// Rate dependence of the loop; absent (the default): rate independent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_dependence: Option<RateDependence>,
}

/// Rate-dependent Bouc–Wen: `alpha(v') = alpha (1 + coefficient |v'| /
/// reference_rate_v_per_s)`, `v'` the mean rate of the amplifier's output
/// voltage over the previous controller sample (the drive rate, not the
/// fast transients of the held command inside a sample). The hysteretic part grows with the drive rate as
/// piezo loops widen with frequency (Ang et al. 2007; docs/virtual-fts.md).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RateDependence {
    /// `c`, dimensionless, >= 0.
    pub coefficient: f64,
    /// `v'_ref`, V/s, > 0: the rate at which `alpha` is `(1 + c)` times its static value.
    pub reference_rate_v_per_s: f64,
}

impl RateDependence {
    /// The factor `1 + c |v'| / v'_ref` of `alpha` at voltage rate `v'` (V/s).
    #[inline(always)]
    pub fn alpha_factor(&self, rate_v_per_s: f64) -> f64 {
        1.0 + self.coefficient * rate_v_per_s.abs() / self.reference_rate_v_per_s
    }
}

/// Flexure hinge mechanics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlexureParams {
    /// Piezo stack stiffness `k_p`, N/um.
    pub piezo_stiffness_n_per_um: f64,
    /// Flexure stiffness `k`, N/um.
    pub flexure_stiffness_n_per_um: f64,
    /// First mode, Hz (\[Li21\]: 2504.8 Hz by FEA).
    pub mode_hz: f64,
    /// Damping ratio of the mode.
    pub damping_ratio: f64,
}

/// Everything that defines a virtual FTS (`fts.virtual-fts/1`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VirtualFtsParams {
    /// Must be `fts.virtual-fts/1`.
    pub format: String,
    /// Free text for people.
    #[serde(default)]
    pub description: String,
    /// Controller sample time, s.
    pub ts: f64,
    /// Internal integration steps per controller sample.
    pub substeps: usize,
    /// Whole samples between computing a command and its reaching the amplifier.
    pub delay_samples: usize,
    /// Amplifier.
    pub amplifier: AmplifierParams,
    /// Piezo stack.
    pub piezo: PiezoParams,
    /// Flexure.
    pub flexure: FlexureParams,
    /// Sensor noise, um RMS.
    pub sensor_noise_rms_um: f64,
    /// Seed of the noise generator (overridden by `--seed`).
    pub seed: u64,
}

/// Why a parameter set is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct VirtualFtsError {
    /// The offending field.
    pub field: &'static str,
    /// What is expected.
    pub message: String,
}

impl VirtualFtsParams {
    /// The embedded default plant.
    pub fn default_plant() -> Self {
        serde_json::from_str(DEFAULT_VIRTUAL_FTS_JSON).expect("the embedded fixture is valid")
    }

    /// Checks ranges; every physical parameter must be finite and sensible.
    pub fn validate(&self) -> Result<(), VirtualFtsError> {
        let err = |field: &'static str, message: &str| {
            Err(VirtualFtsError {
                field,
                message: message.to_owned(),
            })
        };
        if self.format != VIRTUAL_FTS_FORMAT {
            return err("format", &format!("expected {VIRTUAL_FTS_FORMAT:?}"));
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(self.ts) {
            return err("ts", "must be a positive number of seconds");
        }
        if !(1..=1000).contains(&self.substeps) {
            return err("substeps", "must lie in 1..=1000");
        }
        if self.delay_samples > 1000 {
            return err("delay_samples", "must be at most 1000");
        }
        let a = &self.amplifier;
        if !(a.input_min_v.is_finite()
            && a.input_max_v.is_finite()
            && a.input_min_v < a.input_max_v)
        {
            return err(
                "amplifier.input_min_v",
                "need finite input_min_v < input_max_v",
            );
        }
        if !positive(a.gain) {
            return err("amplifier.gain", "must be positive");
        }
        if !positive(a.bandwidth_hz) {
            return err("amplifier.bandwidth_hz", "must be positive");
        }
        let p = &self.piezo;
        if !positive(p.d_um_per_v) {
            return err("piezo.d_um_per_v", "must be positive");
        }
        if !(p.quadratic_um_per_v2.is_finite()
            && p.alpha.is_finite()
            && p.beta.is_finite()
            && p.gamma.is_finite())
        {
            return err("piezo", "every coefficient must be finite");
        }
        if let Some(r) = &p.rate_dependence {
            if !(r.coefficient.is_finite() && r.coefficient >= 0.0) {
                return err(
                    "piezo.rate_dependence.coefficient",
                    "must be a finite number >= 0",
                );
            }
            if !positive(r.reference_rate_v_per_s) {
                return err(
                    "piezo.rate_dependence.reference_rate_v_per_s",
                    "must be a positive number of V/s",
                );
            }
        }
        let f = &self.flexure;
        if !(positive(f.piezo_stiffness_n_per_um)
            && f.flexure_stiffness_n_per_um.is_finite()
            && f.flexure_stiffness_n_per_um >= 0.0)
        {
            return err("flexure", "stiffnesses must be positive (flexure may be 0)");
        }
        if !positive(f.mode_hz) || f.mode_hz >= 0.5 * self.substeps as f64 / self.ts {
            return err(
                "flexure.mode_hz",
                "must be positive and below the internal Nyquist frequency",
            );
        }
        if !(f.damping_ratio.is_finite() && f.damping_ratio > 0.0) {
            return err("flexure.damping_ratio", "must be positive");
        }
        if !(self.sensor_noise_rms_um.is_finite() && self.sensor_noise_rms_um >= 0.0) {
            return err("sensor_noise_rms_um", "must be a non-negative number");
        }
        Ok(())
    }

    /// The stiffness ratio `k_p/(k_p + k)` (\[Li21\] Eq. 1).
    pub fn stiffness_ratio(&self) -> f64 {
        let f = &self.flexure;
        f.piezo_stiffness_n_per_um / (f.piezo_stiffness_n_per_um + f.flexure_stiffness_n_per_um)
    }
}

/// A running virtual FTS. [`VirtualFts::step`] does not allocate.
#[derive(Debug, Clone)]
pub struct VirtualFts {
    params: VirtualFtsParams,
    dt: f64,
    amp_decay: f64,
    kappa: f64,
    /// ZOH transition of the mode: `[x, x'] <- phi [x, x'] + gamma_in * u`.
    phi: [[f64; 2]; 2],
    gamma_in: [f64; 2],
    // State.
    amp_voltage: f64,
    /// Mean amplifier voltage rate over the previous sample, V/s.
    voltage_rate: f64,
    hysteresis: f64,
    free_displacement: f64,
    position: f64,
    velocity: f64,
    pending: Vec<f64>,
    pending_pos: usize,
    rng: ChaCha8Rng,
    noise: Normal<f64>,
}

impl VirtualFts {
    /// A plant at rest (0 V, demagnetised, at zero displacement).
    pub fn new(params: VirtualFtsParams) -> Result<Self, VirtualFtsError> {
        params.validate()?;
        let dt = params.ts / params.substeps as f64;
        let wn = 2.0 * std::f64::consts::PI * params.flexure.mode_hz;
        let zeta = params.flexure.damping_ratio;
        // Van Loan: exp([[A, B], [0, 0]] dt) = [[Phi, Gamma], [0, 1]].
        #[rustfmt::skip]
        let m = Matrix3::new(
            0.0, 1.0, 0.0,
            -wn * wn, -2.0 * zeta * wn, wn * wn,
            0.0, 0.0, 0.0,
        ) * dt;
        let e = m.exp();
        let noise = Normal::new(0.0, params.sensor_noise_rms_um).map_err(|_| VirtualFtsError {
            field: "sensor_noise_rms_um",
            message: "invalid".into(),
        })?;
        Ok(Self {
            dt,
            amp_decay: (-2.0 * std::f64::consts::PI * params.amplifier.bandwidth_hz * dt).exp(),
            kappa: params.stiffness_ratio(),
            phi: [[e[(0, 0)], e[(0, 1)]], [e[(1, 0)], e[(1, 1)]]],
            gamma_in: [e[(0, 2)], e[(1, 2)]],
            amp_voltage: 0.0,
            voltage_rate: 0.0,
            hysteresis: 0.0,
            free_displacement: 0.0,
            position: 0.0,
            velocity: 0.0,
            pending: vec![0.0; params.delay_samples],
            pending_pos: 0,
            rng: ChaCha8Rng::seed_from_u64(params.seed),
            noise,
            params,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &VirtualFtsParams {
        &self.params
    }

    /// Restarts the noise generator from `seed`.
    pub fn reseed(&mut self, seed: u64) {
        self.params.seed = seed;
        self.rng = ChaCha8Rng::seed_from_u64(seed);
    }

    /// Internal integration step, s.
    pub fn internal_step(&self) -> f64 {
        self.dt
    }

    /// True displacement (no noise), um: for tests and plots, never for identification.
    pub fn true_position(&self) -> f64 {
        self.position
    }

    /// A sensor reading of the current displacement, um.
    pub fn measure(&mut self) -> f64 {
        let n = if self.params.sensor_noise_rms_um > 0.0 {
            self.noise.sample(&mut self.rng)
        } else {
            0.0
        };
        self.position + n
    }

    /// Applies command `u` (V) and advances one controller sample. The
    /// command enters the delay line; the one computed `delay_samples` ago
    /// drives the amplifier over this interval.
    pub fn advance(&mut self, command: f64) {
        let u = if self.pending.is_empty() {
            command
        } else {
            let due = self.pending[self.pending_pos];
            self.pending[self.pending_pos] = command;
            self.pending_pos += 1;
            if self.pending_pos == self.pending.len() {
                self.pending_pos = 0;
            }
            due
        };
        let a = &self.params.amplifier;
        let target = a.gain * u.clamp(a.input_min_v, a.input_max_v);
        let p = self.params.piezo;
        let d = p.d_um_per_v;
        // Rate-dependent loop width (docs/virtual-fts.md); exactly alpha when off.
        let alpha = match &p.rate_dependence {
            Some(r) => p.alpha * r.alpha_factor(self.voltage_rate),
            None => p.alpha,
        };
        let v_start = self.amp_voltage;
        for _ in 0..self.params.substeps {
            let v_old = self.amp_voltage;
            let v_new = target + (v_old - target) * self.amp_decay;
            let dv = v_new - v_old;
            // Bouc–Wen in the voltage domain, Heun's method.
            let rate = |h: f64| alpha * d * dv - p.beta * dv.abs() * h - p.gamma * dv * h.abs();
            let k1 = rate(self.hysteresis);
            let k2 = rate(self.hysteresis + k1);
            self.hysteresis += 0.5 * (k1 + k2);
            self.amp_voltage = v_new;
            let free_old = self.free_displacement;
            self.free_displacement =
                d * v_new + p.quadratic_um_per_v2 * v_new * v_new - self.hysteresis;
            // Mode driven by the substep's mean free displacement (trapezoidal hold).
            let drive = self.kappa * 0.5 * (free_old + self.free_displacement);
            let s = Vector2::new(self.position, self.velocity);
            self.position =
                self.phi[0][0] * s[0] + self.phi[0][1] * s[1] + self.gamma_in[0] * drive;
            self.velocity =
                self.phi[1][0] * s[0] + self.phi[1][1] * s[1] + self.gamma_in[1] * drive;
        }
        self.voltage_rate = (self.amp_voltage - v_start) / self.params.ts;
    }

    /// Measures, then applies the command computed from that measurement:
    /// returns the measurement the controller saw.
    pub fn step(&mut self, command: f64) -> f64 {
        let y = self.measure();
        self.advance(command);
        y
    }

    /// Open-loop run: measurement `y(k)` taken before command `u(k)` is applied.
    pub fn run_open_loop(&mut self, commands: &[f64]) -> Vec<f64> {
        commands.iter().map(|&u| self.step(u)).collect()
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn quiet() -> VirtualFtsParams {
        VirtualFtsParams {
            sensor_noise_rms_um: 0.0,
            ..VirtualFtsParams::default_plant()
        }
    }

    pub fn fixture_is_valid_and_round_trips() {
        let p = VirtualFtsParams::default_plant();
        p.validate().unwrap();
        let text = serde_json::to_string(&p).unwrap();
        let back: VirtualFtsParams = serde_json::from_str(&text).unwrap();
        assert_eq!(back, p);
    }

    pub fn static_gain_and_stroke() {
        // Hold 10 V: the amplifier gives G*10 V and the output settles near
        // kappa * (d V + q V^2 - h_sat).
        let mut fts = VirtualFts::new(quiet()).unwrap();
        for _ in 0..5000 {
            fts.step(10.0);
        }
        let x = fts.true_position();
        // "Stroke about 10 um" (virtual-fts.md): the fixture gives about 13 um
        // at 10 V, i.e. about 12 um of usable range above the ~1.2 um remanence,
        // enough for the 5 um-amplitude sines of [Li21] with margin.
        assert!((11.0..14.5).contains(&x), "stroke {x}");
        // Commands outside 0..10 V are clipped by the amplifier.
        let mut clipped = VirtualFts::new(quiet()).unwrap();
        for _ in 0..5000 {
            clipped.step(20.0);
        }
        assert!((clipped.true_position() - x).abs() < 1e-9);
    }

    pub fn hysteresis_is_asymmetric_and_about_ten_percent_wide() {
        // Slow 1 Hz triangle 0 -> 10 -> 0 V twice; compare branches at 5 V
        // (plant delay and lag are negligible at 1 Hz).
        let width = loop_width(quiet(), 1.0);
        assert!(width > 0.0, "descending branch above ascending");
        assert!((0.08..0.18).contains(&width), "loop width {width}");
    }

    /// Loop width (descending minus ascending branch at mid-stroke, over
    /// the top) of the second period of a 0-10 V triangle at `freq` Hz.
    fn loop_width(p: VirtualFtsParams, freq: f64) -> f64 {
        let mut fts = VirtualFts::new(p).unwrap();
        let n = (1.0 / (freq * fts.params().ts)).round() as usize;
        let tri = |k: usize| {
            let ph = (k % n) as f64 / n as f64;
            10.0 * if ph < 0.5 { 2.0 * ph } else { 2.0 - 2.0 * ph }
        };
        let (mut up, mut down, mut top) = (f64::NAN, f64::NAN, f64::NEG_INFINITY);
        for k in 0..2 * n {
            fts.step(tri(k));
            if k >= n {
                top = top.max(fts.true_position());
                if k == n + n / 4 {
                    up = fts.true_position();
                }
                if k == n + 3 * n / 4 {
                    down = fts.true_position();
                }
            }
        }
        (down - up) / top
    }

    pub fn rate_dependence_widens_fast_loops_only() {
        let with = |c: f64| VirtualFtsParams {
            piezo: PiezoParams {
                rate_dependence: Some(RateDependence {
                    coefficient: c,
                    reference_rate_v_per_s: 1e5,
                }),
                ..quiet().piezo
            },
            ..quiet()
        };
        // c = 0 is the rate-independent plant, bit for bit.
        for freq in [2.0, 200.0] {
            assert_eq!(loop_width(with(0.0), freq), loop_width(quiet(), freq));
        }
        // At 1 Hz the rate is 200 V/s: alpha grows by 0.2 %; at 200 Hz by
        // about 40 %, and the loop is visibly wider than without.
        let slow = (loop_width(with(1.0), 1.0), loop_width(quiet(), 1.0));
        assert!((slow.0 - slow.1).abs() < 0.01 * slow.1, "{slow:?}");
        let fast = (loop_width(with(1.0), 200.0), loop_width(quiet(), 200.0));
        assert!(fast.0 > 1.1 * fast.1, "{fast:?}");
        // The fixture has no rate field and writes none.
        let text = serde_json::to_string(&quiet()).unwrap();
        assert!(!text.contains("rate_dependence"));
        let mut bad = with(-1.0);
        assert_eq!(
            bad.validate().unwrap_err().field,
            "piezo.rate_dependence.coefficient"
        );
        bad = with(1.0);
        bad.piezo
            .rate_dependence
            .as_mut()
            .unwrap()
            .reference_rate_v_per_s = 0.0;
        assert_eq!(
            bad.validate().unwrap_err().field,
            "piezo.rate_dependence.reference_rate_v_per_s"
        );
    }

    pub fn deterministic_for_a_seed() {
        let run = |seed| {
            let mut p = VirtualFtsParams::default_plant();
            p.seed = seed;
            let mut f = VirtualFts::new(p).unwrap();
            (0..100)
                .map(|k| f.step((k % 10) as f64))
                .collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
    }

    pub fn validation_names_fields() {
        let mut p = VirtualFtsParams::default_plant();
        p.flexure.mode_hz = -1.0;
        assert_eq!(p.validate().unwrap_err().field, "flexure.mode_hz");
        let mut p = VirtualFtsParams::default_plant();
        p.format = "x".into();
        assert_eq!(p.validate().unwrap_err().field, "format");
    }
}
