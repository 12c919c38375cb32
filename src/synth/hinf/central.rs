//! The central controller of Zhou, Doyle & Glover, *Robust and Optimal
//! Control* (1996), Thm 17.1, at one gamma, on the normalised plant
//! (`D12 = [0; I]`, `D21 = [0 I]`), in two algebraically equal forms:
//!
//! * [`explicit`]: the theorem's formulas in the Riccati solutions `X`, `Y`
//!   and `Z = (I - Y X / gamma^2)^-1`;
//! * [`descriptor`]: the same controller in the bases of the Hamiltonians'
//!   stable subspaces, `X = U2 U1^-1`, `Y = V2 V1^-1`, in the state
//!   `x = U1 zeta` (Safonov, Limebeer & Chiang 1989, Int. J. Control 50(6);
//!   the descriptor matrix `E = V1' U1 - V2' U2 / gamma^2`, since
//!   `Z = U1 E^-1 V1'`).
//!
//! Near the optimum `X` (or `Z`) grows without bound. Its rounding error,
//! `eps ||X||` in every direction, then swamps its small eigenvalues, which
//! on cheap-control problems (`W_u = 1e-6` scales `B2` by 1e6) are 1e-11 of
//! its norm; the bases are accurate to `eps / sep` entry by entry, and only
//! the solve with `E` meets the ill-conditioning, in the controller's one
//! fast mode. Neither form wins everywhere, so the synthesis keeps the
//! explicit one where it meets its level and tries the other where not.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::super::genplant::{Partition, SynthError, chol_factor, inv_or};
use super::{blocks, indefinite_weights};
use crate::lti::riccati::RiccatiSolution;
use crate::lti::ss::{StateSpace, hcat, solve, sub, tr, vcat};
use faer::Mat;

/// The controller's feedthrough and the square factors of Thm 17.1:
/// `D^11`, `D^12` (`D^12 D^12' = I - D1121 (g^2 I - D1111'D1111)^-1 D1121'`)
/// and `D^21` (`D^21' D^21 = I - D1112' (g^2 I - D1111 D1111')^-1 D1112`).
struct Feedthrough {
    dh11: Mat<f64>,
    dh12: Mat<f64>,
    dh21: Mat<f64>,
}

fn feedthrough(p: &Partition, g2: f64) -> Result<Feedthrough, SynthError> {
    let (m1, m2, p1, p2) = (p.m1(), p.m2(), p.p1(), p.p2());
    let infeasible = |why: &str| SynthError::Infeasible(why.into());
    let [d1111, d1112, d1121, d1122] = blocks(&p.d11, p1 - m2, m1 - p2);
    let gi = |k: usize| Mat::<f64>::identity(k, k) * g2;
    let w1 = inv_or(
        &(&gi(p1 - m2) - &d1111 * tr(&d1111)),
        "g^2 I - D1111 D1111'",
    )?;
    let w2 = inv_or(
        &(&gi(m1 - p2) - tr(&d1111) * &d1111),
        "g^2 I - D1111' D1111",
    )?;
    let dh11 = &(-(&d1121 * tr(&d1111) * &w1 * &d1112)) - &d1122;
    let dh12 = chol_factor(&(Mat::<f64>::identity(m2, m2) - &d1121 * &w2 * tr(&d1121)))
        .ok_or_else(|| infeasible("D^12 factor is not positive definite"))?;
    let dh21t = chol_factor(&(Mat::<f64>::identity(p2, p2) - tr(&d1112) * &w1 * &d1112))
        .ok_or_else(|| infeasible("D^21 factor is not positive definite"))?;
    Ok(Feedthrough {
        dh11,
        dh12,
        dh21: tr(&dh21t),
    })
}

/// `R^-1` and `R~^-1` of the two Riccati equations ([`indefinite_weights`]).
fn weights_inverse(p: &Partition, g2: f64) -> Result<(Mat<f64>, Mat<f64>), SynthError> {
    let (r, rt) = indefinite_weights(p, g2);
    Ok((inv_or(&r, "R")?, inv_or(&rt, "R~")?))
}

/// Thm 17.1's formulas (17.5)-(17.6) in `X`, `Y` and `Z`.
pub(super) fn explicit(
    p: &Partition,
    gamma: f64,
    xs: &RiccatiSolution,
    ys: &RiccatiSolution,
) -> Result<StateSpace, SynthError> {
    let (n, m1, m2, p1, p2) = (p.n(), p.m1(), p.m2(), p.p1(), p.p2());
    let g2 = gamma * gamma;
    let (x, y) = (&xs.x, &ys.x);
    let b = hcat(&p.b1, &p.b2);
    // F = -R^-1 (D1.'C1 + B'X) = -Kx, L = -(B1 D.1' + Y C') R~^-1 = -Ky'.
    let f = -&xs.k;
    let l = -tr(&ys.k);
    let f12 = sub(&f, m1 - p2, m1, 0, n);
    let f2 = sub(&f, m1, m1 + m2, 0, n);
    let l12 = sub(&l, 0, n, p1 - m2, p1);
    let l2 = sub(&l, 0, n, p1, p1 + p2);
    let Feedthrough { dh11, dh12, dh21 } = feedthrough(p, g2)?;
    let zinf = inv_or(
        &(Mat::<f64>::identity(n, n) - &(y * x * (1.0 / g2))),
        "I - Y X / gamma^2",
    )?;
    let bh2 = &zinf * &(&p.b2 + &l12) * &dh12;
    let ch2 = -(&dh21 * &(&p.c2 + &f12));
    let dh12i = inv_or(&dh12, "D^12")?;
    let dh21i = inv_or(&dh21, "D^21")?;
    let bh1 = &(-(&zinf * &l2)) + &bh2 * &dh12i * &dh11;
    let ch1 = &f2 + &dh11 * &dh21i * &ch2;
    let ah = &(&p.a + &b * &f) + &bh1 * &dh21i * &ch2;
    StateSpace::new(ah, bh1, ch1, dh11, None).map_err(|e| SynthError::Numerical(e.to_string()))
}

/// The same controller in the state `zeta = U1^-1 x`, from the stable
/// subspaces `[U1; U2]` (with `H [U1; U2] = [U1; U2] T`) and `[V1; V2]`:
///
/// * `F U1 = -R^-1 (D1.'C1 U1 + B' U2)`, `V1' L = -(V1' B1 D.1' + V2' C') R~^-1`
///   (`V1' Y = V2'`, `Y` being symmetric);
/// * `U1^-1 (A + B F) U1 = T` (the subspace's invariance);
/// * `U1^-1 Z = E^-1 V1'`, `E = V1' U1 - V2' U2 / gamma^2`;
///
/// so `A_K = T + E^-1 M D^21^-1 C2h`, `B_K = E^-1 M`, `C_K = F2 U1 + D^11 D^21^-1 C2h`,
/// `D_K = D^11`, with `M = -V1' L2 + (V1' B2 + V1' L12) D^11` and
/// `C2h = -D^21 (C2 U1 + F12 U1)`. `None` when a Riccati solution carries
/// no subspace.
pub(super) fn descriptor(
    p: &Partition,
    gamma: f64,
    xs: &RiccatiSolution,
    ys: &RiccatiSolution,
) -> Result<Option<StateSpace>, SynthError> {
    let (Some(xb), Some(yb)) = (&xs.subspace, &ys.subspace) else {
        return Ok(None);
    };
    let (n, m1, m2, p1, p2) = (p.n(), p.m1(), p.m2(), p.p1(), p.p2());
    let g2 = gamma * gamma;
    let (ri, rti) = weights_inverse(p, g2)?;
    let b = hcat(&p.b1, &p.b2);
    let c = vcat(&p.c1, &p.c2);
    let d1 = hcat(&p.d11, &p.d12);
    let dd1 = vcat(&p.d11, &p.d21);
    let fu = -(&ri * &(&(tr(&d1) * &p.c1 * &xb.u1) + &(tr(&b) * &xb.u2)));
    let vl = -(&(&(tr(&yb.u1) * &p.b1 * tr(&dd1)) + &(tr(&yb.u2) * tr(&c))) * &rti);
    let e = &(tr(&yb.u1) * &xb.u1) - &(tr(&yb.u2) * &xb.u2 * (1.0 / g2));
    let Feedthrough { dh11, dh21, .. } = feedthrough(p, g2)?;
    let dh21i = inv_or(&dh21, "D^21")?;
    let vl12 = sub(&vl, 0, n, p1 - m2, p1);
    let vl2 = sub(&vl, 0, n, p1, p1 + p2);
    let m = &(-&vl2) + &(&(tr(&yb.u1) * &p.b2) + &vl12) * &dh11;
    let ch2 = -(&dh21 * &(&(&p.c2 * &xb.u1) + &sub(&fu, m1 - p2, m1, 0, n)));
    let bk = solve(&e, &m)
        .ok_or_else(|| SynthError::Numerical("the descriptor matrix E is singular".into()))?;
    let ak = &xb.t11 + &bk * &dh21i * &ch2;
    let ck = &sub(&fu, m1, m1 + m2, 0, n) + &dh11 * &dh21i * &ch2;
    StateSpace::new(ak, bk, ck, dh11, None)
        .map(Some)
        .map_err(|e| SynthError::Numerical(e.to_string()))
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::super::riccati_pair;
    use super::*;
    use crate::synth::genplant::normalise;

    /// An open-loop unstable plant with process and sensor noise (so that
    /// neither Riccati solution is zero): `x1' = x2 + w1`,
    /// `x2' = 2 x1 - x2 + u`, `z = [x1; u]`, `y = x1 + w2`.
    fn plant() -> StateSpace {
        let m = |r: usize, c: usize, v: &[f64]| Mat::from_fn(r, c, |i, j| v[i * c + j]);
        StateSpace::new(
            m(2, 2, &[0.0, 1.0, 2.0, -1.0]),
            m(2, 3, &[1.0, 0.0, 0.0, 0.0, 0.0, 1.0]),
            m(3, 2, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
            m(3, 3, &[0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]),
            None,
        )
        .unwrap()
    }

    /// The two forms are one controller: their frequency responses agree
    /// to rounding at a level well above the optimum, where both are
    /// well-conditioned.
    pub fn descriptor_form_is_the_explicit_controller() {
        let p = normalise(&Partition::new(&plant(), 1, 1).unwrap())
            .unwrap()
            .p;
        for gamma in [5.0, 20.0] {
            let pair = riccati_pair(&p, gamma).unwrap();
            assert!(pair.xs.x.norm_l2() > 0.1 && pair.ys.x.norm_l2() > 0.1);
            let k1 = explicit(&p, gamma, &pair.xs, &pair.ys).unwrap();
            let k2 = descriptor(&p, gamma, &pair.xs, &pair.ys).unwrap().unwrap();
            for w in [0.0, 0.01, 0.3, 1.0, 7.0, 100.0] {
                let (a, b) = (k1.freq_response(w).unwrap(), k2.freq_response(w).unwrap());
                let d = (a[(0, 0)] - b[(0, 0)]).norm() / a[(0, 0)].norm();
                assert!(
                    d < 1e-10,
                    "gamma {gamma}, w {w}: {} vs {}",
                    a[(0, 0)],
                    b[(0, 0)]
                );
            }
        }
    }

    /// Without the stable subspaces there is no descriptor form.
    pub fn no_subspace_no_descriptor_form() {
        let p = normalise(&Partition::new(&plant(), 1, 1).unwrap())
            .unwrap()
            .p;
        let mut pair = riccati_pair(&p, 5.0).unwrap();
        pair.xs.subspace = None;
        assert!(descriptor(&p, 5.0, &pair.xs, &pair.ys).unwrap().is_none());
    }
}
