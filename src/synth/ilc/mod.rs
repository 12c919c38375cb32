//! Iterative learning control for repeated trajectories (Bristow, Tharayil
//! & Alleyne 2006, "A survey of iterative learning control"; the
//! plant-inversion ILC of their Sec. IV-C).
//!
//! Trial `j` runs the loop with the learned feedforward `f_j` added to its
//! reference and measures the error `e_j = r - y_j`; between trials
//!
//! `f_{j+1} = Q (f_j + a L e_j)`,                                          (1)
//!
//! `L` the stable (non-causal) inversion of the identified closed loop `G`
//! (loop reference to output; the ZPETC with the exact anticausal-series
//! inversion of its unstable zeros, [`crate::synth::zpetc`]), `a` the
//! learning gain and `Q` a zero-phase low-pass (the windowed sinc of
//! [`super::repetitive::windowed_sinc`]), both applied to the whole trial
//! at once. For trials long against the loop's memory the error contracts
//! from trial to trial, monotonically in the 2-norm, when
//!
//! `rho = max_w |Q(e^jw)| |1 - a L(e^jw) G(e^jw)| < 1`                     (2)
//!
//! (Bristow et al. Eq. 29). Against a true loop `G (1 + D)` with relative
//! model error `|D(e^jw)| <= delta(w)` the condition holds when
//! `|Q| (|1 - a L G| + a |L G| delta) < 1`; the largest such `delta` at each
//! frequency is the robustness margin reported (Eq. 3).

pub mod robust;

use super::repetitive::{q_response, windowed_sinc};
use super::zpetc::{self, StableInversion, Zpetc, ZpetcParams};
use crate::lti::DiscreteTf;
use std::f64::consts::PI;

/// Settings of an ILC design.
#[derive(Debug, Clone, PartialEq)]
pub struct IlcParams {
    /// Learning gain `a`. Default 1 (full inversion each trial).
    pub gain: f64,
    /// Cutoff of `Q` (-6 dB), Hz. Default 2500.
    pub q_cutoff_hz: f64,
    /// One-sided taps of `Q`. Default 32.
    pub q_half_length: usize,
    /// How `L` inverts the model. Default: every zero cancelled
    /// (`rho = 0.999`), zeros outside radius 1.02 by the anticausal series.
    pub inversion: ZpetcParams,
    /// Frequencies on which Eq. (2) is evaluated, uniform in `(0, Nyquist]`.
    /// Default 4096.
    pub points: usize,
}

impl Default for IlcParams {
    fn default() -> Self {
        Self {
            gain: 1.0,
            q_cutoff_hz: 2500.0,
            q_half_length: 32,
            inversion: ZpetcParams {
                rho: 0.999,
                stable_inversion: Some(StableInversion::default()),
                ..ZpetcParams::default()
            },
            points: 4096,
        }
    }
}

/// A designed learning law with its convergence check.
#[derive(Debug, Clone, PartialEq)]
pub struct IlcDesign {
    /// `L`, the model's stable inversion.
    pub learning: Zpetc,
    /// `Q` taps `[q_0, .., q_h]`.
    pub q: Vec<f64>,
    /// Learning gain.
    pub gain: f64,
    /// `Q`'s cutoff as designed (-6 dB), Hz.
    pub q_cutoff_hz: f64,
    /// Sample time, s.
    pub ts: f64,
    /// Eq. (2) on the model.
    pub rho: f64,
    /// Where `rho` peaks, Hz.
    pub rho_at_hz: f64,
    /// The smallest robustness margin of Eq. (3) over frequencies where
    /// `|Q| > 0.01`: the relative model error the learning tolerates there.
    pub tolerated_model_error: f64,
    /// Where that margin is smallest, Hz.
    pub tolerated_at_hz: f64,
    /// `(Hz, |Q| |1 - a L G|)` on the evaluation grid, for plots.
    pub rho_curve: Vec<(f64, f64)>,
}

/// Why no learning law was designed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IlcError {
    /// A setting is out of range.
    #[error("{0}")]
    Setting(String),
    /// The model cannot be inverted.
    #[error("learning filter: {0}")]
    Inversion(String),
    /// Eq. (2) fails on the model: the learning would diverge.
    #[error(
        "the convergence condition fails on the model: max |Q| |1 - a L G| = {rho:.4} >= 1 at {at_hz:.1} Hz; lower the learning gain or Q's cutoff"
    )]
    Diverges {
        /// `rho`.
        rho: f64,
        /// Where, Hz.
        at_hz: f64,
    },
}

/// Designs the learning law for the closed loop `g`; a failing Eq. (2) is
/// returned as [`IlcError::Diverges`] with the design in `Err` context only
/// (use [`design_unchecked`] to run it anyway).
pub fn design(g: &DiscreteTf, params: &IlcParams) -> Result<IlcDesign, IlcError> {
    let d = design_unchecked(g, params)?;
    if d.rho >= 1.0 {
        return Err(IlcError::Diverges {
            rho: d.rho,
            at_hz: d.rho_at_hz,
        });
    }
    Ok(d)
}

/// [`design`] without refusing a failing convergence condition.
pub fn design_unchecked(g: &DiscreteTf, params: &IlcParams) -> Result<IlcDesign, IlcError> {
    let ts = g.ts();
    let nyquist = 0.5 / ts;
    if !(params.gain.is_finite() && params.gain > 0.0) {
        return Err(IlcError::Setting(format!(
            "gain: {}; expected a positive number",
            params.gain
        )));
    }
    if !(params.q_cutoff_hz.is_finite()
        && params.q_cutoff_hz > 0.0
        && params.q_cutoff_hz <= nyquist)
    {
        return Err(IlcError::Setting(format!(
            "q-cutoff: {} Hz; expected a frequency in (0, {nyquist}] Hz (Nyquist)",
            params.q_cutoff_hz
        )));
    }
    if params.q_half_length == 0 || params.q_half_length > 4096 {
        return Err(IlcError::Setting(format!(
            "q-taps: {}; expected 1 to 4096 taps each side",
            params.q_half_length
        )));
    }
    Ok(design_with_inversion(inversion(g, params)?, g, params))
}

/// `L`, the stable inversion of `g` as `params.inversion` makes it: what
/// every law on one model shares ([`design_with_inversion`]).
pub fn inversion(g: &DiscreteTf, params: &IlcParams) -> Result<Zpetc, IlcError> {
    zpetc::design(g, &params.inversion).map_err(|e| IlcError::Inversion(e.to_string()))
}

/// [`design_unchecked`] with the inversion `L` of `g` already made (the
/// settings' ranges checked by the caller): only `Q` and the gain change,
/// as when candidate laws are compared on one model.
pub fn design_with_inversion(learning: Zpetc, g: &DiscreteTf, params: &IlcParams) -> IlcDesign {
    let ts = g.ts();
    let q = windowed_sinc(params.q_cutoff_hz * ts, params.q_half_length);
    let points = params.points.max(16);
    let mut rho_curve = Vec::with_capacity(points);
    let (mut rho, mut rho_at) = (0.0f64, 0.0);
    let (mut tolerated, mut tolerated_at) = (f64::INFINITY, 0.0);
    for i in 1..=points {
        let w = PI * i as f64 / points as f64;
        let lg = learning.response_at_omega(w) * g.response_at_omega(w);
        let qw = q_response(&q, w).abs();
        let value = qw * (crate::lti::c64::new(1.0, 0.0) - params.gain * lg).norm();
        let hz = w / (2.0 * PI * ts);
        rho_curve.push((hz, value));
        if value > rho {
            (rho, rho_at) = (value, hz);
        }
        // Eq. (3): |Q| (|1 - a L G| + a |L G| delta) < 1.
        if qw > 0.01 {
            let margin = (1.0 / qw - (value / qw)) / (params.gain * lg.norm());
            if margin < tolerated {
                (tolerated, tolerated_at) = (margin, hz);
            }
        }
    }
    IlcDesign {
        learning,
        q,
        gain: params.gain,
        q_cutoff_hz: params.q_cutoff_hz,
        ts,
        rho,
        rho_at_hz: rho_at,
        tolerated_model_error: tolerated,
        tolerated_at_hz: tolerated_at,
        rho_curve,
    }
}

/// The zero-phase FIR `q` on a whole signal, zero beyond its ends.
pub fn zero_phase(q: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let h = q.len() - 1;
    (0..n)
        .map(|k| {
            let lo = k.saturating_sub(h);
            let hi = (k + h).min(n - 1);
            (lo..=hi).map(|j| q[k.abs_diff(j)] * x[j]).sum()
        })
        .collect()
}

impl IlcDesign {
    /// `L e`: the causal part of the inversion driven by `e(k + preview)`,
    /// the error taken as 0 past the trial's end.
    pub fn learn(&self, e: &[f64]) -> Vec<f64> {
        let mut filter = self.learning.causal_filter();
        let p = self.learning.preview;
        (0..e.len())
            .map(|k| filter.step(e.get(k + p).copied().unwrap_or(0.0)))
            .collect()
    }

    /// Eq. (1): the next trial's feedforward from this trial's `f` and `e`.
    pub fn update(&self, f: &[f64], e: &[f64]) -> Vec<f64> {
        let le = self.learn(e);
        let raw: Vec<f64> = f
            .iter()
            .zip(&le)
            .map(|(fk, lk)| fk + self.gain * lk)
            .collect();
        zero_phase(&self.q, &raw)
    }

    /// Runs a first trial without feedforward, then `trials` learning
    /// trials: `run(j, f)` plays trial `j` with the feedforward `f` (empty
    /// for trial 0) and returns its outcome, `error` that outcome's
    /// tracking error `e = r - y` over the whole trial. Eq. (1) learns on a
    /// window: the error before `learn_from` is taken as 0 (where the loop
    /// leaves rest, the error is not the trajectory's and cannot be
    /// learned; learning it would only grow `f` from trial to trial).
    /// Returns the feedforward the last trial played and its outcome.
    pub fn run_trials<T, E>(
        &self,
        trials: usize,
        learn_from: usize,
        mut run: impl FnMut(usize, &[f64]) -> Result<T, E>,
        error: impl Fn(&T) -> Vec<f64>,
    ) -> Result<(Vec<f64>, T), E> {
        let mut learned = Vec::new();
        let mut outcome = run(0, &learned)?;
        for trial in 1..=trials {
            let mut e = error(&outcome);
            let window = learn_from.min(e.len());
            e[..window].fill(0.0);
            if learned.is_empty() {
                learned = vec![0.0; e.len()];
            }
            learned = self.update(&learned, &e);
            outcome = run(trial, &learned)?;
        }
        Ok((learned, outcome))
    }
}

/// The measured verdict's trigger: a trial whose max error exceeds the
/// best earlier trial's by `factor` (or is not finite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Divergence {
    /// The trial that grew.
    pub trial: usize,
    /// The best trial before it.
    pub best_trial: usize,
    /// Its error over the best one's.
    pub ratio: f64,
}

/// Whether the last of `max_errors` (trial 0 first) diverged from the best
/// before it by more than `factor`.
pub fn last_diverged(max_errors: &[f64], factor: f64) -> Option<Divergence> {
    let (&last, before) = max_errors.split_last()?;
    let (best_trial, &best) = before
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    (!last.is_finite() || last > factor * best).then_some(Divergence {
        trial: before.len(),
        best_trial,
        ratio: last / best,
    })
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    /// On a minimum-phase model with a delay, `L G = 1` exactly, so one
    /// trial with `a = 1` and `Q = 1` (a single tap) removes the error of a
    /// linear loop that is the model: the second trial's error is round-off.
    pub fn exact_inversion_learns_in_one_trial() {
        let g = DiscreteTf::new(vec![0.3, 0.1], vec![1.0, -0.5], 2, 1e-4).unwrap();
        let p = IlcParams {
            q_cutoff_hz: 5000.0,
            q_half_length: 1,
            ..IlcParams::default()
        };
        let mut d = design(&g, &p).unwrap();
        d.q = vec![1.0];
        assert!(d.rho < 1e-9, "{}", d.rho);
        let n = 400;
        let r: Vec<f64> = (0..n)
            .map(|k| {
                if (100..300).contains(&k) {
                    (k as f64 * 0.05).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let run = |f: &[f64]| -> Vec<f64> {
            let mut filt =
                crate::lti::TdfFilter::from_coeffs(g.num().coeffs(), g.den().coeffs(), g.delay());
            let y: Vec<f64> = r.iter().zip(f).map(|(a, b)| filt.step(a + b)).collect();
            r.iter().zip(&y).map(|(a, b)| a - b).collect()
        };
        let e0 = run(&vec![0.0; n]);
        let f1 = d.update(&vec![0.0; n], &e0);
        let e1 = run(&f1);
        let max = |e: &[f64]| e[..n - 10].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(max(&e0) > 0.3);
        assert!(max(&e1) < 1e-9, "{}", max(&e1));
    }

    /// `run_trials` plays trial 0 without feedforward, learns on the
    /// window only, and returns what the last trial played: with a window
    /// that starts past the trial nothing is learned; with the whole trial
    /// an error of constant `c` is learned as `a c` (L = 1 / G, G = 1).
    pub fn trials_learn_on_their_window() {
        let g = DiscreteTf::new(vec![1.0], vec![1.0], 0, 1e-4).unwrap();
        let mut d = design(&g, &IlcParams::default()).unwrap();
        d.q = vec![1.0];
        let mut played = Vec::new();
        let run = |f: &[f64]| -> Result<Vec<f64>, ()> {
            Ok((0..50)
                .map(|k| 2.0 - f.get(k).copied().unwrap_or(0.0))
                .collect())
        };
        let (f, e) = d
            .run_trials(
                2,
                0,
                |trial, f| {
                    played.push((trial, f.len()));
                    run(f)
                },
                |e| e.clone(),
            )
            .unwrap();
        assert_eq!(played, vec![(0, 0), (1, 50), (2, 50)]);
        // a = 1: 2, then the error is 0 (the preview's tail aside).
        assert!((f[10] - 2.0).abs() < 1e-12, "{}", f[10]);
        assert!(e[10].abs() < 1e-12);
        let (f, _) = d.run_trials(2, 50, |_, f| run(f), |e| e.clone()).unwrap();
        assert!(f.iter().all(|v| *v == 0.0));
    }

    pub fn a_gain_beyond_two_fails_the_condition() {
        let g = DiscreteTf::new(vec![0.5], vec![1.0, -0.5], 1, 1e-4).unwrap();
        let p = IlcParams {
            gain: 2.5,
            ..IlcParams::default()
        };
        match design(&g, &p) {
            Err(IlcError::Diverges { rho, .. }) => assert!((rho - 1.5).abs() < 0.01, "{rho}"),
            other => panic!("{other:?}"),
        }
    }

    /// The trigger fires on growth past the best earlier trial (not past
    /// the previous one), and on a non-finite error.
    pub fn divergence_is_growth_past_the_best_trial() {
        assert_eq!(last_diverged(&[1.0], 2.0), None);
        assert_eq!(last_diverged(&[1.0, 0.1, 0.19], 2.0), None);
        let d = last_diverged(&[1.0, 0.1, 0.15, 0.21], 2.0).unwrap();
        assert_eq!((d.trial, d.best_trial), (3, 1));
        assert!((d.ratio - 2.1).abs() < 1e-12);
        // Larger than trial 0 is not needed: 2x the best suffices.
        assert!(last_diverged(&[1.0, 0.01, 0.03], 2.0).is_some());
        assert!(last_diverged(&[1.0, f64::NAN], 2.0).is_some());
    }

    pub fn zero_phase_filter_is_symmetric_convolution() {
        let q = [0.5, 0.25];
        assert_eq!(zero_phase(&q, &[0.0, 4.0, 0.0]), vec![1.0, 2.0, 1.0]);
    }
}
