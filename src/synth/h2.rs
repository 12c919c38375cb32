//! H2-optimal output feedback on a generalised plant (`h2syn(P, nmeas, ncon)`).
//!
//! **Continuous time.** Zhou & Doyle, *Essentials of Robust Control*
//! Thm 14.7 in its general (non-orthogonal) form: with `R1 = D12'D12 > 0`,
//! `R2 = D21 D21' > 0`, `X2` stabilises
//! `A'X + XA - (XB2 + C1'D12) R1^-1 (B2'X + D12'C1) + C1'C1 = 0`,
//! `Y2` the dual with `(A', C2', B1 B1', R2, B1 D21')`,
//! `F2 = -R1^-1 (B2'X2 + D12'C1)`, `L2 = -(Y2 C2' + B1 D21') R2^-1`, and the
//! unique optimal controller `K = [A + B2 F2 + L2 C2, -L2; F2, 0]`.
//! `D11` must be zero for a finite H2 norm.
//!
//! **Discrete time** (SLICOT SB10ED / SB10SD; Zhou, Doyle & Glover 1996
//! ch. 21), in the same general form, `D11` allowed: `X2` the stabilising
//! DARE solution with `(A, B2, C1'C1, R1, C1'D12)`, `Y2` the dual with
//! `(A', C2', B1 B1', R2, B1 D21')`, `Rb = R1 + B2'X2 B2`,
//! `S = R2 + C2 Y2 C2'`,
//! `F2 = -Rb^-1 (B2'X2 A + D12'C1)`, `F0 = -Rb^-1 (B2'X2 B1 + D12'D11)`,
//! `L2 = -(A Y2 C2' + B1 D21') S^-1`, `L0 = (F2 Y2 C2' + F0 D21') S^-1`,
//! `K = [A + B2 F2 + L2 C2 - B2 L0 C2, -L2 + B2 L0; F2 - L0 C2, L0]`
//! (SB10SD's last lines; `u = F2 x^ + F0 w^` with the current-measurement
//! Kalman estimates of `x` and `w`). The optimum is
//! `J^2 = tr(D11'D11 + B1'X2 B1 - F0'Rb F0) + tr(Rb (F2 Y2 F2' + F0 F0' - L0 S L0'))`
//! (full-information cost plus the estimation cost, by completing the square
//! in the DARE; docs/robust.md, "Discrete H2").
//!
//! Both: `D22 != 0` by the loop shift `K (I + D22 K)^-1`; rank-deficient
//! `D12`/`D21` are regularised as in H-inf.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::genplant::{Partition, SynthError, inv_or};
use crate::lti::c64;
use crate::lti::norms::h2_norm_of_stable;
use crate::lti::riccati::{RiccatiSolution, care, dare};
use crate::lti::ss::{StateSpace, fro, tr};
use faer::Mat;

/// Result of an H2 synthesis.
#[derive(Debug, Clone)]
pub struct H2Result {
    /// The controller (`u = K y`).
    pub k: StateSpace,
    /// Closed-loop H2 norm achieved on the original plant (Gramian of the
    /// closed loop, independent of the Riccati solutions).
    pub h2_norm: f64,
    /// The optimum predicted by the Riccati solutions (discrete plants:
    /// the formula in the module doc; continuous: `None`). Agrees with
    /// `h2_norm` when both are right.
    pub h2_optimum: Option<f64>,
    /// Closed loop `F_l(P, K)`.
    pub closed_loop: StateSpace,
    /// Its poles.
    pub poles: Vec<c64>,
    /// Whether it is stable.
    pub stable: bool,
    /// Relative residuals of the two Riccati equations.
    pub x_residual: f64,
    pub y_residual: f64,
    /// The larger rounding floor of the two residuals
    /// ([`crate::lti::riccati::RiccatiSolution::residual_floor`]).
    pub residual_floor: f64,
    /// Regularisation weights added to `D12` / `D21`, if any.
    pub regularised: (Option<f64>, Option<f64>),
}

impl H2Result {
    /// Largest pole modulus of a discrete closed loop (its margin from the
    /// unit circle is `1 - rho`); `None` for a continuous one.
    pub fn spectral_radius(&self) -> Option<f64> {
        self.closed_loop
            .ts
            .map(|_| self.poles.iter().fold(0.0f64, |r, z| r.max(z.norm())))
    }
}

/// The two Riccati solutions and the controller they give (before the
/// `D22` loop shift), on the synthesis problem.
struct Design {
    k: StateSpace,
    xs: RiccatiSolution,
    ys: RiccatiSolution,
    optimum: Option<f64>,
}

/// H2-optimal synthesis, continuous or discrete (by the plant's `ts`).
pub fn h2syn(
    plant: &StateSpace,
    nmeas: usize,
    ncon: usize,
    eps: f64,
) -> Result<H2Result, SynthError> {
    // Balanced state coordinates (input-output behaviour unchanged).
    let p0 = Partition::new(&plant.balanced(), nmeas, ncon)?;
    if plant.ts.is_none() && fro(&p0.d11) != 0.0 {
        return Err(SynthError::Infeasible(
            "D11 != 0: the closed-loop H2 norm is infinite for every controller (make the \
             exogenous-to-performance feedthrough zero)"
                .into(),
        ));
    }
    p0.check_stabilisable_in(plant.ts.is_some())?;
    let (regularised, design) = match plant.ts {
        None => {
            let mut p = p0.clone();
            let regularised = p.regularise(eps);
            (regularised, continuous(&p)?)
        }
        Some(ts) => discrete_regularised(&p0, eps, ts)?,
    };
    let k = if fro(&p0.d22) == 0.0 {
        design.k
    } else {
        design
            .k
            .feedback(&StateSpace::gain(p0.d22.clone(), plant.ts))
            .map_err(|_| SynthError::Numerical("loop with D22 is not well posed".into()))?
    };
    let (closed_loop, poles, stable, h2) = close_loop(plant, &k)?;
    Ok(H2Result {
        k,
        h2_norm: h2,
        h2_optimum: design.optimum,
        closed_loop,
        poles,
        stable,
        x_residual: design.xs.residual,
        y_residual: design.ys.residual,
        residual_floor: design.xs.residual_floor.max(design.ys.residual_floor),
        regularised,
    })
}

/// Regularisation weights of `D12` / `D21` (`None`: not needed).
type Weights = (Option<f64>, Option<f64>);

/// The discrete design, regularised where `D12` / `D21` lack full rank:
/// with the weight `eps`, raised tenfold (at most to `1e6 eps`) while the
/// DAREs fail. A tiny weight makes `R1 = eps^2 I` and the symplectic
/// pencil's `B R^-1 B'` huge, which the pencil solver cannot separate from
/// the unit circle (SB10ED's plant with `D12 = 0` fails at `eps = 1e-6`);
/// the weight used is reported in the result.
fn discrete_regularised(
    p0: &Partition,
    eps: f64,
    ts: f64,
) -> Result<(Weights, Design), SynthError> {
    let mut weight = eps;
    loop {
        let mut p = p0.clone();
        let regularised = p.regularise_discrete(weight);
        match discrete(&p, ts) {
            Ok(d) => return Ok((regularised, d)),
            Err(e) if regularised == (None, None) || weight >= 1e6 * eps => return Err(e),
            Err(_) => weight *= 10.0,
        }
    }
}

/// `F_l(P, K)`, its poles, stability and H2 norm (infinite when unstable).
fn close_loop(
    plant: &StateSpace,
    k: &StateSpace,
) -> Result<(StateSpace, Vec<c64>, bool, f64), SynthError> {
    let num = |e: crate::lti::ss::SsError| SynthError::Numerical(e.to_string());
    let closed_loop = plant
        .lft(k)
        .map_err(|e| SynthError::Numerical(format!("closed loop: {e}")))?;
    let poles = closed_loop.poles().map_err(num)?;
    let stable = closed_loop.poles_are_stable(&poles);
    let h2 = if stable {
        h2_norm_of_stable(&closed_loop).map_err(|e| SynthError::Numerical(e.to_string()))?
    } else {
        f64::INFINITY
    };
    Ok((closed_loop, poles, stable, h2))
}

/// Zhou & Doyle, Essentials Thm 14.7 (general form).
fn continuous(p: &Partition) -> Result<Design, SynthError> {
    let xs = care(
        &p.a,
        &p.b2,
        &(tr(&p.c1) * &p.c1),
        &(tr(&p.d12) * &p.d12),
        Some(&(tr(&p.c1) * &p.d12)),
    )
    .map_err(|e| SynthError::Infeasible(format!("state-feedback Riccati: {e}")))?;
    let ys = care(
        &tr(&p.a),
        &tr(&p.c2),
        &(&p.b1 * tr(&p.b1)),
        &(&p.d21 * tr(&p.d21)),
        Some(&(&p.b1 * tr(&p.d21))),
    )
    .map_err(|e| SynthError::Infeasible(format!("filter Riccati: {e}")))?;
    let f = -&xs.k;
    let l = -tr(&ys.k);
    let ak = &(&p.a + &p.b2 * &f) + &l * &p.c2;
    let k = StateSpace::new(ak, -&l, f, Mat::zeros(p.m2(), p.p2()), None)
        .map_err(|e| SynthError::Numerical(e.to_string()))?;
    Ok(Design {
        k,
        xs,
        ys,
        optimum: None,
    })
}

/// The discrete-time Riccati solutions: `X2` ([ZDG96] ch. 21; SLICOT SB10SD
/// `Ax'(I + X Dx)^-1 X Ax - X + Cx = 0` in its normalised form) and the
/// dual `Y2`.
fn discrete_riccati(p: &Partition) -> Result<(RiccatiSolution, RiccatiSolution), SynthError> {
    let xs = dare(
        &p.a,
        &p.b2,
        &(tr(&p.c1) * &p.c1),
        &(tr(&p.d12) * &p.d12),
        Some(&(tr(&p.c1) * &p.d12)),
    )
    .map_err(|e| SynthError::Infeasible(format!("state-feedback Riccati (discrete): {e}")))?;
    let ys = dare(
        &tr(&p.a),
        &tr(&p.c2),
        &(&p.b1 * tr(&p.b1)),
        &(&p.d21 * tr(&p.d21)),
        Some(&(&p.b1 * tr(&p.d21))),
    )
    .map_err(|e| SynthError::Infeasible(format!("filter Riccati (discrete): {e}")))?;
    Ok((xs, ys))
}

/// SLICOT SB10SD's controller in the general form (module doc).
fn discrete(p: &Partition, ts: f64) -> Result<Design, SynthError> {
    let (xs, ys) = discrete_riccati(p)?;
    let (x, y) = (&xs.x, &ys.x);
    let rb = &(tr(&p.d12) * &p.d12) + &(tr(&p.b2) * x * &p.b2);
    let rbi = inv_or(&rb, "D12'D12 + B2'X2 B2")?;
    let f2 = -&xs.k;
    let f0 = -(&rbi * &(&(tr(&p.b2) * x * &p.b1) + &(tr(&p.d12) * &p.d11)));
    let s = &(&p.d21 * tr(&p.d21)) + &(&p.c2 * y * tr(&p.c2));
    let si = inv_or(&s, "D21 D21' + C2 Y2 C2'")?;
    let l2 = -tr(&ys.k);
    let l0 = &(&(&f2 * y * tr(&p.c2)) + &(&f0 * tr(&p.d21))) * &si;
    let ck = &f2 - &l0 * &p.c2;
    let ak = &(&p.a + &p.b2 * &ck) + &l2 * &p.c2;
    let bk = &(-&l2) + &p.b2 * &l0;
    // [ZDG96] ch. 21: full-information cost plus the output-estimation cost.
    let fi =
        trace(&(&(tr(&p.d11) * &p.d11) + &(tr(&p.b1) * x * &p.b1))) - trace(&(tr(&f0) * &rb * &f0));
    let oe = trace(&(&rb * &(&(&(&f2 * y * tr(&f2)) + &(&f0 * tr(&f0))) - &(&l0 * &s * tr(&l0)))));
    let k = StateSpace::new(ak, bk, ck, l0, Some(ts))
        .map_err(|e| SynthError::Numerical(e.to_string()))?;
    Ok(Design {
        k,
        xs,
        ys,
        // A negative sum (a wrong Riccati solution) gives NaN, never a clamped 0.
        optimum: Some((fi + oe).sqrt()),
    })
}

fn trace(m: &Mat<f64>) -> f64 {
    (0..m.nrows()).map(|i| m[(i, i)]).sum()
}
