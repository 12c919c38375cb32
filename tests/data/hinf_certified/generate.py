"""A certified H-infinity synthesis test family (issue #29): mixed-sensitivity
problems with near-integrating performance weights and cheap-control weights,
each with its optimum gamma bracketed at 40 digits and a controller whose
closed-loop norm is verified at 40 digits. Read by tests/suite/hinf_certified.rs.

    python3 tests/data/hinf_certified/generate.py   # writes cases.json beside it
    (numpy, scipy, mpmath 1.3, python-control 0.10.2, slycot; about 20 min
    on a loaded two-core machine: SB10AD for every problem first, then the
    certificates on JOBS=2 processes, 15-35 s each; resumable through
    cases.partial.json; `generate.py "<name>"` certifies one problem)

The problems (z = [W_s e; W_u u], y = e = w - G u, one w, one u, one y):
* A (13): the DC servo G = 11.2/((s + 0.12)(s + 1e-6)), W_s = (s/1.5 + 20)/(s + p),
  W_u = 1, p/20 in {1e-9, 3e-9, 1e-8, ..., 3e-4, 1e-3} (20 rad/s is the
  bandwidth of W_s): a near-integrating performance weight.
* B (14): cheap control, W_u in {1e-6, 1e-5, ..., 1e-1, 1} on (i) the DC servo
  with p = 2e-4 and (ii) [Karagoz18]'s Y axis
  G = (548000 s + 13670)/(s^3 + 1.644 s^2 + 8.198 s + 0.06571) with
  W_s = (s/2 + 1000)/(s + 1e-3) (bandwidth 1000 rad/s, so that W_u = 1 costs
  something: gamma 1.71; with 100 rad/s every W_u gives nearly the D11 bound 0.5).
  (B "dc-servo wu=1" is A "p/wb=1e-05" again, as are their C versions.)
* C (14): discrete versions of six A and eight B problems: the zero-order hold
  of the continuous augmented plant (exp of the block matrix [A B; 0 0] Ts in
  mpmath, rounded to double), Ts = 1e-3 s for the DC servo (closed-loop
  bandwidth about 20 rad/s) and 1e-4 s for the Karagoz axis (about 1000 rad/s).

The augmented plant of a continuous problem is built as fts's `augw` builds it
(the controllable canonical realisations of `StateSpace::from_tf`, states
[G; W_s]), so `mixsyn` from the stored weights solves the same doubles. The
stored doubles (A, B, C, D, ts) *are* the certified problem.

Certificate, all in mpmath at 40 digits (a discrete problem is first mapped to
continuous time by the bilinear transform s = (2/Ts)(z - 1)/(z + 1), which
preserves the H-infinity norm of every closed loop and hence the optimum):
* gamma is feasible iff (Zhou, Doyle & Glover, Robust and Optimal Control,
  Thm 17.1, general D11, after the norm-preserving scaling to D12 = [0; I],
  D21 = I): gamma > sigma_max([D1111 D1112]) (here m1 = p2, so D1111 is
  empty and the second D11 condition is void); the Hamiltonians
  H = [A 0; -C1'C1 -A'] - [B; -C1'D1.] R^-1 [D1.'C1 B'],
  J = [A' 0; -B1B1' -A] - [C'; -B1D.1'] Rt^-1 [D.1B1' C]
  (R = D1.'D1. - diag(g^2 I, 0), Rt = D.1D.1' - diag(g^2 I, 0)) have no
  eigenvalue within 1e-30 ||H|| of the imaginary axis, their stable invariant
  subspaces (from mpmath's eig) give X = X2 X1^-1 and Y with X1, Y1
  invertible, X >= 0, Y >= 0 (smallest eigenvalue above -1e-25 max(1, ||X||)),
  and rho(XY) < g^2;
* bisection (seeded by SB10AD's gamma, the seed verified) to a bracket
  [g_lo, g_hi], g_hi/g_lo - 1 <= 1e-7, the conditions failing at g_lo and
  holding at g_hi; then they are checked to fail at g_hi (1 - 1e-4) and to
  hold at g_hi (1 + 1e-4) (`check_minus`, `check_plus`, with the condition
  that fails);
* the central controller of Thm 17.1 (D22 by the loop shift) at
  controller_level = g_hi (1 + 5e-5), built at 40 digits; its closed loop with
  the plant (an LFT of the unscaled plant) is checked stable (eigenvalues),
  its Hamiltonian at controller_level has no imaginary-axis eigenvalue (so the
  norm is below the level), and its norm (controller_norm) is found to 1e-9 by
  Bruinsma-Steinbuch iterations on the same Hamiltonian test, each lower
  value a sigma_max(T(jw)) evaluated at 40 digits.
SLICOT SB10AD's gamma (python-control's hinfsyn, in a child process with a
60 s timeout; on the bilinear continuous equivalent for a discrete problem;
null if refused) is stored as a peer's figure, not as truth.
"""
import json
import multiprocessing as mproc
import os
import sys
import time
import warnings

import mpmath
import numpy as np
from mpmath import mp

mp.dps = 40
warnings.simplefilter("ignore")

DC_NUM, DC_DEN = [11.2], [1.0, 0.12 + 1e-6, 0.12e-6]
KY_NUM, KY_DEN = [548000.0, 13670.0], [1.0, 1.644, 8.198, 0.06571]
KY_WS = ([0.5, 1000.0], [1.0, 1e-3])
A_RATIOS = [1e-9, 3e-9, 1e-8, 3e-8, 1e-7, 3e-7, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3]
WUS = [1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0]
C_A_RATIOS = [1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-3]
C_WUS = [1e-6, 1e-4, 1e-2, 1.0]
TS_DC, TS_KY = 1e-3, 1e-4
BRACKET_RTOL = 1e-7
TIMEOUT_S = 60


def dc_ws(p):
    return [1.0 / 1.5, 20.0], [1.0, p]


def problems():
    """(name, kind, g, ws, wu, ts) for every problem."""
    out = []
    for r in A_RATIOS:
        out.append((f"A dc-servo p/wb={r:g}", "A", (DC_NUM, DC_DEN), dc_ws(20.0 * r), 1.0, None))
    for wu in WUS:
        out.append((f"B dc-servo wu={wu:g}", "B", (DC_NUM, DC_DEN), dc_ws(2e-4), wu, None))
    for wu in WUS:
        out.append((f"B karagoz-y wu={wu:g}", "B", (KY_NUM, KY_DEN), KY_WS, wu, None))
    for r in C_A_RATIOS:
        out.append((f"C dc-servo p/wb={r:g} ts=1e-3", "C", (DC_NUM, DC_DEN), dc_ws(20.0 * r), 1.0, TS_DC))
    for wu in C_WUS:
        out.append((f"C dc-servo wu={wu:g} ts=1e-3", "C", (DC_NUM, DC_DEN), dc_ws(2e-4), wu, TS_DC))
    for wu in C_WUS:
        out.append((f"C karagoz-y wu={wu:g} ts=1e-4", "C", (KY_NUM, KY_DEN), KY_WS, wu, TS_KY))
    return out


# ---------------------------------------------------------------- the plant (doubles)

def from_tf(num, den):
    """fts's StateSpace::from_tf, operation for operation (controllable
    canonical form, states s^(n-1) .. s^0)."""
    n = len(den) - 1
    a0 = den[0]
    den = [x / a0 for x in den]
    numf = [0.0] * (n + 1)
    for i, x in enumerate(num):
        numf[n + 1 - len(num) + i] = x / a0
    d = numf[0]
    a = np.zeros((n, n))
    a[0, :] = [-x for x in den[1:]]
    for i in range(1, n):
        a[i, i - 1] = 1.0
    b = np.zeros((n, 1))
    b[0, 0] = 1.0
    c = np.array([[numf[j + 1] - d * den[j + 1] for j in range(n)]])
    return a, b, c, np.array([[d]])


def augw(g, ws, wu):
    """fts's augw(G, W_s, W_u, None): states [G; W_s], inputs [w; u],
    outputs [W_s v; W_u u; v], v = w - G u."""
    ag, bg, cg, dg = from_tf(*g)
    aw, bw, cw, dw = from_tf(*ws)
    ng, nw = ag.shape[0], aw.shape[0]
    vc, vd = -cg, np.hstack([np.eye(1), -dg])
    a = np.block([[ag, np.zeros((ng, nw))], [bw @ vc, aw]])
    b = np.vstack([np.hstack([np.zeros((ng, 1)), bg]), bw @ vd])
    c = np.vstack([np.hstack([dw @ vc, cw]), np.zeros((1, ng + nw)),
                   np.hstack([vc, np.zeros((1, nw))])])
    d = np.vstack([dw @ vd, wu * np.array([[0.0, 1.0]]), vd])
    return a, b, c, d


def zoh(a, b, ts):
    """Zero-order hold of (A, B) at 40 digits, rounded to double."""
    n, m = b.shape
    blk = mp.zeros(n + m, n + m)
    for i in range(n):
        for j in range(n):
            blk[i, j] = mp.mpf(a[i, j]) * mp.mpf(ts)
        for j in range(m):
            blk[i, n + j] = mp.mpf(b[i, j]) * mp.mpf(ts)
    e = mp.expm(blk)
    ad = np.array([[float(e[i, j]) for j in range(n)] for i in range(n)])
    bd = np.array([[float(e[i, n + j]) for j in range(m)] for i in range(n)])
    return ad, bd


# ---------------------------------------------------------------- mpmath helpers

def M(x):
    x = np.asarray(x, float)
    return mp.matrix([[mp.mpf(float(v)) for v in row] for row in x])


def sub(m, r0, r1, c0, c1):
    out = mp.zeros(r1 - r0, c1 - c0)
    for i in range(r0, r1):
        for j in range(c0, c1):
            out[i - r0, j - c0] = m[i, j]
    return out


def block(rows):
    nr = sum(r[0].rows for r in rows)
    nc = sum(b.cols for b in rows[0])
    out = mp.zeros(nr, nc)
    i0 = 0
    for r in rows:
        j0 = 0
        for b in r:
            for i in range(b.rows):
                for j in range(b.cols):
                    out[i0 + i, j0 + j] = b[i, j]
            j0 += b.cols
        i0 += r[0].rows
    return out


def fro(m):
    return mp.mnorm(m, "f")


def eye(n):
    return mp.eye(n)


def sym_min_eig(x):
    e, _ = mp.eigsy((x + x.T) / 2)
    return min(e)


def real(m):
    out = mp.zeros(m.rows, m.cols)
    for i in range(m.rows):
        for j in range(m.cols):
            out[i, j] = mp.re(m[i, j])
    return out


def max_imag(m):
    return max(abs(mp.im(m[i, j])) for i in range(m.rows) for j in range(m.cols))


# ---------------------------------------------------------------- the problem at 40 digits

class Plant:
    """The continuous problem (discrete ones through the bilinear map),
    partitioned (m1 = 1 w, m2 = 1 u, p1 z, p2 = 1 y)."""

    def __init__(self, a, b, c, d, ts, m2=1, p2=1):
        a, b, c, d = M(a), M(b), M(c), M(d)
        if ts is not None:
            a, b, c, d = bilinear_to_continuous(a, b, c, d, mp.mpf(2) / mp.mpf(ts))
        self.a, self.b, self.c, self.d = a, b, c, d
        n, m, p = a.rows, b.cols, c.rows
        self.n, self.m1, self.m2, self.p1, self.p2 = n, m - m2, m2, p - p2, p2
        assert self.m1 == self.p2, "the central controller below assumes m1 = p2"
        self.b1, self.b2 = sub(b, 0, n, 0, self.m1), sub(b, 0, n, self.m1, m)
        self.c1, self.c2 = sub(c, 0, self.p1, 0, n), sub(c, self.p1, p, 0, n)
        self.d11 = sub(d, 0, self.p1, 0, self.m1)
        self.d12 = sub(d, 0, self.p1, self.m1, m)
        self.d21 = sub(d, self.p1, p, 0, self.m1)
        self.d22 = sub(d, self.p1, p, self.m1, m)
        self.normalise()

    def normalise(self):
        """Theta D12 Su = [0; I] (Theta orthogonal), Sy D21 = I."""
        q, r = mp.qr(self.d12, mode="full")
        m2, p1 = self.m2, self.p1
        theta = block([[sub(q, 0, p1, m2, p1).T], [sub(q, 0, p1, 0, m2).T]])
        self.su = sub(r, 0, m2, 0, m2) ** -1
        self.sy = self.d21 ** -1
        self.nb1 = self.b1
        self.nb2 = self.b2 * self.su
        self.nc1 = theta * self.c1
        self.nc2 = self.sy * self.c2
        self.nd11 = theta * self.d11
        self.nd12 = theta * self.d12 * self.su
        self.nd21 = self.sy * self.d21
        self.nd22 = self.sy * self.d22 * self.su
        self.d11_bound = max(mp.svd_r(sub(self.nd11, 0, p1 - m2, 0, self.m1), compute_uv=False))


def bilinear_to_continuous(a, b, c, d, alpha):
    """s = alpha (z - 1)/(z + 1): Ac = alpha M (Ad - I), Bc = sqrt(2 alpha) M Bd,
    Cc = sqrt(2 alpha) Cd M, Dc = Dd - Cd M Bd, M = (I + Ad)^-1."""
    n = a.rows
    m = (eye(n) + a) ** -1
    k = mp.sqrt(2 * alpha)
    return alpha * m * (a - eye(n)), k * m * b, k * c * m, d - c * m * b


def ric(h, n):
    """Stabilising solution of the Riccati equation of Hamiltonian h, or the
    reason there is none."""
    e, v = mp.eig(h)
    tol = mp.mpf(10) ** -30 * fro(h)
    axis = min(abs(mp.re(x)) for x in e)
    if axis <= tol:
        return None, f"imaginary-axis eigenvalue (|Re| {mp.nstr(axis, 3)})", axis
    idx = [i for i, x in enumerate(e) if mp.re(x) < 0]
    if len(idx) != n:
        return None, "stable subspace dimension", axis
    x1, x2 = mp.zeros(n, n), mp.zeros(n, n)
    for k, i in enumerate(idx):
        col = [v[r, i] for r in range(2 * n)]
        s = mp.sqrt(sum(abs(z) ** 2 for z in col))
        for r in range(n):
            x1[r, k] = col[r] / s
            x2[r, k] = col[n + r] / s
    sv = mp.svd_c(x1, compute_uv=False)
    if min(sv) <= mp.mpf(10) ** -30 * max(sv):
        return None, "X1 singular", axis
    x = x2 * x1 ** -1
    assert max_imag(x) <= mp.mpf(10) ** -15 * (1 + fro(x)), "complex Riccati solution"
    x = real(x)
    return (x + x.T) / 2, None, axis


def riccati_data(p, g2):
    """[B1 B2], [C1; C2], [D11 D12], [D11; D21] and the indefinite weights
    R = D1.'D1. - diag(g^2 I, 0), R~ = D.1 D.1' - diag(g^2 I, 0)."""
    bb = block([[p.nb1, p.nb2]])
    cc = block([[p.nc1], [p.nc2]])
    d1 = block([[p.nd11, p.nd12]])
    dd1 = block([[p.nd11], [p.nd21]])
    r = d1.T * d1
    for i in range(p.m1):
        r[i, i] -= g2
    rt = dd1 * dd1.T
    for i in range(p.p1):
        rt[i, i] -= g2
    return bb, cc, d1, dd1, r, rt


def conditions(p, g):
    """Thm 17.1's conditions at level g: (holds, first failure, margins, X, Y)."""
    g2 = g * g
    info = {}
    if not g > p.d11_bound:
        return False, "D11 condition", info, None, None
    n, m1, m2, p1, p2 = p.n, p.m1, p.m2, p.p1, p.p2
    bb, cc, d1, dd1, r, rt = riccati_data(p, g2)
    h = block([[p.a, mp.zeros(n, n)], [-p.nc1.T * p.nc1, -p.a.T]]) - \
        block([[bb], [-p.nc1.T * d1]]) * r ** -1 * block([[d1.T * p.nc1, bb.T]])
    j = block([[p.a.T, mp.zeros(n, n)], [-p.nb1 * p.nb1.T, -p.a]]) - \
        block([[cc.T], [-p.nb1 * dd1.T]]) * rt ** -1 * block([[dd1 * p.nb1.T, cc]])
    x, why, info["h_axis"] = ric(h, n)
    if x is None:
        return False, "X: " + why, info, None, None
    y, why, info["j_axis"] = ric(j, n)
    if y is None:
        return False, "Y: " + why, info, x, None
    info["x_min_eig"] = sym_min_eig(x)
    info["y_min_eig"] = sym_min_eig(y)
    if info["x_min_eig"] < -mp.mpf(10) ** -25 * max(1, fro(x)):
        return False, "X not >= 0", info, x, y
    if info["y_min_eig"] < -mp.mpf(10) ** -25 * max(1, fro(y)):
        return False, "Y not >= 0", info, x, y
    info["rho_xy_over_g2"] = max(abs(z) for z in mp.eig(x * y, left=False, right=False)) / g2
    if not info["rho_xy_over_g2"] < 1:
        return False, "rho(XY) >= gamma^2", info, x, y
    return True, None, info, x, y


def feasible(p, g):
    return conditions(p, g)[0]


def bracket(p, seed):
    """[g_lo, g_hi] with the conditions failing at g_lo and holding at g_hi."""
    lo = max(p.d11_bound, seed * (1 - 1e-3) if seed else p.d11_bound)
    hi = seed * (1 + 1e-3) if seed else max(1, 2 * p.d11_bound)
    while feasible(p, lo) and lo > p.d11_bound:
        lo = max(p.d11_bound, lo / 2)
    while not feasible(p, hi):
        lo, hi = hi, hi * 2
    n_tests = 0
    while hi / lo - 1 > BRACKET_RTOL:
        mid = mp.sqrt(lo * hi)
        n_tests += 1
        if feasible(p, mid):
            hi = mid
        else:
            lo = mid
    return lo, hi


# ---------------------------------------------------------------- controller and its closed loop

def central(p, g):
    """Thm 17.1's central controller on the scaled plant, then the D22 loop
    shift and the scalings undone: (Ak, Bk, Ck, Dk), u = K y."""
    ok, why, _, x, y = conditions(p, g)
    assert ok, why
    g2 = g * g
    n, m1, m2, p1, p2 = p.n, p.m1, p.m2, p.p1, p.p2
    bb, cc, d1, dd1, r, rt = riccati_data(p, g2)
    f = -(r ** -1) * (d1.T * p.nc1 + bb.T * x)
    ell = -(p.nb1 * dd1.T + y * cc.T) * rt ** -1
    f12, f2 = sub(f, 0, m1, 0, n), sub(f, m1, m1 + m2, 0, n)
    l12, l2 = sub(ell, 0, n, p1 - m2, p1), sub(ell, 0, n, p1, p1 + p2)
    d1112 = sub(p.nd11, 0, p1 - m2, 0, m1)
    d1122 = sub(p.nd11, p1 - m2, p1, 0, m1)
    dh11 = -d1122
    dh21 = mp.cholesky(eye(p2) - d1112.T * d1112 / g2).T  # Dh21' Dh21 = I - D1112'D1112/g^2
    z = (eye(n) - y * x / g2) ** -1
    bh2 = z * (p.nb2 + l12)
    ch2 = -dh21 * (p.nc2 + f12)
    bh1 = -z * l2 + bh2 * dh11
    dh21i = dh21 ** -1
    ch1 = f2 + dh11 * dh21i * ch2
    ah = p.a + bb * f + bh1 * dh21i * ch2
    # Loop shift: u = Kh (y - D22 u).
    fi = (eye(m2) + dh11 * p.nd22) ** -1
    ak = ah - bh1 * p.nd22 * fi * ch1
    bk = bh1 * (eye(p2) - p.nd22 * fi * dh11)
    ck, dk = fi * ch1, fi * dh11
    return ak, bk * p.sy, p.su * ck, p.su * dk * p.sy


def lft(p, k):
    """Closed loop of the unscaled plant with u = K y (D22 included)."""
    ak, bk, ck, dk = k
    e = (eye(p.m2) - dk * p.d22) ** -1
    # u = E (Dk C2 x + Ck xk + Dk D21 w), y = C2 x + D21 w + D22 u
    ux, uk, uw = e * dk * p.c2, e * ck, e * dk * p.d21
    yx, yk, yw = p.c2 + p.d22 * ux, p.d22 * uk, p.d21 + p.d22 * uw
    a = block([[p.a + p.b2 * ux, p.b2 * uk], [bk * yx, ak + bk * yk]])
    b = block([[p.b1 + p.b2 * uw], [bk * yw]])
    c = block([[p.c1 + p.d12 * ux, p.d12 * uk]])
    d = p.d11 + p.d12 * uw
    return a, b, c, d


def below(cl, g):
    """sigma_max(D) < g and the Hamiltonian at g has no imaginary-axis
    eigenvalue: ||T|| < g for the stable T. Returns (True, []) or (False,
    the axis frequencies)."""
    a, b, c, d = cl
    if not max(mp.svd_r(d, compute_uv=False)) < g:
        return False, []
    r = g * g * eye(d.cols) - d.T * d
    ri = r ** -1
    ae = a + b * ri * d.T * c
    h = block([[ae, b * ri * b.T], [-c.T * (eye(d.rows) + d * ri * d.T) * c, -ae.T]])
    e = mp.eig(h, left=False, right=False)
    tol = mp.mpf(10) ** -30 * fro(h)
    ws = sorted(abs(mp.im(x)) for x in e if abs(mp.re(x)) <= tol)
    return not ws, ws


def sigma(cl, w):
    a, b, c, d = cl
    t = c * mp.lu_solve(mp.mpc(0, w) * eye(a.rows) - a, b) + d
    return max(mp.svd_c(t, compute_uv=False))


def cl_norm(cl, level):
    """Bruinsma-Steinbuch at 40 digits: (norm to 1e-9, peak frequency)."""
    a = cl[0]
    poles = mp.eig(a, left=False, right=False)
    mags = [float(abs(x)) for x in poles if abs(x) > 0]
    grid = np.logspace(np.log10(min(mags) / 100), np.log10(max(mags) * 100), 400)
    lo, wpk = max((sigma(cl, mp.mpf(float(w))), float(w)) for w in grid)
    for _ in range(30):
        ok, ws = below(cl, lo * (1 + mp.mpf(1e-9)))
        if ok:
            return lo, wpk
        mids = [(ws[i] + ws[i + 1]) / 2 for i in range(len(ws) - 1)] + ws
        s, w = max((sigma(cl, w), w) for w in mids)
        if s > lo:
            lo, wpk = s, float(w)
    raise RuntimeError("Bruinsma-Steinbuch did not converge")


# ---------------------------------------------------------------- SB10AD (peer figure)

def _worker(abcd, queue):
    try:
        import control as ct
        k, cl, gam, _ = ct.hinfsyn(ct.ss(*abcd), 1, 1)
        queue.put((float(gam), None))
    except Exception as e:  # SLICOT refuses the problem
        queue.put((None, str(e)))


def sb10ad(p):
    """SB10AD's gamma on the (continuous) plant, rounded to double."""
    abcd = [np.array([[float(m[i, j]) for j in range(m.cols)] for i in range(m.rows)])
            for m in (p.a, p.b, p.c, p.d)]
    queue = mproc.Queue()
    proc = mproc.Process(target=_worker, args=(abcd, queue))
    proc.start()
    try:
        gam, err = queue.get(timeout=TIMEOUT_S)
    except Exception:
        proc.kill()
        proc.join()
        return None, f"SB10AD did not return within {TIMEOUT_S} s"
    proc.join()
    return gam, err


# ---------------------------------------------------------------- one problem

def f(x):
    return float(x)


def stored_plant(spec):
    _, _, g, ws, wu, ts = spec
    a, b, c, d = augw(g, ws, wu)
    if ts is not None:
        a, b = zoh(a, b, ts)
    return a, b, c, d


def certify(job):
    spec, (gam, err) = job
    name, kind, g, ws, wu, ts = spec
    t0 = time.perf_counter()
    a, b, c, d = stored_plant(spec)
    p = Plant(a, b, c, d, ts)
    g_lo, g_hi = bracket(p, mp.mpf(gam) if gam else None)
    assert not feasible(p, g_lo) and feasible(p, g_hi)
    ok_m, why_m, _, _, _ = conditions(p, g_hi * (1 - mp.mpf(1e-4)))
    ok_p, _, info_p, _, _ = conditions(p, g_hi * (1 + mp.mpf(1e-4)))
    assert not ok_m and ok_p, name
    level = g_hi * (1 + mp.mpf(5e-5))
    cl = lft(p, central(p, level))
    poles = mp.eig(cl[0], left=False, right=False)
    max_re = max(mp.re(x) for x in poles)
    assert max_re < 0, f"{name}: the central controller does not stabilise"
    ok, _ = below(cl, level)
    assert ok, f"{name}: the central controller misses its level"
    norm, wpk = cl_norm(cl, level)
    assert g_lo <= norm < level, name
    case = {
        "name": name, "family": kind,
        "a": a.tolist(), "b": b.tolist(), "c": c.tolist(), "d": d.tolist(),
        "ts": ts, "nmeas": 1, "ncon": 1,
        "g_num": g[0], "g_den": g[1], "ws_num": ws[0], "ws_den": ws[1], "wu": wu,
        "g_lo": f(g_lo), "g_hi": f(g_hi),
        "g_lo_40": mp.nstr(g_lo, 40), "g_hi_40": mp.nstr(g_hi, 40),
        "check_minus": f"fails at g_hi (1 - 1e-4): {why_m}",
        "check_plus": {k: mp.nstr(v, 5) for k, v in info_p.items()},
        "controller_level": f(level), "controller_norm": f(norm),
        "controller_norm_40": mp.nstr(norm, 15), "controller_peak_rad_s": wpk,
        "closed_loop_max_real_pole": f(max_re),
        "sb10ad_gamma": gam, "sb10ad_error": err,
        "seconds": round(time.perf_counter() - t0, 1),
    }
    print(f"{name:34s} [{f(g_lo):.10g}, {f(g_hi):.10g}] K {f(norm):.10g} "
          f"SB10AD {gam} ({case['seconds']} s)", flush=True)
    return case


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    partial = os.path.join(here, "cases.partial.json")
    done = json.load(open(partial)) if os.path.exists(partial) else {}
    # SB10AD first, in this process's children (a pool worker may not have any).
    todo = []
    for s in problems():
        if s[0] not in done:
            todo.append((s, sb10ad(Plant(*stored_plant(s), s[5]))))
            print(f"{s[0]:34s} SB10AD {todo[-1][1][0]}", flush=True)
    workers = int(os.environ.get("JOBS", "2"))
    with mproc.get_context("fork").Pool(workers) as pool:
        for case in pool.imap_unordered(certify_safe, todo):
            if case is not None:
                done[case["name"]] = case
                with open(partial, "w") as fh:
                    json.dump(done, fh)
    missing = [s[0] for s in problems() if s[0] not in done]
    if missing:
        sys.exit(f"not certified: {missing}")
    out = {"generator": "tests/data/hinf_certified/generate.py", "mp_dps": mp.dps,
           "mpmath": mpmath.__version__, "bracket_rtol": BRACKET_RTOL,
           "cases": [done[s[0]] for s in problems()]}
    with open(os.path.join(here, "cases.json"), "w") as fh:
        json.dump(out, fh, indent=1)
        fh.write("\n")
    os.remove(partial)


def certify_safe(job):
    try:
        return certify(job)
    except Exception as e:
        print(f"{job[0][0]}: FAILED {e!r}", flush=True)
        return None


if __name__ == "__main__":
    if len(sys.argv) > 1:  # one problem by name, for debugging
        spec = [s for s in problems() if s[0] == sys.argv[1]][0]
        job = (spec, sb10ad(Plant(*stored_plant(spec), spec[5])))
        print(json.dumps(certify(job))[:3000])
    else:
        main()
