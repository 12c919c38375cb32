//! Polynomial roots: eigenvalues of the balanced companion matrix (faer),
//! then guarded Newton polishing on the original coefficients.
//!
//! The companion eigenvalues are backward stable (Edelman & Murakami 1995),
//! i.e. exact roots of a polynomial whose coefficients are perturbed by
//! `O(eps * ||p||)`; Newton polishing then removes most of the forward error
//! that balancing and the QR iteration leave on well-conditioned roots.

use crate::lti::c64;
use faer::Mat;

/// Why roots could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RootsError {
    /// A coefficient was NaN or infinite.
    #[error("polynomial coefficient {index} is not finite")]
    NonFinite {
        /// Position of the offending coefficient.
        index: usize,
    },
    /// The eigenvalue iteration did not converge.
    #[error("companion-matrix eigenvalue iteration did not converge")]
    NoConvergence,
}

/// Newton steps tried per root when polishing.
const POLISH_STEPS: usize = 8;

/// Roots of `c0 x^n + c1 x^(n-1) + ... + cn` (descending powers, the MATLAB
/// `roots` convention). Leading zero coefficients are ignored; trailing zero
/// coefficients give roots exactly at 0. Complex roots of a real polynomial
/// come out in exact conjugate pairs.
pub fn roots_descending(coeffs: &[f64]) -> Result<Vec<c64>, RootsError> {
    if let Some(index) = coeffs.iter().position(|c| !c.is_finite()) {
        return Err(RootsError::NonFinite { index });
    }
    let start = coeffs
        .iter()
        .position(|&c| c != 0.0)
        .unwrap_or(coeffs.len());
    let mut p = &coeffs[start..];
    let mut out = Vec::new();
    while p.len() > 1 && p[p.len() - 1] == 0.0 {
        out.push(c64::new(0.0, 0.0));
        p = &p[..p.len() - 1];
    }
    let n = p.len().saturating_sub(1);
    match n {
        0 => return Ok(out),
        1 => {
            out.push(c64::new(-p[1] / p[0], 0.0));
            return Ok(out);
        }
        _ => {}
    }

    // Companion matrix (first-row form) of the monic polynomial.
    let mut m = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        m[(0, j)] = -p[j + 1] / p[0];
    }
    for i in 1..n {
        m[(i, i - 1)] = 1.0;
    }
    balance(&mut m);
    let eig = fts_kernels::dense::eigenvalues(m.as_ref()).map_err(|_| RootsError::NoConvergence)?;
    let mut roots: Vec<c64> = eig.into_iter().map(|z| c64::new(z.re, z.im)).collect();
    for r in &mut roots {
        *r = polish(p, *r);
    }
    make_conjugate_pairs(&mut roots);
    out.extend(roots);
    Ok(out)
}

/// Parlett–Reinsch balancing by powers of two (LAPACK `dgebal`, scaling only):
/// companion matrices of polynomials with widely spread coefficients are badly
/// scaled, and the eigenvalues' accuracy depends on that scaling.
fn balance(m: &mut Mat<f64>) {
    let n = m.nrows();
    let radix = 2.0f64;
    let mut converged = false;
    let mut sweeps = 0;
    while !converged && sweeps < 100 {
        converged = true;
        sweeps += 1;
        for i in 0..n {
            let mut c = 0.0;
            let mut r = 0.0;
            for j in 0..n {
                if j != i {
                    c += m[(j, i)].abs();
                    r += m[(i, j)].abs();
                }
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            let mut cc = c;
            let mut rr = r;
            while cc < rr / radix {
                cc *= radix;
                rr /= radix;
                f *= radix;
            }
            while cc >= rr * radix {
                cc /= radix;
                rr *= radix;
                f /= radix;
            }
            if (cc + rr) < 0.95 * s {
                converged = false;
                for j in 0..n {
                    m[(i, j)] /= f;
                }
                for j in 0..n {
                    m[(j, i)] *= f;
                }
            }
        }
    }
}

/// Value and derivative of a descending-coefficient polynomial at `x`.
fn eval_with_derivative(p: &[f64], x: c64) -> (c64, c64) {
    let mut v = c64::new(0.0, 0.0);
    let mut d = c64::new(0.0, 0.0);
    for &c in p {
        d = d * x + v;
        v = v * x + c;
    }
    (v, d)
}

/// Newton steps accepted only while they reduce `|p(x)|`, so a multiple or
/// ill-conditioned root is never made worse than the eigenvalue solver left it.
fn polish(p: &[f64], mut x: c64) -> c64 {
    let (mut v, mut d) = eval_with_derivative(p, x);
    for _ in 0..POLISH_STEPS {
        if v.norm() == 0.0 || d.norm() == 0.0 {
            break;
        }
        let next = x - v / d;
        let (nv, nd) = eval_with_derivative(p, next);
        if nv.norm().partial_cmp(&v.norm()) != Some(std::cmp::Ordering::Less) {
            break;
        }
        x = next;
        v = nv;
        d = nd;
    }
    x
}

/// Real polynomials have conjugate-symmetric roots; the solver's tiny
/// asymmetries are removed so that products of `(1 - r z^-1)` factors are real.
fn make_conjugate_pairs(roots: &mut [c64]) {
    let scale = roots.iter().fold(1.0f64, |m, r| m.max(r.norm()));
    let tiny = 1e3 * f64::EPSILON * scale;
    let mut used = vec![false; roots.len()];
    for i in 0..roots.len() {
        if used[i] {
            continue;
        }
        used[i] = true;
        if roots[i].im.abs() <= tiny {
            roots[i].im = 0.0;
            continue;
        }
        // The nearest unused root to the conjugate becomes its partner.
        let target = roots[i].conj();
        let partner = (0..roots.len()).filter(|&j| !used[j]).min_by(|&a, &b| {
            (roots[a] - target)
                .norm()
                .total_cmp(&(roots[b] - target).norm())
        });
        if let Some(j) = partner {
            used[j] = true;
            let re = 0.5 * (roots[i].re + roots[j].re);
            let im = 0.5 * (roots[i].im.abs() + roots[j].im.abs());
            let sign = if roots[i].im >= 0.0 { 1.0 } else { -1.0 };
            roots[i] = c64::new(re, sign * im);
            roots[j] = c64::new(re, -sign * im);
        }
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn sorted(mut v: Vec<c64>) -> Vec<c64> {
        v.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        v
    }

    pub fn quadratic_closed_form() {
        // x^2 - 3x + 2 = (x-1)(x-2)
        let r = sorted(roots_descending(&[1.0, -3.0, 2.0]).unwrap());
        assert!((r[0] - c64::new(1.0, 0.0)).norm() < 1e-15);
        assert!((r[1] - c64::new(2.0, 0.0)).norm() < 1e-15);
        // x^2 + 1
        let r = sorted(roots_descending(&[1.0, 0.0, 1.0]).unwrap());
        assert_eq!(r[0], c64::new(0.0, -1.0));
        assert_eq!(r[1], c64::new(0.0, 1.0));
    }

    pub fn zeros_and_degenerate_cases() {
        assert!(roots_descending(&[2.0]).unwrap().is_empty());
        assert!(roots_descending(&[0.0, 0.0, 3.0]).unwrap().is_empty());
        let r = roots_descending(&[1.0, -1.0, 0.0, 0.0]).unwrap();
        assert_eq!(r.len(), 3);
        assert_eq!(r.iter().filter(|z| z.norm() == 0.0).count(), 2);
        assert!(matches!(
            roots_descending(&[1.0, f64::NAN]),
            Err(RootsError::NonFinite { index: 1 })
        ));
    }

    pub fn degree_fifty_roots_of_unity_scaled() {
        // x^50 - 0.5^50: roots 0.5 e^{2 pi j k / 50}, well separated.
        let mut p = vec![0.0; 51];
        p[0] = 1.0;
        p[50] = -(0.5f64.powi(50));
        let r = roots_descending(&p).unwrap();
        assert_eq!(r.len(), 50);
        for z in &r {
            assert!((z.norm() - 0.5).abs() < 1e-12, "{z}");
        }
    }
}
