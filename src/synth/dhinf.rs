//! The discrete-time H-infinity central controller at a given `gamma`
//! (SLICOT SB10DD; Green & Limebeer, *Linear Robust Control* (1995) §8;
//! Zhou, Doyle & Glover (1996) ch. 21 / Gu, Petkov & Konstantinov,
//! Report 99-8), computed on the discrete plant itself, without
//! normalising `D12` / `D21` and without the bilinear map.
//!
//! With `D1. = [D11 D12]`, `R0 = D1.'D1. - diag(g^2 I, 0)`:
//! * `X` is the stabilising solution of the DARE with `(A, B, C1'C1, R0, C1'D1.)`;
//! * `R0 + B'XB = [R1 R2'; R2 R3]` needs `R3 = V12'V12 > 0` and
//!   `Nabla = R1 - R2' R3^-1 R2 = -V21'V21 < 0`;
//! * `[L1; L2] = D1.'C1 + B'XA`, `L~ = V21^-T (L1 - R2' R3^-1 L2)` (with
//!   `R2 <- V12^-T R2`, `L2 <- V12^-T L2`), `Bt1 = B1 V21^-1`, `At = A + Bt1 L~`,
//!   `[Dt11; Dt21] = [R2; D21] V21^-1`, `Ct = [L2; C2] + [Dt11; Dt21] L~`;
//! * `Z` is the stabilising solution of the dual DARE with
//!   `(At', Ct', g^2 Bt1 Bt1', S0, g^2 Bt1 Dt')`,
//!   `S0 = g^2 Dt Dt' - diag(g^2 I, 0)`;
//! * `S0 + Ct Z Ct' = [St1 St2; St2' St3]` needs `St3 > 0` and
//!   `St1 - St2 St3^-1 St2' < 0`;
//! * `DK^ = -V12^-1 St2 St3^-1`, `CK^ = -V12^-1 (Ct1 - St2 St3^-1 Ct2)`,
//!   `BK0 = (g^2 Bt1 Dt21' + At Z Ct2') St3^-1`,
//!   `AK^ = At + B2 CK^ - BK0 Ct2`, `BK^ = BK0 + B2 DK^`,
//!   and `D22` by the loop shift `K^ (I + D22 K^)^-1`.
//!
//! These are SB10DD's steps in matrix form (its in-place scalings of `Bt1`
//! and `Dt` by `gamma` included). The feasibility of `gamma` itself is
//! decided elsewhere (the bisection); here a violated condition is an error.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::genplant::{Partition, SynthError, chol_factor, inv_or};
use crate::lti::riccati::{RiccatiSolution, dare};
use crate::lti::ss::{StateSpace, fro, hcat, sub, tr, vcat};
use faer::Mat;

fn infeasible(why: &str) -> SynthError {
    SynthError::Infeasible(format!("discrete central controller: {why}"))
}

/// `M - diag(g2 I_k, 0)`.
fn minus_g2(mut m: Mat<f64>, k: usize, g2: f64) -> Mat<f64> {
    for i in 0..k {
        m[(i, i)] -= g2;
    }
    m
}

/// The X step: the DARE, the factors `V12'` (lower, `R3 = V12' V12`) and
/// `V21'` (lower, `-Nabla = V21' V21`), `R2 <- V12^-T R2`, and `L~`.
struct XStep {
    xs: RiccatiSolution,
    v12t: Mat<f64>,
    v21t: Mat<f64>,
    r2: Mat<f64>,
    l2: Mat<f64>,
    ltilde: Mat<f64>,
}

fn x_step(p: &Partition, g2: f64) -> Result<XStep, SynthError> {
    let (m1, m2, n) = (p.m1(), p.m2(), p.n());
    let b = hcat(&p.b1, &p.b2);
    let d1 = hcat(&p.d11, &p.d12);
    let r0 = minus_g2(tr(&d1) * &d1, m1, g2);
    let xs = dare(
        &p.a,
        &b,
        &(tr(&p.c1) * &p.c1),
        &r0,
        Some(&(tr(&p.c1) * &d1)),
    )
    .map_err(|e| infeasible(&format!("X Riccati: {e}")))?;
    let x = &xs.x;
    let r = &r0 + &(tr(&b) * x * &b);
    let v12t = chol_factor(&sub(&r, m1, m1 + m2, m1, m1 + m2))
        .ok_or_else(|| infeasible("R3 = D12'D12 + B2'XB2 is not positive definite"))?;
    let v12ti = inv_or(&v12t, "V12'")?;
    let r2 = &v12ti * &sub(&r, m1, m1 + m2, 0, m1);
    let neg_nabla = &(tr(&r2) * &r2) - &sub(&r, 0, m1, 0, m1);
    let v21t = chol_factor(&neg_nabla)
        .ok_or_else(|| infeasible("Nabla = R1 - R2'R3^-1 R2 is not negative definite"))?;
    let l = &(tr(&d1) * &p.c1) + &(tr(&b) * x * &p.a);
    let l2 = &v12ti * &sub(&l, m1, m1 + m2, 0, n);
    let ln = &sub(&l, 0, m1, 0, n) - &(tr(&r2) * &l2);
    let ltilde = inv_or(&v21t, "V21'")? * ln;
    Ok(XStep {
        xs,
        v12t,
        v21t,
        r2,
        l2,
        ltilde,
    })
}

/// SB10DD's central controller and the accuracy of its two DAREs.
#[derive(Debug, Clone)]
pub struct DiscreteCentral {
    /// The controller (`u = K y`), `D22` included.
    pub k: StateSpace,
    /// Relative residuals of the X and Z equations.
    pub x_residual: f64,
    pub z_residual: f64,
    /// The larger rounding floor of the two
    /// ([`crate::lti::riccati::RiccatiSolution::residual_floor`]).
    pub residual_floor: f64,
}

/// The central controller `K^` before the `D22` loop shift.
fn central_hat(p: &Partition, gamma: f64) -> Result<DiscreteCentral, SynthError> {
    let (m2, p2, n) = (p.m2(), p.p2(), p.n());
    let g2 = gamma * gamma;
    let xs = x_step(p, g2)?;
    let v21i = tr(&inv_or(&xs.v21t, "V21'")?); // V21^-1 = (V21'^-1)'
    let bt1 = &p.b1 * &v21i;
    let at = &p.a + &bt1 * &xs.ltilde;
    let dt = &vcat(&xs.r2, &p.d21) * &v21i;
    let ct = &vcat(&xs.l2, &p.c2) + &dt * &xs.ltilde;
    // SB10DD scales Bt1 and Dt by gamma before the Z equation.
    let (bt1, dt) = (&bt1 * gamma, &dt * gamma);
    let s0 = minus_g2(&dt * tr(&dt), m2, g2);
    let zs = dare(
        &tr(&at),
        &tr(&ct),
        &(&bt1 * tr(&bt1)),
        &s0,
        Some(&(&bt1 * tr(&dt))),
    )
    .map_err(|e| infeasible(&format!("Z Riccati: {e}")))?;
    let st = &s0 + &(&ct * &zs.x * tr(&ct));
    let st3 = sub(&st, m2, m2 + p2, m2, m2 + p2);
    let st3i = chol_factor(&st3)
        .ok_or_else(|| infeasible("St3 is not positive definite"))
        .and_then(|_| inv_or(&st3, "St3"))?;
    let st2 = sub(&st, 0, m2, m2, m2 + p2);
    let schur = &sub(&st, 0, m2, 0, m2) - &(&st2 * &st3i * tr(&st2));
    if chol_factor(&(-&schur)).is_none() {
        return Err(infeasible("St1 - St2 St3^-1 St2' is not negative definite"));
    }
    let g = &st2 * &st3i;
    let v12i = inv_or(&tr(&xs.v12t), "V12")?;
    let (ct1, ct2) = (sub(&ct, 0, m2, 0, n), sub(&ct, m2, m2 + p2, 0, n));
    let dk = -(&v12i * &g);
    let ck = -(&v12i * &(&ct1 - &g * &ct2));
    let dt21 = sub(&dt, m2, m2 + p2, 0, dt.ncols());
    let bk0 = &(&(&bt1 * tr(&dt21)) + &(&at * &zs.x * tr(&ct2))) * &st3i;
    let ak = &(&at + &p.b2 * &ck) - &bk0 * &ct2;
    let bk = &bk0 + &p.b2 * &dk;
    let k =
        StateSpace::new(ak, bk, ck, dk, None).map_err(|e| SynthError::Numerical(e.to_string()))?;
    Ok(DiscreteCentral {
        k,
        x_residual: xs.xs.residual,
        z_residual: zs.residual,
        residual_floor: xs.xs.residual_floor.max(zs.residual_floor),
    })
}

/// SLICOT SB10DD's central controller for the discrete plant `p` (sample
/// time `ts`) at level `gamma`, `D22` included (`u = K y`).
pub fn discrete_central(p: &Partition, gamma: f64, ts: f64) -> Result<DiscreteCentral, SynthError> {
    let mut c = central_hat(p, gamma)?;
    c.k.ts = Some(ts);
    if fro(&p.d22) != 0.0 {
        c.k =
            c.k.feedback(&StateSpace::gain(p.d22.clone(), Some(ts)))
                .map_err(|_| {
                    SynthError::Numerical("the controller's loop with D22 is not well posed".into())
                })?;
    }
    Ok(c)
}
