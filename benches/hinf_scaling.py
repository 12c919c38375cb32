"""Random well-posed generalised plants for the H-infinity scaling table in
docs/benchmarks.md (issue #19): order n, inputs [w1 w2 u], outputs
[z1 z2 y], D12 = [0; 1], D21 = [0 1], A random with its spectrum shifted
left by 1 + sqrt(n) (seed 20261125 + n).

    python3 benches/hinf_scaling.py write DIR      # DIR/P<n>.json (fts.ss/1)
    python3 benches/hinf_scaling.py slycot DIR/P<n>.json   # SB10AD via python-control

`fts hinf --generalized DIR/P<n>.json --nmeas 1 --ncon 1` is timed beside
the `slycot` run as a whole process.
"""
import json
import sys

import numpy as np

ORDERS = [8, 16, 24, 32, 36, 38, 40, 48, 64, 80, 100]


def plant(n):
    rng = np.random.default_rng(20261125 + n)
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


if __name__ == "__main__":
    {"write": write, "slycot": slycot}[sys.argv[1]](sys.argv[2])
