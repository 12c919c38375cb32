//! Analytic inverses (docs/math.md §1.6): of a classical PI model, and of an
//! MPI-deadzone model.
//!
//! For `y = sum_i w_i F_{r_i}[x]` on the symmetric play with `r_0 = 0` and
//! positive partial sums `W_i = w_0 + ... + w_i`, the inverse is again a PI
//! model on the symmetric play with
//! `r'_i = sum_{j<=i} w_j (r_i - r_j)`, `w'_0 = 1/w_0`,
//! `w'_i = -w_i / (W_i W_{i-1})`.
//! (Kuhnen & Janocha; the loading curve is piecewise linear with slopes `W_i`
//! and break points `r_i`, and the inverse has slopes `1/W_i` at break points
//! `y(r_i) = r'_i`.) The one-sided dead-zone stage `D[v] = sum_j g_j S_{d_j}[v]`
//! (\[Tang17\] Eq. 41) is the same piecewise-linear map for `v >= 0` (slope
//! `g_0` below 0), so the same formula inverts it (Kuhnen 2003, "Modeling,
//! identification and compensation of complex hysteretic nonlinearities: a
//! modified Prandtl-Ishlinskii approach"). MPI-deadzone, `y = D[P[x]]`,
//! inverts to `P^-1[D^-1[y]]`: a PI model with an input dead-zone stage; and
//! that model inverts back to MPI-deadzone. Offsets carry over:
//! `y = off + P[u - u0]` inverts to `u = u0 + P^-1[y - off]`.

use super::model::{DeadZoneStage, HysteresisModel, ModelKind};
use super::operators::PlayOperator;

/// Why a model has no analytic inverse here.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InverseError {
    /// MPI-cbrt has no closed-form inverse.
    #[error(
        "the analytic inverse needs a 'pi' or 'mpi-deadzone' model; an 'mpi-cbrt' model has no closed-form inverse (identify the inverse directly instead: the `inverse` setting)"
    )]
    NoClosedForm,
    /// Rate-dependent weights change the loading curve from sample to sample.
    #[error(
        "the analytic inverse needs a rate-independent model; this one has rate-dependent weights (identify the inverse directly instead: the `inverse` setting)"
    )]
    RateDependent,
    /// The formula is for the symmetric play.
    #[error(
        "the analytic inverse needs the symmetric play (play-symmetric); this model uses play-lower (identify the inverse directly instead: the `inverse` setting)"
    )]
    NotSymmetric,
    /// The first threshold must be 0 (otherwise the map has a flat piece).
    #[error("the first threshold of '{stage}' must be 0 for an invertible model, found {value}")]
    FirstThreshold {
        /// Which threshold list.
        stage: &'static str,
        /// Its first entry.
        value: f64,
    },
    /// A partial sum of the weights is not positive.
    #[error(
        "partial sum {symbol}_{index} = {value} of the {stage} is not positive: the model is not invertible (identify with the `invertible` setting)"
    )]
    NotInvertible {
        /// `W` for the play weights, `G` for dead-zone weights.
        symbol: &'static str,
        /// Which weight list.
        stage: &'static str,
        /// Index of the first bad partial sum.
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// Kuhnen's inverse of the piecewise-linear stage with break points `t` and
/// weights `w` (play loading curve, or one-sided dead zone): break points
/// `t'_i = sum_{j<=i} w_j (t_i - t_j)`, weights `w'_0 = 1/w_0`,
/// `w'_i = -w_i / (W_i W_{i-1})`.
fn invert_stage(
    t: &[f64],
    w: &[f64],
    thresholds: &'static str,
    weights: &'static str,
) -> Result<(Vec<f64>, Vec<f64>), InverseError> {
    if t[0] != 0.0 {
        return Err(InverseError::FirstThreshold {
            stage: thresholds,
            value: t[0],
        });
    }
    let partial: Vec<f64> = w
        .iter()
        .scan(0.0, |acc, wi| {
            *acc += wi;
            Some(*acc)
        })
        .collect();
    if let Some((index, &value)) = partial
        .iter()
        .enumerate()
        .find(|(_, s)| s.partial_cmp(&&0.0) != Some(std::cmp::Ordering::Greater))
    {
        return Err(InverseError::NotInvertible {
            symbol: if weights == "weights" { "W" } else { "G" },
            stage: weights,
            index,
            value,
        });
    }
    let breaks = (0..t.len())
        .map(|i| (0..=i).map(|j| w[j] * (t[i] - t[j])).sum())
        .collect();
    let slopes = (0..w.len())
        .map(|i| {
            if i == 0 {
                1.0 / w[0]
            } else {
                -w[i] / (partial[i] * partial[i - 1])
            }
        })
        .collect();
    Ok((breaks, slopes))
}

fn inverse_dead_zone(
    dz: &DeadZoneStage,
    thresholds: &'static str,
    weights: &'static str,
) -> Result<DeadZoneStage, InverseError> {
    let (thresholds, weights) = invert_stage(&dz.thresholds, &dz.weights, thresholds, weights)?;
    Ok(DeadZoneStage {
        thresholds,
        weights,
    })
}

/// The analytic inverse of a PI model, of an MPI-deadzone model (a PI model
/// with an input dead-zone stage), or of such an inverse (docs/math.md §1.6).
/// The input model is assumed valid ([`HysteresisModel::validate`]).
pub fn analytic_inverse(model: &HysteresisModel) -> Result<HysteresisModel, InverseError> {
    if model.kind == ModelKind::MpiCbrt {
        return Err(InverseError::NoClosedForm);
    }
    if model.rate.is_some() {
        return Err(InverseError::RateDependent);
    }
    if model.operator != PlayOperator::Symmetric {
        return Err(InverseError::NotSymmetric);
    }
    let (thresholds, weights) =
        invert_stage(&model.thresholds, &model.weights, "thresholds", "weights")?;
    // y = D[P[x]] -> P^-1[D^-1[y]]: the output stage becomes the input
    // stage, and back.
    let dead_zone = match &model.input_dead_zone {
        Some(dz) => Some(inverse_dead_zone(
            dz,
            "input_dead_zone.thresholds",
            "input_dead_zone.weights",
        )?),
        None => None,
    };
    let input_dead_zone = match &model.dead_zone {
        Some(dz) => Some(inverse_dead_zone(
            dz,
            "dead_zone.thresholds",
            "dead_zone.weights",
        )?),
        None => None,
    };
    Ok(HysteresisModel {
        kind: if dead_zone.is_some() {
            ModelKind::MpiDeadzone
        } else {
            ModelKind::Pi
        },
        operator: PlayOperator::Symmetric,
        thresholds,
        weights,
        cbrt_gain: 0.0,
        offset: model.input_offset,
        input_offset: model.offset,
        dead_zone,
        input_dead_zone,
        rate: None,
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn two_operator_inverse_by_hand() {
        // w = [1, 1], r = [0, 1]: loading curve slope 1 up to 1, then 2.
        // Inverse: r' = [0, 1], w' = [1, -1/(2*1)] -> slope 1 then 1/2.
        let m = HysteresisModel {
            kind: ModelKind::Pi,
            operator: PlayOperator::Symmetric,
            thresholds: vec![0.0, 1.0],
            weights: vec![1.0, 1.0],
            cbrt_gain: 0.0,
            offset: 2.0,
            input_offset: 0.0,
            dead_zone: None,
            input_dead_zone: None,
            rate: None,
        };
        let inv = analytic_inverse(&m).unwrap();
        assert_eq!(inv.thresholds, vec![0.0, 1.0]);
        assert_eq!(inv.weights, vec![1.0, -0.5]);
        assert_eq!((inv.offset, inv.input_offset), (0.0, 2.0));
        let u = [0.0, 0.5, 2.0, 3.0, 1.0, -1.0, 0.5];
        let back = inv.simulate(&m.simulate(&u));
        for (a, b) in back.iter().zip(u) {
            assert!((a - b).abs() < 1e-14, "{a} vs {b}");
        }
    }
}
