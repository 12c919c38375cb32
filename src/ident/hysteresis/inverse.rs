//! The analytic inverse of a classical PI model (docs/math.md §1.6).
//!
//! For `y = sum_i w_i F_{r_i}[x]` on the symmetric play with `r_0 = 0` and
//! positive partial sums `W_i = w_0 + ... + w_i`, the inverse is again a PI
//! model on the symmetric play with
//! `r'_i = sum_{j<=i} w_j (r_i - r_j)`, `w'_0 = 1/w_0`,
//! `w'_i = -w_i / (W_i W_{i-1})`.
//! (Kuhnen & Janocha; the loading curve is piecewise linear with slopes `W_i`
//! and break points `r_i`, and the inverse has slopes `1/W_i` at break points
//! `y(r_i) = r'_i`.) Offsets carry over: `y = off + P[u - u0]` inverts to
//! `u = u0 + P^-1[y - off]`.

use super::model::{HysteresisModel, ModelKind};
use super::operators::PlayOperator;

/// Why a model has no analytic inverse here.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InverseError {
    /// Only classical PI models have the closed form.
    #[error(
        "the analytic inverse needs a classical PI model; this one is '{0}' (identify the inverse directly instead: the `inverse` setting)"
    )]
    NotPi(String),
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
    /// `r_0` must be 0 (otherwise the loop has flat pieces after reversals).
    #[error("the first threshold must be 0 for an invertible PI model, found {0}")]
    FirstThreshold(f64),
    /// A partial sum of the weights is not positive.
    #[error(
        "partial sum W_{index} = {value} of the weights is not positive: the model is not invertible (identify with the `invertible` setting)"
    )]
    NotInvertible {
        /// Index of the first bad partial sum.
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// The analytic inverse of a PI model (docs/math.md §1.6). The input model is
/// assumed valid ([`HysteresisModel::validate`]).
pub fn analytic_inverse(model: &HysteresisModel) -> Result<HysteresisModel, InverseError> {
    if model.kind != ModelKind::Pi {
        return Err(InverseError::NotPi(model.kind.name().into()));
    }
    if model.rate.is_some() {
        return Err(InverseError::RateDependent);
    }
    if model.operator != PlayOperator::Symmetric {
        return Err(InverseError::NotSymmetric);
    }
    let r = &model.thresholds;
    let w = &model.weights;
    if r[0] != 0.0 {
        return Err(InverseError::FirstThreshold(r[0]));
    }
    let partial = model.partial_sums();
    if let Some((index, &value)) = partial
        .iter()
        .enumerate()
        .find(|(_, s)| s.partial_cmp(&&0.0) != Some(std::cmp::Ordering::Greater))
    {
        return Err(InverseError::NotInvertible { index, value });
    }
    let thresholds: Vec<f64> = (0..r.len())
        .map(|i| (0..=i).map(|j| w[j] * (r[i] - r[j])).sum())
        .collect();
    let weights: Vec<f64> = (0..w.len())
        .map(|i| {
            if i == 0 {
                1.0 / w[0]
            } else {
                -w[i] / (partial[i] * partial[i - 1])
            }
        })
        .collect();
    Ok(HysteresisModel {
        kind: ModelKind::Pi,
        operator: PlayOperator::Symmetric,
        thresholds,
        weights,
        cbrt_gain: 0.0,
        offset: model.input_offset,
        input_offset: model.offset,
        dead_zone: None,
        rate: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_operator_inverse_by_hand() {
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
