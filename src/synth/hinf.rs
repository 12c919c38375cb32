//! H-infinity output-feedback synthesis on a generalised plant
//! (`hinfsyn(P, nmeas, ncon)` convention, see [`super::genplant`]).
//!
//! Suboptimal central controller of Glover & Doyle (1988) in the general
//! form of Zhou, Doyle & Glover, *Robust and Optimal Control* (1996),
//! Theorem 17.1 (`D11 != 0` handled directly, `D22 != 0` by the loop shift of
//! §17.2), after scaling to `D12 = [0; I]`, `D21 = [0 I]` (SLICOT SB10PD).
//! Rank-deficient `D12`/`D21` are regularised by `eps u` / `eps v` channels.
//! `gamma` is found to a relative tolerance by a safeguarded secant search
//! on the conditions' margins (the coupling `ln(gamma^2 / rho(XY))` and the
//! squared distances of the Hamiltonians' eigenvalues from the imaginary
//! axis, each nearly linear in gamma where it fails), with log-scale
//! bisection steps as the fallback (`Search::narrow`).
//! Continuous plants directly; discrete plants through the norm-preserving
//! bilinear map `z = (1+s)/(1-s)` (the LFT commutes with the substitution).

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::dhinf::discrete_central;
use super::genplant::{Normalised, Partition, SynthError, denormalise, normalise};
use crate::lti::c2d::bilinear_to_discrete;
use crate::lti::c64;
use crate::lti::freqresp::HessenbergResponse;
use crate::lti::norms::{HinfNorm, bilinear_to_continuous, hinf_norm};
use crate::lti::riccati::{RiccatiSolution, care};
use crate::lti::ss::{StateSpace, eigvals, hcat, sigma_max, sub, tr, vcat};
use faer::Mat;

pub(crate) mod central;

/// Options of the synthesis.
#[derive(Debug, Clone, Copy)]
pub struct HinfOptions {
    /// Relative tolerance of the gamma search: the bound returned is within
    /// `rtol` above a level found infeasible.
    pub rtol: f64,
    /// Regularisation weight for rank-deficient `D12` / `D21`.
    pub eps: f64,
    /// Largest gamma tried before declaring the problem infeasible.
    pub gamma_max: f64,
    /// The returned controller is built for `lo * (1 + backoff)`, `lo` the
    /// largest level the bisection found infeasible (so at most
    /// `gamma_opt * (1 + backoff)`, and above the bisection bound when
    /// `backoff > rtol`): at the optimum itself `I - Y X / gamma^2` is
    /// singular and the central controller is numerically meaningless (cf.
    /// MATLAB hinfsyn's backoff).
    pub backoff: f64,
    /// Discrete plants: the smallest accepted `1 - |z|` of a closed-loop
    /// pole the controller moves (fixed plant modes exempt); the synthesis
    /// backs off from the optimum (at most to `1.1 gamma_opt`) to meet it.
    pub pole_margin: f64,
    /// Design the central controller at exactly this level instead of
    /// searching for the optimum (MATLAB `hinfsyn(P, ny, nu, gamTry)`,
    /// SLICOT SB10FD / SB10DD): no backoff, no pole-margin search; a level
    /// below the optimum is refused naming the bisection bound. `None`
    /// (default): search.
    pub gamma: Option<f64>,
}

impl Default for HinfOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            eps: 1e-6,
            gamma_max: 1e8,
            backoff: 1e-4,
            pole_margin: 1e-4,
            gamma: None,
        }
    }
}

/// Result of a synthesis.
#[derive(Debug, Clone)]
pub struct HinfResult {
    /// The controller (`u = K y`).
    pub k: StateSpace,
    /// The one gamma: the H-infinity norm of `F_l(P, K)` on the *original*
    /// plant with the controller returned, recomputed (Bruinsma–Steinbuch on
    /// the balanced closed loop, checked against a frequency sweep).
    pub gamma: f64,
    /// Frequency of the closed loop's peak (where `gamma` is attained),
    /// rad/s; infinite for a supremum at infinite frequency, NaN when the
    /// loop is unstable.
    pub peak_omega: f64,
    /// Certified upper bound on the closed-loop norm (`gamma <= ||Tzw|| <=
    /// gamma_upper`, [`HinfNorm`]); infinite when none could be certified.
    pub gamma_upper: f64,
    /// Diagnostic: the level the central controller was built for, the
    /// bisection's infeasible end times `1 + backoff` (at least
    /// `bisection_bound`), on the synthesis problem
    /// (regularised, if `regularised` says so). `gamma` is at most
    /// `design_level (1 + 1e-6)` or `bisection_bound (1 + 2 backoff)`,
    /// whichever is larger (docs/robust.md, "Verified H-inf controllers").
    pub design_level: f64,
    /// Diagnostic: the smallest level the bisection found feasible on the
    /// synthesis problem.
    pub bisection_bound: f64,
    /// Closed loop `F_l(P, K)` on the *original* plant.
    pub closed_loop: StateSpace,
    /// Its poles.
    pub poles: Vec<c64>,
    /// Whether it is stable.
    pub stable: bool,
    /// Relative residuals of the X and Y Riccati equations (of X and Z,
    /// the discrete ones, when `form` is [`ControllerForm::DiscreteCentral`]).
    pub x_residual: f64,
    pub y_residual: f64,
    /// The larger rounding floor of the two residuals
    /// ([`crate::lti::riccati::RiccatiSolution::residual_floor`]).
    pub residual_floor: f64,
    /// Regularisation weights added to `D12` / `D21`, if any.
    pub regularised: (Option<f64>, Option<f64>),
    /// Levels tested by the gamma search (bracketing included).
    pub iterations: usize,
    /// Discrete plants: the closed loop's spectral radius (`None` when continuous).
    pub spectral_radius: Option<f64>,
    /// Discrete plants: [`moved_pole_margin`], `1 - |z|` of the closed-loop
    /// pole nearest the unit circle that is not a fixed plant mode.
    pub pole_margin: Option<f64>,
    /// Discrete plants: whether `pole_margin >= HinfOptions::pole_margin`.
    pub pole_margin_met: Option<bool>,
    /// How the controller was built.
    pub form: ControllerForm,
}

impl HinfResult {
    /// Modulus of the controller's fastest pole, rad/s (0 for a static gain);
    /// for a discrete controller, of its continuous (bilinear) equivalent.
    pub fn controller_fastest_pole(&self) -> f64 {
        fastest_pole(&self.k)
    }
}

/// Modulus of the fastest pole in rad/s (continuous equivalent when discrete).
pub fn fastest_pole(sys: &StateSpace) -> f64 {
    let cont = match sys.ts {
        None => Ok(sys.clone()),
        Some(ts) => bilinear_to_continuous(sys, 2.0 / ts),
    };
    cont.and_then(|c| c.poles())
        .map(|p| p.iter().fold(0.0f64, |a, z| a.max(z.norm())))
        .unwrap_or(f64::INFINITY)
}

/// The central controller and residuals at one gamma, or why it is infeasible.
struct AtGamma {
    k: StateSpace,
    /// How `k` was formed: the explicit form, or another in its place where
    /// only that one stabilised the plant during the search.
    form: ControllerForm,
    /// The same controller in descriptor form (`None` where it could not
    /// be formed), tried where `k` misses its level or fails to stabilise.
    alternative: Option<StateSpace>,
    /// The Riccati solutions it was built from (for the extended-precision
    /// form, [`central::explicit_extended`], built only where both others
    /// miss their level).
    xs: RiccatiSolution,
    ys: RiccatiSolution,
}

fn blocks(m: &Mat<f64>, r: usize, c: usize) -> [Mat<f64>; 4] {
    let (nr, nc) = (m.nrows(), m.ncols());
    [
        sub(m, 0, r, 0, c),
        sub(m, 0, r, c, nc),
        sub(m, r, nr, 0, c),
        sub(m, r, nr, c, nc),
    ]
}

fn min_sym_eig(x: &Mat<f64>) -> f64 {
    if x.nrows() == 0 {
        return 0.0;
    }
    x.self_adjoint_eigenvalues(faer::Side::Lower)
        .map(|v| v.into_iter().fold(f64::INFINITY, f64::min))
        .unwrap_or(f64::NEG_INFINITY)
}

/// Lower bound on gamma from `D11` (Zhou, Doyle & Glover Thm 17.1 condition (i)).
fn gamma_lower(p: &Partition) -> f64 {
    let (m1, m2, p1, p2) = (p.m1(), p.m2(), p.p1(), p.p2());
    let [d1111, d1112, d1121, _] = blocks(&p.d11, p1 - m2, m1 - p2);
    sigma_max(&hcat(&d1111, &d1112)).max(sigma_max(&vcat(&d1111, &d1121)))
}

/// The two Riccati solutions of Thm 17.1 at one gamma (conditions (ii)
/// and (iii)) and the coupling margin of condition (iv).
struct RiccatiPair {
    xs: RiccatiSolution,
    ys: RiccatiSolution,
    /// `ln(gamma^2 / rho(X Y))`: positive when the coupling condition
    /// `rho(XY) < gamma^2` holds, smooth in gamma while X and Y exist (so
    /// the search can extrapolate it); infinite when `X Y = 0`.
    coupling: f64,
}

/// The indefinite weights of Thm 17.1's two Riccati equations:
/// `R = D1.'D1. - diag(g^2 I, 0)` and `R~ = D.1 D.1' - diag(g^2 I, 0)`.
fn indefinite_weights(p: &Partition, g2: f64) -> (Mat<f64>, Mat<f64>) {
    let d1 = hcat(&p.d11, &p.d12);
    let mut r = tr(&d1) * &d1;
    for i in 0..p.m1() {
        r[(i, i)] -= g2;
    }
    let dd1 = vcat(&p.d11, &p.d21);
    let mut rt = &dd1 * tr(&dd1);
    for i in 0..p.p1() {
        rt[(i, i)] -= g2;
    }
    (r, rt)
}

/// Thm 17.1 conditions (ii)-(iii) at one gamma, and the value of (iv).
fn riccati_pair(p: &Partition, gamma: f64) -> Result<RiccatiPair, SynthError> {
    let g2 = gamma * gamma;
    let infeasible = |why: String| SynthError::Infeasible(why);
    let (r, rt) = indefinite_weights(p, g2);
    // X: A'X + XA - (XB + C1'D1.) R^-1 (B'X + D1.'C1) + C1'C1 = 0.
    let b = hcat(&p.b1, &p.b2);
    let d1 = hcat(&p.d11, &p.d12);
    let xs = care(&p.a, &b, &(tr(&p.c1) * &p.c1), &r, Some(&(tr(&p.c1) * &d1)))
        .map_err(|e| infeasible(format!("X Riccati: {e}")))?;
    // Y: the dual, with R~.
    let c = vcat(&p.c1, &p.c2);
    let dd1 = vcat(&p.d11, &p.d21);
    let ys = care(
        &tr(&p.a),
        &tr(&c),
        &(&p.b1 * tr(&p.b1)),
        &rt,
        Some(&(&p.b1 * tr(&dd1))),
    )
    .map_err(|e| infeasible(format!("Y Riccati: {e}")))?;
    let (x, y) = (&xs.x, &ys.x);
    if min_sym_eig(x) < -psd_tolerance(&xs) || min_sym_eig(y) < -psd_tolerance(&ys) {
        return Err(infeasible("X or Y is not positive semidefinite".into()));
    }
    let rho = eigvals(&(x * y))
        .map_err(|e| SynthError::Numerical(e.to_string()))?
        .iter()
        .fold(0.0f64, |a, l| a.max(l.norm()));
    Ok(RiccatiPair {
        xs,
        ys,
        coupling: (g2 / rho).ln(),
    })
}

/// How negative the smallest eigenvalue of a stabilising Riccati solution
/// may be and still count as positive semidefinite: `1e-9 ||X||`, or the
/// solution's rounding error when that is larger. The stabilising solution
/// is the Hamiltonian's stable invariant subspace, whose rounding error
/// grows like `eps / sep`, `sep` the relative gap of the Hamiltonian's
/// eigenvalues to the imaginary axis: a weight with a pole at `-1e-7`
/// (integral action) leaves a gap of `1e-7`, and a solution that is 0 in
/// exact arithmetic comes out with eigenvalues of `-2e-9` (Golub & Van
/// Loan, invariant subspace perturbation; cf. the separation in SLICOT
/// SB02RD's condition estimate).
fn psd_tolerance(s: &RiccatiSolution) -> f64 {
    let scale = s.x.norm_l2().max(1.0);
    let speed = s.closed_loop.iter().fold(0.0f64, |m, l| m.max(l.norm()));
    let relative_gap = match s.axis_gap {
        Some(gap) if speed > 0.0 => gap / speed,
        _ => 1.0,
    };
    scale * 1e-9f64.max(1e2 * f64::EPSILON / relative_gap)
}

/// Thm 17.1 at one gamma on the normalised plant.
fn central(p: &Partition, gamma: f64) -> Result<AtGamma, SynthError> {
    central_from(p, gamma, riccati_pair(p, gamma)?)
}

/// The central controller from the Riccati pair at `gamma`, if the
/// coupling condition (iv) holds: the explicit form, with the descriptor
/// form beside it (the `central` module's doc says why both).
fn central_from(p: &Partition, gamma: f64, pair: RiccatiPair) -> Result<AtGamma, SynthError> {
    let g2 = gamma * gamma;
    // rho(XY) < g^2 (1 - 1e-10).
    if !(pair.coupling > -(1.0 - 1e-10f64).ln()) {
        return Err(SynthError::Infeasible(format!(
            "spectral radius of XY {:.4e} >= gamma^2",
            g2 / pair.coupling.exp()
        )));
    }
    let RiccatiPair { xs, ys, .. } = pair;
    let k = central::explicit(p, gamma, &xs, &ys)?;
    // A failure of the second form only withdraws the alternative.
    let alternative = central::descriptor(p, gamma, &xs, &ys).unwrap_or(None);
    Ok(AtGamma {
        k,
        form: ControllerForm::ContinuousCentral,
        alternative,
        xs,
        ys,
    })
}

/// The central controller at a given `gamma` (no bisection), on the
/// original plant's coordinates (continuous plants only).
pub fn hinf_at_gamma(
    plant: &StateSpace,
    nmeas: usize,
    ncon: usize,
    gamma: f64,
    eps: f64,
) -> Result<StateSpace, SynthError> {
    let p0 = Partition::new(&plant.balanced(), nmeas, ncon)?;
    let mut p = p0.clone();
    p.regularise(eps);
    let norm = normalise(&p)?;
    let r = central(&norm.p, gamma)?;
    denormalise(&r.k, &norm, &p0.d22)
}

/// What one test of a level found: the central controller when the level
/// is feasible, and then its [`Margins`].
struct Probe {
    outcome: Result<AtGamma, SynthError>,
    margins: Option<Margins>,
}

/// At a feasible level, how far each condition of Thm 17.1 is from
/// failing, each roughly linear in gamma near the level where it fails
/// (what the search extrapolates): the coupling margin
/// [`RiccatiPair::coupling`] and the squared axis gaps of the X and Y
/// Hamiltonians ([`RiccatiSolution::axis_gap`]); infinite where a
/// condition cannot fail.
type Margins = [f64; 3];

/// Thm 17.1 at one gamma, accepted only if the central controller really
/// stabilises the (normalised) plant: this guards the search against
/// levels that pass the Riccati tests only through rounding.
fn probe(p: &Partition, pss: &StateSpace, gamma: f64) -> Probe {
    let pair = match riccati_pair(p, gamma) {
        Ok(pair) => pair,
        Err(e) => {
            return Probe {
                outcome: Err(e),
                margins: None,
            };
        }
    };
    let gap2 = |s: &RiccatiSolution| s.axis_gap.map_or(f64::INFINITY, |g| g * g);
    let margins = [pair.coupling, gap2(&pair.xs), gap2(&pair.ys)];
    let outcome = central_from(p, gamma, pair).and_then(|r| stabilising(p, pss, gamma, r));
    Probe {
        margins: outcome.is_ok().then_some(margins),
        outcome,
    }
}

/// `r`, if its controller stabilises the normalised plant `pss`, or, in
/// its place, its descriptor form or its form in double-double
/// ([`central::explicit_extended`]) if only that one does.
fn stabilising(
    p: &Partition,
    pss: &StateSpace,
    gamma: f64,
    mut r: AtGamma,
) -> Result<AtGamma, SynthError> {
    let stabilises = |k: &StateSpace| {
        pss.lft(k)
            .is_ok_and(|cl| matches!(cl.is_stable(), Ok(true)))
    };
    if stabilises(&r.k) {
        return Ok(r);
    }
    if let Some(k) = r.alternative.take().filter(|k| stabilises(k)) {
        r.k = k;
        r.form = ControllerForm::ContinuousDescriptor;
        return Ok(r);
    }
    match central::explicit_extended(p, gamma, &r.xs, &r.ys) {
        Ok(k) if stabilises(&k) => {
            r.k = k;
            r.form = ControllerForm::ContinuousExtended;
            Ok(r)
        }
        _ => Err(SynthError::Infeasible(
            "the central controller does not stabilise the plant (numerically)".into(),
        )),
    }
}

/// [`probe`]'s verdict alone.
fn feasible(p: &Partition, pss: &StateSpace, gamma: f64) -> Result<AtGamma, SynthError> {
    probe(p, pss, gamma).outcome
}

/// H-infinity synthesis: bisection on gamma, central controller at the
/// smallest feasible gamma found, verified on the original plant.
pub fn hinfsyn(
    plant: &StateSpace,
    nmeas: usize,
    ncon: usize,
    opts: HinfOptions,
) -> Result<HinfResult, SynthError> {
    match opts.gamma {
        None => search_and_design(plant, nmeas, ncon, opts),
        Some(gamma) => design_at_chosen_level(plant, nmeas, ncon, gamma, opts),
    }
}

/// [`hinfsyn`] at a chosen level: the central controller at `gamma` when
/// it exists and achieves `gamma`; otherwise the optimum is searched for, to
/// say how far below it `gamma` lies (or, at or above it, that `gamma` is
/// too close to it for a reliable central controller).
fn design_at_chosen_level(
    plant: &StateSpace,
    nmeas: usize,
    ncon: usize,
    gamma: f64,
    opts: HinfOptions,
) -> Result<HinfResult, SynthError> {
    let failure = match search_and_design(plant, nmeas, ncon, opts) {
        Ok(r) => return Ok(r),
        Err(e @ (SynthError::Infeasible(_) | SynthError::Numerical(_))) => e,
        Err(e) => return Err(e),
    };
    let searched = HinfOptions {
        gamma: None,
        ..opts
    };
    let Ok(optimum) = search_and_design(plant, nmeas, ncon, searched) else {
        return Err(failure);
    };
    let bound = optimum.bisection_bound;
    if gamma < bound {
        return Err(SynthError::BelowOptimum(format!(
            "no stabilising controller achieves gamma {gamma}: it is below the optimum, which \
             lies within {:e} (relative) below the bisection bound {bound:.8} (the search's own \
             controller achieves {:.8}); choose a gamma above the bound",
            opts.rtol, optimum.gamma
        )));
    }
    Err(SynthError::Numerical(format!(
        "gamma {gamma} is at or above the optimum (bisection bound {bound:.8}) but the central \
         controller there is not reliable ({failure}); choose a gamma further above the bound"
    )))
}

fn search_and_design(
    plant: &StateSpace,
    nmeas: usize,
    ncon: usize,
    opts: HinfOptions,
) -> Result<HinfResult, SynthError> {
    let cont = match plant.ts {
        None => plant.clone(),
        Some(ts) => bilinear_to_continuous(plant, 2.0 / ts).map_err(|e| {
            SynthError::Numerical(format!("bilinear map of the discrete plant: {e}"))
        })?,
    };
    let p0 = Partition::new(&cont.balanced(), nmeas, ncon)?;
    p0.check_stabilisable()?;
    // Singular problems (D12 / D21 rank deficient) and cheap-control ones
    // (full rank but tiny, docs/robust.md "Conditioning") are regularised with
    // a weight eps. The true optimum gamma(eps) is nondecreasing in eps, while
    // a too small eps makes the Riccati tests fail through ill-conditioning
    // and *overestimates* gamma. So try eps, 10 eps, ... (at most 1e6 eps) and
    // keep the controller with the smallest closed-loop norm on the original
    // plant, stopping once it clearly grows again. A problem with full-rank
    // D12 / D21 is first tried as it is.
    if p0.clone().regularise_with(opts.eps, true) == (None, None) {
        return hinfsyn_regularised(plant, &p0, opts, false);
    }
    // Candidates in order of increasing weight.
    let mut found: Vec<HinfResult> = Vec::new();
    let mut last_err = None;
    let mut keep = |r: Result<HinfResult, SynthError>, found: &mut Vec<HinfResult>| match r {
        Ok(r) if r.stable => {
            let min = found.iter().map(|b| b.gamma).fold(f64::INFINITY, f64::min);
            let grew = r.gamma > min * (1.0 + 1e-3);
            found.push(r);
            Ok(grew)
        }
        Ok(_) => Ok(false),
        // A weight whose controller fails verification is skipped like an infeasible one.
        Err(e @ (SynthError::Infeasible(_) | SynthError::Numerical(_))) => {
            last_err = Some(e);
            Ok(false)
        }
        Err(e) => Err(e),
    };
    if p0.clone().regularise(opts.eps) == (None, None) {
        keep(hinfsyn_regularised(plant, &p0, opts, false), &mut found)?;
    }
    let mut eps = opts.eps / 10.0;
    let mut previous = None;
    for _ in 0..7 {
        eps *= 10.0;
        // Skip weights that the conditioning floor maps to one already tried.
        let weights = p0.clone().regularise_with(eps, true);
        if previous == Some(weights) {
            continue;
        }
        previous = Some(weights);
        let o = HinfOptions { eps, ..opts };
        if keep(hinfsyn_regularised(plant, &p0, o, true), &mut found)? {
            break;
        }
    }
    // The smallest achieved norm wins (the first, i.e. the smallest weight,
    // on ties).
    let mut best: Option<HinfResult> = None;
    for r in found {
        if best.as_ref().is_none_or(|b| r.gamma < b.gamma) {
            best = Some(r);
        }
    }
    best.ok_or_else(|| {
        last_err.unwrap_or_else(|| SynthError::Numerical("no regularisation weight worked".into()))
    })
}

fn hinfsyn_regularised(
    plant: &StateSpace,
    p0: &Partition,
    opts: HinfOptions,
    regularise: bool,
) -> Result<HinfResult, SynthError> {
    let mut p = p0.clone();
    let regularised = if regularise {
        p.regularise_with(opts.eps, true)
    } else {
        (None, None)
    };
    let norm: Normalised = normalise(&p)?;
    let pss = norm.p.to_ss()?;
    let verify = |iterations, infeasible_below| -> Result<Verify<'_>, SynthError> {
        Ok(Verify {
            plant,
            norm: &norm,
            pss: &pss,
            p0,
            discrete: discrete_partition(plant, p0, regularised)?,
            regularised,
            iterations,
            infeasible_below,
            opts,
        })
    };
    if let Some(gamma) = opts.gamma {
        return verify(1, gamma)?.at_chosen_level(gamma);
    }
    let lo0 = gamma_lower(&norm.p);
    if lo0 >= opts.gamma_max {
        return Err(SynthError::Infeasible(format!(
            "no stabilising controller achieves gamma <= {:.3e}: the feedthrough D11 alone forces gamma > {lo0:.6}",
            opts.gamma_max
        )));
    }
    let mut search = Search {
        p: &norm.p,
        pss: &pss,
        iterations: 0,
        above: None,
    };
    let (mut hi, mut best) = search.feasible_level(lo0, opts, regularised)?;
    let lo = if lo0 == 0.0 {
        search.infeasible_level(&mut hi, &mut best)?
    } else {
        lo0
    };
    let (lo, hi, best) = search.narrow(lo, hi, best, opts.rtol)?;
    // The bracket's lower end, unless the bisection stopped short of rtol.
    let infeasible_below = if hi.gamma / lo - 1.0 <= opts.rtol {
        lo
    } else {
        hi.gamma
    };
    verify(search.iterations, infeasible_below)?.choose(hi.gamma, best)
}

/// A feasible level and its margins.
#[derive(Debug, Clone, Copy)]
struct End {
    gamma: f64,
    margins: Margins,
}

/// The search for the smallest feasible gamma on the normalised plant.
struct Search<'a> {
    p: &'a Partition,
    pss: &'a StateSpace,
    /// Levels tested.
    iterations: usize,
    /// The feasible level tested before the current upper end, if any.
    above: Option<End>,
}

impl Search<'_> {
    fn probe(&mut self, gamma: f64) -> Probe {
        self.iterations += 1;
        probe(self.p, self.pss, gamma)
    }

    /// The feasible `gamma` with its margins and controller, or the test's error.
    fn feasible_end(&mut self, gamma: f64) -> Result<(End, AtGamma), SynthError> {
        let t = self.probe(gamma);
        let r = t.outcome?;
        let margins = t.margins.unwrap_or([f64::INFINITY; 3]);
        Ok((End { gamma, margins }, r))
    }

    /// A feasible level: `max(1, 2 lo0)`, then four times more until
    /// `gamma_max`.
    fn feasible_level(
        &mut self,
        lo0: f64,
        opts: HinfOptions,
        regularised: (Option<f64>, Option<f64>),
    ) -> Result<(End, AtGamma), SynthError> {
        let mut hi = (2.0 * lo0).max(1.0).min(opts.gamma_max);
        loop {
            match self.feasible_end(hi) {
                Err(SynthError::Infeasible(why)) if hi >= opts.gamma_max => {
                    return Err(not_found(&why, opts, regularised));
                }
                Err(SynthError::Infeasible(_)) => hi = (hi * 4.0).min(opts.gamma_max),
                found => return found,
            }
        }
    }

    /// Without a lower bound from `D11` (gamma_opt may be tiny or zero): an
    /// infeasible level below `hi`, a quarter of the last feasible one each
    /// time (which becomes `hi`), down to `1e-8 max(hi, 1)`.
    fn infeasible_level(&mut self, hi: &mut End, best: &mut AtGamma) -> Result<f64, SynthError> {
        let mut g = hi.gamma / 4.0;
        loop {
            if g < 1e-8 * hi.gamma.max(1.0) {
                return Ok(g);
            }
            match self.feasible_end(g) {
                Ok((end, r)) => {
                    self.above = Some(*hi);
                    (*hi, *best) = (end, r);
                    g /= 4.0;
                }
                Err(SynthError::Infeasible(_)) => return Ok(g),
                Err(e) => return Err(e),
            }
        }
    }

    /// Narrows `[lo, hi]` (`lo` infeasible, `hi` feasible, with `best` its
    /// controller) until `hi / lo - 1 <= rtol`; returns the final bracket. After a feasible level the
    /// next one is aimed just above the secant estimate of the optimum
    /// ([`first_zero`], [`next_level`]); after an infeasible one (the
    /// estimate has not changed), when there is no estimate, and after ten
    /// secant levels in a row it is the geometric midpoint (bisection in
    /// `ln gamma`), so the search always terminates.
    fn narrow(
        &mut self,
        mut lo: f64,
        mut hi: End,
        mut best: AtGamma,
        rtol: f64,
    ) -> Result<(f64, End, AtGamma), SynthError> {
        let (mut last_feasible, mut secant_run) = (false, 0);
        while hi.gamma / lo.max(1e-300) - 1.0 > rtol && self.iterations < 200 {
            let zero = match self.above {
                Some(above) if last_feasible && secant_run < 10 => first_zero(above, hi, lo),
                _ => None,
            };
            secant_run = if zero.is_some() { secant_run + 1 } else { 0 };
            let g = next_level(lo, hi.gamma, rtol, zero);
            match self.feasible_end(g) {
                Ok((end, r)) => {
                    self.above = Some(hi);
                    (hi, best, last_feasible) = (end, r, true);
                }
                Err(SynthError::Infeasible(_)) => (lo, last_feasible) = (g, false),
                Err(e) => return Err(e),
            }
        }
        Ok((lo, hi, best))
    }
}

/// Where the first of the margins reaches zero going down from `hi`: each
/// margin extrapolated along the straight line through its values at
/// `above` and `hi`, the largest of the zeros above `lo` (the level where
/// the first condition fails); `None` when no margin decreases.
fn first_zero(above: End, hi: End, lo: f64) -> Option<f64> {
    let mut best: Option<f64> = None;
    for (m_above, m_hi) in above.margins.into_iter().zip(hi.margins) {
        let slope = (m_above - m_hi) / (above.gamma - hi.gamma);
        let zero = hi.gamma - m_hi / slope;
        if slope > 0.0 && zero.is_finite() && zero > lo {
            best = Some(best.map_or(zero, |b| b.max(zero)));
        }
    }
    best
}

/// The next level to test strictly inside `(lo, hi)`, at least `rtol / 2`
/// (relative) from either end. With an estimated optimum `zero`: a tenth
/// of the way from it back to `hi`, but at least `rtol / 4` above it (a
/// slightly concave margin's line lands just below the optimum, where a
/// level adds little; a level just above brings `hi`, and the next
/// estimate, closer; once the estimate is accurate the next two levels
/// close the bracket around it). Without one, the geometric midpoint.
fn next_level(lo: f64, hi: f64, rtol: f64, zero: Option<f64>) -> f64 {
    if !(lo > 0.0) {
        return 0.5 * hi;
    }
    let (a, b) = (lo.ln(), hi.ln());
    let tau = rtol.ln_1p();
    let guess = match zero {
        Some(z) => z.ln() + (0.1 * (b - z.ln())).max(0.25 * tau),
        None => 0.5 * (a + b),
    };
    guess.max(a + 0.5 * tau).min(b - 0.5 * tau).exp()
}

/// The error when no level up to `gamma_max` is feasible.
fn not_found(why: &str, opts: HinfOptions, regularised: (Option<f64>, Option<f64>)) -> SynthError {
    let hint = match regularised {
        (None, None) => String::new(),
        (e12, e21) => format!(
            "; note: the rank-deficient {} was regularised with weight {:e}, a \
             nearly singular problem: add a control weight (mixsyn --wu) or \
             raise --eps",
            if e12.is_some() { "D12" } else { "D21" },
            e12.or(e21).unwrap_or(opts.eps)
        ),
    };
    SynthError::Infeasible(format!(
        "no stabilising controller achieves gamma <= {:.3e} ({why}){hint}",
        opts.gamma_max
    ))
}

/// A controller verifies when its recomputed closed-loop norm is within this
/// relative tolerance of the level it was built for.
const VERIFY_RTOL: f64 = 1e-6;

/// What the verification of the controller needs besides the bisection's result.
struct Verify<'a> {
    plant: &'a StateSpace,
    norm: &'a Normalised,
    /// `norm`'s plant as a state-space system (for the stability test).
    pss: &'a StateSpace,
    p0: &'a Partition,
    /// The discrete plant (balanced, regularised like its bilinear
    /// equivalent), for SB10DD's central controller; `None` when continuous.
    discrete: Option<Partition>,
    regularised: (Option<f64>, Option<f64>),
    iterations: usize,
    /// The largest level the bisection found infeasible (`gamma_opt` lies
    /// between it and the bisection bound): backing off from it, not from
    /// the bound, keeps the design level within `backoff` of the optimum.
    infeasible_below: f64,
    opts: HinfOptions,
}

/// The discrete plant in the synthesis coordinates: balanced, with the same
/// regularising channels as its bilinear equivalent (a static channel maps
/// to itself under the bilinear map).
fn discrete_partition(
    plant: &StateSpace,
    p0: &Partition,
    regularised: (Option<f64>, Option<f64>),
) -> Result<Option<Partition>, SynthError> {
    if plant.ts.is_none() {
        return Ok(None);
    }
    let mut dp = Partition::new(&plant.balanced(), p0.p2(), p0.m2())?;
    dp.add_regularisation(regularised);
    Ok(Some(dp))
}

impl Verify<'_> {
    /// Builds the controller at `infeasible_below (1 + backoff)` and
    /// verifies it on the original plant: accepted at once when the closed
    /// loop is stable, its recomputed H-inf norm is within VERIFY_RTOL of
    /// the level it was built for and (discrete plants) no pole the
    /// controller moved is closer to the unit circle than `pole_margin`.
    ///
    /// Otherwise the central controller is ill-conditioned there. On
    /// cheap-control problems (`W_u = 1e-4` on Karagoz18 Y) its DC gain
    /// depends on rounding in `(I - Y X / gamma^2)^-1` and the Riccati
    /// solutions: built at levels 1e-5..1e-3 above the bound it achieves,
    /// evaluated in double-double, +9e-5, +3e-4, +8e-3 and +1.5e-5 of its
    /// level, in no order. So a ladder of levels ([`scan_backoffs`], from
    /// a tenth of the backoff up to 0.1) is built, and the stable
    /// controller with the smallest achieved norm kept (preferring one that
    /// meets the pole margin); the scan stops once that norm is below the
    /// next level. The reported gamma is the achieved norm either way; a
    /// best norm above `1.2 gamma_opt`, or no stable controller, is
    /// reported as a numerical failure rather than returned.
    fn choose(&self, gamma_opt: f64, best: AtGamma) -> Result<HinfResult, SynthError> {
        let first = if self.opts.backoff <= 0.0 {
            (gamma_opt, best)
        } else {
            self.at_level(gamma_opt, self.opts.backoff)?
        };
        let mut tried = vec![first.0];
        let mut scan = Scan::default();
        if let Some(r) = self.consider(first, gamma_opt, &mut scan)? {
            return Ok(r);
        }
        for backoff in scan_backoffs(self.opts.backoff) {
            let level = self.level(gamma_opt, backoff);
            if scan.best_norm() <= level {
                break;
            }
            if tried.contains(&level) {
                continue;
            }
            tried.push(level);
            match feasible(&self.norm.p, self.pss, level) {
                Ok(at) => {
                    if let Some(r) = self.consider((level, at), gamma_opt, &mut scan)? {
                        scan.keep(r);
                    }
                }
                Err(SynthError::Infeasible(_)) => continue,
                Err(e) => return Err(e),
            }
        }
        scan.finish(gamma_opt)
    }

    /// Builds and judges one candidate: `Some` when it meets its own level
    /// (and the pole margin), else records it in `scan` and returns `None`.
    fn consider(
        &self,
        (gamma, at): (f64, AtGamma),
        gamma_opt: f64,
        scan: &mut Scan,
    ) -> Result<Option<HinfResult>, SynthError> {
        let built = self.build(&at, gamma)?;
        scan.last = Some((gamma, built.achieved, built.stable));
        if !built.stable {
            return Ok(None);
        }
        let meets = self.meets(&built, gamma);
        let r = self.result(built, &at, gamma, gamma_opt);
        if meets {
            return Ok(Some(r));
        }
        scan.keep(r);
        Ok(None)
    }

    /// The central controller at the chosen `gamma`, verified on the
    /// original plant like [`Verify::choose`]'s: stable, its norm within
    /// [`VERIFY_RTOL`] of `gamma` or, just above the optimum where the
    /// central controller is ill-conditioned, within the backoff (the
    /// reported gamma is the achieved norm, and the report warns when it
    /// exceeds `gamma`). No backoff: `design_level` and `bisection_bound`
    /// are both `gamma`.
    fn at_chosen_level(&self, gamma: f64) -> Result<HinfResult, SynthError> {
        let at = feasible(&self.norm.p, self.pss, gamma)?;
        let built = self.build(&at, gamma)?;
        let tolerance = VERIFY_RTOL.max(self.opts.backoff);
        if built.stable && built.achieved <= gamma * (1.0 + tolerance) {
            return Ok(self.result(built, &at, gamma, gamma));
        }
        Err(SynthError::Numerical(format!(
            "the central controller at gamma {gamma} does not achieve it (closed loop {})",
            if built.stable {
                format!("H-inf norm {:.8}", built.achieved)
            } else {
                "unstable".to_string()
            }
        )))
    }

    /// The design level for `backoff`: `infeasible_below (1 + backoff)`,
    /// at least `gamma_opt`.
    fn level(&self, gamma_opt: f64, backoff: f64) -> f64 {
        (self.infeasible_below * (1.0 + backoff)).max(gamma_opt)
    }

    /// The central controller (continuous, normalised) at
    /// `infeasible_below (1 + backoff)` (at least `gamma_opt`, the
    /// bisection bound); at the first backoff, the bound's own if that
    /// level fails.
    fn at_level(&self, gamma_opt: f64, backoff: f64) -> Result<(f64, AtGamma), SynthError> {
        let gb = self.level(gamma_opt, backoff);
        match feasible(&self.norm.p, self.pss, gb) {
            Ok(r) => Ok((gb, r)),
            Err(SynthError::Infeasible(_)) if backoff <= self.opts.backoff => {
                Ok((gamma_opt, central(&self.norm.p, gamma_opt)?))
            }
            Err(e) => Err(e),
        }
    }

    /// The controller on the original plant: for a discrete plant SB10DD's
    /// discrete central controller at `gamma` when it exists, else (and for
    /// continuous plants) the continuous central controller, mapped back.
    /// When that controller misses its level, the continuous central
    /// controller's descriptor form is built too, and the better kept; when
    /// that misses too, its form in double-double (the `central` module's
    /// doc says when each helps).
    fn build(&self, at: &AtGamma, gamma: f64) -> Result<Built, SynthError> {
        let mut best = self.build_first(at, gamma)?;
        if let Some(k) = &at.alternative
            && !self.meets(&best, gamma)
        {
            best = self.better(best, k, ControllerForm::ContinuousDescriptor);
        }
        if !self.meets(&best, gamma)
            && at.form != ControllerForm::ContinuousExtended
            && let Ok(k) = central::explicit_extended(&self.norm.p, gamma, &at.xs, &at.ys)
        {
            best = self.better(best, &k, ControllerForm::ContinuousExtended);
        }
        Ok(best)
    }

    /// `best`, or the continuous controller `k` (normalised) in its place
    /// if that one is acceptable and `best` is not, or is as acceptable and
    /// stable with a smaller norm (where no form meets the pole margin, as
    /// when the optimal controller cancels a slow plant zero, the smaller
    /// norm still wins). An alternative only ever replaces a controller;
    /// its failure (a pole the Tustin map cannot take) leaves `best`.
    fn better(&self, best: Built, k: &StateSpace, form: ControllerForm) -> Built {
        let Ok(other) = finish(self.plant, self.norm, self.p0, k, form) else {
            return best;
        };
        let rank = |b: &Built| (self.acceptable(b), b.stable);
        let better = match rank(&other).cmp(&rank(&best)) {
            std::cmp::Ordering::Greater => true,
            std::cmp::Ordering::Equal => other.stable && other.achieved < best.achieved,
            std::cmp::Ordering::Less => false,
        };
        if better { other } else { best }
    }

    /// Stable and, for a discrete plant, no moved pole closer to the unit
    /// circle than the pole margin.
    fn acceptable(&self, b: &Built) -> bool {
        b.stable && b.pole_margin.is_none_or(|m| m >= self.opts.pole_margin)
    }

    /// [`Verify::acceptable`], with its norm within [`VERIFY_RTOL`] of `gamma`.
    fn meets(&self, b: &Built, gamma: f64) -> bool {
        self.acceptable(b) && b.achieved <= gamma * (1.0 + VERIFY_RTOL)
    }

    fn build_first(&self, at: &AtGamma, gamma: f64) -> Result<Built, SynthError> {
        if let (Some(dp), Some(ts)) = (&self.discrete, self.plant.ts)
            && let Ok(c) = discrete_central(dp, gamma, ts)
        {
            let mut built = close(self.plant, c.k, ControllerForm::DiscreteCentral)?;
            built.residuals = Some((c.x_residual, c.z_residual, c.residual_floor));
            return Ok(built);
        }
        finish(self.plant, self.norm, self.p0, &at.k, at.form)
    }

    fn result(&self, built: Built, at: &AtGamma, gamma: f64, gamma_opt: f64) -> HinfResult {
        let Built {
            k,
            closed_loop,
            poles,
            stable,
            achieved,
            norm: cl_norm,
            form,
            pole_margin: margin,
            residuals,
        } = built;
        let (xres, yres, floor) = residuals.unwrap_or((
            at.xs.residual,
            at.ys.residual,
            at.xs.residual_floor.max(at.ys.residual_floor),
        ));
        HinfResult {
            k,
            gamma: achieved,
            peak_omega: cl_norm.map_or(f64::NAN, |h| h.omega),
            gamma_upper: cl_norm.map_or(f64::INFINITY, |h| h.upper),
            design_level: gamma,
            bisection_bound: gamma_opt,
            spectral_radius: self
                .plant
                .ts
                .map(|_| poles.iter().fold(0.0f64, |r, z| r.max(z.norm()))),
            pole_margin: margin,
            pole_margin_met: margin.map(|m| m >= self.opts.pole_margin),
            form,
            closed_loop,
            poles,
            stable,
            x_residual: xres,
            y_residual: yres,
            residual_floor: floor,
            regularised: self.regularised,
            iterations: self.iterations,
        }
    }
}

/// The backoffs [`Verify::choose`] scans when the central controller at
/// the default one misses its level: `backoff x {0.1, 0.2, 0.5, 1, 2, 5}`
/// times powers of ten, up to 0.1.
fn scan_backoffs(backoff: f64) -> impl Iterator<Item = f64> {
    let start = if backoff > 0.0 { backoff / 10.0 } else { 1e-5 };
    (0..30)
        .map(move |k| start * [1.0, 2.0, 5.0][k % 3] * 10f64.powi((k / 3) as i32))
        .take_while(|&b| b <= 0.1 * (1.0 + 1e-12))
}

/// The stable candidates [`Verify::choose`] has built: the one with the
/// smallest achieved norm among those meeting the pole margin, and among
/// all; and the last candidate's level, norm and stability for the error.
#[derive(Default)]
struct Scan {
    best_with_margin: Option<HinfResult>,
    best_any: Option<HinfResult>,
    last: Option<(f64, f64, bool)>,
}

impl Scan {
    fn keep(&mut self, r: HinfResult) {
        let better = |b: &Option<HinfResult>| b.as_ref().is_none_or(|b| r.gamma < b.gamma);
        if r.pole_margin_met != Some(false) && better(&self.best_with_margin) {
            self.best_with_margin = Some(r.clone());
        }
        if better(&self.best_any) {
            self.best_any = Some(r);
        }
    }

    fn best_norm(&self) -> f64 {
        self.best_with_margin
            .as_ref()
            .map_or(f64::INFINITY, |r| r.gamma)
    }

    /// The best candidate, if its norm is within `1.2 gamma_opt`.
    fn finish(self, gamma_opt: f64) -> Result<HinfResult, SynthError> {
        let within = |r: &HinfResult| r.gamma <= gamma_opt * 1.2;
        if let Some(r) = self.best_with_margin.filter(within) {
            return Ok(r);
        }
        if let Some(r) = self.best_any.filter(within) {
            return Ok(r);
        }
        let (gamma, achieved, stable) = self.last.unwrap_or((gamma_opt, f64::INFINITY, false));
        Err(SynthError::Numerical(format!(
            "the central controller does not reach the gamma it is built for (gamma {gamma:.6e}, \
             closed loop {}): the problem is too ill-conditioned (gamma_opt {gamma_opt:.3e}) for a \
             reliable controller; scale the weights or add a control weight",
            if stable {
                format!("H-inf norm {achieved:.6e}")
            } else {
                "unstable".to_string()
            }
        )))
    }
}

/// `1 - |z|` of the closed-loop pole nearest the unit circle among those
/// that are not modes of the plant's `A` (a mode neither reachable from `u`
/// nor seen by `y` stays a closed-loop pole whatever the controller; it is
/// the plant's, not the design's). 1 when every pole is a plant mode.
pub fn moved_pole_margin(poles: &[c64], plant_a: &Mat<f64>) -> f64 {
    let modes = eigvals(plant_a).unwrap_or_default();
    let scale = 1.0 + plant_a.norm_l2();
    poles
        .iter()
        .filter(|z| !modes.iter().any(|m| (*z - m).norm() <= 1e-8 * scale))
        .map(|z| 1.0 - z.norm())
        .fold(1.0, f64::min)
}

/// How the returned controller was built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerForm {
    /// The continuous central controller (Zhou, Doyle & Glover Thm 17.1),
    /// mapped back by the bilinear transform for a discrete plant.
    ContinuousCentral,
    /// SLICOT SB10DD's discrete central controller ([`super::dhinf`]).
    DiscreteCentral,
    /// The continuous central controller in descriptor form (built from the
    /// Hamiltonians' stable subspaces), where the explicit
    /// form misses its level.
    ContinuousDescriptor,
    /// The continuous central controller formed in double-double arithmetic
    /// and returned in modal coordinates, where both other forms miss their
    /// level (cheap control).
    ContinuousExtended,
}

impl ControllerForm {
    /// A short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            ControllerForm::ContinuousCentral => "continuous central (Thm 17.1)",
            ControllerForm::DiscreteCentral => "discrete central (SB10DD)",
            ControllerForm::ContinuousDescriptor => "continuous central, descriptor form",
            ControllerForm::ContinuousExtended => {
                "continuous central, double-double, modal coordinates"
            }
        }
    }
}

/// A controller mapped back to the plant's coordinates with its closed loop.
#[derive(Clone)]
struct Built {
    k: StateSpace,
    closed_loop: StateSpace,
    poles: Vec<c64>,
    stable: bool,
    achieved: f64,
    norm: Option<HinfNorm>,
    form: ControllerForm,
    /// Discrete plants: [`moved_pole_margin`] of the closed loop.
    pole_margin: Option<f64>,
    /// The discrete central controller's X and Z residuals and floor.
    residuals: Option<(f64, f64, f64)>,
}

fn finish(
    plant: &StateSpace,
    norm: &Normalised,
    p0: &Partition,
    k: &StateSpace,
    form: ControllerForm,
) -> Result<Built, SynthError> {
    let kc = denormalise(k, norm, &p0.d22)?;
    // Back to discrete time if needed.
    // Balanced (an exact powers-of-two similarity): the central controller
    // of a cheap-control problem has poles near 1e8 rad/s beside 0.2 rad/s,
    // and its raw realisation is too badly scaled for a Tustin
    // discretisation's `(I - A ts/2)^-1`.
    let k = match plant.ts {
        None => kc.balanced(),
        Some(ts) => bilinear_to_discrete(&kc, 2.0 / ts, ts)
            .map_err(|e| SynthError::Numerical(e.to_string()))?,
    };
    close(plant, k, form)
}

/// The closed loop of `k` on the original plant, its poles and norm.
fn close(plant: &StateSpace, k: StateSpace, form: ControllerForm) -> Result<Built, SynthError> {
    let closed_loop = plant
        .lft(&k)
        .map_err(|e| SynthError::Numerical(format!("closed loop: {e}")))?;
    let poles = closed_loop
        .poles()
        .map_err(|e| SynthError::Numerical(e.to_string()))?;
    // StateSpace::is_stable's test, on the poles already computed.
    let stable = match closed_loop.ts {
        None => poles.iter().all(|z| z.re < 0.0),
        Some(_) => poles.iter().all(|z| z.norm() < 1.0),
    };
    let norm = if stable {
        closed_loop_hinf(&closed_loop)
    } else {
        None
    };
    let achieved = norm.map_or(f64::INFINITY, |h| h.peak);
    let pole_margin = plant.ts.map(|_| moved_pole_margin(&poles, &plant.a));
    Ok(Built {
        k,
        closed_loop,
        poles,
        stable,
        achieved,
        norm,
        form,
        pole_margin,
        residuals: None,
    })
}

/// The H-infinity norm of a stable closed loop, recomputed independently of
/// the synthesis: Bruinsma–Steinbuch on the balanced realisation (stiff
/// loops, poles from 1e-2 to 1e11 rad/s, keep their slow modes), then a log
/// sweep of 2000 points over the pole range, which can only raise it (a
/// missed peak is never reported as a lower norm).
pub fn closed_loop_norm(cl: &StateSpace) -> f64 {
    closed_loop_hinf(cl).map_or(f64::INFINITY, |h| h.peak)
}

/// [`closed_loop_norm`] with the peak frequency and the certified bound
/// (`None` when the norm cannot be computed). A sweep point above the
/// Hamiltonian's certified bound raises the peak and withdraws the bound
/// (`upper` infinite): the certificate was wrong there.
pub fn closed_loop_hinf(cl: &StateSpace) -> Option<HinfNorm> {
    let bal = cl.balanced();
    let mut h = hinf_norm(&bal, 1e-8).ok()?;
    let poles = bal.poles().unwrap_or_default();
    let grid = crate::lti::norms::log_grid_to_nyquist(&poles, bal.ts, 2000);
    for (w, s) in sweep(&bal, &grid, h.peak) {
        if s > h.peak {
            (h.peak, h.omega) = (s, w);
            if s > h.upper {
                h.upper = f64::INFINITY;
            }
        }
    }
    crate::lti::norms::confirm_extended(&bal, &grid, &mut h);
    Some(h)
}

/// `(w, sigma_max(G(jw)))` at the frequencies of `grid` that can matter
/// against `peak`. The whole grid is evaluated in Hessenberg coordinates
/// ([`HessenbergResponse`], `O(n^2)` a point instead of `O(n^3)`) when they
/// agree with the dense evaluation ([`StateSpace::sigma_at`]) to 1e-9 at
/// five points across the grid; every point that comes within 1e-6 of
/// `peak` is then evaluated densely again, and only dense values are
/// returned. Without that agreement (stiff loops can lose accuracy to the
/// orthogonal reduction) every point is evaluated densely.
fn sweep(sys: &StateSpace, grid: &[f64], peak: f64) -> Vec<(f64, f64)> {
    let dense = |w: f64| (w, sys.sigma_at(w));
    if grid.is_empty() {
        return Vec::new();
    }
    let fast = HessenbergResponse::new(sys);
    let agrees = (0..5).map(|k| grid[k * (grid.len() - 1) / 4]).all(|w| {
        let (d, f) = (sys.sigma_at(w), fast.sigma_at(w));
        (d - f).abs() <= 1e-9 * d
    });
    if !agrees {
        return grid.iter().map(|&w| dense(w)).collect();
    }
    grid.iter()
        .filter(|&&w| fast.sigma_at(w) > peak * (1.0 - 1e-6))
        .map(|&w| dense(w))
        .collect()
}
