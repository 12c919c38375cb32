"""H2 synthesis and system analysis against SLICOT in process (issue #30).

    python3 benches/h2_ssinfo_slicot.py write DIR        # DIR/H<n>.json, DIR/S<n>.json (fts.ss/1)
    OPENBLAS_NUM_THREADS=1 python3 benches/h2_ssinfo_slicot.py inprocess DIR [ORDER...]
    python3 benches/h2_ssinfo_slicot.py time DIR FTS [ORDER...]

Plants, order n in 10, 50, 100, 200 (seed 20261130 + n):

* `H<n>.json`, the generalised plant of `fts h2`: inputs [w1 w2 u], outputs
  [z1 z2 y], D11 = 0, D12 = [0; 1], D21 = [0 1], D22 = 0, A random with its
  spectrum shifted left by 1 + sqrt(n) (the H-inf plants' shape,
  benches/hinf_scaling.py). SLICOT's peer is SB10HD (H2 controller).
* `S<n>.json`, the system of `fts ss-info`: two inputs, two outputs, D = 0,
  the same kind of A. SLICOT's peers, all of what `ss-info` prints: the
  poles (LAPACK dgeev through numpy), the invariant zeros (AB08ND, then the
  generalised eigenvalues of its reduced pencil), the H2 norm (AB13BD) and
  the H-inf norm with its frequency (AB13DD).

`inprocess` calls slycot's wrappers of those routines directly (no
python-control), one BLAS thread, and prints the median of 7 timed calls
after one warm-up, with the figures computed. `time` runs `FTS h2 ...` and
`FTS ss-info ... --json` as whole processes, 5 times each, and prints the
medians of their CPU (user + system) and wall times with the figures printed.
"""
import json
import os
import resource
import statistics
import subprocess
import sys
import time as clock

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hinf_scaling import plant as hinf_plant  # noqa: E402

ORDERS = [10, 50, 100, 200]


def stable_a(rng, n):
    return rng.uniform(-1, 1, (n, n)) - (1 + np.sqrt(n)) * np.eye(n)


def h2_plant(n):
    # The H-inf scaling table's plant (benches/hinf_scaling.py), another seed.
    return hinf_plant(n, seed=20261130)


def analysed_system(n):
    rng = np.random.default_rng(20261130 + 1000 + n)
    a = stable_a(rng, n)
    b = rng.uniform(-1, 1, (n, 2))
    c = rng.uniform(-1, 1, (2, n))
    return a, b, c, np.zeros((2, 2))


def dump(path, a, b, c, d):
    doc = {"format": "fts.ss/1", "ts": None, "a": a.tolist(), "b": b.tolist(),
           "c": c.tolist(), "d": d.tolist()}
    with open(path, "w") as f:
        json.dump(doc, f)


def write(folder):
    os.makedirs(folder, exist_ok=True)
    for n in ORDERS:
        dump(os.path.join(folder, f"H{n}.json"), *h2_plant(n))
        dump(os.path.join(folder, f"S{n}.json"), *analysed_system(n))


def median_ms(call):
    call()
    times = []
    for _ in range(7):
        t0 = clock.perf_counter()
        call()
        times.append(clock.perf_counter() - t0)
    return statistics.median(times) * 1e3


def h2_norm_of_loop(a, b, c, d, ak, bk, ck, dk):
    """H2 norm of F_l(P, K) (D11 = D22 = 0, Dk = 0), by a Lyapunov equation."""
    import scipy.linalg as sl
    n, nk = a.shape[0], ak.shape[0]
    b1, b2 = b[:, :2], b[:, 2:]
    c1, c2 = c[:2, :], c[2:, :]
    d12, d21 = d[:2, 2:], d[2:, :2]
    acl = np.block([[a + b2 @ dk @ c2, b2 @ ck], [bk @ c2, ak]])
    bcl = np.vstack([b1 + b2 @ dk @ d21, bk @ d21])
    ccl = np.hstack([c1 + d12 @ dk @ c2, d12 @ ck])
    assert nk == ak.shape[0]
    x = sl.solve_continuous_lyapunov(acl, -bcl @ bcl.T)
    return float(np.sqrt(np.trace(ccl @ x @ ccl.T)))


def inprocess(folder, *orders):
    import scipy.linalg as sl
    from slycot import ab08nd, ab13bd, ab13dd, sb10hd

    for n in [int(o) for o in orders] or ORDERS:
        a, b, c, d = (np.array(json.load(open(os.path.join(folder, f"H{n}.json")))[k], dtype=float)
                      for k in "abcd")
        h2 = lambda: sb10hd(n, 3, 3, 1, 1, a, b, c, d)
        ak, bk, ck, dk, _ = h2()
        t_h2 = median_ms(h2)
        achieved = h2_norm_of_loop(a, b, c, d, ak, bk, ck, dk)
        print(f"order {n}: SB10HD in process: median {t_h2:.2f} ms, closed-loop H2 norm {achieved:.10f}",
              flush=True)

        sa, sb, sc, sd = (np.array(json.load(open(os.path.join(folder, f"S{n}.json")))[k], dtype=float)
                          for k in "abcd")
        e = np.eye(n)

        def analysis():
            poles = np.linalg.eigvals(sa)
            out = ab08nd(n, 2, 2, sa, sb, sc, sd, equil="S")
            nu, af, bf = out[0], out[-2], out[-1]
            zeros = sl.eigvals(af[:nu, :nu], bf[:nu, :nu]) if nu > 0 else np.array([])
            h2n = ab13bd("C", "H", n, 2, 2, sa, sb, sc, sd)
            gpeak, fpeak = ab13dd("C", "I", "S", "Z", n, 2, 2, sa, e, sb, sc, sd)[:2]
            return poles, zeros, h2n, gpeak, fpeak

        poles, zeros, h2n, gpeak, fpeak = analysis()
        t_an = median_ms(analysis)
        peak, omega = gpeak, fpeak
        print(f"order {n}: AB13DD + AB13BD + AB08ND + eigenvalues in process: median {t_an:.2f} ms; "
              f"{len(poles)} poles, {len(zeros)} zeros, H2 {h2n:.10f}, H-inf {peak:.10f} at {omega:.6f} rad/s",
              flush=True)


def whole_process(argv, runs=5):
    cpu, wall, out = [], [], ""
    for _ in range(runs):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = clock.perf_counter()
        done = subprocess.run(argv, capture_output=True, text=True, check=True)
        wall.append(clock.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        out = done.stdout
    return statistics.median(cpu) * 1e3, statistics.median(wall) * 1e3, out


def time(folder, fts, *orders):
    for n in [int(o) for o in orders] or ORDERS:
        plant = os.path.join(folder, f"H{n}.json")
        k = os.path.join(folder, f"K{n}.json")
        cpu, wall, out = whole_process([fts, "h2", "--generalized", plant, "--nmeas", "1", "--ncon", "1",
                                        "-o", k, "--json"])
        norm = json.loads(out).get("h2_norm")
        print(f"order {n}: fts h2 whole process: median {cpu:.1f} ms CPU ({wall:.1f} ms wall), "
              f"closed-loop H2 norm {norm}", flush=True)
        system = os.path.join(folder, f"S{n}.json")
        cpu, wall, out = whole_process([fts, "ss-info", system, "--json"])
        info = json.loads(out)
        print(f"order {n}: fts ss-info whole process: median {cpu:.1f} ms CPU ({wall:.1f} ms wall); "
              f"{len(info['poles'])} poles, {len(info['zeros'])} zeros, H2 {info['h2_norm']}, "
              f"H-inf {info['hinf_norm']} at {info['hinf_omega']} rad/s", flush=True)


if __name__ == "__main__":
    {"write": write, "inprocess": inprocess, "time": time}[sys.argv[1]](*sys.argv[2:])
