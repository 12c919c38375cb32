"""Synthesis corpus for tests/suite/synth_corpus.rs (issue #19): random continuous
and discrete generalised plants, orders 2 to 40, with reference figures
computed here from the Riccati theory with SciPy, fixed seed. Run once:
`python3 generate.py` writes `cases.json` beside this file. No test needs
Python. SLICOT (through Slycot) is only an extra column, never a reference.

Families (`family`):
* `h2_c`, `h2_d`: continuous / discrete H2. The optimal controller is built
  here from SciPy's CARE / DARE solutions (Zhou & Doyle, Essentials
  Thm 14.7; discrete: Zhou, Doyle & Glover 1996 ch. 21, SLICOT SB10SD's
  form), and the reference `h2_reference` is the H2 norm of its closed loop
  from SciPy's Lyapunov solver. Independently the optimum is given by the
  Riccati trace formula (`h2_formula`: continuous
  `tr(B1'X B1) + tr(R1 F Y F')`, discrete the full-information plus
  output-estimation cost); a case is kept only if the two agree to 1e-9.
  `slycot_h2` is the closed-loop H2 norm of SB10HD's controller
  (continuous) or of SB10DD's central controller at gamma = 1e6 (discrete;
  it tends to the H2 optimum as gamma grows), null where Slycot refused.
* `hinf_c`: continuous H-inf. The optimum is the infimum of the gammas at
  which the Glover-Doyle conditions hold, in the general form with D11
  (Zhou, Doyle & Glover 1996 Thm 17.1, written without normalising D12,
  D21: the X and Y Riccati equations are invariant under the scalings):
  (i) gamma > max(||(I - P12) D11||, ||D11 (I - P21)||), P12 / P21 the
  projections on the range of D12 / the row space of D21; (ii) the
  Hamiltonian of `A'X + XA - (XB + C1'D1.) R^-1 (B'X + D1.'C1) + C1'C1 = 0`,
  `R = D1.'D1. - diag(g^2 I, 0)`, has no imaginary-axis eigenvalue, its
  stable subspace `[U1; U2]` has `U1` invertible, `X = U2 U1^-1 >= 0`;
  (iii) the same for the dual `Y`; (iv) `rho(XY) < gamma^2`. X and Y are
  computed from an ordered real Schur form of the Hamiltonian (SciPy's
  `schur(sort='lhp')`, after an exact diagonal state balancing), checked
  by residual (1e-7 relative), PSD-ness and closed-loop stability; an
  eigenvalue with `|Re| < 1e-5 |lambda|` counts as on the axis. The
  conditions are necessary and sufficient, so bisection on them (to 1e-8)
  gives `gamma_opt`. They are evaluated again at `gamma_opt (1 + 1e-4)`,
  where they must hold, also with SciPy's `solve_continuous_are` in place
  of the Schur solver (else the case is dropped), and at
  `gamma_opt (1 - 1e-4)`, where the reason they fail is stored
  (`below_fails`; SciPy's solver's in `below_fails_scipy`). A case where a
  controller is verified here to achieve less than `gamma_opt` is
  dropped. `slycot_gamma` is SB10AD's claimed optimum and
  `slycot_achieved` the norm (Hamiltonian bisection here) its controller
  achieves (null: unstable), both informative only.
* `hinf_d`: discrete H-inf. `gamma_opt` by the same bisection on the
  continuous conditions of the bilinear equivalent `z = (1 + s)/(1 - s)`
  (it preserves the H-inf norm and stability, so both optima coincide),
  cross-checked by a second bisection on the discrete Riccati conditions
  (SB10DD's: X and Z stabilising, PSD, `R3 > 0`, `Nabla < 0`, `St3 > 0`,
  `St1 - St2 St3^-1 St2' < 0`, with SciPy's DARE solver): `cross_gamma_opt`,
  which must agree to 1e-5 or the case is dropped (the DAREs' accuracy
  checks fail a few 1e-6 early near the optimum). The ±1e-4 checks as
  above (the discrete conditions too, `below_fails_discrete`).
  `slycot_achieved` is the norm of SB10DD's controller at
  `gamma_opt (1 + 1e-4)`.

`scaled` cases are badly scaled: a diagonal state similarity with entries
10^U(-2, 2) (A's entries then span about 1e-4..1e4) and a small control
weight (D12 multiplied by 1e-3 or 1e-2).
"""

import json

import numpy as np
import scipy.linalg as sl
import slycot

SEED = 20261127
BISECT_RTOL = 1e-8
STEP = 1e-4


# ---------------------------------------------------------------- plants

def random_plant(rng, dims, discrete, d11, d22, scaled):
    n, m1, m2, p1, p2 = dims
    A = rng.standard_normal((n, n))
    ev = np.linalg.eigvals(A)
    if discrete:
        A *= rng.uniform(0.6, 1.2) / max(abs(ev))
    else:
        A -= (max(ev.real) + rng.uniform(-1.0, 1.0)) * np.eye(n)
    B = rng.standard_normal((n, m1 + m2))
    C = rng.standard_normal((p1 + p2, n))
    D = np.zeros((p1 + p2, m1 + m2))
    D[:p1, m1:] = rng.standard_normal((p1, m2))
    D[p1:, :m1] = rng.standard_normal((p2, m1))
    if d11:
        D[:p1, :m1] = 0.5 * rng.standard_normal((p1, m1))
    if d22:
        D[p1:, m1:] = 0.5 * rng.standard_normal((p2, m2))
    if scaled:
        t = 10.0 ** rng.uniform(-2, 2, n)
        A = A * t[None, :] / t[:, None]
        B = B / t[:, None]
        C = C * t[None, :]
        D[:p1, m1:] *= 10.0 ** -rng.integers(2, 4)
    return A, B, C, D


def split(p, ncon, nmeas):
    A, B, C, D = p
    m1, p1 = B.shape[1] - ncon, C.shape[0] - nmeas
    return (A, B[:, :m1], B[:, m1:], C[:p1], C[p1:],
            D[:p1, :m1], D[:p1, m1:], D[p1:, :m1], D[p1:, m1:])


def closed_loop(p, k, ncon, nmeas):
    """F_l(P, K) with u = K y (positive feedback), D22 included."""
    A, B1, B2, C1, C2, D11, D12, D21, D22 = split(p, ncon, nmeas)
    Ak, Bk, Ck, Dk = k
    M = np.linalg.inv(np.eye(ncon) - Dk @ D22)
    cu_x, cu_k, du = M @ Dk @ C2, M @ Ck, M @ Dk @ D21
    cy_x, cy_k, dy = C2 + D22 @ cu_x, D22 @ cu_k, D21 + D22 @ du
    Acl = np.block([[A + B2 @ cu_x, B2 @ cu_k], [Bk @ cy_x, Ak + Bk @ cy_k]])
    Bcl = np.vstack([B1 + B2 @ du, Bk @ dy])
    Ccl = np.hstack([C1 + D12 @ cu_x, D12 @ cu_k])
    return Acl, Bcl, Ccl, D11 + D12 @ du


def bilinear_to_continuous(p):
    """z = (1 + s)/(1 - s): same H-inf norm, same stability."""
    A, B, C, D = p
    E = np.linalg.inv(A + np.eye(A.shape[0]))
    r2 = np.sqrt(2.0)
    return (E @ (A - np.eye(A.shape[0])), r2 * E @ B, r2 * C @ E, D - C @ E @ B)


# ---------------------------------------------------------------- norms

def stable(A, discrete):
    ev = np.linalg.eigvals(A)
    return max(abs(ev)) < 1 if discrete else max(ev.real) < 0


def h2(cl, discrete):
    A, B, C, D = cl
    if not stable(A, discrete):
        return np.inf
    if discrete:
        P = sl.solve_discrete_lyapunov(A, B @ B.T)
        return float(np.sqrt(np.trace(C @ P @ C.T + D @ D.T)))
    P = sl.solve_continuous_lyapunov(A, -B @ B.T)
    return float(np.sqrt(np.trace(C @ P @ C.T)))


def hinf_continuous(cl):
    """H-inf norm of a stable continuous system: bisection on the
    imaginary-axis eigenvalues of the Hamiltonian (Boyd, Balakrishnan &
    Kabamba 1989), started from a sweep's lower bound; relative 1e-7."""
    A, B, C, D = cl
    if not stable(A, False):
        return np.inf
    ws = np.concatenate([[0.0], np.logspace(-4, 6, 400)])
    lo = max(max(sigma_at(cl, w) for w in ws), np.linalg.norm(D, 2))
    if not np.isfinite(lo) or lo == 0.0:
        return float(lo)
    hi = 2 * lo
    while has_axis_eig(cl, hi):
        hi *= 2
        if hi > 1e200:
            return np.inf
    while hi / lo - 1 > 1e-7:
        mid = np.sqrt(lo * hi)
        if has_axis_eig(cl, mid):
            lo = mid
        else:
            hi = mid
    return hi


def sigma_at(cl, w):
    A, B, C, D = cl
    g = C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B) + D
    return np.linalg.svd(g, compute_uv=False)[0]


def has_axis_eig(cl, g):
    """Whether the Hamiltonian of ||G|| < g has an imaginary-axis
    eigenvalue, confirmed by the gain at its frequency (a stiff closed loop
    puts eigenvalues near the axis only by rounding)."""
    A, B, C, D = cl
    R = g * g * np.eye(D.shape[1]) - D.T @ D
    Ri = np.linalg.inv(R)
    Ah = A + B @ Ri @ D.T @ C
    H = np.block([[Ah, B @ Ri @ B.T],
                  [-C.T @ (np.eye(D.shape[0]) + D @ Ri @ D.T) @ C, -Ah.T]])
    for lam in np.linalg.eigvals(H):
        if abs(lam.real) <= 1e-6 * max(1.0, abs(lam)):
            if sigma_at(cl, abs(lam.imag)) >= g * (1 - 1e-6):
                return True
    return False


# ------------------------------------------- continuous H-inf conditions

class Fails(Exception):
    pass


def care_schur(A, B, Q, R, S):
    """Stabilising solution from the ordered Schur form of the Hamiltonian."""
    n = A.shape[0]
    Ri = np.linalg.inv(R)
    Ah = A - B @ Ri @ S.T
    H = np.block([[Ah, -B @ Ri @ B.T], [-(Q - S @ Ri @ S.T), -Ah.T]])
    # The spectrum is symmetric about the axis: fewer than n eigenvalues
    # on the left means some lie on it (to rounding). Eigenvalues that have
    # reached the axis can also split symmetrically by rounding (a
    # quadruple +-eps +-jw): 1e-5 relative is far below the real parts
    # the bisection meets just above the optimum (those grow like the
    # square root of the distance to it), far above rounding.
    ev = np.linalg.eigvals(H)
    ratio = np.min(np.abs(ev.real) / np.maximum(np.abs(ev), 1e-300))
    if ratio < 1e-5:
        raise Fails("Hamiltonian has imaginary-axis eigenvalues (|Re|/|lambda| %.1e)" % ratio)
    try:
        _, Z, sdim = sl.schur(H, output="real", sort="lhp")
    except np.linalg.LinAlgError:
        raise Fails("Hamiltonian eigenvalues at the axis (ordering failed)")
    if sdim != n:
        raise Fails("Hamiltonian has imaginary-axis eigenvalues (%d stable of %d)"
                    % (sdim, 2 * n))
    U1, U2 = Z[:n, :n], Z[n:, :n]
    if np.linalg.cond(U1) > 1e12:
        raise Fails("U1 singular (no stabilising solution)")
    return np.linalg.solve(U1.T, U2.T).T


def care_scipy(A, B, Q, R, S):
    try:
        return sl.solve_continuous_are(A, B, Q, R, s=S)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise Fails("scipy: %s" % str(e).split("\n")[0])


def riccati(solver, A, B, Q, R, S, what):
    try:
        X = solver(A, B, Q, R, S)
    except Fails as e:
        raise Fails("%s: %s" % (what, e))
    X = 0.5 * (X + X.T)
    K = np.linalg.solve(R, B.T @ X + S.T)
    terms = [A.T @ X, X @ A, (X @ B + S) @ K, Q]
    res = terms[0] + terms[1] - terms[2] + terms[3]
    if np.linalg.norm(res) > 1e-7 * sum(np.linalg.norm(t) for t in terms):
        raise Fails("%s: residual" % what)
    if not stable(A - B @ K, False):
        raise Fails("%s: not stabilising" % what)
    if np.linalg.eigvalsh(X).min() < -1e-9 * max(1.0, np.abs(X).max()):
        raise Fails("%s not PSD" % what)
    return X


def d11_bound(D11, D12, D21):
    """Thm 17.1 (i) without normalisation."""
    P12 = D12 @ np.linalg.pinv(D12)
    P21 = np.linalg.pinv(D21) @ D21
    return max(np.linalg.norm((np.eye(P12.shape[0]) - P12) @ D11, 2),
               np.linalg.norm(D11 @ (np.eye(P21.shape[0]) - P21), 2))


def balance(p):
    """An exact diagonal state similarity (SciPy's matrix balancing of
    [A B; C 0]): gamma_opt is invariant, badly scaled plants are helped."""
    A, B, C, D = p
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = np.abs(A)
    M[:n, n] = np.abs(B).sum(axis=1)
    M[n, :n] = np.abs(C).sum(axis=0)
    _, (t, _) = sl.matrix_balance(M, permute=False, separate=True)
    t = t[:n] / t[n]
    return A * t[None, :] / t[:, None], B / t[:, None], C * t[None, :], D


def conditions_c(p, ncon, nmeas, g, solver=care_schur):
    """None when the continuous conditions hold at g, else why not."""
    A, B1, B2, C1, C2, D11, D12, D21, _ = split(balance(p), ncon, nmeas)
    m1, p1 = B1.shape[1], C1.shape[0]
    if not g > d11_bound(D11, D12, D21):
        return "D11: gamma below the feedthrough bound"
    g2 = g * g
    B, D1 = np.hstack([B1, B2]), np.hstack([D11, D12])
    R = D1.T @ D1
    R[:m1, :m1] -= g2 * np.eye(m1)
    C, Dd1 = np.vstack([C1, C2]), np.vstack([D11, D21])
    Rt = Dd1 @ Dd1.T
    Rt[:p1, :p1] -= g2 * np.eye(p1)
    try:
        X = riccati(solver, A, B, C1.T @ C1, R, C1.T @ D1, "X")
        Y = riccati(solver, A.T, C.T, B1 @ B1.T, Rt, B1 @ Dd1.T, "Y")
    except Fails as e:
        return str(e)
    if max(abs(np.linalg.eigvals(X @ Y))) >= g2:
        return "rho(XY) >= gamma^2"
    return None


# --------------------------------------------- discrete H-inf conditions

def dare_stab(A, B, Q, R, S):
    X = sl.solve_discrete_are(A, B, Q, R, s=S)
    K = np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A + S.T)
    res = A.T @ X @ A - X - (A.T @ X @ B + S) @ K + Q
    if np.abs(res).max() > 1e-6 * max(1.0, np.abs(X).max()):
        raise np.linalg.LinAlgError("residual")
    if max(abs(np.linalg.eigvals(A - B @ K))) >= 1:
        raise np.linalg.LinAlgError("not stabilising")
    return X


def psd(M, tol=1e-9):
    M = 0.5 * (M + M.T)
    return np.linalg.eigvalsh(M).min() >= -tol * max(1.0, np.abs(M).max())


def pd(M):
    return np.linalg.eigvalsh(0.5 * (M + M.T)).min() > 0


def conditions_d(p, ncon, nmeas, g):
    """None when SB10DD's discrete conditions hold at g, else why not."""
    A, B1, B2, C1, C2, D11, D12, D21, _ = split(p, ncon, nmeas)
    m1, m2 = B1.shape[1], ncon
    B, C, D1 = np.hstack([B1, B2]), np.vstack([C1, C2]), np.hstack([D11, D12])
    n, g2 = A.shape[0], g * g
    R0 = D1.T @ D1
    R0[:m1, :m1] -= g2 * np.eye(m1)
    try:
        X = dare_stab(A, B, C1.T @ C1, R0, C1.T @ D1)
    except (np.linalg.LinAlgError, ValueError) as e:
        return "X: %s" % str(e).split("\n")[0]
    if not psd(X):
        return "X not PSD"
    R = R0 + B.T @ X @ B
    R1, R2, R3 = R[:m1, :m1], R[m1:, :m1], R[m1:, m1:]
    if not pd(R3):
        return "R3"
    V12t = np.linalg.cholesky(R3)
    R2s = np.linalg.solve(V12t, R2)
    negnab = R2s.T @ R2s - R1
    if not pd(negnab):
        return "Nabla"
    V21t = np.linalg.cholesky(negnab)
    L = D1.T @ C1 + B.T @ X @ A
    L2 = np.linalg.solve(V12t, L[m1:])
    Lt = np.linalg.solve(V21t, L[:m1] - R2s.T @ L2)
    V21i = np.linalg.inv(V21t).T
    Bt1 = B1 @ V21i
    At = A + Bt1 @ Lt
    Dt = np.vstack([R2s, D21]) @ V21i
    Ct = np.vstack([L2, C2]) + Dt @ Lt
    Bt1, Dt = g * Bt1, g * Dt
    S0 = Dt @ Dt.T
    S0[:m2, :m2] -= g2 * np.eye(m2)
    try:
        Z = dare_stab(At.T, Ct.T, Bt1 @ Bt1.T, S0, Bt1 @ Dt.T)
    except (np.linalg.LinAlgError, ValueError) as e:
        return "Z: %s" % str(e).split("\n")[0]
    if not psd(Z):
        return "Z not PSD"
    St = S0 + Ct @ Z @ Ct.T
    St1, St2, St3 = St[:m2, :m2], St[:m2, m2:], St[m2:, m2:]
    if not pd(St3):
        return "St3"
    if not pd(-(St1 - St2 @ np.linalg.solve(St3, St2.T))):
        return "St"
    return None


def bisect(holds, lo, rtol=BISECT_RTOL):
    """Smallest gamma where `holds` (monotone), bracketed to rtol:
    returns (hi, lo) with holds(hi) and not holds(lo)."""
    hi = max(1.0, 2.0 * lo)
    while not holds(hi):
        lo, hi = hi, 2.0 * hi
        if hi > 1e9:
            return None
    if lo == 0.0:
        lo = hi / 2
        while holds(lo):
            hi, lo = lo, lo / 2
    while hi / lo - 1 > rtol:
        mid = np.sqrt(lo * hi)
        if holds(mid):
            hi = mid
        else:
            lo = mid
    return hi, lo


# ---------------------------------------------------------------- H2

def h2_controller_c(p, ncon, nmeas):
    """Zhou & Doyle, Essentials Thm 14.7 (general form), D22 left out:
    F_l(P, K shifted by D22) = F_l(P with D22 = 0, K)."""
    A, B1, B2, C1, C2, D11, D12, D21, _ = split(p, ncon, nmeas)
    R1, R2 = D12.T @ D12, D21 @ D21.T
    X = sl.solve_continuous_are(A, B2, C1.T @ C1, R1, s=C1.T @ D12)
    Y = sl.solve_continuous_are(A.T, C2.T, B1 @ B1.T, R2, s=B1 @ D21.T)
    F = -np.linalg.solve(R1, B2.T @ X + D12.T @ C1)
    L = -np.linalg.solve(R2, C2 @ Y + D21 @ B1.T).T
    k = (A + B2 @ F + L @ C2, -L, F, np.zeros((ncon, nmeas)))
    formula = np.sqrt(np.trace(B1.T @ X @ B1) + np.trace(R1 @ F @ Y @ F.T))
    return k, float(formula)


def h2_controller_d(p, ncon, nmeas):
    """[ZDG96] ch. 21 / SLICOT SB10SD's controller (general form), D22 left out."""
    A, B1, B2, C1, C2, D11, D12, D21, _ = split(p, ncon, nmeas)
    R1, R2 = D12.T @ D12, D21 @ D21.T
    X = sl.solve_discrete_are(A, B2, C1.T @ C1, R1, s=C1.T @ D12)
    Y = sl.solve_discrete_are(A.T, C2.T, B1 @ B1.T, R2, s=B1 @ D21.T)
    Rb = R1 + B2.T @ X @ B2
    F2 = -np.linalg.solve(Rb, B2.T @ X @ A + D12.T @ C1)
    F0 = -np.linalg.solve(Rb, B2.T @ X @ B1 + D12.T @ D11)
    S = R2 + C2 @ Y @ C2.T
    L2 = -np.linalg.solve(S, C2 @ Y @ A.T + D21 @ B1.T).T
    L0 = np.linalg.solve(S.T, (F2 @ Y @ C2.T + F0 @ D21.T).T).T
    Ck = F2 - L0 @ C2
    k = (A + B2 @ Ck + L2 @ C2, -L2 + B2 @ L0, Ck, L0)
    fi = np.trace(D11.T @ D11 + B1.T @ X @ B1) - np.trace(F0.T @ Rb @ F0)
    oe = np.trace(Rb @ (F2 @ Y @ F2.T + F0 @ F0.T - L0 @ S @ L0.T))
    return k, float(np.sqrt(fi + oe))


def without_d22(p, ncon, nmeas):
    A, B, C, D = p
    D = D.copy()
    D[C.shape[0] - nmeas:, B.shape[1] - ncon:] = 0.0
    return A, B, C, D


def slycot_h2(p, ncon, nmeas, discrete):
    A, B, C, D = p
    n, m, q = A.shape[0], B.shape[1], C.shape[0]
    try:
        if discrete:
            k = slycot.sb10dd(n, m, q, ncon, nmeas, 1e6, A, B, C, D)[1:5]
        else:
            k = slycot.sb10hd(n, m, q, ncon, nmeas, A, B, C, D)[:4]
    except Exception:
        return None
    return h2(closed_loop(p, k, ncon, nmeas), discrete)


def h2_case(p, ncon, nmeas, discrete, name):
    build = h2_controller_d if discrete else h2_controller_c
    k, formula = build(p, ncon, nmeas)
    ref = h2(closed_loop(without_d22(p, ncon, nmeas), k, ncon, nmeas), discrete)
    if not abs(ref / formula - 1) < 1e-9:
        print(f"{name}: dropped (Gramian {ref} vs formula {formula})")
        return None
    return {"kind": "h2", "h2_reference": ref, "h2_formula": formula,
            "slycot_h2": slycot_h2(p, ncon, nmeas, discrete)}


# ---------------------------------------------------------------- H-inf

def slycot_hinf_c(p, ncon, nmeas):
    A, B, C, D = p
    n, m, q = A.shape[0], B.shape[1], C.shape[0]
    try:
        r = slycot.sb10ad(n, m, q, ncon, nmeas, 1e6, A, B, C, D)
    except Exception as e:
        print("  SB10AD refused: %s" % str(e).split("\n")[0])
        return None, None
    return float(r[0]), hinf_continuous(closed_loop(p, r[1:5], ncon, nmeas))


def slycot_hinf_d(p, ncon, nmeas, g):
    A, B, C, D = p
    n, m, q = A.shape[0], B.shape[1], C.shape[0]
    try:
        k = slycot.sb10dd(n, m, q, ncon, nmeas, g, A, B, C, D)[1:5]
    except Exception as e:
        print("  SB10DD refused: %s" % str(e).split("\n")[0])
        return None
    cl = bilinear_to_continuous(closed_loop(p, k, ncon, nmeas))
    return hinf_continuous(cl)


def certify(pc, ncon, nmeas, name):
    """gamma_opt by bisection on the continuous conditions, checked at
    gamma_opt (1 +- STEP); None (dropped) when they do not hold above."""
    d11 = d11_bound(*split(pc, ncon, nmeas)[5:8])
    got = bisect(lambda g: conditions_c(pc, ncon, nmeas, g) is None, d11)
    if got is None:
        print(f"{name}: dropped (conditions never hold)")
        return None
    hi, lo = got
    for solver in (care_schur, care_scipy):
        above = conditions_c(pc, ncon, nmeas, hi * (1 + STEP), solver)
        if above is not None:
            print(f"{name}: dropped ({solver.__name__} above: {above})")
            return None
    return {"kind": "hinf", "gamma_opt": hi, "gamma_bracket": hi / lo - 1,
            "below_fails": conditions_c(pc, ncon, nmeas, hi * (1 - STEP)),
            "below_fails_scipy": conditions_c(pc, ncon, nmeas, hi * (1 - STEP), care_scipy)}


def hinf_case(p, ncon, nmeas, discrete, name):
    pc = bilinear_to_continuous(p) if discrete else p
    ref = certify(pc, ncon, nmeas, name)
    if ref is None:
        return None
    g = ref["gamma_opt"]
    if not discrete:
        ref["slycot_gamma"], ref["slycot_achieved"] = slycot_hinf_c(p, ncon, nmeas)
        return consistent(ref, name)
    got = bisect(lambda x: conditions_d(p, ncon, nmeas, x) is None, 0.0)
    cross = got[0] if got else None
    if cross is None or abs(cross / g - 1) > 1e-5:
        print(f"{name}: dropped (discrete conditions' optimum {cross} vs {g})")
        return None
    ref.update({"cross_gamma_opt": cross,
                "below_fails_discrete": conditions_d(p, ncon, nmeas, g * (1 - STEP)),
                "slycot_achieved": slycot_hinf_d(p, ncon, nmeas, g * (1 + STEP))})
    if conditions_d(p, ncon, nmeas, g * (1 + STEP)) is not None:
        print(f"{name}: dropped (discrete conditions fail above)")
        return None
    return consistent(ref, name)


def consistent(ref, name):
    """A controller verified here to achieve less than gamma_opt would
    prove the bisection wrong (conditions failing by rounding)."""
    achieved = ref.get("slycot_achieved")
    if achieved is not None and achieved < ref["gamma_opt"] * (1 - 1e-7):
        print(f"{name}: dropped (SLICOT's controller achieves {achieved} "
              f"< gamma_opt {ref['gamma_opt']})")
        return None
    return ref


# ---------------------------------------------------------------- plan

# (family, n, m1, m2, p1, p2, d11, d22, scaled)
PLAN = [
    ("h2_c", 2, 2, 1, 2, 1, False, False, False),
    ("h2_c", 3, 2, 1, 2, 1, False, True, False),
    ("h2_c", 5, 3, 2, 3, 2, False, True, False),
    ("h2_c", 8, 2, 1, 2, 1, False, False, True),
    ("h2_c", 12, 3, 2, 3, 2, False, True, False),
    ("h2_c", 16, 2, 2, 3, 2, False, False, True),
    ("h2_c", 20, 3, 1, 2, 2, False, True, False),
    ("h2_c", 25, 4, 2, 3, 2, False, False, False),
    ("h2_c", 30, 2, 1, 2, 1, False, True, True),
    ("h2_c", 40, 3, 2, 3, 2, False, True, False),
    ("h2_c", 40, 2, 1, 2, 1, False, False, True),
    ("h2_d", 2, 2, 1, 2, 1, True, False, False),
    ("h2_d", 4, 3, 2, 3, 2, True, True, False),
    ("h2_d", 6, 2, 1, 2, 1, True, True, True),
    ("h2_d", 10, 3, 2, 3, 2, True, False, False),
    ("h2_d", 14, 2, 1, 3, 1, True, True, True),
    ("h2_d", 20, 3, 1, 2, 2, True, True, False),
    ("h2_d", 24, 3, 2, 3, 2, False, False, False),
    ("h2_d", 30, 2, 1, 2, 1, True, True, True),
    ("h2_d", 36, 4, 2, 3, 3, True, False, False),
    ("h2_d", 40, 3, 2, 3, 2, True, True, False),
    ("hinf_c", 2, 2, 1, 2, 1, False, False, False),
    ("hinf_c", 3, 2, 1, 2, 1, True, False, False),
    ("hinf_c", 4, 3, 2, 3, 2, True, True, False),
    ("hinf_c", 6, 2, 1, 2, 1, False, True, True),
    ("hinf_c", 8, 3, 2, 3, 2, False, False, False),
    ("hinf_c", 10, 2, 1, 3, 1, True, True, True),
    ("hinf_c", 12, 3, 1, 2, 2, True, False, False),
    ("hinf_c", 16, 2, 2, 3, 2, False, True, True),
    ("hinf_c", 20, 3, 2, 3, 2, True, True, False),
    ("hinf_c", 24, 2, 1, 2, 1, False, False, True),
    ("hinf_c", 30, 3, 2, 3, 2, True, False, False),
    ("hinf_c", 26, 2, 1, 2, 1, True, True, False),
    ("hinf_c", 40, 3, 2, 3, 2, False, False, True),
    ("hinf_d", 2, 2, 1, 2, 1, False, False, False),
    ("hinf_d", 4, 3, 2, 3, 2, True, True, False),
    ("hinf_d", 6, 2, 1, 2, 1, True, False, True),
    ("hinf_d", 8, 2, 1, 2, 1, True, True, False),
    ("hinf_d", 12, 3, 2, 3, 2, False, True, True),
    ("hinf_d", 16, 3, 2, 3, 2, True, False, False),
    ("hinf_d", 20, 2, 1, 3, 1, True, True, False),
    ("hinf_d", 30, 3, 1, 2, 2, True, False, True),
    ("hinf_d", 40, 2, 1, 2, 1, True, True, False),
]


def main():
    cases = []
    for i, (family, n, m1, m2, p1, p2, d11, d22, scaled) in enumerate(PLAN):
        # One stream per case: editing one line of the plan leaves the others.
        rng = np.random.default_rng([SEED, i])
        discrete = family.endswith("_d")
        name = f"{family}_{i}_n{n}" + ("_scaled" if scaled else "")
        p = random_plant(rng, (n, m1, m2, p1, p2), discrete, d11, d22, scaled)
        build = h2_case if family.startswith("h2") else hinf_case
        ref = build(p, m2, p2, discrete, name)
        if ref is None:
            continue
        A, B, C, D = p
        # JSON has no Infinity / NaN: an unstable SLICOT loop is stored as null.
        ref = {k: (None if isinstance(v, float) and not np.isfinite(v) else v)
               for k, v in ref.items()}
        ref.update({"name": name, "family": family, "ts": 1.0 if discrete else None,
                    "scaled": scaled, "nmeas": p2, "ncon": m2, "a": A.tolist(),
                    "b": B.tolist(), "c": C.tolist(), "d": D.tolist()})
        cases.append(ref)
        print(name, {k: v for k, v in ref.items() if k not in "abcd"}, flush=True)
    meta = {"generator": "tests/data/synth_corpus/generate.py",
            "slycot": slycot.__version__, "numpy": np.__version__,
            "scipy": __import__("scipy").__version__, "seed": SEED,
            "bisection_rtol": BISECT_RTOL, "step": STEP}
    with open(__file__.replace("generate.py", "cases.json"), "w") as f:
        json.dump({"meta": meta, "cases": cases}, f)


if __name__ == "__main__":
    main()
