//! Invariant zeros of any state-space system, square or not, as SLICOT
//! `AB08ND` computes them: the staircase reduction of Emami-Naeini & Van
//! Dooren (1982) ("Computation of zeros of linear multivariable systems",
//! Automatica 18, 415-430) brings the system pencil
//!
//! ```text
//! S(s) = [ A - sI  B ]
//!        [   C     D ]
//! ```
//!
//! to a regular pencil `Af - s Bf` whose generalized eigenvalues are the
//! finite invariant zeros. The infinite zeros and the left and right
//! Kronecker indices (Svaricek 1985) fall out of the rank decisions.
//!
//! Rank decisions use singular value decompositions where `AB08NX` uses
//! QR with column pivoting and incremental condition estimation; a
//! singular value counts when it exceeds `tol * max(||S||_F, sigma_max)`,
//! the test `MB03OY` makes.

use faer::Mat;

use super::c64;
use super::schur::gen_schur;
use super::ss::{SsError, StateSpace};

/// The structure of the system pencil found by [`invariant_zeros`].
#[derive(Debug, Clone, PartialEq)]
pub struct Zeros {
    /// The finite invariant zeros (generalized eigenvalues of the reduced
    /// regular pencil), in no particular order.
    pub finite: Vec<c64>,
    /// The normal rank of the transfer matrix `C (sI - A)^-1 B + D`.
    pub normal_rank: usize,
    /// `infinite_orders[i]` infinite elementary divisors of degree `i + 1`
    /// (`AB08ND`'s `INFZ`).
    pub infinite_orders: Vec<usize>,
    /// The number of infinite zeros, `sum (i + 1) infinite_orders[i]`.
    pub n_infinite: usize,
    /// Right Kronecker (column) indices, ascending.
    pub right_kronecker: Vec<usize>,
    /// Left Kronecker (row) indices, ascending.
    pub left_kronecker: Vec<usize>,
}

/// The compound matrix `[B A; D C]` of `AB08NX`, kept as four blocks:
/// `nu` states, `m` inputs, `mu` outputs.
struct Compound {
    a: Mat<f64>,
    b: Mat<f64>,
    c: Mat<f64>,
    d: Mat<f64>,
}

/// Invariant zeros, normal rank, infinite zeros and Kronecker indices of
/// `sys` (SLICOT `AB08ND` without balancing).
///
/// `tol` is the relative rank tolerance (`AB08ND`'s `TOL`): a singular value
/// counts when above `tol * ||[A B; C D]||_F`. Values below `AB08ND`'s floor
/// `sqrt((n+p)(n+m)) eps` are raised to it; `None` uses `(n+p)(n+m) eps`.
/// Zeros are computed for every shape, including empty systems.
pub fn invariant_zeros(sys: &StateSpace, tol: Option<f64>) -> Result<Zeros, SsError> {
    let (n, m, p) = (sys.nx(), sys.nu(), sys.ny());
    if n == 0 && m.min(p) == 0 {
        return Ok(empty_structure());
    }
    let s = Compound {
        a: sys.a.clone(),
        b: sys.b.clone(),
        c: sys.c.clone(),
        d: sys.d.clone(),
    };
    let toler = tolerance(tol, n + p, n + m);
    let thr = Threshold {
        tol: toler,
        svlmax: compound_norm(&s),
    };
    let mut infz = Vec::new();
    let (mut kronl, mut kronr) = (Vec::new(), Vec::new());
    // Steps (a)-(b) of AB08ND: reduce to D of full row rank = normal rank.
    let s = reduce(s, &thr, &mut infz, &mut kronl)?;
    let normal_rank = s.d.nrows();
    // Steps (c)-(d): pertranspose (the dual system has the same zeros) and
    // reduce again, leaving D square and invertible.
    let s = reduce(transpose(s), &thr, &mut infz, &mut kronr)?;
    let finite = regular_pencil_eigenvalues(&s)?;
    trim(&mut infz);
    let n_infinite = infz.iter().enumerate().map(|(i, k)| (i + 1) * k).sum();
    Ok(Zeros {
        finite,
        normal_rank,
        infinite_orders: infz,
        n_infinite,
        right_kronecker: indices(&kronr),
        left_kronecker: indices(&kronl),
    })
}

/// Relative rank tolerance. `AB08ND` raises any `TOL` below
/// `sqrt((n+p)(n+m)) eps`; its default is that floor. The SVD rank tests
/// here see the rounding of every orthogonal transformation applied so far
/// (about `n` times `eps ||S||` on a decoupled mode after a full staircase),
/// so the default is the square of the floor's size factor, `(n+p)(n+m) eps`.
fn tolerance(tol: Option<f64>, rows: usize, cols: usize) -> f64 {
    let size = (rows * cols) as f64;
    match tol.filter(|t| t.is_finite() && *t > 0.0) {
        Some(t) => t.max(size.sqrt() * f64::EPSILON),
        None => size * f64::EPSILON,
    }
}

fn empty_structure() -> Zeros {
    Zeros {
        finite: Vec::new(),
        normal_rank: 0,
        infinite_orders: Vec::new(),
        n_infinite: 0,
        right_kronecker: Vec::new(),
        left_kronecker: Vec::new(),
    }
}

/// The rank test of `MB03OY`: a singular value counts when it exceeds
/// `tol * max(svlmax, sigma_max)`.
struct Threshold {
    tol: f64,
    svlmax: f64,
}

impl Threshold {
    fn rank(&self, s: &[f64]) -> usize {
        let smax = s.iter().copied().fold(0.0, f64::max);
        let cut = self.tol * self.svlmax.max(smax);
        s.iter().filter(|&&x| x > cut).count()
    }
}

fn compound_norm(s: &Compound) -> f64 {
    [&s.a, &s.b, &s.c, &s.d]
        .iter()
        .map(|m| m.norm_l2().powi(2))
        .sum::<f64>()
        .sqrt()
}

/// `(U, s, V)` of a full SVD `M = U diag(s) V^T`.
type Svd = (Mat<f64>, Vec<f64>, Mat<f64>);

/// Full SVD `M = U diag(s) V^T` with the singular values descending. Empty
/// matrices give identity factors.
fn svd_desc(m: &Mat<f64>) -> Result<Svd, SsError> {
    let (r, c) = (m.nrows(), m.ncols());
    if r == 0 || c == 0 {
        return Ok((Mat::identity(r, r), Vec::new(), Mat::identity(c, c)));
    }
    if !m.is_all_finite() {
        return Err(SsError::NonFinite("system pencil"));
    }
    let svd = fts_kernels::dense::svd(m.as_ref()).map_err(|_| SsError::NoConvergence)?;
    let s: Vec<f64> = (0..r.min(c)).map(|i| svd.S()[i]).collect();
    let mut order: Vec<usize> = (0..s.len()).collect();
    order.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
    let perm = |x: faer::MatRef<'_, f64>| {
        let k = x.ncols();
        // Sorted columns first, the null-space columns (beyond min(r, c)) after.
        let cols: Vec<usize> = order.iter().copied().chain(s.len()..k).collect();
        Mat::from_fn(x.nrows(), k, |i, j| x[(i, cols[j])])
    };
    let sorted = order.iter().map(|&i| s[i]).collect();
    Ok((perm(svd.U()), sorted, perm(svd.V())))
}

/// One call of `AB08NX`: the main reduction loop of Emami-Naeini & Van
/// Dooren (1982, Section 3, Eqs. 3.3-3.7), extracting a system with the
/// same zeros whose `D` has full row rank. Each step row-compresses `D`
/// (rank `sigma`), column-compresses the `tau = mu - sigma` rows of `C`
/// left below the zero rows of `D` (rank `rho`) and deflates `rho` states.
/// `infz` collects the infinite elementary divisors, `kron` the counts of
/// the Kronecker indices of this side.
fn reduce(
    mut s: Compound,
    thr: &Threshold,
    infz: &mut Vec<usize>,
    kron: &mut Vec<usize>,
) -> Result<Compound, SsError> {
    let (mut iz, mut ro) = (0usize, 0usize);
    while s.d.nrows() > 0 {
        let mu = s.d.nrows();
        let sigma = compress_d_rows(&mut s, thr)?;
        let tau = mu - sigma;
        if iz > 0 {
            add_at(infz, iz - 1, ro.saturating_sub(tau));
        }
        if tau == 0 {
            break;
        }
        iz += 1;
        let rho = compress_c2_cols(&mut s, sigma, thr)?;
        add_at(kron, iz - 1, tau - rho);
        deflate(&mut s, sigma, rho);
        ro = rho;
        if rho == 0 {
            break;
        }
    }
    Ok(s)
}

fn add_at(v: &mut Vec<usize>, i: usize, k: usize) {
    if v.len() <= i {
        v.resize(i + 1, 0);
    }
    v[i] += k;
}

/// `[D C] <- U^T [D C]` with `U^T D = [Dr; 0]`, `Dr` of full row rank
/// `sigma` (the rows below are set to zero). Returns `sigma`.
fn compress_d_rows(s: &mut Compound, thr: &Threshold) -> Result<usize, SsError> {
    let (u, sv, _) = svd_desc(&s.d)?;
    let sigma = thr.rank(&sv);
    let ut = u.transpose().to_owned();
    s.d = &ut * &s.d;
    s.c = &ut * &s.c;
    for i in sigma..s.d.nrows() {
        for j in 0..s.d.ncols() {
            s.d[(i, j)] = 0.0;
        }
    }
    Ok(sigma)
}

/// State change `x = V x'` with `C2 V = [0 C22]`, `C2` the rows of `C`
/// below `sigma` and `C22` of full column rank `rho` (Eq. 3.5 of the
/// paper). Returns `rho`.
fn compress_c2_cols(s: &mut Compound, sigma: usize, thr: &Threshold) -> Result<usize, SsError> {
    let nu = s.a.nrows();
    let c2 = s.c.subrows(sigma, s.c.nrows() - sigma).to_owned();
    let (_, sv, v) = svd_desc(&c2)?;
    let rho = thr.rank(&sv);
    // Null-space directions first, the row space of C2 last.
    let t = Mat::from_fn(nu, nu, |i, j| v[(i, (j + rho) % nu.max(1))]);
    let tt = t.transpose().to_owned();
    s.a = &tt * &s.a * &t;
    s.b = &tt * &s.b;
    s.c = &s.c * &t;
    for i in sigma..s.c.nrows() {
        for j in 0..nu - rho {
            s.c[(i, j)] = 0.0;
        }
    }
    Ok(rho)
}

/// Drops the `tau` rows `[0 0 C22]` and the last `rho` states: the new
/// system is `A11`, `B1`, `C = [A21; C11]`, `D = [B2; Dr]` (`AB08NX`'s
/// reduction diagram).
fn deflate(s: &mut Compound, sigma: usize, rho: usize) {
    let nu = s.a.nrows();
    let k = nu - rho;
    let m = s.b.ncols();
    let c = Mat::from_fn(rho + sigma, k, |i, j| {
        if i < rho {
            s.a[(k + i, j)]
        } else {
            s.c[(i - rho, j)]
        }
    });
    let d = Mat::from_fn(rho + sigma, m, |i, j| {
        if i < rho {
            s.b[(k + i, j)]
        } else {
            s.d[(i - rho, j)]
        }
    });
    s.a = s.a.submatrix(0, 0, k, k).to_owned();
    s.b = s.b.subrows(0, k).to_owned();
    s.c = c;
    s.d = d;
}

/// The dual system `(A^T, C^T, B^T, D^T)`: same invariant zeros, left and
/// right structure exchanged.
fn transpose(s: Compound) -> Compound {
    Compound {
        a: s.a.transpose().to_owned(),
        b: s.c.transpose().to_owned(),
        c: s.b.transpose().to_owned(),
        d: s.d.transpose().to_owned(),
    }
}

/// Step (e) of `AB08ND`: with `D` square invertible, an orthogonal column
/// transformation `[D C] W = [Y 0]` leaves `[B A-sI] W = [X, Af - s Bf]`;
/// `W`'s last `nu` columns span the null space of `[D C]`. The finite zeros
/// are the generalized eigenvalues of `(Af, Bf)` (`Bf = I` when `D` is
/// empty).
fn regular_pencil_eigenvalues(s: &Compound) -> Result<Vec<c64>, SsError> {
    let (nu, r) = (s.a.nrows(), s.d.nrows());
    if nu == 0 {
        return Ok(Vec::new());
    }
    let dc = Mat::from_fn(
        r,
        r + nu,
        |i, j| {
            if j < r { s.d[(i, j)] } else { s.c[(i, j - r)] }
        },
    );
    let (_, _, w) = svd_desc(&dc)?;
    let null = w.subcols(r, nu);
    let ba = Mat::from_fn(nu, r + nu, |i, j| {
        if j < r { s.b[(i, j)] } else { s.a[(i, j - r)] }
    });
    let af = &ba * null;
    let bf = null.subrows(r, nu).to_owned();
    generalized_eigenvalues(&af, &bf)
}

/// Finite generalized eigenvalues `alpha / beta` of `(Af, Bf)` by the
/// complex QZ of [`gen_schur`], made conjugate-symmetric as the real pencil's
/// are.
fn generalized_eigenvalues(af: &Mat<f64>, bf: &Mat<f64>) -> Result<Vec<c64>, SsError> {
    if !(af.is_all_finite() && bf.is_all_finite()) {
        return Err(SsError::NonFinite("reduced pencil"));
    }
    let qz = gen_schur(af, bf).map_err(|_| SsError::NoConvergence)?;
    let z = qz
        .pairs()
        .into_iter()
        .map(|(alpha, beta)| alpha / beta)
        .filter(|z| z.re.is_finite() && z.im.is_finite())
        .collect();
    Ok(conjugate_symmetric(z))
}

/// Restores the symmetry of a real pencil's spectrum that complex QZ only
/// keeps to rounding: a value that is its own nearest conjugate is made
/// real; otherwise it and its nearest conjugate partner become an exact
/// pair `m, conj(m)` (their mean).
fn conjugate_symmetric(mut z: Vec<c64>) -> Vec<c64> {
    let mut done = vec![false; z.len()];
    for i in 0..z.len() {
        if done[i] {
            continue;
        }
        done[i] = true;
        let target = z[i].conj();
        let partner = (0..z.len())
            .filter(|&j| !done[j])
            .map(|j| (j, (z[j] - target).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match partner {
            Some((j, d)) if d < (z[i] - target).norm() => {
                let m = (z[i] + z[j].conj()) * 0.5;
                let m = if m.im < 0.0 { m.conj() } else { m };
                (z[i], z[j]) = (m, m.conj());
                done[j] = true;
            }
            _ => z[i].im = 0.0,
        }
    }
    z
}

fn trim(v: &mut Vec<usize>) {
    while v.last() == Some(&0) {
        v.pop();
    }
}

/// `counts[i]` indices of value `i`, listed ascending (`AB08ND`'s final
/// loops over `KRONR`/`KRONL`).
fn indices(counts: &[usize]) -> Vec<usize> {
    counts
        .iter()
        .enumerate()
        .flat_map(|(i, &k)| std::iter::repeat_n(i, k))
        .collect()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    fn sys(n: usize, m: usize, p: usize, f: impl Fn(usize, usize) -> f64) -> StateSpace {
        StateSpace::new(
            Mat::from_fn(n, n, &f),
            Mat::from_fn(n, m, |i, j| f(i + 7, j + 3)),
            Mat::from_fn(p, n, |i, j| f(i + 5, j + 11)),
            Mat::from_fn(p, m, |i, j| f(i + 2, j + 13)),
            None,
        )
        .unwrap()
    }

    pub fn empty_and_zero_systems_do_not_panic() {
        for n in 0..4 {
            for m in 0..3 {
                for p in 0..3 {
                    let z = invariant_zeros(&sys(n, m, p, |_, _| 0.0), None).unwrap();
                    assert_eq!(z.normal_rank, 0);
                    // [-sI 0; 0 0] has rank n everywhere but at s = 0, unless
                    // the zero columns or rows leave it without a rank drop.
                    assert!(z.finite.iter().all(|s| s.norm() == 0.0));
                    let g = invariant_zeros(&sys(n, m, p, |i, j| ((i * 3 + j) % 5) as f64), None);
                    assert!(g.is_ok(), "{n} {m} {p}");
                }
            }
        }
    }

    pub fn static_gain_has_no_finite_zeros() {
        let g = sys(0, 2, 3, |i, j| (i + 2 * j) as f64);
        let z = invariant_zeros(&g, None).unwrap();
        assert!(z.finite.is_empty());
        assert_eq!(z.normal_rank, 2);
    }

    pub fn siso_zero_and_relative_degree() {
        // (s + 2) / (s^2 + 4 s + 3): one zero at -2, one infinite zero.
        let g = StateSpace::from_tf(&[1.0, 2.0], &[1.0, 4.0, 3.0], None).unwrap();
        let z = invariant_zeros(&g, None).unwrap();
        assert_eq!(z.finite.len(), 1);
        assert!((z.finite[0] - c64::new(-2.0, 0.0)).norm() < 1e-12);
        assert_eq!((z.normal_rank, z.n_infinite), (1, 1));
    }

    pub fn input_free_system_has_its_unobservable_modes_as_zeros() {
        // A = diag(-1, -2), C = [1 0]: the mode -2 is unobservable.
        let g = StateSpace::new(
            Mat::from_fn(2, 2, |i, j| if i == j { -1.0 - i as f64 } else { 0.0 }),
            Mat::zeros(2, 0),
            Mat::from_fn(1, 2, |_, j| if j == 0 { 1.0 } else { 0.0 }),
            Mat::zeros(1, 0),
            None,
        )
        .unwrap();
        let z = invariant_zeros(&g, None).unwrap();
        assert_eq!(z.finite.len(), 1);
        assert!((z.finite[0] - c64::new(-2.0, 0.0)).norm() < 1e-12);
    }

    pub fn spectra_are_made_conjugate_symmetric() {
        let z = conjugate_symmetric(vec![
            c64::new(-1.0, 2.0 + 1e-15),
            c64::new(3.0, 1e-17),
            c64::new(-1.0 + 1e-15, -2.0),
        ]);
        assert_eq!(z[0], z[2].conj());
        assert!(z[0].im > 0.0 && (z[0] - c64::new(-1.0, 2.0)).norm() < 1e-14);
        assert_eq!(z[1], c64::new(3.0, 0.0));
    }

    pub fn tolerance_is_floored_like_ab08nd() {
        let floor = 12f64.sqrt() * f64::EPSILON;
        assert_eq!(tolerance(Some(0.0), 3, 4), 12.0 * f64::EPSILON);
        assert_eq!(tolerance(Some(1e-30), 3, 4), floor);
        assert_eq!(tolerance(Some(1e-6), 3, 4), 1e-6);
        assert_eq!(tolerance(Some(f64::NAN), 3, 4), 12.0 * f64::EPSILON);
    }
}
