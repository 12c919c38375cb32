"""Analysis oracle corpus: H2 and H-infinity norms, invariant zeros and
stability of continuous and discrete systems, with independent checks.

Run once from the repository root (numpy, scipy, mpmath, slycot):

    python3 tests/data/analysis/generate.py

writes tests/data/analysis/cases.json. Every family has fixed seeds.

Families (c: continuous, d: discrete with a sample time ts):

* siso_c/d, mimo_c/d: random stable systems, 1..8 states, SISO to 3x3 and
  non-square, D zero or not;
* jordan_c/d: repeated eigenvalues in Jordan blocks of size 2 and 3;
* rankdef_c/d: rank-deficient B, C or D;
* light_c/d: lightly damped poles (damping 1e-3..1e-2; discrete poles at
  radius 1 - 1e-3..1e-2);
* scaled_c/d: a random system under the state scaling diag(10^k), k in
  [-2, 3], with B, C and D scaled too, so entries span 1e-4..1e6;
* unstable_c/d: one pole in the right half plane / outside the unit circle;
* SLICOT's AB13BD and AB13DD example programs' data (SLICOT-Reference
  examples/data/AB13BD.dat, AB13DD.dat; see PROVENANCE.md).

Stability is decided by construction (poles placed with a margin), and
checked against numpy's eigenvalues.

Reference values, for stable systems:

* h2: the Lyapunov equation solved as a Kronecker linear system in 40-digit
  arithmetic (mpmath) -- independent of any float Lyapunov solver.
  slycot AB13BD (h2_ab13bd) and scipy's solve_{continuous,discrete}_lyapunov
  (h2_scipy) are stored beside it; h2_disagree lists the ones more than 1e-9
  away. Continuous with D != 0: infinite (null).
* hinf: sigma_max(G) on a dense frequency grid (log spaced over the poles'
  range, plus the poles' frequencies, DC and Nyquist), the best points and
  AB13DD's peak frequency refined by golden-section search: an attained
  value, so a true lower bound, independent of AB13DD's algorithm.
  hinf_ab13dd is AB13DD's value; hinf_disagree says whether the two differ
  by more than 1e-9 (then the attained value is kept). hinf_omega is the
  frequency of the reference peak in rad/s (null: at infinity).
* zeros: slycot AB08ND with TOL = (n+p)(n+m) eps and no balancing, as
  tests/data/zeros/generate.py.

For the scaled families, h2 and hinf are computed on the unscaled
realisation (a similarity leaves both unchanged), so the reference does not
share the scaling the system under test carries.
"""

import json
import os

import mpmath
import numpy as np
import scipy.linalg
import slycot

EPS = float(np.finfo(float).eps)
HERE = os.path.dirname(os.path.abspath(__file__))
mpmath.mp.dps = 40


# ---------------------------------------------------------------- references


def h2_exact(a, b, c, d, ts):
    """||G||_2 from the Gramian, Kronecker form solved in 40 digits."""
    n = a.shape[0]
    if ts is None and np.any(d != 0):
        return None
    am = mpmath.matrix(a.tolist())
    bb = mpmath.matrix((b @ b.T).tolist())
    eye = mpmath.eye(n)
    # vec(A P A') = (A kron A) vec P; vec(A P + P A') = (I kron A + A kron I) vec P.
    k = mpmath.matrix(n * n, n * n)
    for i in range(n):
        for j in range(n):
            for r in range(n):
                for s in range(n):
                    if ts is None:
                        v = eye[j, s] * am[i, r] + am[j, s] * eye[i, r]
                    else:
                        v = eye[i, r] * eye[j, s] - am[i, r] * am[j, s]
                    k[i * n + j, r * n + s] = v
    rhs = mpmath.matrix(n * n, 1)
    for i in range(n):
        for j in range(n):
            rhs[i * n + j] = -bb[i, j] if ts is None else bb[i, j]
    x = mpmath.lu_solve(k, rhs)
    p = mpmath.matrix(n, n)
    for i in range(n):
        for j in range(n):
            p[i, j] = x[i * n + j]
    cm = mpmath.matrix(c.tolist())
    val = sum((cm * p * cm.T)[i, i] for i in range(c.shape[0]))
    if ts is not None:
        val += sum(mpmath.mpf(float(v)) ** 2 for v in d.ravel())
    return float(mpmath.sqrt(val))


def h2_scipy(a, b, c, d, ts):
    if ts is None:
        if np.any(d != 0):
            return None
        p = scipy.linalg.solve_continuous_lyapunov(a, -b @ b.T)
        return float(np.sqrt(np.trace(c @ p @ c.T)))
    p = scipy.linalg.solve_discrete_lyapunov(a, b @ b.T)
    return float(np.sqrt(np.trace(c @ p @ c.T) + np.trace(d @ d.T)))


def h2_ab13bd(a, b, c, d, ts):
    if ts is None and np.any(d != 0):
        return None
    n, m, p = a.shape[0], b.shape[1], c.shape[0]
    return float(slycot.ab13bd("C" if ts is None else "D", "H", n, m, p,
                               a.copy(), b.copy(), c.copy(), d.copy()))


def sigma(a, b, c, d, w, ts):
    """sigma_max(G) at w rad/s (z = exp(j w ts) when discrete)."""
    n = a.shape[0]
    s = 1j * w if ts is None else np.exp(1j * w * ts)
    g = c @ np.linalg.solve(s * np.eye(n) - a, b) + d
    return float(np.linalg.svd(g, compute_uv=False)[0])


def golden(f, lo, hi, iters=200):
    inv = (np.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - inv * (hi - lo), lo + inv * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(iters):
        if hi - lo <= 1e-15 * max(abs(hi), 1e-300):
            break
        if f1 >= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - inv * (hi - lo)
            f1 = f(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + inv * (hi - lo)
            f2 = f(x2)
    return max([(f1, x1), (f2, x2), (f(lo), lo), (f(hi), hi)])


def hinf_sweep(a, b, c, d, ts, extra=()):
    """Attained peak: dense grid, then golden-section refinement around the
    best grid points and around `extra` frequencies. Returns (value, w)."""
    poles = np.linalg.eigvals(a)
    top = np.inf if ts is None else np.pi / ts
    if ts is None:
        mags = np.abs(poles[np.abs(poles) > 0])
    else:
        nz = poles[np.abs(poles) > 0]
        mags = np.abs(np.log(nz.astype(complex)) / ts)
    lo = max(mags.min() / 1e3, 1e-12) if mags.size else 1e-3
    hi = mags.max() * 1e3 if mags.size else 1e3
    grid = list(np.logspace(np.log10(lo), np.log10(hi), 6000))
    if ts is None:
        grid += list(np.abs(poles.imag)) + list(mags)
    else:
        grid += list(np.abs(np.angle(poles)) / ts)
    grid = sorted(w for w in set(float(w) for w in grid + [0.0]) if w <= top)
    if ts is not None:
        grid.append(top)
    vals = [sigma(a, b, c, d, w, ts) for w in grid]
    best = (max(vals), grid[int(np.argmax(vals))])
    if ts is None:
        dval = float(np.linalg.svd(d, compute_uv=False)[0]) if d.size else 0.0
        if dval > best[0]:
            best = (dval, None)
    f = lambda w: sigma(a, b, c, d, w, ts)
    order = np.argsort(vals)[::-1][:8]
    brackets = [(grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]) for i in order]
    for w in extra:
        if w is not None and np.isfinite(w) and w <= top:
            brackets.append((w * (1 - 1e-3), min(w * (1 + 1e-3), top)))
    for lo_w, hi_w in brackets:
        v, w = golden(f, lo_w, hi_w)
        if v > best[0]:
            best = (v, w)
    return best


def hinf_ab13dd(a, b, c, d, ts):
    n, m, p = a.shape[0], b.shape[1], c.shape[0]
    e = np.eye(n)
    g, fpk = slycot.ab13dd("C" if ts is None else "D", "I", "N", "D", n, m, p,
                           a.copy(), e, b.copy(), c.copy(), d.copy(), tol=1e-12)
    w = None if not np.isfinite(fpk) else (fpk if ts is None else fpk / ts)
    return float(g), w


def ab08nd(a, b, c, d):
    n, m, p = a.shape[0], b.shape[1], c.shape[0]
    s = max(m, p)
    ldwork = 4 * (max(s, n) + max(3 * s - 1, n + s)) + 64
    tol = (n + p) * (n + m) * EPS
    nu, rank, *_rest, af, bf = slycot.ab08nd(n, m, p, a.copy(), b.copy(), c.copy(), d.copy(),
                                             equil="N", tol=tol, ldwork=ldwork)
    z = scipy.linalg.eigvals(af[:nu, :nu], bf[:nu, :nu]) if nu > 0 else np.zeros(0, complex)
    return [float(x) for x in z.real], [float(x) for x in z.imag], int(rank)


# ---------------------------------------------------------------- systems


def block_a(poles, rng, cond=3.0):
    """Real A with the given poles (conjugates paired), T diag T^-1 with a
    random, moderately conditioned T."""
    blocks = []
    for p in poles:
        if abs(p.imag) > 0:
            blocks.append(np.array([[p.real, p.imag], [-p.imag, p.real]]))
        else:
            blocks.append(np.array([[p.real]]))
    j = scipy.linalg.block_diag(*blocks)
    n = j.shape[0]
    q1, _ = np.linalg.qr(rng.standard_normal((n, n)))
    q2, _ = np.linalg.qr(rng.standard_normal((n, n)))
    t = q1 @ np.diag(np.logspace(0, np.log10(cond), n)) @ q2
    return t @ j @ np.linalg.inv(t)


def random_poles(rng, n, discrete, light=None, unstable=False):
    """n poles (complex ones counted twice), stable with a margin."""
    out, k = [], 0
    while k < n:
        pair = n - k >= 2 and rng.random() < 0.5
        if discrete:
            r = rng.uniform(0.05, 0.95) if light is None else 1.0 - light * rng.uniform(1, 10)
            th = rng.uniform(0.05, 3.0) if pair else (0.0 if rng.random() < 0.7 else np.pi)
            p = r * np.exp(1j * th)
        else:
            w = 10 ** rng.uniform(-1, 2)
            zeta = rng.uniform(0.05, 1.0) if light is None else light * rng.uniform(1, 10)
            p = complex(-zeta * w, w * np.sqrt(1 - zeta ** 2)) if pair else complex(-w, 0)
        out.append(p if pair else complex(p.real, 0.0))
        k += 2 if pair else 1
    if unstable:
        i = int(rng.integers(len(out)))
        p = out[i]
        out[i] = (p / abs(p) * rng.uniform(1.02, 1.5)) if discrete else complex(
            abs(p.real) * rng.uniform(0.1, 1.0), p.imag)
    return out


def dims(rng, mimo):
    if not mimo:
        return 1, 1
    return int(rng.integers(1, 4)), int(rng.integers(1, 4))


def make_case(name, family, a, b, c, d, ts, stable, ref=None):
    """Reference values; `ref` = (a, b, c, d) of an equivalent realisation
    for the norms (the unscaled one)."""
    a, b, c, d = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (a, b, c, d))
    rows = lambda x: [[float(v) for v in r] for r in x]
    n, m, p = a.shape[0], b.shape[1], c.shape[0]
    eig = np.linalg.eigvals(a)
    numeric = bool(np.all(eig.real < 0)) if ts is None else bool(np.all(np.abs(eig) < 1))
    assert numeric == stable, (name, eig)
    out = {"name": name, "family": family, "n": n, "m": m, "p": p, "ts": ts,
           "a": rows(a), "b": rows(b), "c": rows(c), "d": rows(d), "stable": stable}
    out["zeros_re"], out["zeros_im"], out["normal_rank"] = ab08nd(a, b, c, d)
    out.update({k: None for k in ("h2", "h2_scipy", "h2_ab13bd", "hinf", "hinf_omega",
                                  "hinf_ab13dd", "hinf_ab13dd_omega")})
    out["h2_disagree"], out["hinf_disagree"] = [], False
    if not stable:
        return out
    ra, rb, rc, rd = ref if ref is not None else (a, b, c, d)
    out["h2"] = h2_exact(ra, rb, rc, rd, ts)
    out["h2_scipy"] = h2_scipy(a, b, c, d, ts)
    out["h2_ab13bd"] = h2_ab13bd(a, b, c, d, ts)
    if out["h2"] is not None:
        for key in ("h2_scipy", "h2_ab13bd"):
            if not abs(out[key] - out["h2"]) <= 1e-9 * out["h2"]:
                out["h2_disagree"].append(key)
    g, w_ab = hinf_ab13dd(a, b, c, d, ts)
    out["hinf_ab13dd"], out["hinf_ab13dd_omega"] = g, w_ab
    val, w = hinf_sweep(ra, rb, rc, rd, ts, extra=(w_ab,))
    out["hinf"], out["hinf_omega"] = val, w
    out["hinf_disagree"] = bool(not abs(g - val) <= 1e-9 * val)
    return out


def random_family(family, k, discrete, mimo, light=None, unstable=False, with_d=None):
    rng = np.random.default_rng(seed_of(family, k))
    n = int(rng.integers(1, 9))
    m, p = dims(rng, mimo)
    ts = [1e-3, 0.1, 1.0][k % 3] if discrete else None
    a = block_a(random_poles(rng, n, discrete, light, unstable), rng)
    b, c = rng.standard_normal((n, m)), rng.standard_normal((p, n))
    has_d = (k % 2 == 1) if with_d is None else with_d
    d = rng.standard_normal((p, m)) if has_d else np.zeros((p, m))
    return make_case(f"{family}_{k}", family, a, b, c, d, ts, not unstable)


FAMILY_SEEDS = {}


def seed_of(family, k):
    base = FAMILY_SEEDS.setdefault(family, 10000 * (len(FAMILY_SEEDS) + 1))
    return base + k


def jordan_family(family, k, discrete):
    rng = np.random.default_rng(seed_of(family, k))
    sizes = [[2], [3], [2, 2], [3, 2], [2, 1], [3, 1, 1]][k % 6]
    blocks = []
    for s in sizes:
        lam = rng.uniform(-0.9, 0.9) if discrete else -10 ** rng.uniform(-1, 1.5)
        blocks.append(lam * np.eye(s) + np.diag(np.ones(s - 1), 1))
    # One block repeated: the same eigenvalue in two Jordan blocks.
    if k % 4 == 3:
        blocks.append(blocks[0].copy())
    j = scipy.linalg.block_diag(*blocks)
    n = j.shape[0]
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    t = q @ np.diag(np.logspace(0, 0.5, n))
    a = t @ j @ np.linalg.inv(t)
    m, p = dims(rng, k % 2 == 1)
    b, c = rng.standard_normal((n, m)), rng.standard_normal((p, n))
    d = rng.standard_normal((p, m)) if k % 3 == 0 else np.zeros((p, m))
    ts = [1e-3, 0.1, 1.0][k % 3] if discrete else None
    return make_case(f"{family}_{k}", family, a, b, c, d, ts, True)


def rankdef_family(family, k, discrete):
    rng = np.random.default_rng(seed_of(family, k))
    n = int(rng.integers(2, 9))
    m, p = int(rng.integers(2, 4)), int(rng.integers(2, 4))
    a = block_a(random_poles(rng, n, discrete), rng)
    b, c = rng.standard_normal((n, m)), rng.standard_normal((p, n))
    d = rng.standard_normal((p, m)) if k % 2 else np.zeros((p, m))
    which = k % 3
    if which == 0:
        b = rng.standard_normal((n, 1)) @ rng.standard_normal((1, m))
    elif which == 1:
        c = rng.standard_normal((p, 1)) @ rng.standard_normal((1, n))
    else:
        d = rng.standard_normal((p, 1)) @ rng.standard_normal((1, m))
    ts = [1e-3, 0.1, 1.0][k % 3] if discrete else None
    return make_case(f"{family}_{k}", family, a, b, c, d, ts, True)


def scaled_family(family, k, discrete):
    rng = np.random.default_rng(seed_of(family, k))
    n = int(rng.integers(2, 9))
    m, p = dims(rng, k % 2 == 1)
    a = block_a(random_poles(rng, n, discrete), rng)
    b, c = rng.standard_normal((n, m)), rng.standard_normal((p, n))
    d = rng.standard_normal((p, m)) if k % 3 else np.zeros((p, m))
    # Input/output scaling changes the system; state scaling does not.
    su, sy = 10 ** rng.uniform(-1, 2, m), 10 ** rng.uniform(-1, 2, p)
    b, c, d = b * su, sy[:, None] * c, sy[:, None] * d * su
    t = 10 ** rng.uniform(-2, 3, n)
    a_s = (a / t[:, None]) * t[None, :]
    b_s, c_s = b / t[:, None], c * t[None, :]
    ts = [1e-3, 0.1, 1.0][k % 3] if discrete else None
    return make_case(f"{family}_{k}", family, a_s, b_s, c_s, d, ts, True, ref=(a, b, c, d))


# ---------------------------------------------------------------- SLICOT examples


def slicot_examples():
    # AB13BD.dat (continuous, JOBN = 'L'): 7 states, 2 inputs, 3 outputs;
    # A, B, C, D read row by row. The system is unstable (poles
    # 0.1605 +- 0.1532j): AB13BD.res gives its L2 norm, 7.93948.
    a = [[-0.04165, 0.0, 4.9200, 0.4920, 0.0, 0.0, 0.0],
         [-5.2100, -12.500, 0.0, 0.0, 0.0, 0.0, 0.0],
         [0.0, 3.3300, -3.3300, 0.0, 0.0, 0.0, 0.0],
         [0.5450, 0.0, 0.0, 0.0, 0.0545, 0.0, 0.0],
         [0.0, 0.0, 0.0, -0.49200, 0.004165, 0.0, 4.9200],
         [0.0, 0.0, 0.0, 0.0, 0.5210, -12.500, 0.0],
         [0.0, 0.0, 0.0, 0.0, 0.0, 3.3300, -3.3300]]
    b = [[0, 0], [12.5, 0], [0, 0], [0, 0], [0, 0], [0, 12.5], [0, 0]]
    c = [[1, 0, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0, 0], [0, 0, 0, 0, 1, 0, 0]]
    d = np.zeros((3, 2))
    ex_bd = make_case("ab13bd_example", "slicot_example", a, b, c, d, None, False)
    ex_bd["l2_ab13bd_res"] = 7.93948
    ex_bd["l2_ab13bd"] = float(slycot.ab13bd("C", "L", 7, 2, 3, np.array(a), np.array(b, float),
                                             np.array(c, float), d.copy()))
    # AB13DD.dat: N = 6, M = 1, P = 1, FPEAK = (0, 1), TOL = 1e-9, DICO = C,
    # JOBE = I, EQUIL = N, JOBD = D. AB13DD.res: norm 0.5000000001D+06 at
    # 0.1414213562D+01 rad/s.
    a = [[0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
         [-0.5, -0.0002, 0.0, 0.0, 0.0, 0.0],
         [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
         [0.0, 0.0, -1.0, -0.00002, 0.0, 0.0],
         [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
         [0.0, 0.0, 0.0, 0.0, -2.0, -0.000002]]
    b = [[1.0], [0.0], [1.0], [0.0], [1.0], [0.0]]
    c = [[1.0, 0.0, 1.0, 0.0, 1.0, 0.0]]
    ex_dd = make_case("ab13dd_example", "slicot_example", a, b, c, [[0.0]], None, True)
    ex_dd["hinf_ab13dd_res"] = 0.5000000001e6
    ex_dd["hinf_omega_ab13dd_res"] = 0.1414213562e1
    return [ex_bd, ex_dd]


def main():
    cases = slicot_examples()
    for k in range(30):
        cases.append(random_family("siso_c", k, False, False))
        cases.append(random_family("siso_d", k, True, False))
    for k in range(40):
        cases.append(random_family("mimo_c", k, False, True))
        cases.append(random_family("mimo_d", k, True, True))
    for k in range(20):
        cases.append(jordan_family("jordan_c", k, False))
        cases.append(jordan_family("jordan_d", k, True))
        cases.append(rankdef_family("rankdef_c", k, False))
        cases.append(rankdef_family("rankdef_d", k, True))
        cases.append(random_family("light_c", k, False, k % 2 == 1, light=1e-3))
        cases.append(random_family("light_d", k, True, k % 2 == 1, light=1e-3))
        cases.append(scaled_family("scaled_c", k, False))
        cases.append(scaled_family("scaled_d", k, True))
    for k in range(15):
        cases.append(random_family("unstable_c", k, False, k % 2 == 1, unstable=True))
        cases.append(random_family("unstable_d", k, True, k % 2 == 1, unstable=True))
    with open(os.path.join(HERE, "cases.json"), "w") as f:
        json.dump({"generator": "tests/data/analysis/generate.py",
                   "slycot": slycot.__version__, "numpy": np.__version__,
                   "scipy": scipy.__version__, "mpmath": mpmath.__version__,
                   "cases": cases}, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print(len(cases), "cases")
    fams = sorted(set(c["family"] for c in cases))
    for fam in fams:
        cs = [c for c in cases if c["family"] == fam]
        h2d = sum(1 for c in cs if c["h2_disagree"])
        hid = [c["name"] for c in cs if c["hinf_disagree"]]
        print(f"{fam:16s} {len(cs):4d} h2 disagreements {h2d}, ab13dd disagreements {len(hid)} {hid[:6]}")
    for c in cases[:2]:
        print(c["name"], c["h2"], c["hinf"], c["hinf_omega"], c["hinf_ab13dd"], c.get("l2_ab13bd"))


if __name__ == "__main__":
    main()
