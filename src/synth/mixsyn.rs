//! Mixed-sensitivity H-infinity design: the augmented plant in the
//! python-control `augw(G, W1, W2, W3)` convention and `mixsyn`.
//!
//! Inputs `[w; u]`, outputs `[z1; z2; z3; v]` with `v = w - G u`,
//! `z1 = W1 v`, `z2 = W2 u`, `z3 = W3 G u`; with `u = K v` the closed loop
//! is `[W1 S; W2 K S; W3 T]` (S = (I + GK)^-1, T = GK S). Absent weights
//! drop their rows.

use super::genplant::SynthError;
use super::hinf::{HinfOptions, HinfResult, hinfsyn};
use crate::lti::ss::{StateSpace, block2, hcat, vcat};
use faer::Mat;

/// Appends the states of a weight: `x' = Aw x + coupling x_old + bw_in [w; u]`.
fn add_state_block(
    a: &mut Mat<f64>,
    b: &mut Mat<f64>,
    rows: &mut [(Mat<f64>, Mat<f64>)],
    aw: &Mat<f64>,
    coupling: Mat<f64>,
    bw_in: Mat<f64>,
) {
    let n_old = a.nrows();
    *a = block2(a, &z(n_old, aw.nrows()), &coupling, aw);
    *b = vcat(b, &bw_in);
    for (c, _) in rows.iter_mut() {
        *c = hcat(c, &z(c.nrows(), aw.nrows()));
    }
}

fn z(r: usize, c: usize) -> Mat<f64> {
    Mat::zeros(r, c)
}

/// The augmented plant; `W1`, `W3` must be `ny x ny`, `W2` `nu x nu`.
pub fn augw(
    g: &StateSpace,
    w1: Option<&StateSpace>,
    w2: Option<&StateSpace>,
    w3: Option<&StateSpace>,
) -> Result<StateSpace, SynthError> {
    if g.is_discrete() {
        return Err(SynthError::Dimension(
            "augw: the plant must be continuous".into(),
        ));
    }
    if w1.is_none() && w2.is_none() && w3.is_none() {
        return Err(SynthError::Dimension(
            "augw: give at least one weight".into(),
        ));
    }
    let (ny, nu, ng) = (g.ny(), g.nu(), g.nx());
    for (w, k, name) in [
        (w1, ny, "W1 (ws)"),
        (w2, nu, "W2 (wu)"),
        (w3, ny, "W3 (wt)"),
    ] {
        if let Some(w) = w {
            if w.nu() != k || w.ny() != k {
                return Err(SynthError::Dimension(format!(
                    "{name} must be {k}x{k} to match the plant, got {}x{}",
                    w.ny(),
                    w.nu()
                )));
            }
            if w.is_discrete() {
                return Err(SynthError::Dimension(format!("{name} must be continuous")));
            }
        }
    }
    // Start with the plant states and the v = w - G u row.
    let mut a = g.a.clone();
    let mut b = hcat(&z(ng, ny), &g.b);
    // Output rows are assembled as (C over all states, D over [w u]).
    let mut rows: Vec<(Mat<f64>, Mat<f64>)> = Vec::new();
    // v = w - Cg xg - Dg u
    let v_c = -&g.c;
    let v_d = hcat(&Mat::<f64>::identity(ny, ny), &(-&g.d));
    if let Some(w) = w1 {
        let n_old = a.nrows();
        let coupling = hcat(&(&w.b * &v_c), &z(w.nx(), n_old - ng));
        add_state_block(&mut a, &mut b, &mut rows, &w.a, coupling, &w.b * &v_d);
        let n_new = a.nrows();
        let c = hcat(&hcat(&(&w.d * &v_c), &z(ny, n_old - ng)), &w.c);
        debug_assert_eq!(c.ncols(), n_new);
        rows.push((c, &w.d * &v_d));
    }
    if let Some(w) = w2 {
        let n_old = a.nrows();
        let sel_u = hcat(&z(nu, ny), &Mat::<f64>::identity(nu, nu));
        add_state_block(
            &mut a,
            &mut b,
            &mut rows,
            &w.a,
            z(w.nx(), n_old),
            &w.b * &sel_u,
        );
        let c = hcat(&z(nu, n_old), &w.c);
        rows.push((c, &w.d * &sel_u));
    }
    if let Some(w) = w3 {
        let n_old = a.nrows();
        // G u output: yg = Cg xg + Dg u
        let yg_d = hcat(&z(ny, ny), &g.d);
        let coupling = hcat(&(&w.b * &g.c), &z(w.nx(), n_old - ng));
        add_state_block(&mut a, &mut b, &mut rows, &w.a, coupling, &w.b * &yg_d);
        let c = hcat(&hcat(&(&w.d * &g.c), &z(ny, n_old - ng)), &w.c);
        rows.push((c, &w.d * &yg_d));
    }
    let n = a.nrows();
    let vc = hcat(&v_c, &z(ny, n - ng));
    rows.push((vc, v_d));
    let mut c = z(0, n);
    let mut d = z(0, ny + nu);
    for (rc, rd) in rows {
        c = vcat(&c, &rc);
        d = vcat(&d, &rd);
    }
    StateSpace::new(a, b, c, d, None).map_err(|e| SynthError::Dimension(e.to_string()))
}

/// `mixsyn(G, W1, W2, W3)`: H-infinity synthesis on [`augw`].
pub fn mixsyn(
    g: &StateSpace,
    w1: Option<&StateSpace>,
    w2: Option<&StateSpace>,
    w3: Option<&StateSpace>,
    opts: HinfOptions,
) -> Result<(StateSpace, HinfResult), SynthError> {
    let p = augw(g, w1, w2, w3)?;
    let r = hinfsyn(&p, g.ny(), g.nu(), opts)?;
    Ok((p, r))
}
