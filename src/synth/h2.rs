//! H2-optimal output feedback on a generalised plant (`h2syn(P, nmeas, ncon)`).
//!
//! Zhou & Doyle, *Essentials of Robust Control* Thm 14.7 in its general
//! (non-orthogonal) form: with `R1 = D12'D12 > 0`, `R2 = D21 D21' > 0`,
//! `X2` stabilises `A'X + XA - (XB2 + C1'D12) R1^-1 (B2'X + D12'C1) + C1'C1 = 0`,
//! `Y2` the dual with `(A', C2', B1 B1', R2, B1 D21')`,
//! `F2 = -R1^-1 (B2'X2 + D12'C1)`, `L2 = -(Y2 C2' + B1 D21') R2^-1`, and the
//! unique optimal controller `K = [A + B2 F2 + L2 C2, -L2; F2, 0]`
//! (`D22 != 0` by the loop shift `K (I + D22 K)^-1`). `D11` must be zero for a
//! finite H2 norm. Rank-deficient `D12`/`D21` are regularised as in H-inf.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::genplant::{Partition, SynthError};
use crate::lti::c64;
use crate::lti::norms::h2_norm;
use crate::lti::riccati::care;
use crate::lti::ss::{StateSpace, fro, tr};

/// Result of an H2 synthesis.
#[derive(Debug, Clone)]
pub struct H2Result {
    /// The controller (`u = K y`).
    pub k: StateSpace,
    /// Closed-loop H2 norm achieved on the original plant.
    pub h2_norm: f64,
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

/// H2-optimal synthesis (continuous time).
pub fn h2syn(
    plant: &StateSpace,
    nmeas: usize,
    ncon: usize,
    eps: f64,
) -> Result<H2Result, SynthError> {
    if plant.is_discrete() {
        return Err(SynthError::Dimension(
            "fts synthesises H2 controllers for continuous-time plants only (the plant has a \
             sample time): synthesise in continuous time and discretise the controller with `fts c2d`"
                .into(),
        ));
    }
    // Balanced state coordinates (input-output behaviour unchanged).
    let p0 = Partition::new(&plant.balanced(), nmeas, ncon)?;
    if fro(&p0.d11) != 0.0 {
        return Err(SynthError::Infeasible(
            "D11 != 0: the closed-loop H2 norm is infinite for every controller (make the \
             exogenous-to-performance feedthrough zero)"
                .into(),
        ));
    }
    p0.check_stabilisable()?;
    let mut p = p0.clone();
    let regularised = p.regularise(eps);
    let q1 = tr(&p.c1) * &p.c1;
    let xs = care(
        &p.a,
        &p.b2,
        &q1,
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
    let k0 = StateSpace::new(ak, -&l, f, faer::Mat::zeros(p.m2(), p.p2()), None)
        .map_err(|e| SynthError::Numerical(e.to_string()))?;
    let k = if fro(&p0.d22) == 0.0 {
        k0
    } else {
        k0.feedback(&StateSpace::gain(p0.d22.clone(), None))
            .map_err(|_| SynthError::Numerical("loop with D22 is not well posed".into()))?
    };
    let closed_loop = plant
        .lft(&k)
        .map_err(|e| SynthError::Numerical(format!("closed loop: {e}")))?;
    let poles = closed_loop
        .poles()
        .map_err(|e| SynthError::Numerical(e.to_string()))?;
    let stable = closed_loop
        .is_stable()
        .map_err(|e| SynthError::Numerical(e.to_string()))?;
    let h2 = if stable {
        h2_norm(&closed_loop).map_err(|e| SynthError::Numerical(e.to_string()))?
    } else {
        f64::INFINITY
    };
    Ok(H2Result {
        k,
        h2_norm: h2,
        closed_loop,
        poles,
        stable,
        x_residual: xs.residual,
        y_residual: ys.residual,
        residual_floor: xs.residual_floor.max(ys.residual_floor),
        regularised,
    })
}
