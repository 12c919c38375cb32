//! Prandtl–Ishlinskii models and their modified forms (docs/math.md §1.2-1.4),
//! evaluated sample by sample with explicit state.

use super::operators::{PlayOperator, ThresholdError, check_thresholds, dead_zone};

/// Which model structure (docs/math.md §1.2-1.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelKind {
    /// Classical PI: `y = sum_i w_i F_{r_i}[u]` (\[Li21\] Eq. 3).
    Pi,
    /// PI plus a cube-root term `c cbrt(u)` (\[Li21\] Eq. 4).
    MpiCbrt,
    /// PI stage followed by one-sided dead-zone output operators (\[Tang17\] Eq. 40-43).
    MpiDeadzone,
}

impl ModelKind {
    /// The name used on the command line and in model files.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Pi => "pi",
            ModelKind::MpiCbrt => "mpi-cbrt",
            ModelKind::MpiDeadzone => "mpi-deadzone",
        }
    }

    /// Inverse of [`ModelKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "pi" => Some(ModelKind::Pi),
            "mpi-cbrt" => Some(ModelKind::MpiCbrt),
            "mpi-deadzone" => Some(ModelKind::MpiDeadzone),
            _ => None,
        }
    }
}

/// A dead-zone stage `D[v] = sum_j g_j S_{d_j}[v]` (\[Tang17\] Eq. 41): the
/// output stage of MPI-deadzone, or the input stage of its analytic inverse
/// (docs/math.md §1.6).
#[derive(Debug, Clone, PartialEq)]
pub struct DeadZoneStage {
    /// Dead-zone thresholds `d_j`, strictly increasing, `d_0 = 0` normally.
    pub thresholds: Vec<f64>,
    /// Output weights `g_j`.
    pub weights: Vec<f64>,
}

impl DeadZoneStage {
    /// `D[v]`, summed in operator order (the runtime sums in the same order).
    #[inline]
    pub fn apply(&self, v: f64) -> f64 {
        self.thresholds
            .iter()
            .zip(&self.weights)
            .map(|(&d, &g)| g * dead_zone(d, v))
            .sum()
    }
}

/// Rate-dependent play weights (docs/math.md §1.7): the weight of play `i`
/// at sample `k` is `w_i + w1_i |s(k)|` with the normalised input rate
/// `s(k) = (x(k) - x(k-1)) / (ts rate_scale)` (`x(-1) = 0`, the
/// demagnetised state), the linear-in-parameters form of Ang et al. 2007
/// ("Modeling rate-dependent hysteresis in piezoelectric actuators"), plus
/// a velocity term `g s(k)` added to the output (a first-order lag of the
/// loop, `y(t - tau) ~ y(t) - tau y'(t)`).
#[derive(Debug, Clone, PartialEq)]
pub struct RateStage {
    /// Sample time the model runs at, s (the rate is a backward difference).
    pub ts: f64,
    /// Input rate at which `rho = 1`, input units per second (the largest
    /// rate of the identification record).
    pub rate_scale: f64,
    /// Rate weights `w1_i`, one per play operator.
    pub weights: Vec<f64>,
    /// Velocity gain `g`, output units.
    pub velocity_gain: f64,
}

/// A hysteresis model
/// `y = offset + c cbrt(x) + Out[ sum_i (w_i + w1_i |s|) F_{r_i}[In[x]] ] + g s`, `x = u - input_offset`,
/// where `Out` is the identity, or the dead-zone stage for MPI-deadzone,
/// `In` is the identity, or the input dead-zone stage of a PI model that is
/// the analytic inverse of an MPI-deadzone model, and the rate weights
/// `w1_i` are 0 unless the model has a [`RateStage`].
///
/// `offset` absorbs the sensor offset of real records (on by default when
/// identifying); `input_offset` is 0 for identified models and is what an
/// analytic inverse needs to undo the forward model's `offset`.
#[derive(Debug, Clone, PartialEq)]
pub struct HysteresisModel {
    /// Model structure.
    pub kind: ModelKind,
    /// Play operator form of every operator in the model.
    pub operator: PlayOperator,
    /// Play thresholds `r_i`, strictly increasing, non-negative.
    pub thresholds: Vec<f64>,
    /// Play weights `w_i`.
    pub weights: Vec<f64>,
    /// Cube-root gain `c` (0 unless MPI-cbrt).
    pub cbrt_gain: f64,
    /// Constant added to the output.
    pub offset: f64,
    /// Constant subtracted from the input before the operators.
    pub input_offset: f64,
    /// Output stage (MPI-deadzone only).
    pub dead_zone: Option<DeadZoneStage>,
    /// Input stage (PI only, without a rate stage): what the analytic
    /// inverse of an MPI-deadzone model has in front of its plays.
    pub input_dead_zone: Option<DeadZoneStage>,
    /// Rate-dependent weights (PI and MPI-cbrt only; docs/math.md §1.7).
    pub rate: Option<RateStage>,
}

/// A model that cannot be evaluated as given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// Two lists that must have one entry per operator differ in length.
    #[error("'{field}' has {found} entries but '{reference}' has {expected}; they must match")]
    LengthMismatch {
        /// The list that is off.
        field: &'static str,
        /// The list it is compared with.
        reference: &'static str,
        /// Length of `reference`.
        expected: usize,
        /// Length of `field`.
        found: usize,
    },
    /// Bad thresholds.
    #[error("'{field}': {source}")]
    Thresholds {
        /// Which threshold list.
        field: &'static str,
        /// What is wrong with it.
        source: ThresholdError,
    },
    /// A coefficient is NaN or infinite.
    #[error("'{field}' must be finite")]
    NonFinite {
        /// The coefficient.
        field: &'static str,
    },
    /// The parts present do not match the model kind.
    #[error("{0}")]
    Inconsistent(String),
}

/// One operator stage (play or dead zone): valid thresholds, one finite
/// weight per threshold.
fn check_stage(
    thresholds: &[f64],
    weights: &[f64],
    thresholds_field: &'static str,
    weights_field: &'static str,
) -> Result<(), ModelError> {
    check_thresholds(thresholds).map_err(|source| ModelError::Thresholds {
        field: thresholds_field,
        source,
    })?;
    if weights.len() != thresholds.len() {
        return Err(ModelError::LengthMismatch {
            field: weights_field,
            reference: thresholds_field,
            expected: thresholds.len(),
            found: weights.len(),
        });
    }
    if weights.iter().any(|w| !w.is_finite()) {
        return Err(ModelError::NonFinite {
            field: weights_field,
        });
    }
    Ok(())
}

impl HysteresisModel {
    /// Checks lengths, thresholds, finiteness and kind consistency.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_stage(&self.thresholds, &self.weights, "thresholds", "weights")?;
        for (field, v) in [
            ("cbrt_gain", self.cbrt_gain),
            ("offset", self.offset),
            ("input_offset", self.input_offset),
        ] {
            if !v.is_finite() {
                return Err(ModelError::NonFinite { field });
            }
        }
        if self.kind != ModelKind::MpiCbrt && self.cbrt_gain != 0.0 {
            return Err(ModelError::Inconsistent(format!(
                "a '{}' model has no cube-root term, but cbrt_gain is {}",
                self.kind.name(),
                self.cbrt_gain
            )));
        }
        match (&self.dead_zone, self.kind) {
            (Some(dz), ModelKind::MpiDeadzone) => {
                check_stage(
                    &dz.thresholds,
                    &dz.weights,
                    "dead_zone.thresholds",
                    "dead_zone.weights",
                )?;
            }
            (None, ModelKind::MpiDeadzone) => {
                return Err(ModelError::Inconsistent(
                    "an 'mpi-deadzone' model needs a dead-zone stage".into(),
                ));
            }
            (Some(_), kind) => {
                return Err(ModelError::Inconsistent(format!(
                    "a '{}' model has no dead-zone stage",
                    kind.name()
                )));
            }
            (None, _) => {}
        }
        if let Some(dz) = &self.input_dead_zone {
            if self.kind != ModelKind::Pi || self.rate.is_some() {
                return Err(ModelError::Inconsistent(format!(
                    "an input dead-zone stage belongs to a rate-independent 'pi' model (the inverse of an mpi-deadzone model), not to this '{}' model",
                    self.kind.name()
                )));
            }
            check_stage(
                &dz.thresholds,
                &dz.weights,
                "input_dead_zone.thresholds",
                "input_dead_zone.weights",
            )?;
        }
        if let Some(rate) = &self.rate {
            self.validate_rate(rate)?;
        }
        Ok(())
    }

    fn validate_rate(&self, rate: &RateStage) -> Result<(), ModelError> {
        if self.kind == ModelKind::MpiDeadzone {
            return Err(ModelError::Inconsistent(
                "an 'mpi-deadzone' model has no rate-dependent stage (pi and mpi-cbrt only)".into(),
            ));
        }
        if rate.weights.len() != self.thresholds.len() {
            return Err(ModelError::LengthMismatch {
                field: "rate_dependent.weights",
                reference: "thresholds",
                expected: self.thresholds.len(),
                found: rate.weights.len(),
            });
        }
        if rate.weights.iter().any(|w| !w.is_finite()) {
            return Err(ModelError::NonFinite {
                field: "rate_dependent.weights",
            });
        }
        if !rate.velocity_gain.is_finite() {
            return Err(ModelError::NonFinite {
                field: "rate_dependent.velocity_gain",
            });
        }
        for (field, v) in [
            ("rate_dependent.ts", rate.ts),
            ("rate_dependent.rate_scale", rate.rate_scale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::Inconsistent(format!(
                    "'{field}' must be a positive number, found {v}"
                )));
            }
        }
        Ok(())
    }

    /// The normalised signed rate `s` of a step from `previous` to `x`
    /// (§1.7); 0 without a rate stage.
    #[inline(always)]
    fn signed_rate(&self, previous: f64, x: f64) -> f64 {
        match &self.rate {
            Some(rate) => (x - previous) / (rate.ts * rate.rate_scale),
            None => 0.0,
        }
    }

    /// Number of play operators.
    pub fn operators(&self) -> usize {
        self.thresholds.len()
    }

    /// A fresh (demagnetised) state for this model.
    pub fn new_state(&self) -> ModelState {
        ModelState {
            play: vec![PlayOperator::INITIAL_STATE; self.thresholds.len()],
            previous_input: 0.0,
        }
    }

    /// Evaluates one sample and advances the state. Allocation-free.
    ///
    /// # Panics
    /// If `state` was made for a model with a different number of operators.
    #[inline]
    pub fn step(&self, state: &mut ModelState, u: f64) -> f64 {
        assert_eq!(
            state.play.len(),
            self.thresholds.len(),
            "state of another model"
        );
        let x = u - self.input_offset;
        let z = self.input_stage(x);
        let mut v = 0.0;
        // [Li21] Eq. 3 / [Tang17] Eq. 39: weighted sum of play outputs.
        for ((s, &r), &w) in state
            .play
            .iter_mut()
            .zip(&self.thresholds)
            .zip(&self.weights)
        {
            *s = self.operator.step(r, z, *s);
            v += w * *s;
        }
        let sigma = self.signed_rate(state.previous_input, x);
        if let Some(rate) = &self.rate {
            // §1.7: the rate part of the weights, summed after the static part.
            let rho = sigma.abs();
            for (s, &w1) in state.play.iter().zip(&rate.weights) {
                v += w1 * rho * *s;
            }
        }
        state.previous_input = x;
        // [Tang17] Eq. 41: y = sum_j g_j S_{d_j}[v].
        let out = self.dead_zone.as_ref().map_or(v, |dz| dz.apply(v));
        // [Li21] Eq. 4: the cube-root term (cbrt_gain is 0 for other kinds).
        self.offset + self.cbrt_gain * crate::runtime::cbrt(x) + out + self.velocity_term(sigma)
    }

    /// `In[x]`: the input dead-zone stage, or `x` without one.
    #[inline(always)]
    fn input_stage(&self, x: f64) -> f64 {
        self.input_dead_zone.as_ref().map_or(x, |dz| dz.apply(x))
    }

    /// `g s` of §1.7 (0 without a rate stage).
    #[inline(always)]
    fn velocity_term(&self, sigma: f64) -> f64 {
        self.rate.as_ref().map_or(0.0, |r| r.velocity_gain * sigma)
    }

    /// Runs the model over a signal from the demagnetised state.
    ///
    /// Same arithmetic as [`HysteresisModel::step`] per sample, but computed
    /// a block of samples at a time (the play operators side by side in SIMD
    /// lanes, then the weighted sums), which is several times faster on long
    /// records. Allocates the output and a small scratch buffer.
    pub fn simulate(&self, u: &[f64]) -> Vec<f64> {
        const BLOCK: usize = 256;
        let n = self.thresholds.len();
        let mut out = vec![0.0; u.len()];
        let mut states = vec![PlayOperator::INITIAL_STATE; n];
        let mut scratch = vec![0.0; n * BLOCK];
        let mut x = [0.0f64; BLOCK];
        let mut z = [0.0f64; BLOCK];
        let mut columns: Vec<&mut [f64]> = scratch.chunks_mut(BLOCK).collect();
        let mut sigma = [0.0f64; BLOCK];
        let mut previous = 0.0;
        for (ub, ob) in u.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
            let len = ub.len();
            for ((xk, zk), uk) in x.iter_mut().zip(z.iter_mut()).zip(ub) {
                *xk = uk - self.input_offset;
                *zk = self.input_stage(*xk);
            }
            super::identify::play_columns(
                self.operator,
                &self.thresholds,
                &z[..len],
                &mut states,
                &mut columns,
            );
            // v = sum_i w_i F_i, summed in operator order as in `step`.
            ob.fill(0.0);
            for (col, &w) in columns.iter().zip(&self.weights) {
                for (o, f) in ob.iter_mut().zip(&col[..len]) {
                    *o += w * f;
                }
            }
            for (r, &xk) in sigma.iter_mut().zip(&x[..len]) {
                *r = self.signed_rate(previous, xk);
                previous = xk;
            }
            if let Some(rate) = &self.rate {
                for (col, &w1) in columns.iter().zip(&rate.weights) {
                    for ((o, f), r) in ob.iter_mut().zip(&col[..len]).zip(&sigma) {
                        *o += w1 * r.abs() * f;
                    }
                }
            }
            for ((o, &xk), &sk) in ob.iter_mut().zip(&x[..len]).zip(&sigma) {
                let v = *o;
                let stage = self.dead_zone.as_ref().map_or(v, |dz| dz.apply(v));
                *o = self.offset
                    + self.cbrt_gain * crate::runtime::cbrt(xk)
                    + stage
                    + self.velocity_term(sk);
            }
        }
        out
    }

    /// Partial sums `W_i = w_0 + ... + w_i` of the play weights: the slopes of
    /// the model's loading curve. All positive means strictly increasing
    /// (invertible) for a classical PI model (docs/math.md §1.5).
    pub fn partial_sums(&self) -> Vec<f64> {
        self.weights
            .iter()
            .scan(0.0, |acc, w| {
                *acc += w;
                Some(*acc)
            })
            .collect()
    }
}

/// The memory of a model: one value per play operator.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelState {
    /// Previous output of each play operator.
    pub play: Vec<f64>,
    /// Previous operator input `x(k-1)` (for the rate of §1.7); 0 at rest.
    pub previous_input: f64,
}

impl ModelState {
    /// Back to the demagnetised state, without reallocating.
    pub fn reset(&mut self) {
        self.play.fill(PlayOperator::INITIAL_STATE);
        self.previous_input = 0.0;
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn pi(weights: Vec<f64>, thresholds: Vec<f64>) -> HysteresisModel {
        HysteresisModel {
            kind: ModelKind::Pi,
            operator: PlayOperator::Lower,
            thresholds,
            weights,
            cbrt_gain: 0.0,
            offset: 0.0,
            input_offset: 0.0,
            dead_zone: None,
            input_dead_zone: None,
            rate: None,
        }
    }

    pub fn pi_loop_by_hand() {
        // w = [1, 0.5], r = [0, 1]: rising from 0 to 2, y = u + 0.5 max(u - 1, 0).
        let m = pi(vec![1.0, 0.5], vec![0.0, 1.0]);
        let y = m.simulate(&[0.0, 1.0, 2.0, 1.5, 1.0]);
        // Falling from 2: the r = 1 play holds 1 until u < 1, so y = u + 0.5.
        assert_eq!(y, vec![0.0, 1.0, 2.5, 2.0, 1.5]);
    }

    pub fn block_simulation_equals_sample_by_sample_steps() {
        // Bit-identical: both sum the same products in the same order.
        let u: Vec<f64> = (0..1000)
            .map(|k| 7.0 * (k as f64 * 0.013).sin() + 0.5 * (k as f64 * 0.2).cos())
            .collect();
        for (kind, op) in [
            (ModelKind::Pi, PlayOperator::Lower),
            (ModelKind::MpiCbrt, PlayOperator::Symmetric),
            (ModelKind::MpiDeadzone, PlayOperator::Symmetric),
        ] {
            let m = HysteresisModel {
                kind,
                operator: op,
                thresholds: vec![0.0, 0.7, 1.4, 2.1, 2.8, 3.5, 4.2, 4.9, 5.6, 6.3],
                weights: vec![0.9, 0.1, -0.05, 0.2, 0.03, -0.1, 0.07, 0.02, 0.05, 0.1],
                cbrt_gain: if kind == ModelKind::MpiCbrt {
                    -0.3
                } else {
                    0.0
                },
                offset: 0.25,
                input_offset: -0.5,
                dead_zone: (kind == ModelKind::MpiDeadzone).then(|| DeadZoneStage {
                    thresholds: vec![0.0, 1.0, 3.0],
                    weights: vec![1.0, 0.3, -0.2],
                }),
                input_dead_zone: None,
                rate: None,
            };
            let mut state = m.new_state();
            let stepped: Vec<f64> = u.iter().map(|&x| m.step(&mut state, x)).collect();
            assert_eq!(m.simulate(&u), stepped, "{kind:?} {op:?}");
            if kind == ModelKind::MpiDeadzone {
                continue;
            }
            // §1.7's rate stage, across block boundaries.
            let m = HysteresisModel {
                input_dead_zone: None,
                rate: Some(RateStage {
                    ts: 1e-4,
                    rate_scale: 3e3,
                    weights: vec![0.1, -0.2, 0.05, 0.0, 0.3, -0.1, 0.02, 0.2, -0.05, 0.1],
                    velocity_gain: -0.07,
                }),
                ..m
            };
            m.validate().unwrap();
            state.reset();
            let stepped: Vec<f64> = u.iter().map(|&x| m.step(&mut state, x)).collect();
            assert_eq!(m.simulate(&u), stepped, "rate {kind:?} {op:?}");
        }
    }

    pub fn validation_names_the_problem() {
        let m = pi(vec![1.0], vec![0.0, 1.0]);
        let e = m.validate().unwrap_err();
        assert!(e.to_string().contains("'weights' has 1 entries"), "{e}");
        let m = pi(vec![1.0, 1.0], vec![1.0, 0.5]);
        assert!(m.validate().unwrap_err().to_string().contains("increase"));
        let mut m = pi(vec![1.0, 1.0], vec![0.0, 0.5]);
        m.cbrt_gain = 1.0;
        assert!(matches!(m.validate(), Err(ModelError::Inconsistent(_))));
    }
}
