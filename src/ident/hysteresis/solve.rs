//! Hysteresis compensation by per-sample inversion of a forward model
//! (docs/math.md §1.6): `u(k)` is the root of `Y(u; F(k-1), x(k-1)) = y(k)`,
//! computed by the runtime's solve (`fts_runtime::HysteresisSpec::solve`),
//! so the library, `fts simulate` and a target give the same bits.

use super::model::{HysteresisModel, ModelKind};
use super::operators::PlayOperator;
use crate::runtime::{FeedbackSpec, HysteresisSpec, PlayForm, RuntimeController, RuntimeSpec};

/// Checks what makes the forward model strictly increasing in its input
/// from every state (docs/math.md §1.6), so that the per-sample root is
/// unique: `r_0 = 0` with positive partial sums `W_j` of the play weights,
/// `c >= 0`, and for MPI-deadzone `d_0 = 0` with positive partial sums of
/// the dead-zone weights (and the same for an input dead-zone stage). The rate stage is not covered: its slope terms
/// depend on the state and the rate (docs/math.md §1.7). The model is
/// assumed valid ([`HysteresisModel::validate`]).
pub fn check_solvable(model: &HysteresisModel) -> Result<(), String> {
    positive_prefix(&model.thresholds, &model.weights, "thresholds", "W")?;
    if model.cbrt_gain < 0.0 {
        return Err(format!(
            "cbrt_gain {} is negative: the model is not increasing near 0 and cannot be solved for its input",
            model.cbrt_gain
        ));
    }
    if let (ModelKind::MpiDeadzone, Some(dz)) = (model.kind, &model.dead_zone) {
        positive_prefix(&dz.thresholds, &dz.weights, "dead-zone thresholds", "G")?;
    }
    if let Some(dz) = &model.input_dead_zone {
        positive_prefix(
            &dz.thresholds,
            &dz.weights,
            "input dead-zone thresholds",
            "H",
        )?;
    }
    Ok(())
}

fn positive_prefix(r: &[f64], w: &[f64], what: &str, name: &str) -> Result<(), String> {
    if r.first() != Some(&0.0) {
        return Err(format!(
            "the first of the {what} must be 0 for the model to be solved for its input, found {:?}",
            r.first()
        ));
    }
    let mut sum = 0.0;
    for (i, &wi) in w.iter().enumerate() {
        sum += wi;
        if sum.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(format!(
                "partial sum {name}_{i} = {sum} is not positive: the model is not increasing and cannot be solved for its input"
            ));
        }
    }
    Ok(())
}

/// The runtime's block for `model`, solving on `[lo, hi]`.
pub fn solve_spec(model: &HysteresisModel, lo: f64, hi: f64) -> HysteresisSpec<'_> {
    let dz = model.dead_zone.as_ref();
    let idz = model.input_dead_zone.as_ref();
    let rate = model.rate.as_ref();
    HysteresisSpec {
        form: match model.operator {
            PlayOperator::Lower => PlayForm::Lower,
            PlayOperator::Symmetric => PlayForm::Symmetric,
        },
        thresholds: &model.thresholds,
        weights: &model.weights,
        cbrt_gain: model.cbrt_gain,
        offset: model.offset,
        input_offset: model.input_offset,
        dead_zone_thresholds: dz.map_or(&[], |d| &d.thresholds),
        dead_zone_weights: dz.map_or(&[], |d| &d.weights),
        input_dead_zone_thresholds: idz.map_or(&[], |d| &d.thresholds),
        input_dead_zone_weights: idz.map_or(&[], |d| &d.weights),
        rate_weights: rate.map_or(&[], |r| &r.weights),
        rate_ts: rate.map_or(0.0, |r| r.ts),
        rate_scale: rate.map_or(0.0, |r| r.rate_scale),
        velocity_gain: rate.map_or(0.0, |r| r.velocity_gain),
        solve: Some((lo, hi)),
    }
}

/// Applies the solved inverse of the forward `model` to `y` from rest:
/// `u(k)` with `Y(u(k)) = y(k)`, saturated to `[lo, hi]` where `y(k)` is
/// out of the model's reach. Errors name a model the runtime cannot hold.
pub fn solve_inverse(
    model: &HysteresisModel,
    y: &[f64],
    lo: f64,
    hi: f64,
) -> Result<Vec<f64>, String> {
    let spec = RuntimeSpec {
        zpetc: None,
        hysteresis: Some(solve_spec(model, lo, hi)),
        feedback: FeedbackSpec::None,
        repetitive: None,
    };
    let mut c = RuntimeController::new(&spec).map_err(|e| e.to_string())?;
    Ok(y.iter().map(|&v| c.step(v, 0.0)).collect())
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::ident::hysteresis::{RateStage, analytic_inverse};

    fn pi(operator: PlayOperator) -> HysteresisModel {
        HysteresisModel {
            kind: ModelKind::Pi,
            operator,
            thresholds: vec![0.0, 0.5, 1.0, 1.5, 2.0],
            weights: vec![0.8, 0.3, -0.1, 0.2, 0.05],
            cbrt_gain: 0.0,
            offset: 0.4,
            input_offset: 0.1,
            dead_zone: None,
            input_dead_zone: None,
            rate: None,
        }
    }

    /// A triangle sweep of shrinking amplitude, then uniform random values
    /// (xorshift), all inside `[lo, hi]`.
    fn references(lo: f64, hi: f64) -> Vec<f64> {
        let mut v = Vec::new();
        for amp in [1.0, 0.7, 0.4, 0.9] {
            for k in 0..200 {
                let t = f64::from(k) / 100.0;
                let tri = if t < 1.0 { t } else { 2.0 - t };
                v.push(lo + (hi - lo) * (0.5 + amp * (tri - 0.5)));
            }
        }
        let mut s = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..500 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            v.push(lo + (hi - lo) * (s >> 11) as f64 / (1u64 << 53) as f64);
        }
        v
    }

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    /// Solve then forward gives the reference back; returns the solved input.
    fn round_trip(m: &HysteresisModel, lo: f64, hi: f64) -> Vec<f64> {
        // Targets strictly inside the range the model reaches from rest.
        let y_max = m.simulate(&[hi])[0];
        let y_min = m.simulate(&[hi, lo])[1];
        let (a, b) = (
            y_min + 0.05 * (y_max - y_min),
            y_max - 0.05 * (y_max - y_min),
        );
        let y = references(a, b);
        let u = solve_inverse(m, &y, lo, hi).unwrap();
        let back = m.simulate(&u);
        let err = max_abs_diff(&back, &y);
        assert!(err <= 1e-9 * (b - a), "round trip error {err}");
        u
    }

    pub fn pi_solve_equals_the_analytic_inverse() {
        let m = pi(PlayOperator::Symmetric);
        check_solvable(&m).unwrap();
        let (lo, hi) = (-3.0, 6.0);
        let y = references(-1.0, 3.5);
        let solved = solve_inverse(&m, &y, lo, hi).unwrap();
        let analytic = analytic_inverse(&m).unwrap().simulate(&y);
        let err = max_abs_diff(&solved, &analytic);
        assert!(err <= 1e-9 * 4.5, "solved vs analytic inverse: {err}");
        round_trip(&m, lo, hi);
    }

    pub fn mpi_cbrt_and_lower_play_round_trip() {
        let mut m = pi(PlayOperator::Lower);
        round_trip(&m, -2.0, 5.0);
        m.kind = ModelKind::MpiCbrt;
        m.cbrt_gain = 0.6;
        check_solvable(&m).unwrap();
        round_trip(&m, -2.0, 5.0);
    }

    pub fn out_of_reach_saturates_at_the_closer_end() {
        let m = pi(PlayOperator::Symmetric);
        let u = solve_inverse(&m, &[1e6, -1e6, f64::NAN, 1.0], -3.0, 6.0).unwrap();
        assert_eq!(&u[..3], &[6.0, -3.0, -3.0]);
        assert!(u[3].is_finite() && u[3] > -3.0 && u[3] < 6.0);
    }

    pub fn non_increasing_models_are_refused() {
        let mut m = pi(PlayOperator::Symmetric);
        m.weights[1] = -0.9;
        assert!(check_solvable(&m).unwrap_err().contains("W_1"));
        let mut m = pi(PlayOperator::Symmetric);
        m.kind = ModelKind::MpiCbrt;
        m.cbrt_gain = -0.1;
        assert!(check_solvable(&m).unwrap_err().contains("cbrt_gain"));
    }

    fn rate_model() -> HysteresisModel {
        HysteresisModel {
            kind: ModelKind::MpiCbrt,
            cbrt_gain: 0.05,
            rate: Some(RateStage {
                ts: 1e-4,
                rate_scale: 400.0,
                weights: vec![0.05, -0.02, 0.03, 0.01, -0.01],
                velocity_gain: -0.02,
            }),
            ..pi(PlayOperator::Lower)
        }
    }

    pub fn runtime_rate_stage_is_the_model_bit_for_bit() {
        let m = rate_model();
        let u = references(-1.0, 4.0);
        let spec = RuntimeSpec {
            zpetc: None,
            hysteresis: Some(HysteresisSpec {
                solve: None,
                ..solve_spec(&m, 0.0, 1.0)
            }),
            feedback: FeedbackSpec::None,
            repetitive: None,
        };
        let mut c = RuntimeController::new(&spec).unwrap();
        let mut state = m.new_state();
        for &v in &u {
            assert_eq!(c.step(v, 0.0).to_bits(), m.step(&mut state, v).to_bits());
        }
        // Reset clears x(k-1) too.
        c.reset();
        let mut state = m.new_state();
        assert_eq!(
            c.step(u[5], 0.0).to_bits(),
            m.step(&mut state, u[5]).to_bits()
        );
    }

    pub fn rate_model_solve_round_trips_on_triangles() {
        // Triangles at up to 0.1 input units per sample (|s| <= 2.5).
        let m = rate_model();
        let y: Vec<f64> = (0..2000)
            .map(|k| {
                let t = f64::from(k % 80) / 40.0;
                0.5 + 2.0 * if t < 1.0 { t } else { 2.0 - t }
            })
            .collect();
        let u = solve_inverse(&m, &y, -2.0, 6.0).unwrap();
        let err = max_abs_diff(&m.simulate(&u), &y);
        assert!(err <= 1e-9 * 2.0, "round trip error {err}");
    }
}
