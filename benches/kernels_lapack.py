"""LAPACK's times for the factorisations of `cargo bench --bench kernels`
(issue #30: every Schur / QZ / Riccati / Lyapunov kernel within 3x of
LAPACK's time for the same factorisation), on the same matrices.

    OPENBLAS_NUM_THREADS=1 python3 benches/kernels_lapack.py [N ...]

The matrices are those of benches/kernels.rs, built from the same 64-bit
linear congruential sequence (seed 20261129 + n), so both sides factor
identical data: A (n x n, entries uniform in [-1, 1) / sqrt(n)), B (the next
n x n), the Hamiltonian H = [A, -I; -I, -A'] (2n x 2n, the CARE
A'X + XA - X X + I = 0), and the Lyapunov equation
(A - 2I) X + X (A - 2I)' + B B' = 0. scipy calls LAPACK directly: dgees
(real Schur with vectors), dgees sorted (the stable half of H first),
dgges (real QZ with both factors), and scipy's own Schur-method CARE and
Bartels-Stewart Lyapunov solvers. One thread; median of 7 after a warm-up.
"""
import os
import statistics
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.linalg as sl  # noqa: E402

MASK = (1 << 64) - 1


def uniform(seed, count):
    """The sequence of benches/kernels.rs: x <- 6364136223846793005 x +
    1442695040888963407 (mod 2^64), value (x >> 11) / 2^53 * 2 - 1."""
    out = np.empty(count)
    x = seed
    for k in range(count):
        x = (x * 6364136223846793005 + 1442695040888963407) & MASK
        out[k] = (x >> 11) / float(1 << 53) * 2.0 - 1.0
    return out


def matrices(n):
    u = uniform(20261129 + n, 2 * n * n)
    # Column-major, as faer fills Mat::from_fn column by column.
    a = u[: n * n].reshape(n, n, order="F") / np.sqrt(n)
    b = u[n * n:].reshape(n, n, order="F") / np.sqrt(n)
    return a, b


def timed(f, runs=7):
    f()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(sizes):
    print(f"numpy {np.__version__}, scipy {scipy.__version__}, one thread")
    for n in sizes:
        a, b = matrices(n)
        eye = np.eye(n)
        h = np.block([[a, -eye], [-eye, -a.T]])
        shifted = a - 2.0 * eye
        q = b @ b.T
        rows = [
            ("real_schur", lambda: sl.schur(a, output="real")),
            ("ordered_real_schur_hamiltonian", lambda: sl.schur(h, output="real", sort="lhp")),
            ("qz_real", lambda: sl.qz(a, b, output="real")),
            ("care", lambda: sl.solve_continuous_are(a, eye, eye, eye)),
            ("lyap", lambda: sl.solve_continuous_lyapunov(shifted, -q)),
        ]
        for name, f in rows:
            print(f"{name}/{n}: {timed(f) * 1e3:.3f} ms")


if __name__ == "__main__":
    main([int(s) for s in sys.argv[1:]] or [50, 100, 160, 200, 320])
