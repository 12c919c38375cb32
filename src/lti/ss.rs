//! State-space systems `x' = A x + B u, y = C x + D u` (continuous) or
//! `x[k+1] = A x[k] + B u[k]` (discrete, sample time `ts`), MIMO.
//!
//! Interconnections follow the usual block formulas (e.g. Zhou & Doyle,
//! *Essentials of Robust Control* §3.6); transfer-function realisations are
//! the controllable canonical form (minimal when numerator and denominator
//! are coprime).

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::c64;
use super::tf::ContinuousTf;
use faer::Mat;
use thiserror::Error;

/// Errors from building or combining state-space systems.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SsError {
    /// Matrix dimensions do not fit together.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// A matrix entry is NaN or infinite.
    #[error("matrix {0} has a non-finite entry")]
    NonFinite(&'static str),
    /// The sample time is not a positive finite number.
    #[error("sample time must be a positive finite number of seconds, got {0}")]
    BadSampleTime(f64),
    /// Continuous and discrete (or different sample times) were mixed.
    #[error("cannot combine systems with different sample times ({0:?} and {1:?})")]
    SampleTimeMismatch(Option<f64>, Option<f64>),
    /// The transfer function is improper (numerator degree > denominator degree).
    #[error("improper transfer function has no state-space realisation")]
    Improper,
    /// A feedback interconnection is algebraically ill-posed (`I + D1 D2` singular).
    #[error("feedback loop is not well posed: I + D1*D2 is singular")]
    IllPosed,
    /// An eigenvalue computation failed to converge.
    #[error("eigenvalue iteration did not converge")]
    NoConvergence,
    /// A continuous input delay has no finite realisation.
    #[error("an input delay of {0} s has no finite state-space realisation")]
    Delayed(f64),
    /// A delayed discrete transfer function would need more states than
    /// [`crate::lti::margins::MAX_REALISED_STATES`] (`z^-d` is `d` states).
    #[error(
        "field 'delay': {delay} samples would be realised as {states} states; a discrete transfer function is realised as at most {max} states (docs/formats.md, Bounds)"
    )]
    TooManyStates {
        /// The delay, samples.
        delay: usize,
        /// The states its realisation would need.
        states: usize,
        /// The bound.
        max: usize,
    },
    /// The bilinear (Tustin) map `s = alpha (z - 1)/(z + 1)` sends an
    /// eigenvalue at (or within rounding of) `s = alpha` to `z = infinity`.
    #[error(
        "the Tustin map is undefined: A has an eigenvalue at {eigenvalue} rad/s, where the map \
         s = {alpha:e} (z-1)/(z+1) puts z at infinity (ts = {ts:e} s{prewarp}); choose another \
         sample time{or_prewarp}"
    )]
    TustinPole {
        /// The eigenvalue, as `re+imj`.
        eigenvalue: String,
        /// `2/ts`, or the prewarped `w / tan(w ts / 2)`.
        alpha: f64,
        /// The sample time.
        ts: f64,
        /// `", prewarped at W rad/s"` or empty.
        prewarp: String,
        /// `" or prewarp frequency"` or empty.
        or_prewarp: String,
    },
    /// A prewarp frequency outside `(0, pi/ts)`.
    #[error(
        "prewarp frequency must be in (0, pi/ts) = (0, {nyquist:e}) rad/s (below Nyquist), got {w}"
    )]
    BadPrewarp {
        /// The frequency given, rad/s.
        w: f64,
        /// `pi / ts`, rad/s.
        nyquist: f64,
    },
}

/// A state-space system; `ts = None` for continuous time.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    /// State matrix (n x n).
    pub a: Mat<f64>,
    /// Input matrix (n x m).
    pub b: Mat<f64>,
    /// Output matrix (p x n).
    pub c: Mat<f64>,
    /// Feedthrough (p x m).
    pub d: Mat<f64>,
    /// Sample time in seconds for discrete systems, `None` for continuous ones.
    pub ts: Option<f64>,
}

/// Builds a matrix from row slices (all rows must have length `ncols`).
pub fn mat_from_rows(rows: &[Vec<f64>], ncols: usize) -> Mat<f64> {
    Mat::from_fn(rows.len(), ncols, |i, j| rows[i][j])
}

/// `[A B]`.
pub fn hcat(a: &Mat<f64>, b: &Mat<f64>) -> Mat<f64> {
    debug_assert_eq!(a.nrows(), b.nrows());
    let r = a.nrows();
    Mat::from_fn(r, a.ncols() + b.ncols(), |i, j| {
        if j < a.ncols() {
            a[(i, j)]
        } else {
            b[(i, j - a.ncols())]
        }
    })
}

/// `[A; B]`.
pub fn vcat(a: &Mat<f64>, b: &Mat<f64>) -> Mat<f64> {
    debug_assert_eq!(a.ncols(), b.ncols());
    Mat::from_fn(a.nrows() + b.nrows(), a.ncols(), |i, j| {
        if i < a.nrows() {
            a[(i, j)]
        } else {
            b[(i - a.nrows(), j)]
        }
    })
}

/// `[[A, B], [C, D]]`.
pub fn block2(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>, d: &Mat<f64>) -> Mat<f64> {
    vcat(&hcat(a, b), &hcat(c, d))
}

/// `diag(A, B)`.
pub fn blkdiag(a: &Mat<f64>, b: &Mat<f64>) -> Mat<f64> {
    block2(
        a,
        &Mat::zeros(a.nrows(), b.ncols()),
        &Mat::zeros(b.nrows(), a.ncols()),
        b,
    )
}

/// A sub-block copy `M[r0..r1, c0..c1]`.
pub fn sub(m: &Mat<f64>, r0: usize, r1: usize, c0: usize, c1: usize) -> Mat<f64> {
    Mat::from_fn(r1 - r0, c1 - c0, |i, j| m[(r0 + i, c0 + j)])
}

/// Transpose copy.
pub fn tr(m: &Mat<f64>) -> Mat<f64> {
    m.transpose().to_owned()
}

/// Frobenius norm.
pub fn fro(m: &Mat<f64>) -> f64 {
    m.norm_l2()
}

/// Inverse of a square matrix by partial-pivoting LU; `None` when (numerically) singular.
pub fn inv(m: &Mat<f64>) -> Option<Mat<f64>> {
    let n = m.nrows();
    if n == 0 {
        return Some(Mat::zeros(0, 0));
    }
    let x = fts_kernels::dense::lu_inverse(m.as_ref());
    // Accept when the computed inverse reproduces the identity (a backward
    // check that is insensitive to row/column scaling, unlike a condition
    // number threshold).
    let ok = x.is_all_finite() && {
        let e = m * &x - Mat::<f64>::identity(n, n);
        fro(&e) <= 1e-6 * (n as f64).sqrt()
    };
    ok.then_some(x)
}

/// Solves `M X = B` (square `M`); `None` when singular.
pub fn solve(m: &Mat<f64>, b: &Mat<f64>) -> Option<Mat<f64>> {
    if m.nrows() == 0 {
        return Some(Mat::zeros(0, b.ncols()));
    }
    inv(m)?;
    let x = fts_kernels::dense::lu_solve(m.as_ref(), b.as_ref());
    x.is_all_finite().then_some(x)
}

/// Eigenvalues of a real square matrix (faer's QR algorithm; never nalgebra's).
pub fn eigvals(m: &Mat<f64>) -> Result<Vec<c64>, SsError> {
    if m.nrows() == 0 {
        return Ok(Vec::new());
    }
    if !m.is_all_finite() {
        return Err(SsError::NoConvergence);
    }
    fts_kernels::dense::eigenvalues(m.as_ref()).map_err(|_| SsError::NoConvergence)
}

/// Where the frequency `omega` rad/s lies for a system sampled every `ts`
/// seconds: `s = j omega`, or `z = e^{j omega ts}` when discrete.
pub fn frequency_point(ts: Option<f64>, omega: f64) -> c64 {
    match ts {
        None => c64::new(0.0, omega),
        Some(t) => c64::from_polar(1.0, omega * t),
    }
}

/// Largest singular value of a complex matrix.
pub fn sigma_max_c(m: &Mat<c64>) -> f64 {
    if m.nrows() == 0 || m.ncols() == 0 {
        return 0.0;
    }
    if m.nrows() == 1 || m.ncols() == 1 {
        let mut s = 0.0;
        for j in 0..m.ncols() {
            for i in 0..m.nrows() {
                s += m[(i, j)].norm_sqr();
            }
        }
        return s.sqrt();
    }
    fts_kernels::dense::singular_values_c64(m.as_ref())
        .map(|s| s.into_iter().fold(0.0, f64::max))
        .unwrap_or(f64::NAN)
}

/// Largest singular value of a real matrix.
pub fn sigma_max(m: &Mat<f64>) -> f64 {
    if m.nrows() == 0 || m.ncols() == 0 {
        return 0.0;
    }
    fts_kernels::dense::singular_values(m.as_ref())
        .map(|s| s.into_iter().fold(0.0, f64::max))
        .unwrap_or(f64::NAN)
}

/// Coefficients (descending powers) of `prod (s - r_i)`, real part kept.
/// The diagonal `T` (powers of two) of [`StateSpace::balanced`]: the
/// scaling `x = T z` that balances the off-diagonal row and column norms of
/// `[A B; C 0]` (Parlett & Reinsch 1969; LAPACK `dgebal` without
/// permutations). With empty `B`, `C` it balances the square matrix `A`.
pub fn balancing_scales(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>) -> Vec<f64> {
    let n = a.nrows();
    let mut a = a.clone();
    let (mut b, mut c) = (b.clone(), c.clone());
    let mut t = vec![1.0; n];
    let radix = 2.0f64;
    for _ in 0..100 {
        let mut changed = false;
        for i in 0..n {
            let mut cn = 0.0;
            let mut rn = 0.0;
            for k in 0..n {
                if k != i {
                    cn += a[(k, i)].abs();
                    rn += a[(i, k)].abs();
                }
            }
            for k in 0..c.nrows() {
                cn += c[(k, i)].abs();
            }
            for k in 0..b.ncols() {
                rn += b[(i, k)].abs();
            }
            if cn == 0.0 || rn == 0.0 {
                continue;
            }
            let (c0, r0) = (cn, rn);
            let mut f = 1.0;
            while cn < rn / radix {
                cn *= radix;
                rn /= radix;
                f *= radix;
            }
            while cn >= rn * radix {
                cn /= radix;
                rn *= radix;
                f /= radix;
            }
            if cn + rn < 0.95 * (c0 + r0) {
                changed = true;
                t[i] *= f;
                for k in 0..n {
                    a[(k, i)] *= f;
                    a[(i, k)] /= f;
                }
                for k in 0..c.nrows() {
                    c[(k, i)] *= f;
                }
                for k in 0..b.ncols() {
                    b[(i, k)] /= f;
                }
            }
        }
        if !changed {
            break;
        }
    }
    t
}

pub fn poly_from_roots(roots: &[c64]) -> Vec<f64> {
    let mut p = vec![c64::new(1.0, 0.0)];
    for r in roots {
        let mut q = vec![c64::new(0.0, 0.0); p.len() + 1];
        for (i, c) in p.iter().enumerate() {
            q[i] += c;
            q[i + 1] -= c * r;
        }
        p = q;
    }
    p.into_iter().map(|c| c.re).collect()
}

impl StateSpace {
    /// Checks dimensions and finiteness.
    pub fn new(
        a: Mat<f64>,
        b: Mat<f64>,
        c: Mat<f64>,
        d: Mat<f64>,
        ts: Option<f64>,
    ) -> Result<Self, SsError> {
        let n = a.nrows();
        if a.ncols() != n {
            return Err(SsError::Dimension(format!(
                "A must be square, got {}x{}",
                a.nrows(),
                a.ncols()
            )));
        }
        if b.nrows() != n {
            return Err(SsError::Dimension(format!(
                "B has {} rows, A has {n}",
                b.nrows()
            )));
        }
        if c.ncols() != n {
            return Err(SsError::Dimension(format!(
                "C has {} columns, A has {n}",
                c.ncols()
            )));
        }
        if d.nrows() != c.nrows() || d.ncols() != b.ncols() {
            return Err(SsError::Dimension(format!(
                "D is {}x{}, expected {}x{} (outputs x inputs)",
                d.nrows(),
                d.ncols(),
                c.nrows(),
                b.ncols()
            )));
        }
        for (m, name) in [(&a, "A"), (&b, "B"), (&c, "C"), (&d, "D")] {
            if !m.is_all_finite() {
                return Err(SsError::NonFinite(name));
            }
        }
        if let Some(t) = ts
            && !(t.is_finite() && t > 0.0)
        {
            return Err(SsError::BadSampleTime(t));
        }
        Ok(Self { a, b, c, d, ts })
    }

    /// A static gain `y = D u`.
    pub fn gain(d: Mat<f64>, ts: Option<f64>) -> Self {
        Self {
            a: Mat::zeros(0, 0),
            b: Mat::zeros(0, d.ncols()),
            c: Mat::zeros(d.nrows(), 0),
            d,
            ts,
        }
    }

    /// Number of states.
    pub fn nx(&self) -> usize {
        self.a.nrows()
    }
    /// Number of inputs.
    pub fn nu(&self) -> usize {
        self.b.ncols()
    }
    /// Number of outputs.
    pub fn ny(&self) -> usize {
        self.c.nrows()
    }
    /// Whether the system is discrete.
    pub fn is_discrete(&self) -> bool {
        self.ts.is_some()
    }

    /// Controllable canonical realisation of a proper SISO continuous
    /// transfer function (descending powers of `s`). The realisation has
    /// `deg(den)` states: minimal when numerator and denominator are coprime.
    pub fn from_tf(num: &[f64], den: &[f64], ts: Option<f64>) -> Result<Self, SsError> {
        let strip = |p: &[f64]| -> Vec<f64> {
            let k = p.iter().position(|&x| x != 0.0).unwrap_or(p.len());
            p[k..].to_vec()
        };
        let num = strip(num);
        let den = strip(den);
        if den.is_empty() {
            return Err(SsError::Dimension("zero denominator".into()));
        }
        if num.len() > den.len() {
            return Err(SsError::Improper);
        }
        let n = den.len() - 1;
        let a0 = den[0];
        let den: Vec<f64> = den.iter().map(|x| x / a0).collect();
        let mut numf = vec![0.0; n + 1];
        for (i, x) in num.iter().enumerate() {
            numf[n + 1 - num.len() + i] = x / a0;
        }
        let d = numf[0];
        // Controllable canonical form: states are s^(n-1) .. s^0 of the partial state.
        let a = Mat::from_fn(n, n, |i, j| {
            if i == 0 {
                -den[j + 1]
            } else if j + 1 == i {
                1.0
            } else {
                0.0
            }
        });
        let b = Mat::from_fn(n, 1, |i, _| if i == 0 { 1.0 } else { 0.0 });
        // num - d*den gives the strictly proper remainder.
        let c = Mat::from_fn(1, n, |_, j| numf[j + 1] - d * den[j + 1]);
        let dm = Mat::from_fn(1, 1, |_, _| d);
        Self::new(a, b, c, dm, ts)
    }

    /// Realisation of a continuous fts transfer function; one with an
    /// input delay has none and is refused ([`Self::delay_approximation`]).
    pub fn from_continuous_tf(g: &ContinuousTf) -> Result<Self, SsError> {
        if g.delay() != 0.0 {
            return Err(SsError::Delayed(g.delay()));
        }
        Self::from_tf(g.num(), g.den(), None)
    }

    /// Sections of the delay approximation [`Self::delay_approximation`].
    pub const DELAY_SECTIONS: usize = 10;

    /// `e^{-s tau}` as `[(1 - a s)/(1 + a s)]^m`, `a = tau/(2 m)`, `m =`
    /// [`Self::DELAY_SECTIONS`]: all-pass (exact magnitude), phase error
    /// about `(w tau)^3 / (12 m^2)` rad (0.8 mrad at `w tau = 1`),
    /// each section well conditioned (one pole at `-1/a`), unlike a
    /// high-order Pade polynomial. A section is `-1 + 2/(1 + a s)`:
    /// `A = -1/a, B = 1, C = 2/a, D = -1`.
    pub fn delay_approximation(tau: f64) -> Result<Self, SsError> {
        let mut out = Self::gain(Mat::from_fn(1, 1, |_, _| 1.0), None);
        if tau == 0.0 {
            return Ok(out);
        }
        let a = tau / (2.0 * Self::DELAY_SECTIONS as f64);
        let one = |v: f64| Mat::from_fn(1, 1, |_, _| v);
        let section = Self::new(one(-1.0 / a), one(1.0), one(2.0 / a), one(-1.0), None)?;
        for _ in 0..Self::DELAY_SECTIONS {
            out = out.series(&section)?;
        }
        Ok(out)
    }

    /// SISO transfer function `(num, den)` in descending powers (of `s` or `z`),
    /// from `det(sI - A + B C) = det(sI - A)(1 + C (sI-A)^-1 B)`.
    pub fn to_tf(&self) -> Result<(Vec<f64>, Vec<f64>), SsError> {
        if self.nu() != 1 || self.ny() != 1 {
            return Err(SsError::Dimension(format!(
                "transfer function of a {}x{} system: only SISO is supported",
                self.ny(),
                self.nu()
            )));
        }
        let den = poly_from_roots(&eigvals(&self.a)?);
        let abc = &self.a - &self.b * &self.c;
        let p = poly_from_roots(&eigvals(&abc)?);
        let d = self.d[(0, 0)];
        let num: Vec<f64> = p.iter().zip(&den).map(|(x, y)| x + (d - 1.0) * y).collect();
        Ok((num, den))
    }

    fn check_ts(&self, other: &Self) -> Result<(), SsError> {
        let same = match (self.ts, other.ts) {
            (None, None) => true,
            (Some(a), Some(b)) => (a - b).abs() <= 1e-12 * a.abs().max(b.abs()),
            _ => false,
        };
        if same {
            Ok(())
        } else {
            Err(SsError::SampleTimeMismatch(self.ts, other.ts))
        }
    }

    /// `other * self`: the output of `self` drives `other`.
    pub fn series(&self, other: &Self) -> Result<Self, SsError> {
        self.check_ts(other)?;
        if self.ny() != other.nu() {
            return Err(SsError::Dimension(format!(
                "series: first system has {} outputs, second {} inputs",
                self.ny(),
                other.nu()
            )));
        }
        let a = block2(
            &self.a,
            &Mat::zeros(self.nx(), other.nx()),
            &(&other.b * &self.c),
            &other.a,
        );
        let b = vcat(&self.b, &(&other.b * &self.d));
        let c = hcat(&(&other.d * &self.c), &other.c);
        let d = &other.d * &self.d;
        Self::new(a, b, c, d, self.ts)
    }

    /// `self + other` (same inputs, outputs added).
    pub fn parallel(&self, other: &Self) -> Result<Self, SsError> {
        self.check_ts(other)?;
        if self.nu() != other.nu() || self.ny() != other.ny() {
            return Err(SsError::Dimension(
                "parallel: systems differ in size".into(),
            ));
        }
        Self::new(
            blkdiag(&self.a, &other.a),
            vcat(&self.b, &other.b),
            hcat(&self.c, &other.c),
            &self.d + &other.d,
            self.ts,
        )
    }

    /// Stacks outputs and inputs: `diag(self, other)`.
    pub fn append(&self, other: &Self) -> Result<Self, SsError> {
        self.check_ts(other)?;
        Self::new(
            blkdiag(&self.a, &other.a),
            blkdiag(&self.b, &other.b),
            blkdiag(&self.c, &other.c),
            blkdiag(&self.d, &other.d),
            self.ts,
        )
    }

    /// Negative feedback `y = G (u - H y)`: `G (I + H G)^-1`.
    pub fn feedback(&self, h: &Self) -> Result<Self, SsError> {
        self.check_ts(h)?;
        if h.nu() != self.ny() || h.ny() != self.nu() {
            return Err(SsError::Dimension(
                "feedback: H must map the outputs of G back to its inputs".into(),
            ));
        }
        // u_g = u - H y, y = C1 x1 + D1 u_g, H: x2' = A2 x2 + B2 y, yh = C2 x2 + D2 y.
        // (I + D1 D2) y = C1 x1 - D1 C2 x2 + D1 u.
        let m = Mat::<f64>::identity(self.ny(), self.ny()) + &self.d * &h.d;
        let e = inv(&m).ok_or(SsError::IllPosed)?;
        let cy = hcat(&self.c, &(-(&self.d * &h.c)));
        let cy = &e * &cy; // y = cy x + dy u
        let dy = &e * &self.d;
        // u_g = u - C2 x2 - D2 y
        let cug = &hcat(&Mat::zeros(self.nu(), self.nx()), &(-&h.c)) - &h.d * &cy;
        let dug = Mat::<f64>::identity(self.nu(), self.nu()) - &h.d * &dy;
        let a_top = hcat(&self.a, &Mat::zeros(self.nx(), h.nx()));
        let a_bot = hcat(&Mat::zeros(h.nx(), self.nx()), &h.a);
        let a = &vcat(&a_top, &a_bot) + &vcat(&(&self.b * &cug), &(&h.b * &cy));
        let b = vcat(&(&self.b * &dug), &(&h.b * &dy));
        Self::new(a, b, cy, dy, self.ts)
    }

    /// Lower linear fractional transformation `F_l(P, K)`: the last `K.ny()`
    /// inputs of `P` are driven by `K`, whose inputs are the last `K.nu()`
    /// outputs of `P` (positive feedback, the hinfsyn convention).
    pub fn lft(&self, k: &Self) -> Result<Self, SsError> {
        self.check_ts(k)?;
        let (ncon, nmeas) = (k.ny(), k.nu());
        if ncon > self.nu() || nmeas > self.ny() {
            return Err(SsError::Dimension(
                "lft: controller larger than the plant's control channels".into(),
            ));
        }
        let (n, nk) = (self.nx(), k.nx());
        let m1 = self.nu() - ncon;
        let p1 = self.ny() - nmeas;
        let b1 = sub(&self.b, 0, n, 0, m1);
        let b2 = sub(&self.b, 0, n, m1, self.nu());
        let c1 = sub(&self.c, 0, p1, 0, n);
        let c2 = sub(&self.c, p1, self.ny(), 0, n);
        let d11 = sub(&self.d, 0, p1, 0, m1);
        let d12 = sub(&self.d, 0, p1, m1, self.nu());
        let d21 = sub(&self.d, p1, self.ny(), 0, m1);
        let d22 = sub(&self.d, p1, self.ny(), m1, self.nu());
        // u = Ck xk + Dk y, y = C2 x + D21 w + D22 u  =>  (I - Dk D22) u = Ck xk + Dk C2 x + Dk D21 w
        let m = Mat::<f64>::identity(ncon, ncon) - &k.d * &d22;
        let e = inv(&m).ok_or(SsError::IllPosed)?;
        let cu = &e * &hcat(&(&k.d * &c2), &k.c);
        let du = &e * &(&k.d * &d21);
        // y = C2 x + D21 w + D22 u
        let cy = &hcat(&c2, &Mat::zeros(nmeas, nk)) + &d22 * &cu;
        let dy = &d21 + &d22 * &du;
        let a = &blkdiag(&self.a, &k.a) + &vcat(&(&b2 * &cu), &(&k.b * &cy));
        let b = vcat(&(&b1 + &b2 * &du), &(&k.b * &dy));
        let c = &hcat(&c1, &Mat::zeros(p1, nk)) + &d12 * &cu;
        let d = &d11 + &d12 * &du;
        Self::new(a, b, c, d, self.ts)
    }

    /// Poles (eigenvalues of A, computed on the balanced realisation so
    /// that stiff systems keep their slow poles accurate).
    pub fn poles(&self) -> Result<Vec<c64>, SsError> {
        let s = Self {
            a: self.a.clone(),
            b: Mat::zeros(self.nx(), 0),
            c: Mat::zeros(0, self.nx()),
            d: Mat::zeros(0, 0),
            ts: self.ts,
        };
        eigvals(&s.balanced().a)
    }

    /// Asymptotic stability: all poles in the open left half plane
    /// (continuous) or the open unit disc (discrete), with margin `tol`.
    pub fn is_stable(&self) -> Result<bool, SsError> {
        Ok(self.poles_are_stable(&self.poles()?))
    }

    /// [`is_stable`](Self::is_stable) of poles already computed.
    pub fn poles_are_stable(&self, poles: &[c64]) -> bool {
        match self.ts {
            None => poles.iter().all(|z| z.re < 0.0),
            Some(_) => poles.iter().all(|z| z.norm() < 1.0),
        }
    }

    /// Finite invariant zeros of any system, square or not: the values where
    /// the Rosenbrock matrix `[A - sI, B; C, D]` drops below its normal rank,
    /// by the staircase reduction of SLICOT `AB08ND` (see
    /// [`invariant_zeros`](super::zeros::invariant_zeros), default tolerance).
    pub fn zeros(&self) -> Result<Vec<c64>, SsError> {
        super::zeros::invariant_zeros(self, None).map(|z| z.finite)
    }

    /// Frequency response at the complex point `s` (continuous) or `z` (discrete).
    pub fn eval(&self, s: c64) -> Result<Mat<c64>, SsError> {
        let n = self.nx();
        let d = Mat::from_fn(self.ny(), self.nu(), |i, j| c64::new(self.d[(i, j)], 0.0));
        if n == 0 {
            return Ok(d);
        }
        let m = self.shifted(s);
        let b = Mat::from_fn(n, self.nu(), |i, j| c64::new(self.b[(i, j)], 0.0));
        let x = fts_kernels::dense::lu_solve_c64(m.as_ref(), b.as_ref());
        if !x.is_all_finite() {
            return Err(SsError::IllPosed);
        }
        let c = Mat::from_fn(self.ny(), n, |i, j| c64::new(self.c[(i, j)], 0.0));
        Ok(&c * &x + &d)
    }

    /// `s I - A` in complex arithmetic.
    pub(crate) fn shifted(&self, s: c64) -> Mat<c64> {
        Mat::from_fn(self.nx(), self.nx(), |i, j| {
            let v = c64::new(-self.a[(i, j)], 0.0);
            if i == j { v + s } else { v }
        })
    }

    /// Frequency response at `omega` rad/s (`z = e^{j omega ts}` when discrete).
    pub fn freq_response(&self, omega: f64) -> Result<Mat<c64>, SsError> {
        self.eval(frequency_point(self.ts, omega))
    }

    /// Largest singular value of the frequency response at `omega` rad/s.
    pub fn sigma_at(&self, omega: f64) -> f64 {
        self.freq_response(omega)
            .map(|g| sigma_max_c(&g))
            .unwrap_or(f64::INFINITY)
    }

    /// DC gain (`s = 0` or `z = 1`), real.
    pub fn dc_gain(&self) -> Result<Mat<f64>, SsError> {
        let p = match self.ts {
            None => c64::new(0.0, 0.0),
            Some(_) => c64::new(1.0, 0.0),
        };
        let g = self.eval(p)?;
        Ok(Mat::from_fn(g.nrows(), g.ncols(), |i, j| g[(i, j)].re))
    }

    /// Similarity transform `x = T z`: `(T^-1 A T, T^-1 B, C T, D)`.
    pub fn transform(&self, t: &Mat<f64>) -> Result<Self, SsError> {
        let ti = inv(t).ok_or(SsError::IllPosed)?;
        Self::new(
            &ti * &(&self.a * t),
            &ti * &self.b,
            &self.c * t,
            self.d.clone(),
            self.ts,
        )
    }

    /// Diagonal state scaling `x = T z` (powers of two, so exact) that
    /// balances the row and column norms of `[A B; C 0]` (Parlett & Reinsch
    /// 1969, as in LAPACK `dgebal` and MATLAB `ssbal`). The input-output
    /// behaviour is unchanged; badly scaled plants (e.g. a weight with gain
    /// 1e3 on a plant with gain 1e5) become tractable for the Riccati solvers.
    pub fn balanced(&self) -> Self {
        let t = balancing_scales(&self.a, &self.b, &self.c);
        let mut s = self.clone();
        for (i, &f) in t.iter().enumerate() {
            for k in 0..self.nx() {
                s.a[(k, i)] *= f;
                s.a[(i, k)] /= f;
            }
            for k in 0..s.ny() {
                s.c[(k, i)] *= f;
            }
            for k in 0..s.nu() {
                s.b[(i, k)] /= f;
            }
        }
        s
    }

    /// `(A', C', B', D')`.
    pub fn dual(&self) -> Self {
        Self {
            a: tr(&self.a),
            b: tr(&self.c),
            c: tr(&self.b),
            d: tr(&self.d),
            ts: self.ts,
        }
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn m(rows: &[&[f64]]) -> Mat<f64> {
        Mat::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
    }

    pub fn tf_round_trip() {
        let g = StateSpace::from_tf(&[2.0, 3.0, 1.0], &[1.0, 5.0, 6.0], None).unwrap();
        let (num, den) = g.to_tf().unwrap();
        for (a, b) in num.iter().zip([2.0, 3.0, 1.0]) {
            assert!((a - b).abs() < 1e-12, "{num:?}");
        }
        for (a, b) in den.iter().zip([1.0, 5.0, 6.0]) {
            assert!((a - b).abs() < 1e-12);
        }
        // G(j) = (2 j^2 + 3 j + 1)/(j^2 + 5 j + 6) = (-1 + 3j)/(5 + 5j)
        let r = g.freq_response(1.0).unwrap()[(0, 0)];
        let want = c64::new(-1.0, 3.0) / c64::new(5.0, 5.0);
        assert!((r - want).norm() < 1e-14);
    }

    pub fn feedback_of_integrator() {
        let g = StateSpace::from_tf(&[1.0], &[1.0, 0.0], None).unwrap();
        let one = StateSpace::gain(m(&[&[1.0]]), None);
        let cl = g.feedback(&one).unwrap();
        let p = cl.poles().unwrap();
        assert!((p[0] - c64::new(-1.0, 0.0)).norm() < 1e-14);
        let s = g.series(&g).unwrap();
        assert_eq!(s.nx(), 2);
        let par = g.parallel(&one).unwrap();
        assert!((par.dc_gain().is_err() || par.nx() == 1));
    }

    pub fn lft_matches_feedback() {
        // P = [[G, G]; [-G, -G]] with w = r... use the standard: z = G u, y = -G u; K = k.
        let g = StateSpace::from_tf(&[1.0], &[1.0, 1.0], None).unwrap();
        let p = StateSpace::new(
            g.a.clone(),
            hcat(&g.b, &g.b),
            vcat(&g.c, &(-&g.c)),
            m(&[&[0.0, 0.0], &[0.0, 0.0]]),
            None,
        )
        .unwrap();
        let k = StateSpace::gain(m(&[&[3.0]]), None);
        let cl = p.lft(&k).unwrap();
        // x' = -x + w + u, u = -3 x => pole -4
        assert!((cl.poles().unwrap()[0] - c64::new(-4.0, 0.0)).norm() < 1e-14);
    }

    pub fn zeros_of_siso() {
        let g = StateSpace::from_tf(&[1.0, 2.0], &[1.0, 4.0, 3.0], None).unwrap();
        let z = g.zeros().unwrap();
        assert_eq!(z.len(), 1);
        assert!((z[0] - c64::new(-2.0, 0.0)).norm() < 1e-10);
    }

    pub fn bad_dimensions_are_errors() {
        assert!(matches!(
            StateSpace::new(
                Mat::zeros(2, 3),
                Mat::zeros(2, 1),
                Mat::zeros(1, 2),
                Mat::zeros(1, 1),
                None
            ),
            Err(SsError::Dimension(_))
        ));
        assert!(StateSpace::from_tf(&[1.0, 0.0, 0.0], &[1.0, 1.0], None).is_err());
    }
}
