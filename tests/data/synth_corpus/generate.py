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
  alone do not give (its gamma is not trusted without that check).
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
    return {"kind": "hinf", "ts": 1.0, "slycot_verified_gamma": hi,
            "slycot_achieved": verified(hi)}, p


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
