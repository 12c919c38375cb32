//! Play (backlash) and dead-zone operators, docs/math.md §1.1 and §1.4.
//!
//! Every operator here is a pure function of the new input and the previous
//! state, so a model can keep its state in a plain slice and evaluate sample by
//! sample without allocating.

/// The two play-operator forms of the papers. A model file records the one it
/// was identified with; the two are never mixed inside one model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlayOperator {
    /// One-sided play, output in `[u - r, u]` (\[Li21\] Eq. 3).
    Lower,
    /// Symmetric play, output in `[u - r, u + r]` (\[Tang17\] Eq. 37-39).
    Symmetric,
}

impl PlayOperator {
    /// The name used on the command line and in model files.
    pub fn name(self) -> &'static str {
        match self {
            PlayOperator::Lower => "play-lower",
            PlayOperator::Symmetric => "play-symmetric",
        }
    }

    /// Inverse of [`PlayOperator::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "play-lower" => Some(PlayOperator::Lower),
            "play-symmetric" => Some(PlayOperator::Symmetric),
            _ => None,
        }
    }

    /// Upper edge of the band for threshold `r`: the lower play follows the
    /// input from below only, the symmetric play sits up to `r` above it.
    #[inline(always)]
    fn upper_offset(self, r: f64) -> f64 {
        match self {
            PlayOperator::Lower => 0.0,
            PlayOperator::Symmetric => r,
        }
    }

    /// One step of the play operator:
    /// `F(k) = max(u(k) - r, min(u(k) + r_up, F(k-1)))` with `r_up = 0` for the
    /// lower play (\[Li21\] Eq. 3) and `r_up = r` for the symmetric play
    /// (\[Tang17\] Eq. 38).
    ///
    /// Written with plain comparisons rather than `f64::max/min`: those handle
    /// NaN specially and cost extra instructions on this critical recursion
    /// (inputs are checked finite before identification; a NaN input leaves
    /// the state unchanged here).
    #[inline(always)]
    pub fn step(self, r: f64, u: f64, previous: f64) -> f64 {
        let upper = u + self.upper_offset(r);
        let clipped = if upper < previous { upper } else { previous };
        let lower = u - r;
        if lower > clipped { lower } else { clipped }
    }

    /// The state before the first sample: the operators start demagnetised
    /// (previous output 0), so `F(0) = step(r, u(0), 0)` (docs/math.md §1.1).
    pub const INITIAL_STATE: f64 = 0.0;

    /// The band `[lo, hi]` the output must lie in for input `u`.
    pub fn band(self, r: f64, u: f64) -> (f64, f64) {
        (u - r, u + self.upper_offset(r))
    }
}

/// One-sided dead-zone operator of \[Tang17\] Eq. 41: `S_d[v] = max(v - d, 0)`
/// for `d > 0` and the identity `S_0[v] = v`: the runtime's own function,
/// so that identification, simulation and the real-time loop agree bit for bit.
#[inline(always)]
pub fn dead_zone(d: f64, v: f64) -> f64 {
    crate::runtime::dead_zone(d, v)
}

/// The uniform threshold grid `r_i = i/n * max_abs`, `i = 0..n-1` (docs/math.md §1.1;
/// \[Li21\], and \[Tang17\]'s `(i-1)/n`, `i = 1..n`, is the same grid).
pub fn uniform_thresholds(n: usize, max_abs: f64) -> Vec<f64> {
    (0..n).map(|i| i as f64 / n as f64 * max_abs).collect()
}

/// Why a threshold list is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThresholdError {
    /// No thresholds.
    #[error("at least one threshold is needed")]
    Empty,
    /// A threshold is negative, NaN or infinite.
    #[error("threshold {index} is {value}; thresholds must be finite and >= 0")]
    Invalid {
        /// Position in the list.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The list does not increase strictly.
    #[error(
        "thresholds must increase strictly: threshold {index} ({value}) does not exceed the one before ({previous})"
    )]
    NotIncreasing {
        /// Position of the first offending entry.
        index: usize,
        /// Its value.
        value: f64,
        /// The value before it.
        previous: f64,
    },
}

/// Checks that thresholds are finite, non-negative and strictly increasing (a
/// repeated threshold gives two identical regressor columns).
pub fn check_thresholds(thresholds: &[f64]) -> Result<(), ThresholdError> {
    if thresholds.is_empty() {
        return Err(ThresholdError::Empty);
    }
    for (index, &value) in thresholds.iter().enumerate() {
        if !value.is_finite() || value < 0.0 {
            return Err(ThresholdError::Invalid { index, value });
        }
        if index > 0 && value <= thresholds[index - 1] {
            return Err(ThresholdError::NotIncreasing {
                index,
                value,
                previous: thresholds[index - 1],
            });
        }
    }
    Ok(())
}

/// Runs one play operator over a whole signal into `out` (same length as `u`),
/// starting from the demagnetised state.
pub fn play_into(op: PlayOperator, r: f64, u: &[f64], out: &mut [f64]) {
    let mut state = PlayOperator::INITIAL_STATE;
    for (o, &x) in out.iter_mut().zip(u) {
        state = op.step(r, x, state);
        *o = state;
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn initial_states_match_math_md() {
        // docs/math.md §1.1: lower F(0) = max(u0 - r, min(u0, 0)),
        // symmetric F(0) = max(u0 - r, min(u0 + r, 0)).
        for &(u0, r) in &[(3.0, 1.0), (-3.0, 1.0), (0.5, 1.0), (-0.5, 1.0), (0.0, 0.0)] {
            let lower = PlayOperator::Lower.step(r, u0, PlayOperator::INITIAL_STATE);
            assert_eq!(lower, (u0 - r).max(u0.min(0.0)));
            let sym = PlayOperator::Symmetric.step(r, u0, PlayOperator::INITIAL_STATE);
            assert_eq!(sym, (u0 - r).max((u0 + r).min(0.0)));
        }
    }

    pub fn zero_threshold_lower_play_is_identity() {
        let u = [0.0, 1.0, -2.0, 3.5, 3.0, -1.0];
        let mut out = [0.0; 6];
        play_into(PlayOperator::Lower, 0.0, &u, &mut out);
        assert_eq!(out, u);
        play_into(PlayOperator::Symmetric, 0.0, &u, &mut out);
        assert_eq!(out, u);
    }

    pub fn hand_computed_lower_play() {
        // r = 1: rising 0 -> 3 follows u - 1 once u > 1, falling back holds the
        // value until u drops below it, then follows u.
        let u = [0.0, 1.0, 2.0, 3.0, 2.5, 2.0, 1.0, 0.0];
        let mut out = [0.0; 8];
        play_into(PlayOperator::Lower, 1.0, &u, &mut out);
        assert_eq!(out, [0.0, 0.0, 1.0, 2.0, 2.0, 2.0, 1.0, 0.0]);
        play_into(PlayOperator::Symmetric, 1.0, &u, &mut out);
        assert_eq!(out, [0.0, 0.0, 1.0, 2.0, 2.0, 2.0, 2.0, 1.0]);
    }

    pub fn dead_zone_and_grid() {
        assert_eq!(dead_zone(0.0, -2.0), -2.0);
        assert_eq!(dead_zone(1.0, -2.0), 0.0);
        assert_eq!(dead_zone(1.0, 3.0), 2.0);
        assert_eq!(uniform_thresholds(4, 2.0), vec![0.0, 0.5, 1.0, 1.5]);
        assert!(check_thresholds(&[0.0, 1.0, 2.0]).is_ok());
        assert!(matches!(
            check_thresholds(&[0.0, 2.0, 1.0]),
            Err(ThresholdError::NotIncreasing { index: 2, .. })
        ));
        assert!(matches!(
            check_thresholds(&[-1.0]),
            Err(ThresholdError::Invalid { .. })
        ));
        assert_eq!(check_thresholds(&[]), Err(ThresholdError::Empty));
    }
}
