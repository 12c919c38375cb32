"""Synthesis corpus for tests/synth_corpus.rs (issue #19): random continuous
and discrete generalised plants with reference figures from SLICOT (through
Slycot 0.7.1) and SciPy, fixed seeds. Run once: `python3 generate.py`
writes `cases.json` beside this file. No test needs Python.

References, each computed here independently of fts:
* discrete H2: the H2 norm (SciPy discrete Lyapunov solve of the closed
  loop) of SLICOT SB10DD's central controller at a very large gamma. The
  central controller tends to the H2-optimal one as gamma -> infinity (its
  closed-loop H2 norm converges to the optimum from above, to second order
  in 1/gamma). Levels 1e2..1e7 are tried; the reference is the value at the
  larger of the two consecutive levels that agree best (their relative
  difference is stored as `h2_reference_spread`; more than 1e-8 drops the
  case). Beyond that SB10DD's own rounding grows. (Slycot has no SB10ED.)
* continuous H2: the H2 norm of SLICOT SB10HD's controller (SciPy Lyapunov).
* discrete H-inf: the smallest gamma at which SB10DD returns a controller
  whose closed loop is stable and whose H-inf norm (dense sweep of the unit
  circle, refined around the peak) is at most gamma (1 + 1e-6), by
  bisection to 1e-5: an upper bound on the optimum that SLICOT's claims
  alone do not give (its gamma is not trusted without that check). Then
  the discrete Riccati feasibility conditions (`conditions` below: X and Z
  stabilising, positive semidefinite, accurate to 1e-6, with `R3 > 0`,
  `Nabla < 0`, `St3 > 0`, `St1 - St2 St3^-1 St2' < 0`, as in SB10DD) are
  evaluated with SciPy's DARE solver at `gamma (1 + 1e-4)`, where they must
  hold (else the case is dropped), and at `gamma (1 - 1e-4)`, where the
  reason they fail is stored (`conditions_below.fails`; null if they hold).
  A failure by "not PSD" or a violated inequality is evidence that no
  controller reaches that level; "residual" (SciPy's solution inaccurate
  there) is not.
"""

import json

import numpy as np
import scipy.linalg as sl
import slycot

GAMMAS_H2 = [10.0**k for k in range(2, 8)]


def closed_loop(p, k, ncon, nmeas):
    """F_l(P, K) with u = K y (positive feedback), D22 included."""
    A, B, C, D = p
    Ak, Bk, Ck, Dk = k
    m1, p1 = B.shape[1] - ncon, C.shape[0] - nmeas
    B1, B2, C1, C2 = B[:, :m1], B[:, m1:], C[:p1], C[p1:]
    D11, D12, D21, D22 = D[:p1, :m1], D[:p1, m1:], D[p1:, :m1], D[p1:, m1:]
    M = np.linalg.inv(np.eye(ncon) - Dk @ D22)
    cu_x, cu_k, du = M @ Dk @ C2, M @ Ck, M @ Dk @ D21
    cy_x, cy_k, dy = C2 + D22 @ cu_x, D22 @ cu_k, D21 + D22 @ du
    Acl = np.block([[A + B2 @ cu_x, B2 @ cu_k], [Bk @ cy_x, Ak + Bk @ cy_k]])
    Bcl = np.vstack([B1 + B2 @ du, Bk @ dy])
    Ccl = np.hstack([C1 + D12 @ cu_x, D12 @ cu_k])
    return Acl, Bcl, Ccl, D11 + D12 @ du


def h2(cl, discrete):
    A, B, C, D = cl
    if discrete:
        if max(abs(np.linalg.eigvals(A))) >= 1:
            return np.inf
        P = sl.solve_discrete_lyapunov(A, B @ B.T)
        return float(np.sqrt(np.trace(C @ P @ C.T + D @ D.T)))
    if max(np.linalg.eigvals(A).real) >= 0:
        return np.inf
    P = sl.solve_continuous_lyapunov(A, -B @ B.T)
    return float(np.sqrt(np.trace(C @ P @ C.T)))


def hinf_discrete(cl):
    A, B, C, D = cl
    if max(abs(np.linalg.eigvals(A))) >= 1:
        return np.inf
    n = A.shape[0]

    def sig(th):
        g = C @ np.linalg.solve(np.exp(1j * th) * np.eye(n) - A, B) + D
        return np.linalg.svd(g, compute_uv=False)[0]

    grid = np.linspace(0, np.pi, 4000)
    vals = [sig(t) for t in grid]
    i = int(np.argmax(vals))
    fine = np.linspace(grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)], 2001)
    return float(max(max(vals), max(sig(t) for t in fine)))


def psd(M, tol=1e-9):
    M = 0.5 * (M + M.T)
    return np.linalg.eigvalsh(M).min() >= -tol * max(1.0, np.abs(M).max())

def pd(M):
    M = 0.5 * (M + M.T)
    return np.linalg.eigvalsh(M).min() > 0

def dare_stab(A, B, Q, R, S):
    X = sl.solve_discrete_are(A, B, Q, R, s=S)
    K = np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A + S.T)
    res = A.T @ X @ A - X - (A.T @ X @ B + S) @ K + Q
    if np.abs(res).max() > 1e-6 * max(1.0, np.abs(X).max()):
        raise np.linalg.LinAlgError("residual")
    if max(abs(np.linalg.eigvals(A - B @ K))) >= 1:
        raise np.linalg.LinAlgError("not stabilising")
    return X

def conditions(p, ncon, nmeas, g):
    A, B, C, D = p
    n = A.shape[0]; m1 = B.shape[1] - ncon; p1 = C.shape[0] - nmeas; m2, p2 = ncon, nmeas
    B1, B2, C1, C2 = B[:, :m1], B[:, m1:], C[:p1], C[p1:]
    D1 = D[:p1]; D21 = D[p1:, :m1]
    g2 = g * g
    R0 = D1.T @ D1; R0[:m1, :m1] -= g2 * np.eye(m1)
    try:
        X = dare_stab(A, B, C1.T @ C1, R0, C1.T @ D1)
    except (np.linalg.LinAlgError, ValueError) as e:
        return "X: %s" % e
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
    S0 = Dt @ Dt.T; S0[:m2, :m2] -= g2 * np.eye(m2)
    try:
        Z = dare_stab(At.T, Ct.T, Bt1 @ Bt1.T, S0, Bt1 @ Dt.T)
    except (np.linalg.LinAlgError, ValueError) as e:
        return "Z: %s" % e
    if not psd(Z):
        return "Z not PSD"
    St = S0 + Ct @ Z @ Ct.T
    St1, St2, St3 = St[:m2, :m2], St[:m2, m2:], St[m2:, m2:]
    if not pd(St3):
        return "St3"
    if not pd(-(St1 - St2 @ np.linalg.solve(St3, St2.T))):
        return "St"
    return None


def random_plant(rng, n, m1, m2, p1, p2, discrete, d11, d22):
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
    return A, B, C, D


def sb10dd(p, ncon, nmeas, gamma):
    A, B, C, D = p
    n, m, q = A.shape[0], B.shape[1], C.shape[0]
    try:
        r = slycot.sb10dd(n, m, q, ncon, nmeas, gamma, A, B, C, D)
    except Exception:
        return None
    return r[1:5]


def discrete_h2_case(rng, name, dims, d22):
    p = random_plant(rng, *dims, True, True, d22)
    ncon, nmeas = dims[2], dims[4]
    vals = []
    for g in GAMMAS_H2:
        k = sb10dd(p, ncon, nmeas, g)
        vals.append(np.inf if k is None else h2(closed_loop(p, k, ncon, nmeas), True))
    # The pair of consecutive levels that agree best: beyond it SB10DD's
    # rounding (R0 ~ -gamma^2 I) takes over from the 1/gamma^2 convergence.
    diffs = [abs(vals[i] / vals[i + 1] - 1) if np.isfinite(vals[i] + vals[i + 1]) else np.inf
             for i in range(len(vals) - 1)]
    i = int(np.argmin(diffs))
    if not diffs[i] < 1e-8:
        print(f"{name}: dropped (SB10DD at large gamma does not settle: {vals})")
        return None
    return {"kind": "h2", "ts": 1.0, "h2_reference": vals[i + 1],
            "h2_reference_spread": diffs[i], "reference_gamma": GAMMAS_H2[i + 1]}, p


def continuous_h2_case(rng, name, dims, d22):
    p = random_plant(rng, *dims, False, False, d22)
    A, B, C, D = p
    ncon, nmeas = dims[2], dims[4]
    try:
        r = slycot.sb10hd(A.shape[0], B.shape[1], C.shape[0], ncon, nmeas, A, B, C, D)
    except Exception as e:
        print(f"{name}: dropped (SB10HD: {e})")
        return None
    val = h2(closed_loop(p, r[:4], ncon, nmeas), False)
    return {"kind": "h2", "ts": None, "h2_reference": val}, p


def discrete_hinf_case(rng, name, dims, d22):
    p = random_plant(rng, *dims, True, True, d22)
    ncon, nmeas = dims[2], dims[4]

    def verified(g):
        k = sb10dd(p, ncon, nmeas, g)
        if k is None:
            return None
        norm = hinf_discrete(closed_loop(p, k, ncon, nmeas))
        return norm if norm <= g * (1 + 1e-6) else None

    hi = 1.0
    while verified(hi) is None:
        hi *= 2
        if hi > 1e7:
            print(f"{name}: dropped (no verified SB10DD controller up to 1e7)")
            return None
    lo = hi / 2 if hi > 1 else 0.0
    while hi - lo > 1e-5 * hi:
        mid = 0.5 * (lo + hi)
        if verified(mid) is None:
            lo = mid
        else:
            hi = mid
    # The discrete Riccati conditions (SB10DD's, plus X >= 0 and Z >= 0),
    # evaluated here with SciPy's DARE solver, must hold just above the
    # verified level; just below it they show where gamma cannot go.
    above = conditions(p, ncon, nmeas, hi * (1 + 1e-4))
    if above is not None:
        print(f"{name}: dropped (conditions fail above the verified level: {above})")
        return None
    below = conditions(p, ncon, nmeas, hi * (1 - 1e-4))
    return {"kind": "hinf", "ts": 1.0, "slycot_verified_gamma": hi,
            "slycot_achieved": verified(hi),
            "conditions_below": {"gamma": hi * (1 - 1e-4), "fails": below}}, p


def main():
    rng = np.random.default_rng(20261126)
    cases = []
    plan = [
        # (builder, n, m1, m2, p1, p2, d22)
        (discrete_h2_case, 2, 2, 1, 2, 1, False),
        (discrete_h2_case, 4, 3, 2, 3, 2, True),
        (discrete_h2_case, 8, 2, 1, 2, 1, True),
        (discrete_h2_case, 12, 3, 2, 3, 2, False),
        (discrete_h2_case, 20, 3, 1, 2, 2, True),
        (discrete_h2_case, 40, 3, 2, 3, 2, True),
        (continuous_h2_case, 3, 2, 1, 2, 1, False),
        (continuous_h2_case, 6, 3, 2, 3, 2, True),
        (continuous_h2_case, 15, 2, 1, 2, 1, False),
        (continuous_h2_case, 40, 3, 2, 3, 2, True),
        (discrete_hinf_case, 2, 2, 1, 2, 1, False),
        (discrete_hinf_case, 4, 3, 2, 3, 2, True),
        (discrete_hinf_case, 8, 2, 1, 2, 1, True),
        (discrete_hinf_case, 16, 3, 2, 3, 2, False),
        (discrete_hinf_case, 40, 2, 1, 2, 1, True),
    ]
    for i, (builder, n, m1, m2, p1, p2, d22) in enumerate(plan):
        name = f"{builder.__name__.replace('_case', '')}_{i}_n{n}"
        got = builder(rng, name, (n, m1, m2, p1, p2), d22)
        if got is None:
            continue
        ref, (A, B, C, D) = got
        ref.update({"name": name, "nmeas": p2, "ncon": m2, "a": A.tolist(),
                    "b": B.tolist(), "c": C.tolist(), "d": D.tolist()})
        cases.append(ref)
        print(name, {k: v for k, v in ref.items() if k not in "abcd"})
    meta = {"generator": "tests/data/synth_corpus/generate.py",
            "slycot": slycot.__version__, "numpy": np.__version__,
            "scipy": __import__("scipy").__version__, "seed": 20261126}
    with open(__file__.replace("generate.py", "cases.json"), "w") as f:
        json.dump({"meta": meta, "cases": cases}, f)


if __name__ == "__main__":
    main()
