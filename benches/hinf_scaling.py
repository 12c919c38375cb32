"""Random well-posed generalised plants for the H-infinity scaling table in
docs/benchmarks.md (issue #19): order n, inputs [w1 w2 u], outputs
[z1 z2 y], D12 = [0; 1], D21 = [0 1], A random with its spectrum shifted
left by 1 + sqrt(n) (seed 20261125 + n).

    python3 benches/hinf_scaling.py write DIR      # DIR/P<n>.json (fts.ss/1)
    python3 benches/hinf_scaling.py slycot DIR/P<n>.json   # SB10AD via python-control
    python3 benches/hinf_scaling.py time DIR FTS [RUNS_FTS RUNS_SB10AD]
    python3 benches/hinf_scaling.py reference DIR   # tests/data/hinf_scaling/sb10ad.json
    python3 benches/hinf_scaling.py filter DIR/P<n>.json GAMMA...  # Y Hamiltonian's axis gap
    python3 benches/hinf_scaling.py achieved DIR/P<n>.json  # SB10AD's claim and what its K achieves
    OPENBLAS_NUM_THREADS=1 python3 benches/hinf_scaling.py inprocess DIR [ORDER...]  # SB10AD alone, from gamma 10

`inprocess` is the fair peer of `cargo bench --bench hinf_scaling`: slycot's
sb10ad called directly (no python-control), its bisection started at
gamma = 10 (above every optimum of these plants), one BLAS thread, only the
call timed (median of 7 after one warm-up run), with its claimed gamma.

`time` runs, order by order (8 to 160), on one thread each, `FTS hinf --generalized DIR/P<n>.json --nmeas 1
--ncon 1` and the `slycot` command above side by side as whole processes
under `/usr/bin/time -v` (wall time and peak resident memory; each run's
wall and CPU (user + system) time also go to stderr: on a loaded machine
the CPU time of these one-thread processes is the steadier figure), RUNS_FTS
times (default 5) and RUNS_SB10AD times (default 3; one run from order 64,
where one run takes most of a minute; a run is stopped after
SB10AD_LIMIT_S), and prints the table of
docs/benchmarks.md (medians) plus each order's step against n^3.
The plants of orders 8 to 48 are also stored in tests/data/hinf_scaling/
for the criterion bench (benches/hinf_scaling.rs).
"""
import json
import os
import re
import statistics
import subprocess
import sys

import numpy as np

ORDERS = [8, 16, 32, 48, 64, 100, 128, 160]
SB10AD_LIMIT_S = 300  # one SB10AD run is stopped after this long


def plant(n, seed=20261125):
    rng = np.random.default_rng(seed + n)
    a = rng.uniform(-1, 1, (n, n)) - (1 + np.sqrt(n)) * np.eye(n)
    b = rng.uniform(-1, 1, (n, 3))
    c = rng.uniform(-1, 1, (3, n))
    d = np.zeros((3, 3))
    d[1, 2] = 1.0
    d[2, 1] = 1.0
    return a, b, c, d


def write(folder):
    for n in ORDERS:
        a, b, c, d = plant(n)
        doc = {"format": "fts.ss/1", "ts": None, "a": a.tolist(), "b": b.tolist(),
               "c": c.tolist(), "d": d.tolist()}
        with open(f"{folder}/P{n}.json", "w") as f:
            json.dump(doc, f)


def slycot(path):
    import control
    with open(path) as f:
        doc = json.load(f)
    p = control.ss(*(np.array(doc[k], dtype=float) for k in "abcd"))
    k, cl, gam, rcond = control.hinfsyn(p, 1, 1)
    print(f"gamma {gam:.9f}")


def reference(folder):
    """SB10AD's claimed gamma and the H-inf norm its own controller achieves
    (python-control `linfnorm` of the closed loop) for the orders stored in
    tests/data/hinf_scaling/, written to sb10ad.json there (read by
    tests/suite/hinf_scaling.rs)."""
    import control
    import slycot
    out = {"generator": "benches/hinf_scaling.py reference", "python_control": control.__version__,
           "slycot": slycot.__version__, "plants": {}}
    for n in (8, 16, 32, 48):
        a, b, c, d = plant(n)
        p = control.ss(a, b, c, d)
        k, cl, gam, _ = control.hinfsyn(p, 1, 1)
        achieved = control.linfnorm(cl)[0]
        out["plants"][f"P{n}"] = {"sb10ad_gamma": float(gam), "sb10ad_achieved": float(achieved),
                                  "sb10ad_closed_loop_stable": bool(max(cl.poles().real) < 0)}
    with open(f"{folder}/sb10ad.json", "w") as f:
        json.dump(out, f, indent=1)


def achieved(path):
    """SB10AD's claimed gamma, its closed loop's slowest pole and the H-inf
    norm its controller achieves (python-control `linfnorm`)."""
    import control
    with open(path) as f:
        doc = json.load(f)
    p = control.ss(*(np.array(doc[k], dtype=float) for k in "abcd"))
    k, cl, gam, rcond = control.hinfsyn(p, 1, 1)
    print(f"claim {gam:.9f}, max Re(pole) {max(cl.poles().real):.6f}, "
          f"achieved {control.linfnorm(cl)[0]:.9f}, rcond {list(rcond)}")


def filter_hamiltonian(path, *gammas):
    """The Hamiltonian of the Y (filter) Riccati equation of Thm 17.1 at each
    level (numpy, independently of fts): `min |Re lambda|` and how many
    eigenvalues have negative real part (n of 2n when the stabilising
    solution can exist). Eigenvalues on the imaginary axis at a level mean
    that no controller achieves it."""
    with open(path) as f:
        doc = json.load(f)
    a, b, c, d = (np.array(doc[k], dtype=float) for k in "abcd")
    b1, c2 = b[:, :2], c[2:]
    dd1 = d[:, :2]  # [D11; D21]
    cc = np.vstack([c[:2], c2])
    for g in map(float, gammas):
        rt = dd1 @ dd1.T - np.diag([g * g, g * g, 0.0])
        ri = np.linalg.inv(rt)
        at = a.T - cc.T @ ri @ dd1 @ b1.T
        gg = cc.T @ ri @ cc
        q = b1 @ b1.T - b1 @ dd1.T @ ri @ dd1 @ b1.T
        ev = np.linalg.eigvals(np.block([[at, -gg], [-q, -at.T]]))
        print(f"gamma {g}: min |Re lambda| {np.min(np.abs(ev.real)):.3e}, "
              f"{np.sum(ev.real < 0)} of {len(ev)} with Re < 0")


# fts runs on one thread (faer without rayon); OpenBLAS under python-control
# is held to one too: its spinning worker threads made SB10AD 40 times slower
# on a shared two-core machine.
ONE_THREAD = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")


def timed(argv, limit=None):
    """One whole-process run under /usr/bin/time -v: (wall s, MiB, stdout,
    CPU s = user + system); None past `limit` seconds."""
    try:
        res = subprocess.run(["/usr/bin/time", "-v"] + argv, capture_output=True, text=True,
                             timeout=limit, env=ONE_THREAD)
    except subprocess.TimeoutExpired:
        return None
    wall = re.search(r"Elapsed \(wall clock\) time.*: (?:(\d+):)?(\d+):([\d.]+)", res.stderr)
    hours, mins, secs = wall.groups()
    seconds = int(hours or 0) * 3600 + int(mins) * 60 + float(secs)
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", res.stderr).group(1))
    cpu = sum(float(x) for x in re.findall(r"(?:User|System) time \(seconds\): ([\d.]+)", res.stderr))
    print(f"#   {argv[1]} {argv[-1] if 'slycot' in argv else argv[3]}: wall {seconds:.2f} s, "
          f"cpu {cpu:.2f} s", file=sys.stderr, flush=True)
    return seconds, rss / 1024, res.stdout, cpu


def median_run(argv, runs, limit=None):
    """(median wall s, peak MiB, last stdout, median CPU s), or None."""
    out = [timed(argv, limit) for _ in range(runs)]
    if None in out:
        return None
    return (statistics.median(r[0] for r in out), max(r[1] for r in out), out[-1][2],
            statistics.median(r[3] for r in out))


def time(folder, fts, runs_fts="5", runs_sb10ad="3"):
    """The table of docs/benchmarks.md: per order, fts and SB10AD side by
    side (wall and CPU medians), fts's search iterations, and fts's step
    from the previous order against n^3, in CPU time (steadier than wall
    time on a shared machine)."""
    print("| order | fts wall s | fts CPU s | fts levels | fts gamma | SB10AD wall s | SB10AD CPU s "
          "| SB10AD gamma | SB10AD / fts (CPU) | fts CPU step (n^3 step) | fts MiB | SB10AD MiB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    last = None
    for n in ORDERS:
        path = f"{folder}/P{n}.json"
        t_f, m_f, out_f, c_f = median_run([fts, "hinf", "--generalized", path, "--nmeas", "1",
                                           "--ncon", "1", "--json"], int(runs_fts))
        runs = int(runs_sb10ad) if n < 64 else 1
        sb10ad = median_run(["python3", __file__, "slycot", path], runs, SB10AD_LIMIT_S)
        # /usr/bin/time reports CPU seconds to 0.01: an idle machine can
        # show 0.00 at the smallest orders; ratios use that resolution.
        c_f_ratio = max(c_f, 0.01)
        report = json.loads(out_f)
        g_f, levels = report["gamma"], report["bisection"]["iterations"]
        step = "" if last is None else f"{c_f_ratio / last[1]:.2f} ({(n / last[0]) ** 3:.2f})"
        if sb10ad is None:
            sb = f"> {SB10AD_LIMIT_S} (stopped) | | | > {SB10AD_LIMIT_S / c_f_ratio:.0f}"
            m_s = ""
        else:
            t_s, m_s, out_s, c_s = sb10ad
            sb = f"{t_s:.2f} | {c_s:.2f} | {float(out_s.split()[1]):.6f} | {c_s / c_f_ratio:.1f}"
            m_s = f"{m_s:.0f}"
        print(f"| {n} | {t_f:.3f} | {c_f:.3f} | {levels} | {g_f:.6f} | {sb} | {step} | {m_f:.1f} "
              f"| {m_s} |", flush=True)
        last = (n, c_f_ratio)


def inprocess(folder, *orders):
    import time as clock

    from slycot import sb10ad
    for n in [int(o) for o in orders] or [8, 16, 32, 48]:
        with open(os.path.join(folder, f"P{n}.json")) as f:
            doc = json.load(f)
        a, b, c, d = (np.array(doc[k], dtype=float) for k in "abcd")
        call = lambda: sb10ad(a.shape[0], b.shape[1], c.shape[0], 1, 1, 10.0, a, b, c, d)
        gamma = call()[0]
        times = []
        for _ in range(7):
            t0 = clock.perf_counter()
            call()
            times.append(clock.perf_counter() - t0)
        print(f"order {n}: SB10AD in process from gamma 10: median {statistics.median(times) * 1e3:.2f} ms "
              f"(min {min(times) * 1e3:.2f}), claimed gamma {gamma:.6f}")


if __name__ == "__main__":
    {"write": write, "slycot": slycot, "time": time, "reference": reference,
     "filter": filter_hamiltonian, "achieved": achieved, "inprocess": inprocess}[sys.argv[1]](*sys.argv[2:])
