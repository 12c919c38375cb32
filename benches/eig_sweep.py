"""Size sweep of the eigenvalue-based commands (issue #19, docs/benchmarks.md
"Every size from 2 to 160 states"): random systems of every order n, written
with fixed seeds, and each command timed as a whole process per size.

    python3 benches/eig_sweep.py write DIR [NMIN NMAX]
    python3 benches/eig_sweep.py time DIR FTS [NMIN NMAX] [--runs R] [--only CMD,...]
    python3 benches/eig_sweep.py summary DIR
    python3 benches/eig_sweep.py recheck DIR FTS CMD N [--runs R]

`write` puts, for each order n (seed 20261127 + n):

* `S<n>.json`  (`fts ss-info`): a random stable 2-input 2-output continuous
  system, A uniform in [-1, 1] shifted left by 1 + sqrt(n).
* `P<n>.json`  (`fts h2`, `fts hinf`): a random well-posed continuous
  generalised plant, inputs [w1 w2 u], outputs [z1 z2 y], D12 = [0; 1],
  D21 = [0 1] (the recipe of benches/hinf_scaling.py).
* `Pd<n>.json` (`fts h2`, `fts hinf` on a discrete plant, ts = 1e-4): the
  same structure with A scaled to spectral radius 0.9.
* `G<n>.json`  (`fts mixsyn`): a random stable SISO plant (`fts.ss/1`), with
  `WS.json` = (s/2 + 10)/(s + 0.01) and `WU.json` = 0.1 shared by all sizes.
* `Z<n>.json`  (`fts zpetc`): a random discrete SISO `fts.tf/1` of order n:
  denominator 1 + a_1 z^-1 + ... + a_n z^-n, a_k uniform scaled to
  sum |a_k| = 0.5 (stable by Rouche), numerator of degree n - 1 with
  Gaussian coefficients (zeros near the unit circle, some outside), delay 1.

`time` runs each command R times per size (default 3) with
hyperfine and appends `command n median_s min_s max_s exit cpu_s` lines to
DIR/times.tsv (cpu_s: mean user + system time of the runs; on a shared
machine the CPU time of these one-thread processes is the steadier figure). Exit codes 1 (a result the command flags, e.g. an unstable
closed loop) are kept: the time is still the command's. `summary` prints,
per command, the largest ratio of a size's median to a neighbour's (n - 1 or
n + 1) and where it occurs. `recheck` re-times sizes N - 1, N, N + 1 of one
command back to back (R runs each, default 10) and appends them to
DIR/recheck.tsv: on a shared machine a single slow median is often a burst of
someone else's load, and only a ratio that survives this counts.
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

SEED = 20261127
COMMANDS = {
    "ss-info": lambda d, n: ["ss-info", f"{d}/S{n}.json"],
    "h2": lambda d, n: ["h2", "--generalized", f"{d}/P{n}.json", "--nmeas", "1", "--ncon", "1"],
    "hinf": lambda d, n: ["hinf", "--generalized", f"{d}/P{n}.json", "--nmeas", "1", "--ncon", "1"],
    "h2-discrete": lambda d, n: ["h2", "--generalized", f"{d}/Pd{n}.json", "--nmeas", "1", "--ncon", "1"],
    "hinf-discrete": lambda d, n: ["hinf", "--generalized", f"{d}/Pd{n}.json", "--nmeas", "1", "--ncon", "1"],
    "mixsyn": lambda d, n: ["mixsyn", "--plant", f"{d}/G{n}.json", "--ws", f"{d}/WS.json", "--wu", f"{d}/WU.json"],
    "zpetc": lambda d, n: ["zpetc", "--tf", f"{d}/Z{n}.json"],
}


def stable_a(rng, n):
    return rng.uniform(-1, 1, (n, n)) - (1 + np.sqrt(n)) * np.eye(n)


def ss_doc(a, b, c, d, ts=None):
    return {"format": "fts.ss/1", "ts": ts, "a": a.tolist(), "b": b.tolist(),
            "c": c.tolist(), "d": d.tolist()}


def generalised(rng, n, discrete):
    a = rng.uniform(-1, 1, (n, n))
    if discrete:
        a *= 0.9 / max(abs(np.linalg.eigvals(a)))
    else:
        a -= (1 + np.sqrt(n)) * np.eye(n)
    b = rng.uniform(-1, 1, (n, 3))
    c = rng.uniform(-1, 1, (3, n))
    d = np.zeros((3, 3))
    d[1, 2] = 1.0  # D12 = [0; 1]
    d[2, 1] = 1.0  # D21 = [0 1]
    return ss_doc(a, b, c, d, 1e-4 if discrete else None)


def zpetc_tf(rng, n):
    # den(z^-1) = 1 + a_1 z^-1 + ... + a_n z^-n with sum |a_k| = 0.5: every
    # pole is inside the unit circle (Rouche on |z| = 1, |z^n| = 1 > 0.5) and,
    # unlike a product of random poles expanded, stays so when the roots are
    # recomputed from the coefficients at order 160.
    a = rng.uniform(-1, 1, n)
    den = np.concatenate(([1.0], 0.5 * a / np.sum(np.abs(a))))
    num = rng.standard_normal(n)
    return {"format": "fts.tf/1", "var": "z^-1", "ts": 1e-4, "num": num.tolist(),
            "den": den.tolist(), "delay": 1}


def write_size(folder, n):
    rng = np.random.default_rng(SEED + n)
    docs = {
        "S": ss_doc(stable_a(rng, n), rng.uniform(-1, 1, (n, 2)), rng.uniform(-1, 1, (2, n)),
                    np.zeros((2, 2))),
        "P": generalised(rng, n, False),
        "Pd": generalised(rng, n, True),
        "G": ss_doc(stable_a(rng, n), rng.uniform(-1, 1, (n, 1)), rng.uniform(-1, 1, (1, n)),
                    np.zeros((1, 1))),
        "Z": zpetc_tf(rng, n),
    }
    for prefix, doc in docs.items():
        with open(f"{folder}/{prefix}{n}.json", "w") as f:
            json.dump(doc, f)


def write(folder, nmin=2, nmax=160):
    os.makedirs(folder, exist_ok=True)
    with open(f"{folder}/WS.json", "w") as f:
        json.dump({"format": "fts.tf/1", "var": "s", "num": [0.5, 10.0], "den": [1.0, 0.01]}, f)
    with open(f"{folder}/WU.json", "w") as f:
        json.dump({"format": "fts.tf/1", "var": "s", "num": [0.1], "den": [1.0]}, f)
    for n in range(int(nmin), int(nmax) + 1):
        write_size(folder, n)


def hyperfine(argv, runs):
    with tempfile.NamedTemporaryFile(suffix=".json") as out:
        # -N: no shell in between; -i: exit 1 (a flagged result) is still timed.
        subprocess.run(["hyperfine", "-N", "-i", "--runs", str(runs),
                        "--export-json", out.name, "--style", "none", " ".join(argv)],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        res = json.load(open(out.name))["results"][0]
    return (res["median"], res["min"], res["max"], max(res["exit_codes"]),
            res["user"] + res["system"])


def time(folder, fts, *rest):
    args = list(rest)
    runs, only = 3, list(COMMANDS)
    if "--runs" in args:
        i = args.index("--runs")
        runs = int(args[i + 1])
        del args[i:i + 2]
    if "--only" in args:
        i = args.index("--only")
        only = args[i + 1].split(",")
        del args[i:i + 2]
    nmin, nmax = (int(args[0]), int(args[1])) if args else (2, 160)
    with open(f"{folder}/times.tsv", "a") as log:
        for name in only:
            for n in range(nmin, nmax + 1):
                argv = [fts] + COMMANDS[name](folder, n)
                med, lo, hi, code, cpu = hyperfine(argv, runs)
                log.write(f"{name}\t{n}\t{med:.5f}\t{lo:.5f}\t{hi:.5f}\t{code}\t{cpu:.5f}\n")
                log.flush()


def worst_neighbour(by_n):
    """Largest ratio of a size's value to a neighbour's (n - 1 or n + 1)."""
    worst = (0.0, None)
    for n, t in by_n.items():
        for m in (n - 1, n + 1):
            if m in by_n and by_n[m] > 0:
                worst = max(worst, (t / by_n[m], (n, m)))
    return worst


def summary(folder):
    rows = {}
    for line in open(f"{folder}/times.tsv"):
        fields = line.rstrip("\n").split("\t")
        name, n, med, code = fields[0], int(fields[1]), float(fields[2]), int(fields[5])
        cpu = float(fields[6]) if len(fields) > 6 else None
        rows.setdefault(name, {})[n] = (med, code, cpu)  # last run of a size wins
    for name, by_n in rows.items():
        ns = sorted(by_n)
        wall = worst_neighbour({n: v[0] for n, v in by_n.items()})
        text = (f"{name}: n {ns[0]}..{ns[-1]}, median {by_n[ns[0]][0]:.3f} s at {ns[0]}, "
                f"{by_n[ns[-1]][0]:.3f} s at {ns[-1]}; largest wall ratio to a neighbour "
                f"{wall[0]:.2f} ({wall[1][0]} vs {wall[1][1]})")
        if all(v[2] is not None for v in by_n.values()):
            cpu = worst_neighbour({n: v[2] for n, v in by_n.items()})
            text += f", CPU {cpu[0]:.2f} ({cpu[1][0]} vs {cpu[1][1]})"
        codes = sorted({v[1] for v in by_n.values()})
        print(f"{text}; exit codes {codes}")


def recheck(folder, fts, name, n, *rest):
    runs = int(rest[1]) if rest[:1] == ("--runs",) else 10
    n = int(n)
    with open(f"{folder}/recheck.tsv", "a") as log:
        for m in (n - 1, n, n + 1):
            med, lo, hi, code, cpu = hyperfine([fts] + COMMANDS[name](folder, m), runs)
            line = f"{name}\t{m}\t{med:.5f}\t{lo:.5f}\t{hi:.5f}\t{code}\t{cpu:.5f}"
            log.write(line + "\n")
            print(line, flush=True)


if __name__ == "__main__":
    {"write": write, "time": time, "summary": summary, "recheck": recheck}[sys.argv[1]](*sys.argv[2:])
