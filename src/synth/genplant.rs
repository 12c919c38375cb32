//! The generalised plant `P = [A B1 B2; C1 D11 D12; C2 D21 D22]` in the
//! MATLAB / python-control `hinfsyn(P, nmeas, ncon)` convention: the last
//! `nmeas` outputs are measurements `y`, the last `ncon` inputs are controls
//! `u`; the rest are exogenous inputs `w` and performance outputs `z`.
//!
//! Also the preparations the DGKF formulas need (Glover & Doyle 1988;
//! Safonov, Limebeer & Chiang 1989; SLICOT SB10PD): checks of
//! stabilisability/detectability, regularisation of rank-deficient `D12` /
//! `D21`, and the orthogonal/invertible scalings to `D12 = [0; I]`,
//! `D21 = [0 I]`.

// `!(x < y)` is deliberate: it is also true for NaN, which must fail the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::lti::c64;
use crate::lti::ss::{StateSpace, eigvals, fro, hcat, inv, sub, tr, vcat};
use faer::Mat;
use thiserror::Error;

/// Synthesis errors; every variant is a property of the input problem.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SynthError {
    /// Bad partition sizes or plant dimensions.
    #[error("{0}")]
    Dimension(String),
    /// `(A, B2)` is not stabilisable or `(C2, A)` is not detectable.
    #[error("{0}")]
    NotStabilisable(String),
    /// The requested performance level cannot be achieved.
    #[error("{0}")]
    Infeasible(String),
    /// Numerical breakdown.
    #[error("{0}")]
    Numerical(String),
    /// A chosen gamma below the optimum (a fact about a valid request, not a
    /// bad input).
    #[error("{0}")]
    BelowOptimum(String),
}

/// A partitioned generalised plant.
#[derive(Debug, Clone)]
pub struct Partition {
    pub a: Mat<f64>,
    pub b1: Mat<f64>,
    pub b2: Mat<f64>,
    pub c1: Mat<f64>,
    pub c2: Mat<f64>,
    pub d11: Mat<f64>,
    pub d12: Mat<f64>,
    pub d21: Mat<f64>,
    pub d22: Mat<f64>,
}

impl Partition {
    /// Splits `p` with the last `nmeas` outputs and `ncon` inputs as `y`, `u`.
    pub fn new(p: &StateSpace, nmeas: usize, ncon: usize) -> Result<Self, SynthError> {
        let (n, m, q) = (p.nx(), p.nu(), p.ny());
        if ncon == 0 || ncon >= m {
            return Err(SynthError::Dimension(format!(
                "--ncon {ncon} out of range: the plant has {m} inputs; need 1 <= ncon < {m} \
                 (at least one exogenous input must remain)"
            )));
        }
        if nmeas == 0 || nmeas >= q {
            return Err(SynthError::Dimension(format!(
                "--nmeas {nmeas} out of range: the plant has {q} outputs; need 1 <= nmeas < {q} \
                 (at least one performance output must remain)"
            )));
        }
        let (m1, p1) = (m - ncon, q - nmeas);
        Ok(Self {
            a: p.a.clone(),
            b1: sub(&p.b, 0, n, 0, m1),
            b2: sub(&p.b, 0, n, m1, m),
            c1: sub(&p.c, 0, p1, 0, n),
            c2: sub(&p.c, p1, q, 0, n),
            d11: sub(&p.d, 0, p1, 0, m1),
            d12: sub(&p.d, 0, p1, m1, m),
            d21: sub(&p.d, p1, q, 0, m1),
            d22: sub(&p.d, p1, q, m1, m),
        })
    }

    /// The plant as one state-space system `[w; u] -> [z; y]`.
    pub fn to_ss(&self) -> Result<StateSpace, SynthError> {
        StateSpace::new(
            self.a.clone(),
            hcat(&self.b1, &self.b2),
            vcat(&self.c1, &self.c2),
            vcat(&hcat(&self.d11, &self.d12), &hcat(&self.d21, &self.d22)),
            None,
        )
        .map_err(|e| SynthError::Numerical(e.to_string()))
    }

    pub fn n(&self) -> usize {
        self.a.nrows()
    }
    pub fn m1(&self) -> usize {
        self.b1.ncols()
    }
    pub fn m2(&self) -> usize {
        self.b2.ncols()
    }
    pub fn p1(&self) -> usize {
        self.c1.nrows()
    }
    pub fn p2(&self) -> usize {
        self.c2.nrows()
    }

    /// PBH tests: every eigenvalue of `A` with `Re >= 0` must be
    /// controllable from `u` and observable from `y`. A mode counts as
    /// stable (and is not tested) when `Re < -1e-12 ||A||_F`: 1e4 times the
    /// backward error of a simple eigenvalue, while an exact integrator comes
    /// out within about `1e-16 ||A||_F` of the axis. (A coarser margin would
    /// reject well-posed plants with slow stable weights next to fast ones,
    /// e.g. Ding22's `W_e` pole at `-6.9e-4` beside a `W_u` pole at `-1e8`.)
    pub fn check_stabilisable(&self) -> Result<(), SynthError> {
        self.check_stabilisable_in(false)
    }

    /// [`Self::check_stabilisable`] for a continuous (`discrete = false`)
    /// or discrete plant: in discrete time the modes to test are those with
    /// `|z| >= 1` (within the same relative margin), and the messages name `z`.
    pub fn check_stabilisable_in(&self, discrete: bool) -> Result<(), SynthError> {
        let n = self.n();
        let ev = eigvals(&self.a).map_err(|e| SynthError::Numerical(e.to_string()))?;
        let scale = fro(&self.a)
            .max(fro(&self.b2))
            .max(fro(&self.c2))
            .max(1e-300);
        let var = if discrete { "z" } else { "s" };
        for l in ev {
            let margin = if discrete { 1.0 - l.norm() } else { -l.re };
            if margin > 1e-12 * scale.max(1.0) {
                continue;
            }
            let shifted = |i: usize, j: usize| {
                let v = c64::new(self.a[(i, j)], 0.0);
                if i == j { v - l } else { v }
            };
            let mb = Mat::from_fn(n, n + self.m2(), |i, j| {
                if j < n {
                    shifted(i, j)
                } else {
                    c64::new(self.b2[(i, j - n)], 0.0)
                }
            });
            if smin(&mb) <= 1e-10 * scale {
                return Err(SynthError::NotStabilisable(format!(
                    "the plant is not stabilisable: the mode at {var} = {:.6}{:+.6}j is not \
                     reachable from the control inputs (A, B2)",
                    l.re, l.im
                )));
            }
            let mc = Mat::from_fn(n + self.p2(), n, |i, j| {
                if i < n {
                    shifted(i, j)
                } else {
                    c64::new(self.c2[(i - n, j)], 0.0)
                }
            });
            if smin(&mc) <= 1e-10 * scale {
                return Err(SynthError::NotStabilisable(format!(
                    "the plant is not detectable: the mode at {var} = {:.6}{:+.6}j is not seen \
                     by the measurements (C2, A)",
                    l.re, l.im
                )));
            }
        }
        Ok(())
    }

    /// Adds `e12 u` to the performance outputs when `D12` lacks full column
    /// rank and `e21 v` (a fictitious sensor noise) to the measurements when
    /// `D21` lacks full row rank. The weights are `eps`, raised when needed
    /// so that the cheap-control pole they create, about `||C1 B2|| / e12`
    /// (resp. `||C2 B1|| / e21`), stays within 1e3 times the spectral radius
    /// of `A`: a smaller weight changes gamma by less than it costs in
    /// conditioning (Karagoz18 X: `||C1 B2|| = 5.7e7`, radius 1.6e5, weight 0.36).
    /// Returns the weights used (`None`: not needed).
    pub fn regularise(&mut self, eps: f64) -> (Option<f64>, Option<f64>) {
        self.regularise_with(eps, false)
    }

    /// [`Self::regularise`], and with `small_too` also when `D12` / `D21`
    /// have full rank but a smallest singular value below that weight: a
    /// tiny control weight on a high-gain plant (`W2 = 1e-4` on a gain of
    /// 2e4) is a cheap-control problem whose controller pole, about
    /// `||C1 B2|| / sigma_min(D12)`, lies 1e10 times beyond the plant's
    /// modes, where no `f64` realisation keeps the slow closed-loop poles.
    /// The added channel only adds outputs (inputs), so any controller's
    /// closed-loop norm on the original plant is at most its norm on the
    /// regularised one (docs/robust.md, "Conditioning").
    pub fn regularise_with(&mut self, eps: f64, small_too: bool) -> (Option<f64>, Option<f64>) {
        let radius = eigvals(&self.a)
            .map(|ev| ev.iter().fold(0.0f64, |r, l| r.max(l.norm())))
            .unwrap_or(0.0)
            .max(1e-300);
        let floor = |markov: f64| (markov / (1e3 * radius)).max(eps);
        let f12 = floor(fro(&(&self.c1 * &self.b2)));
        let f21 = floor(fro(&(&self.c2 * &self.b1)));
        self.add_channels((f12, f21), small_too)
    }

    /// Regularisation of a discrete-time plant: the weight `eps` itself, only
    /// where `D12` / `D21` lack full rank. (The conditioning floor of
    /// [`Self::regularise`] is about continuous cheap-control poles running
    /// off to infinity; a discrete controller's poles stay in a bounded set.)
    pub fn regularise_discrete(&mut self, eps: f64) -> (Option<f64>, Option<f64>) {
        self.add_channels((eps, eps), false)
    }

    /// Adds the `e12 u` / `e21 v` channels where needed (see [`Self::regularise_with`]).
    fn add_channels(
        &mut self,
        (f12, f21): (f64, f64),
        small_too: bool,
    ) -> (Option<f64>, Option<f64>) {
        let (m2, p2) = (self.m2(), self.p2());
        let tol = 1e-12;
        let needs =
            |d: &Mat<f64>, k: usize, e: f64| rank(d, tol) < k || (small_too && sigma_min(d) < e);
        let r12 = needs(&self.d12, m2, f12).then_some(f12);
        let r21 = needs(&self.d21, p2, f21).then_some(f21);
        self.add_regularisation((r12, r21));
        (r12, r21)
    }

    /// Adds exactly the channels `(e12, e21)` (as returned by
    /// [`Self::regularise_with`]), e.g. to a discrete plant whose bilinear
    /// equivalent was regularised: a static channel maps to itself.
    pub fn add_regularisation(&mut self, (r12, r21): (Option<f64>, Option<f64>)) {
        let (n, m2, p2) = (self.n(), self.m2(), self.p2());
        if let Some(e) = r12 {
            self.c1 = vcat(&self.c1, &Mat::zeros(m2, n));
            self.d11 = vcat(&self.d11, &Mat::zeros(m2, self.m1()));
            self.d12 = vcat(&self.d12, &(Mat::<f64>::identity(m2, m2) * e));
        }
        if let Some(e) = r21 {
            self.b1 = hcat(&self.b1, &Mat::zeros(n, p2));
            self.d11 = hcat(&self.d11, &Mat::zeros(self.p1(), p2));
            self.d21 = hcat(&self.d21, &(Mat::<f64>::identity(p2, p2) * e));
        }
    }
}

/// Smallest singular value (0 for an empty matrix).
fn sigma_min(m: &Mat<f64>) -> f64 {
    if m.nrows() == 0 || m.ncols() == 0 {
        return 0.0;
    }
    fts_kernels::dense::singular_values(m.as_ref())
        .map(|s| s.into_iter().fold(f64::INFINITY, f64::min))
        .unwrap_or(0.0)
}

fn smin(m: &Mat<c64>) -> f64 {
    fts_kernels::dense::singular_values_c64(m.as_ref())
        .map(|s| s.into_iter().fold(f64::INFINITY, f64::min))
        .unwrap_or(0.0)
}

/// Numerical rank (singular values above `tol * max(1, sigma_max)`).
pub fn rank(m: &Mat<f64>, tol: f64) -> usize {
    if m.nrows() == 0 || m.ncols() == 0 {
        return 0;
    }
    let s = fts_kernels::dense::singular_values(m.as_ref()).unwrap_or_default();
    let top = s.iter().cloned().fold(0.0, f64::max);
    s.iter()
        .filter(|&&x| x > tol * top.max(1e-300) && x > 1e-14)
        .count()
}

/// The plant scaled to `D12 = [0; I]`, `D21 = [0 I]` (D22 dropped), with the
/// maps back: the controller of the original plant is `Tu K~ Ty`.
#[derive(Debug, Clone)]
pub struct Normalised {
    pub p: Partition,
    /// `u = Tu u~` (m2 x m2).
    pub tu: Mat<f64>,
    /// `y~ = Ty y` (p2 x p2).
    pub ty: Mat<f64>,
}

/// `(U, singular values, V)`.
type Svd = (Mat<f64>, Vec<f64>, Mat<f64>);

/// Full SVD `M = U S V'` with singular values in descending order.
fn svd_full(m: &Mat<f64>) -> Result<Svd, SynthError> {
    let svd = fts_kernels::dense::svd(m.as_ref())
        .map_err(|_| SynthError::Numerical("SVD did not converge".into()))?;
    let s: Vec<f64> = (0..m.nrows().min(m.ncols()))
        .map(|i| svd.S().column_vector()[i])
        .collect();
    let mut idx: Vec<usize> = (0..s.len()).collect();
    idx.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
    let u0 = svd.U().to_owned();
    let v0 = svd.V().to_owned();
    // Reorder the leading columns by descending singular value.
    let mut u = u0.clone();
    let mut v = v0.clone();
    for (k, &i) in idx.iter().enumerate() {
        for r in 0..u.nrows() {
            u[(r, k)] = u0[(r, i)];
        }
        for r in 0..v.nrows() {
            v[(r, k)] = v0[(r, i)];
        }
    }
    let s = idx.iter().map(|&i| s[i]).collect();
    Ok((u, s, v))
}

/// Scales the (regularised) plant to the DGKF normal form (SLICOT SB10PD).
pub fn normalise(p: &Partition) -> Result<Normalised, SynthError> {
    let (m1, m2, p1, p2) = (p.m1(), p.m2(), p.p1(), p.p2());
    if p1 < m2 || m1 < p2 {
        return Err(SynthError::Dimension(format!(
            "need at least as many performance outputs ({p1}) as controls ({m2}) and as many \
             exogenous inputs ({m1}) as measurements ({p2})"
        )));
    }
    // D12 = U S V', Theta_z = [U2'; U1'] puts the range of D12 last.
    let (u12, s12, v12) = svd_full(&p.d12)?;
    if s12.iter().any(|&s| !(s > 1e-14 * s12[0].max(1e-300))) || s12[0] == 0.0 {
        return Err(SynthError::Numerical("D12 is rank deficient".into()));
    }
    let thz = Mat::from_fn(p1, p1, |i, j| {
        let col = if i < p1 - m2 { m2 + i } else { i - (p1 - m2) };
        u12[(j, col)]
    });
    let tu = Mat::from_fn(m2, m2, |i, j| v12[(i, j)] / s12[j]);
    // D21 = U S V', Theta_w = [V2'; V1'], w = Theta_w' w~.
    let (u21, s21, v21) = svd_full(&p.d21)?;
    if s21.iter().any(|&s| !(s > 1e-14 * s21[0].max(1e-300))) || s21[0] == 0.0 {
        return Err(SynthError::Numerical("D21 is rank deficient".into()));
    }
    let thw = Mat::from_fn(m1, m1, |i, j| {
        let col = if i < m1 - p2 { p2 + i } else { i - (m1 - p2) };
        v21[(j, col)]
    });
    let ty = Mat::from_fn(p2, p2, |i, j| u21[(j, i)] / s21[i]);
    let thw_t = tr(&thw);
    let q = Partition {
        a: p.a.clone(),
        b1: &p.b1 * &thw_t,
        b2: &p.b2 * &tu,
        c1: &thz * &p.c1,
        c2: &ty * &p.c2,
        d11: &thz * &p.d11 * &thw_t,
        d12: &thz * &p.d12 * &tu,
        d21: &ty * &p.d21 * &thw_t,
        d22: Mat::zeros(p2, m2),
    };
    // Clean the structural zeros/identities left by rounding.
    let mut q = q;
    q.d12 = Mat::from_fn(p1, m2, |i, j| {
        if i >= p1 - m2 && i - (p1 - m2) == j {
            1.0
        } else {
            0.0
        }
    });
    q.d21 = Mat::from_fn(p2, m1, |i, j| {
        if j >= m1 - p2 && j - (m1 - p2) == i {
            1.0
        } else {
            0.0
        }
    });
    Ok(Normalised { p: q, tu, ty })
}

/// Undoes the normalisation and the `D22` loop shift:
/// `K = Tu K~ Ty`, then `K (I + D22 K)^-1` (Zhou & Doyle, Essentials §14.7).
pub fn denormalise(
    k: &StateSpace,
    norm: &Normalised,
    d22: &Mat<f64>,
) -> Result<StateSpace, SynthError> {
    let k1 = StateSpace::new(
        k.a.clone(),
        &k.b * &norm.ty,
        &norm.tu * &k.c,
        &norm.tu * &k.d * &norm.ty,
        k.ts,
    )
    .map_err(|e| SynthError::Numerical(e.to_string()))?;
    if fro(d22) == 0.0 {
        return Ok(k1);
    }
    let g = StateSpace::gain(d22.clone(), k.ts);
    k1.feedback(&g).map_err(|_| {
        SynthError::Numerical("the controller's loop with D22 is not well posed".into())
    })
}

/// Symmetric square root factor `M = F F'` for a symmetric positive definite `M`.
pub fn chol_factor(m: &Mat<f64>) -> Option<Mat<f64>> {
    let n = m.nrows();
    let mut l = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        let mut d = m[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if !(d > 0.0) {
            return None;
        }
        let d = d.sqrt();
        l[(j, j)] = d;
        for i in j + 1..n {
            let mut s = m[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / d;
        }
    }
    Some(l)
}

/// `inv` with a synthesis error.
pub fn inv_or(m: &Mat<f64>, what: &str) -> Result<Mat<f64>, SynthError> {
    inv(m).ok_or_else(|| SynthError::Numerical(format!("{what} is singular")))
}
