"""Reference invariant zeros from SLICOT AB08ND (through slycot).

Run once from the repository root:

    python3 tests/data/zeros/generate.py

writes tests/data/zeros/cases.json. The cases (fixed seeds) are the AB08ND
documentation example (SLICOT-Reference examples/TAB08ND.f, AB08ND.dat) and
random systems: square of full normal rank, square with rank-deficient B or
C (normal rank below the size), tall (p > m) and wide (m > p), with and
without D, 1 to 8 states. Non-square systems get decoupling zeros (an
unobservable mode for tall, an uncontrollable one for wide) or outputs
(inputs) that repeat a square system's, so that they have zeros at all.
AB08ND runs without balancing (EQUIL = 'N') and with the tolerance fts
uses by default, TOL = (n+p)(n+m) eps; the zeros found with AB08ND's own
default, sqrt((n+p)(n+m)) eps, are stored too.
"""

import json
import os

import numpy as np
import scipy.linalg
import slycot

EPS = float(np.finfo(float).eps)
HERE = os.path.dirname(os.path.abspath(__file__))


def ab08nd(a, b, c, d, tol):
    n, m, p = a.shape[0], b.shape[1], c.shape[0]
    s = max(m, p)
    # AB08ND's documented upper bound on LDWORK, with room for blocking.
    ldwork = 4 * (max(s, n) + max(3 * s - 1, n + s)) + 64
    nu, rank, dinfz, nkror, nkrol, infz, kronr, kronl, af, bf = slycot.ab08nd(
        n, m, p, a, b, c, d, equil="N", tol=tol, ldwork=ldwork
    )
    if nu > 0:
        z = scipy.linalg.eigvals(af[:nu, :nu], bf[:nu, :nu])
    else:
        z = np.zeros(0, dtype=complex)
    return {
        "zeros_re": [float(x) for x in z.real],
        "zeros_im": [float(x) for x in z.imag],
        "normal_rank": int(rank),
        "infinite_orders": [int(x) for x in infz[:dinfz]],
        "right_kronecker": [int(x) for x in kronr[:nkror]],
        "left_kronecker": [int(x) for x in kronl[:nkrol]],
    }


def case(name, a, b, c, d):
    a, b, c, d = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (a, b, c, d))
    rows = lambda x: [[float(v) for v in r] for r in x]
    out = {"name": name, "n": a.shape[0], "m": b.shape[1], "p": c.shape[0]}
    out.update({"a": rows(a), "b": rows(b), "c": rows(c), "d": rows(d)})
    n, m, p = out["n"], out["m"], out["p"]
    # The tolerance fts uses by default, (n+p)(n+m) eps ...
    out["tol"] = (n + p) * (n + m) * EPS
    out.update(ab08nd(a, b, c, d, out["tol"]))
    # ... and the zeros AB08ND finds with its own default, sqrt((n+p)(n+m)) eps.
    default = ab08nd(a, b, c, d, 0.0)
    out["zeros_default_tol_re"] = default["zeros_re"]
    out["zeros_default_tol_im"] = default["zeros_im"]
    return out


def example():
    a = np.diag([1.0, 1.0, 3.0, -4.0, -1.0, 3.0])
    b = [[0, -1], [-1, 0], [1, -1], [0, 0], [0, 1], [-1, -1]]
    c = [[1, 0, 0, 1, 0, 0], [0, 1, 0, 1, 0, 1], [0, 0, 1, 0, 0, 1]]
    return case("ab08nd_example", a, b, c, np.zeros((3, 2)))


def stable_a(rng, n):
    return rng.standard_normal((n, n)) - 1.5 * np.sqrt(n) * np.eye(n)


def hide_mode(rng, a, c, lam):
    """A = Q [lam x; 0 A22] Q^T and C <- C (I - q q^T), q = Q[:, 0]: the
    mode lam becomes unobservable, an output decoupling zero."""
    n = a.shape[0]
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    top = np.hstack([[[lam]], rng.standard_normal((1, n - 1))])
    bottom = np.hstack([np.zeros((n - 1, 1)), stable_a(rng, n - 1)])
    a = q @ np.vstack([top, bottom]) @ q.T
    return a, c - np.outer(c @ q[:, 0], q[:, 0])


def square_full(k):
    rng = np.random.default_rng(1000 + k)
    n, m = 1 + k % 8, 1 + k % 3
    d = rng.standard_normal((m, m)) if k % 2 else np.zeros((m, m))
    b, c = rng.standard_normal((n, m)), rng.standard_normal((m, n))
    return case(f"square_full_{k}", stable_a(rng, n), b, c, d)


def square_rank_deficient(k):
    """B = Bl Br (or C = Cl Cr) with an inner dimension r < m; D shares the
    factor (or is zero), so the normal rank is at most r."""
    rng = np.random.default_rng(2000 + k)
    n, m = 1 + k % 8, 2 + k % 3
    r = 1 + (k // 3) % (m - 1)
    a = stable_a(rng, n)
    with_d = k % 4 >= 2
    if k % 2 == 0:
        br = rng.standard_normal((r, m))
        b = rng.standard_normal((n, r)) @ br
        c = rng.standard_normal((m, n))
        d = rng.standard_normal((m, r)) @ br if with_d else np.zeros((m, m))
    else:
        cl = rng.standard_normal((m, r))
        b = rng.standard_normal((n, m))
        c = cl @ rng.standard_normal((r, n))
        d = cl @ rng.standard_normal((r, m)) if with_d else np.zeros((m, m))
    # A hidden mode on top for two cases in three: unobservable, or (the
    # dual) uncontrollable.
    if n >= 2 and k % 3 == 0:
        a, c = hide_mode(rng, a, c, -0.3 - 0.2 * k)
    elif n >= 2 and k % 3 == 1:
        at, bt = hide_mode(rng, a.T, b.T, 0.5 - 0.1 * k)
        a, b = at.T, bt.T
    return case(f"square_rankdef_{k}", a, b, c, d)


def tall(k):
    """p > m. Even k: a square system's outputs plus combinations of them;
    odd k: generic outputs plus an unobservable mode."""
    rng = np.random.default_rng(3000 + k)
    n, m = 1 + k % 8, 1 + k % 2
    p = m + 1 + k % 2
    with_d = k % 4 >= 2
    a = stable_a(rng, n)
    b = rng.standard_normal((n, m))
    if k % 2 == 0:
        c1 = rng.standard_normal((m, n))
        d1 = rng.standard_normal((m, m)) if with_d else np.zeros((m, m))
        mix = rng.standard_normal((p - m, m))
        c, d = np.vstack([c1, mix @ c1]), np.vstack([d1, mix @ d1])
    else:
        c = rng.standard_normal((p, n))
        d = rng.standard_normal((p, m)) if with_d else np.zeros((p, m))
        if n >= 2:
            a, c = hide_mode(rng, a, c, -0.7 - 0.1 * k)
    return case(f"tall_{k}", a, b, c, d)


def wide(k):
    """m > p: the duals of the tall cases, regenerated with their own seeds."""
    t = tall(k + 100)
    a, b, c, d = (np.array(t[x]) for x in ("a", "b", "c", "d"))
    return case(f"wide_{k}", a.T, c.T, b.T, d.T)


def main():
    cases = [example()]
    cases += [square_full(k) for k in range(20)]
    cases += [square_rank_deficient(k) for k in range(30)]
    cases += [tall(k) for k in range(16)]
    cases += [wide(k) for k in range(16)]
    with open(os.path.join(HERE, "cases.json"), "w") as f:
        json.dump({"generator": "tests/data/zeros/generate.py",
                   "slycot": slycot.__version__, "cases": cases}, f, indent=1)
        f.write("\n")
    print(len(cases), "cases")
    for c in cases[:1] + cases[21:24] + cases[51:53] + cases[67:69]:
        print(c["name"], c["n"], c["m"], c["p"], c["normal_rank"], len(c["zeros_re"]),
              c["infinite_orders"], c["right_kronecker"], c["left_kronecker"])


if __name__ == "__main__":
    main()
