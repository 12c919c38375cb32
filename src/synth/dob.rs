//! Design of the disturbance-observer (DOB) feedback block
//! (`fts_runtime::DobSpec`): \[Karagoz18\]'s adaptive robust axis controller
//! as the standard discrete DOB (Ohnishi 1987; Umeno & Hori 1991) around an
//! outer PID, with friction feedforward.
//!
//! * The nominal plant `P_n(z) = z^-d B(z^-1)/A(z^-1)`, `b_0 != 0`, from a
//!   discrete model: `A = prod (1 - p_i z^-1) = prod ((1 - p_i) + p_i w)`
//!   over its poles (eigenvalues), kept in powers of `w = 1 - z^-1` (the
//!   runtime's difference form, `fts_runtime::DobSpec`),
//!   `B = h_d prod (1 - z_i z^-1)` over its finite invariant zeros, `d` the
//!   relative degree (states minus finite zeros) and `h_d = C A^(d-1) B`
//!   the first non-zero Markov parameter. The observer runs `A/B`, proper
//!   because the delay `z^-d` is kept on the command side
//!   (`d_hat = Q [(A/B) y - z^-d u]`); it is stable only when every zero
//!   lies inside the unit circle, so a non-minimum-phase nominal model is
//!   refused.
//! * `Q(z) = ((1 - p)/(1 - p z^-1))^r`, `p = exp(-2 pi f_c ts)`: the
//!   binomial low-pass `(1 + tau s)^-r`, `tau = 1/(2 pi f_c)`, with its
//!   poles mapped by `z = exp(s ts)` and unity DC gain (`Q(1) = 1`).
//!
//! [`linear_controller`] is the block's linear part as one system from the
//! measurement to the command, `u = -K_eq y` with
//! `K_eq = (K + Q A/B)/(1 - Q z^-d)` (`K` the outer controller), for the
//! loop's poles; [`reference_commands`] simulates the block's linear part
//! (reference and measurement in, command out) through state-space
//! algebra, independently of the runtime's filters.

use crate::lti::ss::{StateSpace, poly_from_roots};
use crate::runtime::{DobSpec, MAX_DOB_DELAY, MAX_DOB_LEN};
use faer::Mat;
use std::f64::consts::PI;

/// The observer's filters.
#[derive(Debug, Clone, PartialEq)]
pub struct DobFilters {
    /// `Q` numerator, ascending `z^-1`.
    pub q_num: Vec<f64>,
    /// `Q` denominator.
    pub q_den: Vec<f64>,
    /// The nominal inverse's numerator `A`, ascending powers of `1 - z^-1`.
    pub inverse_num: Vec<f64>,
    /// The nominal inverse's denominator `B`.
    pub inverse_den: Vec<f64>,
    /// The nominal plant's delay `d`.
    pub delay: usize,
}

/// The binomial low-pass `Q` of order `order` and cut-off `f_c` Hz at `ts`.
pub fn q_filter(cutoff_hz: f64, order: usize, ts: f64) -> Result<(Vec<f64>, Vec<f64>), String> {
    let nyquist = 0.5 / ts;
    if !(cutoff_hz.is_finite() && cutoff_hz > 0.0 && cutoff_hz < nyquist) {
        return Err(format!(
            "the Q cut-off must be between 0 and the Nyquist frequency {nyquist} Hz, got {cutoff_hz}"
        ));
    }
    if order == 0 || order >= MAX_DOB_LEN {
        return Err(format!(
            "the Q order must be 1 to {}, got {order}",
            MAX_DOB_LEN - 1
        ));
    }
    let p = (-2.0 * PI * cutoff_hz * ts).exp();
    let poles = vec![crate::lti::c64::new(p, 0.0); order];
    Ok((vec![(1.0 - p).powi(order as i32)], poly_from_roots(&poles)))
}

/// `A`, `B` and `d` of a discrete SISO nominal model (module docs).
pub fn nominal_inverse(g: &StateSpace) -> Result<(Vec<f64>, Vec<f64>, usize), String> {
    if g.nu() != 1 || g.ny() != 1 || !g.is_discrete() {
        return Err("the nominal model must be a discrete SISO system".into());
    }
    if g.d[(0, 0)] != 0.0 {
        return Err(
            "the nominal model must be strictly proper (the controller reads before it commands)"
                .into(),
        );
    }
    let n = g.nx();
    let poles = g.poles().map_err(|e| e.to_string())?;
    // b_k = sum_{i<k} a_i h_(k-i): the numerator from A (ascending z^-1)
    // and the Markov parameters h_j = C A^(j-1) B.
    let a = poly_from_roots(&poles);
    let mut h = Vec::with_capacity(n + 1);
    h.push(0.0);
    let mut v = g.b.clone();
    for _ in 0..n {
        h.push((&g.c * &v)[(0, 0)]);
        v = &g.a * &v;
    }
    let full: Vec<f64> = (0..=n)
        .map(|k| (0..k).map(|i| a[i] * h[k - i]).sum())
        .collect();
    let scale = full.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(scale.is_finite() && scale > 0.0) {
        return Err("the nominal model has no gain (its numerator is zero)".into());
    }
    // Leading coefficients below rounding of the largest are the delay.
    let delay = full
        .iter()
        .position(|v| v.abs() > 1e-9 * scale)
        .unwrap_or(n);
    let b = full[delay..].to_vec();
    if delay == 0 || delay > MAX_DOB_DELAY || b.len() > MAX_DOB_LEN || n + 1 > MAX_DOB_LEN {
        return Err(format!(
            "the nominal model has {n} states and delay {delay}; the block takes at most {} states and a delay of 1 to {MAX_DOB_DELAY}",
            MAX_DOB_LEN - 1
        ));
    }
    let zeros = crate::lti::roots_descending(&b).map_err(|e| e.to_string())?;
    if let Some(z) = zeros.iter().find(|z| z.norm() >= 1.0) {
        return Err(format!(
            "the nominal model has a zero at z = {:.9}{:+.9}j (|z| = {:.9}), on or outside the unit circle: it is not minimum phase and its inverse in the observer would be unstable; choose another nominal model or sample time",
            z.re,
            z.im,
            z.norm()
        ));
    }
    Ok((difference_poly(&poles), b, delay))
}

/// `prod ((1 - p_i) + p_i w)`, ascending powers of `w`.
fn difference_poly(roots: &[crate::lti::c64]) -> Vec<f64> {
    let one = crate::lti::c64::new(1.0, 0.0);
    let mut p = vec![one];
    for r in roots {
        let mut q = vec![crate::lti::c64::new(0.0, 0.0); p.len() + 1];
        for (i, c) in p.iter().enumerate() {
            q[i] += c * (one - r);
            q[i + 1] += c * r;
        }
        p = q;
    }
    p.into_iter().map(|c| c.re).collect()
}

/// `sum_j c_j (1 - z^-1)^j` in ascending powers of `z^-1`.
pub fn shift_poly(difference: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; difference.len()];
    let mut power = vec![1.0];
    for c in difference {
        for (o, p) in out.iter_mut().zip(&power) {
            *o += c * p;
        }
        let mut next = vec![0.0; power.len() + 1];
        for (i, p) in power.iter().enumerate() {
            next[i] += p;
            next[i + 1] -= p;
        }
        power = next;
    }
    out
}

/// The observer's filters for nominal model `g` (discrete at `ts`).
pub fn design(g: &StateSpace, cutoff_hz: f64, order: usize, ts: f64) -> Result<DobFilters, String> {
    let (q_num, q_den) = q_filter(cutoff_hz, order, ts)?;
    let (inverse_num, inverse_den, delay) = nominal_inverse(g)?;
    Ok(DobFilters {
        q_num,
        q_den,
        inverse_num,
        inverse_den,
        delay,
    })
}

/// A system `num/den` (ascending `z^-1`) at `ts`.
pub fn tf_ss(num: &[f64], den: &[f64], ts: f64) -> Result<StateSpace, String> {
    let n = num.len().max(den.len());
    let pad = |p: &[f64]| {
        let mut v = p.to_vec();
        v.resize(n, 0.0);
        v
    };
    StateSpace::from_tf(&pad(num), &pad(den), Some(ts)).map_err(|e| e.to_string())
}

/// `Q` as a system.
fn q_ss(s: &DobSpec<'_>, ts: f64) -> Result<StateSpace, String> {
    tf_ss(s.q_num, s.q_den, ts)
}

/// `k sys`.
fn scaled(sys: &StateSpace, k: f64) -> Result<StateSpace, String> {
    let c = Mat::from_fn(sys.ny(), sys.nx(), |i, j| k * sys.c[(i, j)]);
    let d = Mat::from_fn(sys.ny(), sys.nu(), |i, j| k * sys.d[(i, j)]);
    StateSpace::new(sys.a.clone(), sys.b.clone(), c, d, sys.ts).map_err(|e| e.to_string())
}

/// The outer controller `K` as a system.
fn outer_ss(s: &DobSpec<'_>, ts: f64) -> Result<StateSpace, String> {
    let k = &s.outer;
    let n = k.b.len();
    StateSpace::new(
        Mat::from_fn(n, n, |i, j| k.a[i * n + j]),
        Mat::from_fn(n, 1, |i, _| k.b[i]),
        Mat::from_fn(1, n, |_, j| k.c[j]),
        Mat::from_fn(1, 1, |_, _| k.d),
        Some(ts),
    )
    .map_err(|e| e.to_string())
}

/// `1/(1 - Q z^-d)` and `Q A/B` (`Q` given as `q`).
fn observer_parts(
    s: &DobSpec<'_>,
    q: &StateSpace,
    ts: f64,
) -> Result<(StateSpace, StateSpace), String> {
    let mut delayed = q.clone();
    let unit_delay = tf_ss(&[0.0, 1.0], &[1.0], ts)?;
    for _ in 0..s.delay {
        delayed = delayed.series(&unit_delay).map_err(|e| e.to_string())?;
    }
    let one = StateSpace::gain(Mat::from_fn(1, 1, |_, _| 1.0), Some(ts));
    let loop_inverse = one
        .feedback(&scaled(&delayed, -1.0)?)
        .map_err(|e| e.to_string())?;
    let inverse = tf_ss(&shift_poly(s.inverse_num), s.inverse_den, ts)?;
    let q_inverse = inverse.series(q).map_err(|e| e.to_string())?;
    Ok((loop_inverse, q_inverse))
}

/// The block's linear part from the measurement, `K_eq` of `u = -K_eq y`
/// (module docs), at `ts`.
pub fn linear_controller(s: &DobSpec<'_>, ts: f64) -> Result<StateSpace, String> {
    let q = q_ss(s, ts)?;
    let on_y = outer_ss(s, ts)?;
    let (loop_inverse, q_inverse) = observer_parts(s, &q, ts)?;
    on_y.parallel(&q_inverse)
        .and_then(|k| k.series(&loop_inverse))
        .map_err(|e| e.to_string())
}

/// The block's linear part (no limits, no friction feedforward) driven by
/// `reference` and `measurement`: the commands, by state-space algebra.
pub fn reference_commands(
    s: &DobSpec<'_>,
    ts: f64,
    reference: &[f64],
    measurement: &[f64],
) -> Result<Vec<f64>, String> {
    let q = q_ss(s, ts)?;
    let on_r = outer_ss(s, ts)?;
    let on_y = on_r.clone();
    let (loop_inverse, q_inverse) = observer_parts(s, &q, ts)?;
    let from_y = scaled(&on_y.parallel(&q_inverse).map_err(|e| e.to_string())?, -1.0)?;
    // [r; y] -> K r - (K + Q A/B) y -> 1/(1 - Q z^-d).
    let both = on_r.append(&from_y).map_err(|e| e.to_string())?;
    let sum = StateSpace::gain(Mat::from_fn(1, 2, |_, _| 1.0), Some(ts));
    let k = both
        .series(&sum)
        .and_then(|k| k.series(&loop_inverse))
        .map_err(|e| e.to_string())?;
    let n = k.nx();
    let mut x = vec![0.0; n];
    let mut out = Vec::with_capacity(reference.len());
    for (r, y) in reference.iter().zip(measurement) {
        let w = [*r, *y];
        let u = (0..n).map(|j| k.c[(0, j)] * x[j]).sum::<f64>()
            + k.d[(0, 0)] * w[0]
            + k.d[(0, 1)] * w[1];
        let next: Vec<f64> = (0..n)
            .map(|i| {
                (0..n).map(|j| k.a[(i, j)] * x[j]).sum::<f64>()
                    + k.b[(i, 0)] * w[0]
                    + k.b[(i, 1)] * w[1]
            })
            .collect();
        x = next;
        out.push(u);
    }
    Ok(out)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn q_has_unity_dc_gain_and_the_binomial_poles() {
        let (num, den) = q_filter(1000.0, 3, 1e-5).unwrap();
        let dc = num.iter().sum::<f64>() / den.iter().sum::<f64>();
        assert!((dc - 1.0).abs() < 1e-12, "{dc}");
        let p = (-2.0 * PI * 1000.0 * 1e-5f64).exp();
        // (1 - p z^-1)^3 = 1 - 3p z^-1 + 3p^2 z^-2 - p^3 z^-3
        let want = [1.0, -3.0 * p, 3.0 * p * p, -p * p * p];
        for (a, b) in den.iter().zip(want) {
            assert!((a - b).abs() < 1e-14);
        }
        assert!(q_filter(0.0, 1, 1e-5).is_err());
        assert!(q_filter(60_000.0, 1, 1e-5).is_err());
        assert!(q_filter(100.0, 0, 1e-5).is_err());
    }

    pub fn nominal_inverse_is_the_plant_inverted_and_nmp_is_refused() {
        // P = z^-1 (2 - z^-1)/(1 - 0.5 z^-1)... minimum phase: (2 - 0.5 z^-1).
        let ts = 1e-3;
        let g = tf_ss(&[0.0, 2.0, -0.5], &[1.0, -0.9, 0.2], ts).unwrap();
        let (a, b, d) = nominal_inverse(&g).unwrap();
        assert_eq!(d, 1);
        let a = shift_poly(&a);
        for (x, y) in a.iter().zip([1.0, -0.9, 0.2]) {
            assert!((x - y).abs() < 1e-12, "{a:?}");
        }
        for (x, y) in b.iter().zip([2.0, -0.5]) {
            assert!((x - y).abs() < 1e-12, "{b:?}");
        }
        let nmp = tf_ss(&[0.0, 1.0, -1.5], &[1.0, -0.9, 0.2], ts).unwrap();
        let e = nominal_inverse(&nmp).unwrap_err();
        assert!(e.contains("not minimum phase"), "{e}");
    }
}
