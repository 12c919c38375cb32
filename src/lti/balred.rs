//! Balanced truncation of stable systems by the square-root method
//! (Laub, Heath, Paige & Ward 1987; Tombs & Postlethwaite 1987):
//! Gramians `P = Lc Lc'`, `Q = Lo Lo'`, SVD `Lo' Lc = U S W'`, projection
//! `T = Lc W_r S_r^-1/2`, `T^+ = S_r^-1/2 U_r' Lo'`. The a-priori bound is
//! `||G - G_r||_inf <= 2 sum_{i>r} sigma_i` (Glover 1984).
//!
//! The bound holds for the Hankel singular values of the system, not for
//! those of inaccurate Gramians: a stiff system (poles decades apart, such
//! as a mixed-sensitivity controller with a near-integrator at 0.2 rad/s and
//! poles at 1e7 rad/s) loses the small Gramian directions to round-off in
//! its own coordinates, and with them whole modes. So the result is checked
//! on a dense frequency grid; if the error exceeds the bound, the Gramians
//! are recomputed in the real modal coordinates (block-diagonal `A`, where
//! they are accurate), and if that fails too the reduction is marked
//! untrusted with the error found.

use super::lyapunov::lyap_factor;
use super::ss::{SsError, StateSpace, sigma_max_c, tr};
use faer::Mat;

/// A reduced model, the Hankel singular values and the error bound.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// The reduced system.
    pub sys: StateSpace,
    /// Hankel singular values of the original system (descending).
    pub hsv: Vec<f64>,
    /// `2 * sum of the discarded Hankel singular values`.
    pub bound: f64,
    /// Largest `sigma_max(G - G_r)` found on a dense frequency grid
    /// ([`grid_error`]): at most `bound` when the Gramians were accurate.
    pub grid_error: f64,
    /// Whether `grid_error` is within `bound` (allowing for round-off
    /// relative to the system's gain). When it is not, the Hankel singular
    /// values came from inaccurate Gramians: neither they, nor the bound,
    /// nor the reduced model can be trusted.
    pub trusted: bool,
}

/// A real factor `R` (`n x 2n`) of the Gramian `X = R R'` of
/// `A X + X A' + B B' = 0`, from Hammarling's complex factor `L`
/// (`X = Re(L L^H) = [Re L, Im L] [Re L, Im L]'`). Factored directly, the
/// Gramian keeps its small directions (the square-root method's point);
/// the eigenvalues of a computed `X` lose everything below `eps ||X||`.
fn gramian_root(a: &Mat<f64>, b: &Mat<f64>) -> Result<Mat<f64>, SsError> {
    let l = lyap_factor(a, b).map_err(|_| SsError::NoConvergence)?.l;
    let n = l.nrows();
    Ok(Mat::from_fn(n, 2 * n, |i, j| {
        if j < n {
            l[(i, j)].re
        } else {
            l[(i, j - n)].im
        }
    }))
}

/// Balanced truncation to `order` states (continuous, stable systems).
pub fn balred(sys: &StateSpace, order: usize) -> Result<Reduced, SsError> {
    if sys.is_discrete() {
        return Err(SsError::Dimension(
            "balanced truncation is implemented for continuous systems".into(),
        ));
    }
    if !sys.is_stable()? {
        return Err(SsError::Dimension(
            "balanced truncation needs a stable system (the controller has unstable poles)".into(),
        ));
    }
    let n = sys.nx();
    if order > n {
        return Err(SsError::Dimension(format!(
            "requested order {order} exceeds the {n} states"
        )));
    }
    let gain = peak_gain(sys);
    let direct = checked(sys, truncate(sys, order)?, gain);
    if direct.trusted {
        return Ok(direct);
    }
    // Inaccurate Gramians: try again where they are accurate.
    match modal_form(sys).map(|m| truncate(&m, order)) {
        Some(Ok(modal)) => {
            let modal = checked(sys, modal, gain);
            Ok(if modal.trusted || modal.grid_error < direct.grid_error {
                modal
            } else {
                direct
            })
        }
        _ => Ok(direct),
    }
}

/// The reduction with its error on the grid, trusted when that error is
/// within the bound up to round-off relative to `gain`, the system's peak
/// on the grid, and when the Hankel singular values themselves are
/// consistent with it: `sigma_1 <= ||G||_inf <= 2 sum sigma_i` (Glover
/// 1984). The first test alone passes a reduction that keeps the right
/// modes with a wrong singular value (a stiff controller's slow mode
/// reported at 277438 instead of 15808 above a peak gain of about 1e5).
fn checked(sys: &StateSpace, (red, hsv, bound): (StateSpace, Vec<f64>, f64), gain: f64) -> Reduced {
    let grid_error = grid_error(sys, &red);
    // The grid peak is a lower bound on the norm: 1e-3 of room above it.
    let hankel_consistent = hsv.first().is_none_or(|&s1| s1 <= gain * (1.0 + 1e-3))
        && 2.0 * hsv.iter().sum::<f64>() >= gain * (1.0 - 1e-6);
    let trusted = within_bound(grid_error, bound, gain) && hankel_consistent;
    Reduced {
        sys: red,
        hsv,
        bound,
        grid_error,
        trusted,
    }
}

/// Whether `error` meets `bound` up to the accuracy of the computation.
/// Discarding one state can meet the bound with equality (`||G - G_r|| =
/// 2 sigma_n`, Glover 1984; a 2-state system with Hankel singular values
/// 24.42686 and 0.5731395 reaches it at DC), so equality to the last digit
/// must pass. The room is relative to the bound (the singular values' own
/// accuracy on a stiff system: a few 1e-6 on the mixsyn example and on
/// random systems with poles spread over eight decades) plus round-off
/// relative to the gain.
pub fn within_bound(error: f64, bound: f64, gain: f64) -> bool {
    error <= bound * (1.0 + 1e-5) + 1e-9 * gain
}

/// The square-root balanced truncation of `sys` in its own coordinates:
/// the reduced system, the Hankel singular values and the bound.
fn truncate(sys: &StateSpace, order: usize) -> Result<(StateSpace, Vec<f64>, f64), SsError> {
    let n = sys.nx();
    let lc = gramian_root(&sys.a, &sys.b)?;
    let lo = gramian_root(&tr(&sys.a), &tr(&sys.c))?;
    let h = tr(&lo) * &lc;
    let svd = fts_kernels::dense::svd(h.as_ref()).map_err(|_| SsError::NoConvergence)?;
    let s: Vec<f64> = (0..h.nrows()).map(|i| svd.S().column_vector()[i]).collect();
    // `2n` singular values, of which the `n` largest are the Hankel ones.
    let mut idx: Vec<usize> = (0..s.len()).collect();
    idx.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
    idx.truncate(n);
    let hsv: Vec<f64> = idx.iter().map(|&i| s[i]).collect();
    let r = order.min(hsv.iter().filter(|&&x| x > 1e-300).count());
    let (u, w) = (svd.U(), svd.V());
    let t = Mat::from_fn(n, r, |i, k| {
        let c = idx[k];
        (0..lc.ncols()).map(|l| lc[(i, l)] * w[(l, c)]).sum::<f64>() / s[c].sqrt()
    });
    let ti = Mat::from_fn(r, n, |k, j| {
        let c = idx[k];
        (0..lo.ncols()).map(|l| u[(l, c)] * lo[(j, l)]).sum::<f64>() / s[c].sqrt()
    });
    let red = StateSpace::new(
        &ti * &sys.a * &t,
        &ti * &sys.b,
        &sys.c * &t,
        sys.d.clone(),
        None,
    )?;
    let bound = 2.0 * hsv[r..].iter().sum::<f64>();
    Ok((red, hsv, bound))
}

/// `sys` in real modal coordinates (`A` block-diagonal: one 1x1 block per
/// real pole, one 2x2 block per complex pair, columns of unit norm), or
/// `None` when its eigenvectors are too ill-conditioned to change basis
/// (a defective or nearly defective `A`).
pub fn modal_form(sys: &StateSpace) -> Option<StateSpace> {
    sys.transform(&modal_basis(&sys.a)?).ok()
}

/// The basis of [`modal_form`]: `T` with `T^-1 A T` block-diagonal, or
/// `None` when `cond(T) >= 1e8`.
pub(crate) fn modal_basis(a: &Mat<f64>) -> Option<Mat<f64>> {
    let n = a.nrows();
    let eig = fts_kernels::dense::eigen(a.as_ref()).ok()?;
    let (v, lambda) = (eig.U(), eig.S().column_vector());
    let mut columns: Vec<Vec<f64>> = Vec::with_capacity(n);
    for k in 0..n {
        let l = lambda[k];
        let real = l.im.abs() <= 1e-12 * l.norm();
        if real {
            columns.push((0..n).map(|i| v[(i, k)].re).collect());
        } else if l.im > 0.0 {
            columns.push((0..n).map(|i| v[(i, k)].re).collect());
            columns.push((0..n).map(|i| v[(i, k)].im).collect());
        }
    }
    if columns.len() != n {
        return None;
    }
    let t = Mat::from_fn(n, n, |i, j| {
        let norm = columns[j].iter().map(|x| x * x).sum::<f64>().sqrt();
        columns[j][i] / norm
    });
    let sv = fts_kernels::dense::singular_values(t.as_ref()).ok()?;
    let cond = sv.first()? / sv.last()?;
    (cond.is_finite() && cond < 1e8).then_some(t)
}

/// Frequencies (rad/s) that resolve every feature of `systems`: 0, every
/// pole's magnitude, and a log grid from a hundredth of the slowest pole to
/// a hundred times the fastest, 200 points a decade (fewer for large
/// systems, each point costing an `n^3` solve).
fn grid(systems: &[&StateSpace]) -> Vec<f64> {
    let mags: Vec<f64> = systems
        .iter()
        .flat_map(|s| s.poles().unwrap_or_default())
        .map(|p| p.norm())
        .filter(|m| m.is_finite() && *m > 0.0)
        .collect();
    let lo = mags.iter().copied().fold(f64::INFINITY, f64::min).min(1.0) * 1e-2;
    let hi = mags.iter().copied().fold(0.0, f64::max).max(1.0) * 1e2;
    let decades = (hi / lo).log10();
    let states: usize = systems.iter().map(|s| s.nx()).sum();
    let per_decade = (4e8 / (states.max(1) as f64).powi(3) / decades).clamp(20.0, 200.0);
    let points = (decades * per_decade).ceil() as usize + 1;
    let mut w: Vec<f64> = (0..points)
        .map(|k| lo * 10f64.powf(decades * k as f64 / (points - 1) as f64))
        .collect();
    w.push(0.0);
    w.extend(mags);
    w
}

/// The largest `sigma_max(G(jw) - Gr(jw))` over 0, every pole's magnitude
/// and a log grid from a hundredth of the slowest pole to a hundred times
/// the fastest.
pub fn grid_error(g: &StateSpace, gr: &StateSpace) -> f64 {
    grid(&[g, gr])
        .into_iter()
        .map(|w| match (g.freq_response(w), gr.freq_response(w)) {
            (Ok(a), Ok(b)) => sigma_max_c(&(&a - &b)),
            _ => f64::INFINITY,
        })
        .fold(0.0, f64::max)
}

/// The largest `sigma_max(G(jw))` over [`grid`]'s frequencies: the scale of
/// round-off in the error.
fn peak_gain(g: &StateSpace) -> f64 {
    grid(&[g])
        .into_iter()
        .map(|w| g.sigma_at(w))
        .fold(0.0, f64::max)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::lti::norms::hinf_norm;
    use rand::{RngExt, SeedableRng};

    pub fn truncation_error_within_the_bound() {
        // 1/((s+1)(s+10)(s+100)) + 0.01/(s+0.5)
        let g1 = StateSpace::from_tf(&[1.0], &[1.0, 111.0, 1110.0, 1000.0], None).unwrap();
        let g2 = StateSpace::from_tf(&[0.01], &[1.0, 0.5], None).unwrap();
        let g = g1.parallel(&g2).unwrap();
        for r in 1..4 {
            let red = balred(&g, r).unwrap();
            let neg = StateSpace::new(
                red.sys.a.clone(),
                red.sys.b.clone(),
                -&red.sys.c,
                -&red.sys.d,
                None,
            )
            .unwrap();
            let e = hinf_norm(&g.parallel(&neg).unwrap(), 1e-8).unwrap().peak;
            assert!(
                e <= red.bound * (1.0 + 1e-6) + 1e-12,
                "r={r}: {e} > {}",
                red.bound
            );
            assert!(red.sys.is_stable().unwrap());
            assert!(red.trusted);
        }
    }

    /// The balanced realisation with Hankel singular values `s` (SISO,
    /// sign-symmetric): `A_ij = -b_i b_j / (s_i + s_j)`, `C = B'`, so that
    /// `A S + S A' + B B' = 0` and `A' S + S A + C'C = 0` with `S = diag(s)`.
    fn balanced_with(s: &[f64], b: &[f64]) -> StateSpace {
        let n = s.len();
        StateSpace::new(
            Mat::from_fn(n, n, |i, j| -b[i] * b[j] / (s[i] + s[j])),
            Mat::from_fn(n, 1, |i, _| b[i]),
            Mat::from_fn(1, n, |_, j| b[j]),
            Mat::zeros(1, 1),
            None,
        )
        .unwrap()
    }

    /// A 2-state system with MATLAB's `hsvd` values [24.42686, 0.5731395]
    /// (diagonals -1 and -10): removing one state meets the bound
    /// `2 sigma_2` with equality at DC (a sign-symmetric system with
    /// positive `b` is a relaxation system, `G(0) = 2 sum sigma_i` and
    /// `G_r(0) = 2 sigma_1`), so the check must accept an error equal to
    /// the bound to the last digit.
    pub fn a_bound_met_with_equality_is_accepted() {
        let s: [f64; 2] = [24.42686, 0.5731395];
        let b = [(2.0 * s[0]).sqrt(), (20.0 * s[1]).sqrt()];
        let g = balanced_with(&s, &b);
        let red = balred(&g, 1).unwrap();
        for (got, want) in red.hsv.iter().zip(s) {
            assert!((got - want).abs() <= 1e-12 * s[0], "{:?}", red.hsv);
        }
        assert!((red.bound - 2.0 * s[1]).abs() <= 1e-12 * s[0]);
        let dc = |x: &StateSpace| x.dc_gain().unwrap()[(0, 0)];
        let e0 = (dc(&g) - dc(&red.sys)).abs();
        assert!(
            (e0 - red.bound).abs() <= 1e-12 * s[0],
            "{e0} vs {}",
            red.bound
        );
        assert!(
            red.trusted,
            "grid error {:e} bound {:e}",
            red.grid_error, red.bound
        );
    }

    /// `max |G(jw) - Gr(jw)|` over 0 and 4001 log-spaced frequencies from
    /// 1e-5 to 1e11 rad/s: independent of the grid [`balred`] checks on.
    fn dense_error(g: &StateSpace, gr: &StateSpace) -> f64 {
        (0..=4001)
            .map(|k| {
                if k == 4001 {
                    0.0
                } else {
                    10f64.powf(-5.0 + 16.0 * k as f64 / 4000.0)
                }
            })
            .map(|w| {
                let d = &g.freq_response(w).unwrap() - &gr.freq_response(w).unwrap();
                sigma_max_c(&d)
            })
            .fold(0.0, f64::max)
    }

    /// The error stays within the bound, up to round-off relative to the
    /// system's peak gain (a discarded value 1e-6 of the gain is computed
    /// to about 1e-10 of the gain).
    fn assert_bound_holds(g: &StateSpace, r: usize, what: &str) {
        let red = balred(g, r).unwrap();
        let e = dense_error(g, &red.sys);
        let zero = StateSpace::gain(Mat::zeros(g.ny(), g.nu()), None);
        let peak = dense_error(g, &zero);
        assert!(
            red.trusted,
            "{what} r={r}: untrusted, grid error {}",
            red.grid_error
        );
        assert!(
            e <= red.bound * (1.0 + 1e-5) + 1e-9 * peak,
            "{what} r={r}: max error {e:e} > bound {:e}",
            red.bound
        );
    }

    /// The mixed-sensitivity controller of examples/mixsyn (a near-integrator
    /// at -0.2 rad/s, poles near 5e7 rad/s): its own coordinates lose the
    /// slow mode's Gramian directions, so the reduction to 3 states used to
    /// claim a bound of 2e-14 while |K(0)| fell from 3e4 to 2.
    pub fn the_mixsyn_controller_reduces_within_its_bound() {
        let text = include_str!("../../examples/mixsyn/K.json");
        let k = crate::io::ss_json::parse_system(text, "K.json").unwrap();
        let red = balred(&k, 3).unwrap();
        // The Hankel singular values of the modal computation (numpy, modal
        // Gramians by SciPy's Lyapunov solver): 56330.13, 53656.86, 15808.45,
        // 2674.27. In the controller's own coordinates SciPy and the direct
        // square-root method both put the slow mode near 2.8e5 or 4.8e4,
        // above the peak gain 1.08e5: the Hankel check sends it to modal
        // coordinates.
        for (got, want) in red.hsv.iter().zip([56330.13, 53656.86, 15808.45, 2674.27]) {
            assert!((got - want).abs() < 1e-3 * want, "{:?}", red.hsv);
        }
        let dc = |s: &StateSpace| s.dc_gain().unwrap()[(0, 0)];
        assert!((dc(&k) - dc(&red.sys)).abs() <= red.bound * (1.0 + 1e-5));
        for r in 1..=3 {
            assert_bound_holds(&k, r, "mixsyn K");
        }
    }

    /// Random stable systems with poles spread over up to eight decades,
    /// mixed by a random change of basis.
    pub fn random_stable_systems_reduce_within_their_bound() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for case in 0..12 {
            let n = rng.random_range(2..=7);
            let spread = rng.random_range(1.0..8.0);
            let mut a = Mat::<f64>::zeros(n, n);
            let mut i = 0;
            while i < n {
                let re = -(10f64.powf(rng.random_range(-2.0..(spread - 2.0))));
                if i + 1 < n && rng.random_bool(0.4) {
                    let im = re.abs() * rng.random_range(0.1..3.0);
                    a[(i, i)] = re;
                    a[(i + 1, i + 1)] = re;
                    a[(i, i + 1)] = im;
                    a[(i + 1, i)] = -im;
                    i += 2;
                } else {
                    a[(i, i)] = re;
                    i += 1;
                }
            }
            let b = Mat::from_fn(n, 1, |_, _| rng.random_range(-1.0..1.0));
            let c = Mat::from_fn(1, n, |_, _| rng.random_range(-1.0..1.0));
            let t = Mat::from_fn(n, n, |i, j| {
                f64::from(u8::from(i == j)) + 0.5 * rng.random_range(-1.0..1.0)
            });
            let modal = StateSpace::new(a, b, c, Mat::zeros(1, 1), None).unwrap();
            let Ok(g) = modal.transform(&t) else { continue };
            for r in 1..n {
                assert_bound_holds(&g, r, &format!("case {case} (n={n})"));
            }
        }
    }
}
