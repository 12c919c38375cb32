//! Balanced truncation of stable systems by the square-root method
//! (Laub, Heath, Paige & Ward 1987; Tombs & Postlethwaite 1987):
//! Gramians `P = Lc Lc'`, `Q = Lo Lo'`, SVD `Lo' Lc = U S W'`, projection
//! `T = Lc W_r S_r^-1/2`, `T^+ = S_r^-1/2 U_r' Lo'`. The a-priori bound is
//! `||G - G_r||_inf <= 2 sum_{i>r} sigma_i` (Glover 1984).

use super::lyapunov::lyap;
use super::ss::{SsError, StateSpace, tr};
use faer::{Mat, Side};

/// A reduced model, the Hankel singular values and the error bound.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// The reduced system.
    pub sys: StateSpace,
    /// Hankel singular values of the original system (descending).
    pub hsv: Vec<f64>,
    /// `2 * sum of the discarded Hankel singular values`.
    pub bound: f64,
}

fn sqrt_factor(p: &Mat<f64>) -> Result<Mat<f64>, SsError> {
    let n = p.nrows();
    let e = p
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| SsError::NoConvergence)?;
    let u = e.U();
    let s = e.S().column_vector();
    Ok(Mat::from_fn(n, n, |i, j| u[(i, j)] * s[j].max(0.0).sqrt()))
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
    let err = |_| SsError::NoConvergence;
    let p = lyap(&sys.a, &(&sys.b * tr(&sys.b))).map_err(err)?.x;
    let q = lyap(&tr(&sys.a), &(tr(&sys.c) * &sys.c)).map_err(err)?.x;
    let lc = sqrt_factor(&p)?;
    let lo = sqrt_factor(&q)?;
    let h = tr(&lo) * &lc;
    let svd = h.svd().map_err(|_| SsError::NoConvergence)?;
    let s: Vec<f64> = (0..n).map(|i| svd.S().column_vector()[i]).collect();
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
    let hsv: Vec<f64> = idx.iter().map(|&i| s[i]).collect();
    let r = order.min(hsv.iter().filter(|&&x| x > 1e-300).count());
    let (u, w) = (svd.U(), svd.V());
    let t = Mat::from_fn(n, r, |i, k| {
        let c = idx[k];
        (0..n).map(|l| lc[(i, l)] * w[(l, c)]).sum::<f64>() / s[c].sqrt()
    });
    let ti = Mat::from_fn(r, n, |k, j| {
        let c = idx[k];
        (0..n).map(|l| u[(l, c)] * lo[(j, l)]).sum::<f64>() / s[c].sqrt()
    });
    let red = StateSpace::new(
        &ti * &sys.a * &t,
        &ti * &sys.b,
        &sys.c * &t,
        sys.d.clone(),
        None,
    )?;
    let bound = 2.0 * hsv[r..].iter().sum::<f64>();
    Ok(Reduced {
        sys: red,
        hsv,
        bound,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lti::norms::hinf_norm;

    #[test]
    fn truncation_error_within_the_bound() {
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
            let e = hinf_norm(&g.parallel(&neg).unwrap(), 1e-8).unwrap().0;
            assert!(
                e <= red.bound * (1.0 + 1e-6) + 1e-12,
                "r={r}: {e} > {}",
                red.bound
            );
            assert!(red.sys.is_stable().unwrap());
        }
    }
}
