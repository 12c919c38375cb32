//! The central controller of Zhou, Doyle & Glover, *Robust and Optimal
//! Control* (1996), Thm 17.1, at one gamma, on the normalised plant
//! (`D12 = [0; I]`, `D21 = [0 I]`), in three algebraically equal forms:
//!
//! * [`explicit`]: the theorem's formulas in the Riccati solutions `X`, `Y`
//!   and `Z = (I - Y X / gamma^2)^-1`;
//! * [`descriptor`]: the same controller in the bases of the Hamiltonians'
//!   stable subspaces, `X = U2 U1^-1`, `Y = V2 V1^-1`, in the state
//!   `x = U1 zeta` (Safonov, Limebeer & Chiang 1989, Int. J. Control 50(6);
//!   the descriptor matrix `E = V1' U1 - V2' U2 / gamma^2`, since
//!   `Z = U1 E^-1 V1'`);
//! * [`explicit_extended`]: the explicit formulas in double-double, from
//!   `X` and `Y` refined on the unreduced Riccati equations, returned in
//!   modal coordinates.
//!
//! Near the optimum `X` (or `Z`) grows without bound. Its rounding error,
//! `eps ||X||` in every direction, then swamps its small eigenvalues, which
//! on cheap-control problems (`W_u = 1e-6` scales `B2` by 1e6) are 1e-11 of
//! its norm; the bases are accurate to `eps / sep` entry by entry, and only
//! the solve with `E` meets the ill-conditioning, in the controller's one
//! fast mode. Neither form wins everywhere, so the synthesis keeps the
//! explicit one where it meets its level and tries the other where not.
//! Both still miss where the controller itself cannot be rounded to
//! double in its natural coordinates (cheap control below `W_u = 1e-4`);
//! the third form is for those, and costs a few times more.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::super::genplant::{Partition, SynthError, chol_factor, inv_or};
use super::{blocks, indefinite_weights};
use crate::lti::accurate::Dd;
use crate::lti::balred::modal_basis;
use crate::lti::riccati::{RiccatiSolution, care_extended};
use crate::lti::ss::{StateSpace, hcat, solve, sub, tr, vcat};
use faer::Mat;

/// The controller's feedthrough and the square factors of Thm 17.1:
/// `D^11`, `D^12` (`D^12 D^12' = I - D1121 (g^2 I - D1111'D1111)^-1 D1121'`)
/// and `D^21` (`D^21' D^21 = I - D1112' (g^2 I - D1111 D1111')^-1 D1112`).
struct Feedthrough<M = Mat<f64>> {
    dh11: M,
    dh12: M,
    dh21: M,
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

/// The matrix arithmetic Thm 17.1's formulas take, in double (faer's
/// `Mat<f64>`) or double-double ([`Dd`]).
trait Arith: Sized {
    fn mul(&self, b: &Self) -> Self;
    fn plus(&self, b: &Self) -> Self;
    fn minus(&self, b: &Self) -> Self;
    fn neg(&self) -> Self;
    /// `self / gamma^2`.
    fn over_squared(&self, gamma: f64) -> Self;
    fn part(&self, r0: usize, r1: usize, c0: usize, c1: usize) -> Self;
    fn identity(n: usize) -> Self;
    fn inverse(&self, what: &str) -> Result<Self, SynthError>;
}

impl Arith for Mat<f64> {
    fn mul(&self, b: &Self) -> Self {
        self * b
    }
    fn plus(&self, b: &Self) -> Self {
        self + b
    }
    fn minus(&self, b: &Self) -> Self {
        self - b
    }
    fn neg(&self) -> Self {
        -self
    }
    fn over_squared(&self, gamma: f64) -> Self {
        self * (1.0 / (gamma * gamma))
    }
    fn part(&self, r0: usize, r1: usize, c0: usize, c1: usize) -> Self {
        sub(self, r0, r1, c0, c1)
    }
    fn identity(n: usize) -> Self {
        Mat::identity(n, n)
    }
    fn inverse(&self, what: &str) -> Result<Self, SynthError> {
        inv_or(self, what)
    }
}

impl Arith for Dd {
    fn mul(&self, b: &Self) -> Self {
        Dd::mul(self, b)
    }
    fn plus(&self, b: &Self) -> Self {
        self.add(b, 1.0)
    }
    fn minus(&self, b: &Self) -> Self {
        self.add(b, -1.0)
    }
    fn neg(&self) -> Self {
        Dd::neg(self)
    }
    fn over_squared(&self, gamma: f64) -> Self {
        self.divided(gamma).divided(gamma)
    }
    fn part(&self, r0: usize, r1: usize, c0: usize, c1: usize) -> Self {
        Dd {
            hi: sub(&self.hi, r0, r1, c0, c1),
            lo: sub(&self.lo, r0, r1, c0, c1),
        }
    }
    fn identity(n: usize) -> Self {
        Dd::from(&Mat::identity(n, n))
    }
    fn inverse(&self, what: &str) -> Result<Self, SynthError> {
        inverse_or(self, what)
    }
}

/// What Thm 17.1's formulas (17.5)-(17.6) take.
struct Ingredients<M> {
    a: M,
    /// `[B1 B2]`.
    b: M,
    b2: M,
    c2: M,
    /// `F = -R^-1 (D1.'C1 + B'X)` and `L = -(B1 D.1' + Y C') R~^-1`.
    f: M,
    l: M,
    x: M,
    y: M,
    ft: Feedthrough<M>,
    gamma: f64,
}

/// Thm 17.1's formulas (17.5)-(17.6): `[A^, B^1, C^1, D^11]`.
fn assemble<M: Arith>(p: &Partition, i: Ingredients<M>) -> Result<[M; 4], SynthError> {
    let (n, m1, m2, p1, p2) = (p.n(), p.m1(), p.m2(), p.p1(), p.p2());
    let f12 = i.f.part(m1 - p2, m1, 0, n);
    let f2 = i.f.part(m1, m1 + m2, 0, n);
    let l12 = i.l.part(0, n, p1 - m2, p1);
    let l2 = i.l.part(0, n, p1, p1 + p2);
    let Feedthrough { dh11, dh12, dh21 } = i.ft;
    let zinf = M::identity(n)
        .minus(&i.y.mul(&i.x).over_squared(i.gamma))
        .inverse("I - Y X / gamma^2")?;
    let bh2 = zinf.mul(&i.b2.plus(&l12)).mul(&dh12);
    let ch2 = dh21.mul(&i.c2.plus(&f12)).neg();
    let dh12i = dh12.inverse("D^12")?;
    let dh21i = dh21.inverse("D^21")?;
    let bh1 = zinf.mul(&l2).neg().plus(&bh2.mul(&dh12i).mul(&dh11));
    let ch1 = f2.plus(&dh11.mul(&dh21i).mul(&ch2));
    let ah = i.a.plus(&i.b.mul(&i.f)).plus(&bh1.mul(&dh21i).mul(&ch2));
    Ok([ah, bh1, ch1, dh11])
}

/// [`Dd::inverse`], or an error naming the matrix.
fn inverse_or(m: &Dd, what: &str) -> Result<Dd, SynthError> {
    m.inverse()
        .ok_or_else(|| SynthError::Numerical(format!("{what} is singular")))
}

fn into_state_space([a, b, c, d]: [Mat<f64>; 4]) -> Result<StateSpace, SynthError> {
    StateSpace::new(a, b, c, d, None).map_err(|e| SynthError::Numerical(e.to_string()))
}

/// Thm 17.1's formulas (17.5)-(17.6) in `X`, `Y` and `Z`.
pub(super) fn explicit(
    p: &Partition,
    gamma: f64,
    xs: &RiccatiSolution,
    ys: &RiccatiSolution,
) -> Result<StateSpace, SynthError> {
    let g2 = gamma * gamma;
    let ingredients = Ingredients {
        a: p.a.clone(),
        b: hcat(&p.b1, &p.b2),
        b2: p.b2.clone(),
        c2: p.c2.clone(),
        // The Riccati solutions' gains: F = -Kx, L = -Ky'.
        f: -&xs.k,
        l: -tr(&ys.k),
        x: xs.x.clone(),
        y: ys.x.clone(),
        ft: feedthrough(p, g2)?,
        gamma,
    };
    into_state_space(assemble(p, ingredients)?)
}

/// [`explicit`]'s controller, formed in double-double arithmetic ([`Dd`])
/// from `X` and `Y` refined to double-double ([`care_extended`]), and
/// returned in modal coordinates ([`modal_coordinates`]).
///
/// On a cheap-control problem the state matrix `A + B F + ...` has entries
/// of 1e13 (`F` scales like `1 / W_u^2`) beside a pole at 1e-3, the
/// weight's, which the exact controller keeps exactly; formed in double,
/// or formed exactly and then rounded entry by entry, that pole moves by
/// `eps ||A_K||`, all of its size, and the controller's DC gain with it
/// (Karagoz18 Y, `W_u = 1e-5`: +6e-4 above its level, evaluated at 40
/// digits). Rounded in modal coordinates, each pole and its residue are
/// perturbed relative to their own size, and the controller keeps its
/// level. `X` must be refined on the equation as the formulas use it:
/// [`care`](crate::lti::riccati::care) solves the reduced equation, whose
/// rounded `B R^-1 B'` leaves `X` 4e-14 of its norm from that solution
/// (4e-26 after), and `R = D1.'D1. - diag(gamma^2 I, 0)` is formed here in
/// double-double because `gamma^2` cancels against `D11'D11` in it.
pub(super) fn explicit_extended(
    p: &Partition,
    gamma: f64,
    xs: &RiccatiSolution,
    ys: &RiccatiSolution,
) -> Result<StateSpace, SynthError> {
    let [f, l, x, y] = extended_gains(p, gamma, xs, ys)?;
    let Feedthrough { dh11, dh12, dh21 } = feedthrough(p, gamma * gamma)?;
    let ingredients = Ingredients {
        a: Dd::from(&p.a),
        b: Dd::from(&hcat(&p.b1, &p.b2)),
        b2: Dd::from(&p.b2),
        c2: Dd::from(&p.c2),
        f,
        l,
        x,
        y,
        ft: Feedthrough {
            dh11: Dd::from(&dh11),
            dh12: Dd::from(&dh12),
            dh21: Dd::from(&dh21),
        },
        gamma,
    };
    into_state_space(modal_coordinates(assemble(p, ingredients)?)?)
}

/// `[F, L, X, Y]` in double-double: `X` and `Y` refined on the equations
/// of `riccati_pair`, `F = -R^-1 (D1.'C1 + B'X)`, `L = -(B1 D.1' + Y C') R~^-1`.
fn extended_gains(
    p: &Partition,
    gamma: f64,
    xs: &RiccatiSolution,
    ys: &RiccatiSolution,
) -> Result<[Dd; 4], SynthError> {
    let (b, c) = (Dd::from(&hcat(&p.b1, &p.b2)), Dd::from(&vcat(&p.c1, &p.c2)));
    let (d1, dd1) = (
        Dd::from(&hcat(&p.d11, &p.d12)),
        Dd::from(&vcat(&p.d11, &p.d21)),
    );
    let (c1, b1) = (Dd::from(&p.c1), Dd::from(&p.b1));
    // R = D1.'D1. - diag(gamma^2 I, 0), R~ = D.1 D.1' - diag(gamma^2 I, 0):
    // gamma^2 against D11'D11 is where the weights cancel.
    let level = |k: usize, m: usize| {
        let g = Dd::from(&Mat::from_fn(k, k, |i, j| {
            if i == j && i < m { gamma } else { 0.0 }
        }));
        g.mul(&g)
    };
    let r = d1.t().mul(&d1).minus(&level(d1.hi.ncols(), p.m1()));
    let rt = dd1.mul(&dd1.t()).minus(&level(dd1.hi.nrows(), p.p1()));
    let unrefined = || SynthError::Numerical("the Riccati solutions' refinement failed".into());
    // The equations of `riccati_pair`, refined to double-double.
    let x = care_extended(&b, &c1.t().mul(&c1), &r, &c1.t().mul(&d1), &p.a, &xs.x)
        .ok_or_else(unrefined)?;
    let y = care_extended(
        &c.t(),
        &b1.mul(&b1.t()),
        &rt,
        &b1.mul(&dd1.t()),
        &tr(&p.a),
        &ys.x,
    )
    .ok_or_else(unrefined)?;
    // F = -R^-1 (D1.'C1 + B'X); L = -(B1 D.1' + Y C') R~^-1.
    let f = inverse_or(&r, "R")?
        .mul(&d1.t().mul(&c1).plus(&b.t().mul(&x)))
        .neg();
    let l = b1
        .mul(&dd1.t())
        .plus(&y.mul(&c.t()))
        .mul(&inverse_or(&rt, "R~")?)
        .neg();
    Ok([f, l, x, y])
}

/// `[T^-1 A T, T^-1 B, C T, D]` rounded to double, `T` the real modal basis
/// of `A` rounded ([`modal_basis`]: block-diagonal `T^-1 A T`), computed
/// in double and applied exactly in double-double, three times: each pass
/// leaves the coupling between the modes at the eigenvectors' rounding
/// error, relative to the previous pass's. Modal, not Schur, coordinates:
/// the controller's DC gain is the sum of its modes' residues over their
/// poles, which in a triangular `A` run through couplings of 1e5 between a
/// mode at 1e-3 and one at 1e7 whose rounding alone moves it by 4e-3 of
/// its value. A nearly defective `A` keeps its Schur coordinates.
fn modal_coordinates([mut a, mut b, mut c, d]: [Dd; 4]) -> Result<[Mat<f64>; 4], SynthError> {
    for _ in 0..3 {
        let rounded = a.round();
        let t = match modal_basis(&rounded) {
            Some(t) => t,
            None => {
                fts_kernels::schur::real_schur(&rounded)
                    .map_err(|e| {
                        SynthError::Numerical(format!("Schur form of the controller: {e:?}"))
                    })?
                    .q
            }
        };
        let t = Dd::from(&t);
        let ti = inverse_or(&t, "the modal basis")?;
        a = ti.mul(&a).mul(&t);
        b = ti.mul(&b);
        c = c.mul(&t);
    }
    Ok([a.round(), b.round(), c.round(), d.round()])
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

    /// Two controls and two measurements on an open-loop unstable third
    /// order plant, with process noise on every state, sensor noise, and a
    /// direct term `D11` (so that `R`, `R~` and the feedthrough factors
    /// are not trivial): `z = [x; u] + D11 w`, `y = [x1; x2] + [0 I] w`.
    fn plant_mimo() -> StateSpace {
        let (n, nw, nu, nz, ny) = (3, 5, 2, 5, 2);
        let a = Mat::from_fn(n, n, |i, j| {
            [[0.5, 1.0, 0.0], [0.0, -1.0, 1.0], [1.0, -2.0, -3.0]][i][j]
        });
        let b = Mat::from_fn(n, nw + nu, |i, j| match j {
            j if j < n => f64::from(u8::from(i == j)),
            j if j < nw => 0.0,
            j => f64::from(u8::from(i == j - nw + 1)),
        });
        let c = Mat::from_fn(nz + ny, n, |i, j| match i {
            i if i < n => f64::from(u8::from(i == j)),
            i if i < nz => 0.0,
            i => f64::from(u8::from(i - nz == j)),
        });
        let d = Mat::from_fn(nz + ny, nw + nu, |i, j| match (i, j) {
            (0, 0) => 0.3,
            (1, 3) => -0.2,
            (i, j) if i >= n && i < nz && j >= nw => f64::from(u8::from(i - n == j - nw)),
            (i, j) if i >= nz && j >= n && j < nw => f64::from(u8::from(i - nz == j - n)),
            _ => 0.0,
        });
        StateSpace::new(a, b, c, d, None).unwrap()
    }

    type Form = fn(&Partition, f64, &RiccatiSolution, &RiccatiSolution) -> StateSpace;

    /// `form` and [`explicit`] are one controller: at levels well above
    /// the optimum, where both are well-conditioned, their frequency
    /// responses agree to rounding, on the SISO and the MIMO plant.
    fn agrees_with_the_explicit_form(form: Form) {
        for (plant, io, levels) in [(plant(), 1, [5.0, 20.0]), (plant_mimo(), 2, [10.0, 50.0])] {
            let p = normalise(&Partition::new(&plant, io, io).unwrap())
                .unwrap()
                .p;
            for gamma in levels {
                let pair = riccati_pair(&p, gamma).unwrap();
                assert!(pair.xs.x.norm_l2() > 0.1 && pair.ys.x.norm_l2() > 0.1);
                let k1 = explicit(&p, gamma, &pair.xs, &pair.ys).unwrap();
                let k2 = form(&p, gamma, &pair.xs, &pair.ys);
                for w in [0.0, 0.01, 0.3, 1.0, 7.0, 100.0] {
                    let (a, b) = (k1.freq_response(w).unwrap(), k2.freq_response(w).unwrap());
                    let d = (&a - &b).norm_l2() / a.norm_l2();
                    assert!(
                        d < 1e-10,
                        "{io} x {io}, gamma {gamma}, w {w}: {a:?} vs {b:?}"
                    );
                }
            }
        }
    }

    pub fn descriptor_form_is_the_explicit_controller() {
        agrees_with_the_explicit_form(|p, g, xs, ys| descriptor(p, g, xs, ys).unwrap().unwrap());
    }

    /// The form in double-double, in modal coordinates.
    pub fn extended_form_is_the_explicit_controller() {
        agrees_with_the_explicit_form(|p, g, xs, ys| explicit_extended(p, g, xs, ys).unwrap());
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
