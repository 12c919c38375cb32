#!/usr/bin/env python3
"""The peer of `cargo bench --bench hysteresis -- hysteresis_gd`: scipy's
L-BFGS-B on the same least-squares problem, same data, same operators, same
scaling and the same stopping rule as fts's gradient identification.

    OPENBLAS_NUM_THREADS=1 python3 benches/hysteresis_gd_scipy.py

The problem (docs/math.md section 1.5): the SmartHysteresis piezo record
(data/piezo-smarthysteresis, column 4 = V in, column 3 = um out, from row
16286: 33,715 samples), an offset column, the cube root of the input for
MPI-cbrt, and ten lower play operators on r_i = i/10 max|u|, started at 0.
The unknowns are scaled by the column norms of Phi (w = D x), as fts does.
Cost J(x) = ||Phi D x - y||^2 / (2N), started at x = 0.

Two formulations, both timed (scipy.optimize.minimize alone, the regressor
built beforehand; median of several runs, one BLAS thread):

* residual: J and its gradient from the residual Phi D x - y at every
  evaluation (what a scipy user writes);
* factor: the same J from the triangular factor of [Phi | y] (numpy's QR,
  formed once and not timed), which is what fts evaluates: O(p^2) per
  evaluation.

Stopping rule: fts stops when ||grad||_2 <= 1e-12 ||grad(0)||_2 or when an
iteration changes the cost by less than eps^2 J(0). L-BFGS-B is given
gtol = 1e-12 ||grad(0)||_2 on its max-norm (never stricter than fts's rule),
ftol = eps^2 J(0) (its change test, relative to max(|J|, 1) = 1 here), the
same memory (maxcor = 20) and iteration cap (2000).

Each row prints the iterations, the final cost, and the largest difference
of the weights from the least-squares solution (numpy lstsq), relative to
the largest weight: the fits agree when the solvers do.
"""
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.optimize import minimize  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
RECORD = os.path.join(HERE, "..", "data", "piezo-smarthysteresis", "hysteresis_v_150_1hz.csv")
START = 16286
EPS = np.finfo(float).eps


def record():
    data = np.genfromtxt(RECORD, delimiter=",")
    return data[START:, 3].copy(), data[START:, 2].copy()


def regressor(u, cbrt):
    n_ops = 10
    thresholds = np.arange(n_ops) / n_ops * np.max(np.abs(u))
    cols = [np.ones_like(u)]
    if cbrt:
        cols.append(np.cbrt(u))
    play = np.empty((len(u), n_ops))
    state = np.zeros(n_ops)
    for k, x in enumerate(u):
        # F(k) = max(u(k) - r, min(u(k), F(k-1))): the lower play, [Li21] Eq. 3.
        state = np.maximum(x - thresholds, np.minimum(x, state))
        play[k] = state
    return np.column_stack(cols + [play])


def residual_problem(phi_d, y):
    n = len(y)

    def fun(x):
        r = phi_d @ x - y
        return 0.5 * (r @ r) / n, (phi_d.T @ r) / n

    return fun


def factor_problem(phi_d, y):
    n, p = phi_d.shape
    r_aug = np.linalg.qr(np.column_stack([phi_d, y]), mode="r")
    r, z, floor = r_aug[:p, :p], r_aug[:p, p], 0.5 * r_aug[p, p] ** 2 / n

    def fun(x):
        e = r @ x - z
        return 0.5 * (e @ e) / n + floor, (r.T @ e) / n

    return fun


def solve(fun, p, tol_grad, tol_cost):
    return minimize(fun, np.zeros(p), jac=True, method="L-BFGS-B",
                    options={"maxcor": 20, "gtol": tol_grad, "ftol": tol_cost,
                             "maxiter": 2000, "maxfun": 100_000})


def main():
    u, y = record()
    print(f"scipy {scipy.__version__}, numpy {np.__version__}; {len(u)} samples")
    for name, cbrt in [("pi", False), ("mpi_cbrt", True)]:
        phi = regressor(u, cbrt)
        d = 1.0 / np.linalg.norm(phi, axis=0)
        phi_d = phi * d
        w_ls = np.linalg.lstsq(phi, y, rcond=None)[0]
        cost_ls = 0.5 * np.sum((phi @ w_ls - y) ** 2) / len(y)
        cost0, grad0 = residual_problem(phi_d, y)(np.zeros(phi.shape[1]))
        tol_grad = 1e-12 * np.linalg.norm(grad0)
        tol_cost = EPS * EPS * cost0
        print(f"{name}: p = {phi.shape[1]}, least-squares cost {cost_ls:.15e}")
        for form, make in [("residual", residual_problem), ("factor", factor_problem)]:
            fun = make(phi_d, y)
            times = []
            for _ in range(9):
                t0 = time.perf_counter()
                res = solve(fun, phi.shape[1], tol_grad, tol_cost)
                times.append(time.perf_counter() - t0)
            w = res.x * d
            dw = np.max(np.abs(w - w_ls)) / np.max(np.abs(w_ls))
            print(f"  scipy L-BFGS-B {form:8}: median {np.median(times) * 1e3:8.3f} ms "
                  f"(min {min(times) * 1e3:.3f}), {res.nit} iterations, {res.nfev} evaluations, "
                  f"cost {res.fun:.15e}, max|w - w_ls| / max|w_ls| {dw:.1e}; {res.message}")


if __name__ == "__main__":
    main()
