#!/usr/bin/env python3
"""Exact step-response figures of continuous transfer functions for
`tests/suite/responses.rs` (docs/responses.md §2), computed independently of fts
with mpmath at 30 digits from the partial-fraction closed form

    y(t) = N(0)/D(0) + sum_k N(p_k) / (p_k D'(p_k)) e^{p_k t}   (simple poles p_k)

and its derivative h(t) = sum_k N(p_k)/D'(p_k) e^{p_k t}. Every zero of h is
bracketed on a grid whose step is 0.05/|p| for the fastest pole p not yet
decayed by e^-30, up to the time the slowest pole has decayed by 1e-4, and
refined by mpmath.findroot; the crossings of 10 %, 90 % and the 2 % band
the same way on y.

Run once from the repository root (needs mpmath only):
    python3 tests/data/responses/gen_exact_figures.py
It writes tests/data/responses/exact_figures.json next to itself.
"""
import json
import os

import mpmath as mp

mp.mp.dps = 30

CASES = [
    # The stiff system of issue #27: poles -0.01 and -50 +- 1000j (a 691 s
    # slow mode beside a 1 ms fast one); its peak is in the first 2 ms.
    ("stiff", [5000.01, 51.0, 10000.0], [1.0, 100.01, 1000001.0, 10000.0]),
    # The lightly damped 1/(s^2 + 0.002 s + 1): zeta = 0.001.
    ("light", [1.0], [1.0, 0.002, 1.0]),
]


def polyval(c, x):
    v = mp.mpf(0)
    for a in c:
        v = v * x + a
    return v


def deriv(c):
    n = len(c) - 1
    return [c[i] * (n - i) for i in range(n)]


def closed_form(num, den):
    num = [mp.mpf(repr(a)) for a in num]
    den = [mp.mpf(repr(a)) for a in den]
    poles = mp.polyroots(den, maxsteps=200, extraprec=200)
    dd = deriv(den)
    res = [polyval(num, p) / polyval(dd, p) for p in poles]
    yf = polyval(num, 0) / polyval(den, 0)

    def y(t):
        t = mp.mpf(t)
        return mp.re(yf + sum(r / p * mp.e ** (p * t) for r, p in zip(res, poles)))

    def h(t):
        t = mp.mpf(t)
        return mp.re(sum(r * mp.e ** (p * t) for r, p in zip(res, poles)))

    return poles, yf, y, h


def grid(poles):
    slow = min(abs(mp.re(p)) for p in poles)
    horizon = mp.log(10**4) / slow
    t, out = mp.mpf(0), []
    while t <= horizon:
        out.append(t)
        alive = [p for p in poles if mp.re(p) * t > -30]
        t += min(mp.mpf("0.05") / abs(p) for p in alive)
    return out


def refine(f, a, b):
    return mp.findroot(f, (a, b), solver="anderson")


def figures(num, den):
    poles, yf, y, h = closed_form(num, den)
    ts = grid(poles)
    ys = [y(t) for t in ts]
    hs = [h(t) for t in ts]
    # Global extremes of y: endpoints and every sign change of h.
    cands = [(ts[0], ys[0]), (ts[-1], ys[-1])]
    for k in range(1, len(ts)):
        if hs[k - 1] * hs[k] < 0:
            tk = refine(h, ts[k - 1], ts[k])
            cands.append((tk, y(tk)))
    tp, yp = max(cands, key=lambda c: abs(c[1]))
    tu, yu = min(cands, key=lambda c: c[1] * mp.sign(yf))

    def first_crossing(level):
        for k in range(len(ts)):
            if ys[k] >= level:
                return refine(lambda t: y(t) - level, ts[k - 1], ts[k])
        return None

    t10, t90 = first_crossing(yf / 10), first_crossing(yf * 9 / 10)
    # Settling (MATLAB stepinfo): the last time |y - yf| equals 2 % of its
    # peak max |y - yf|, reached at an extremum or an end.
    band = mp.mpf("0.02") * max(abs(c[1] - yf) for c in cands)
    last = max(k for k in range(len(ts)) if abs(ys[k] - yf) >= band)
    edge = yf + band * mp.sign(ys[last] - yf)
    tset = refine(lambda t: y(t) - edge, ts[last], ts[last + 1])
    return {
        "poles": [[float(mp.re(p)), float(mp.im(p))] for p in poles],
        "steady_state": float(yf),
        "peak": float(abs(yp)),
        "peak_time": float(tp),
        "overshoot": float(100 * (yp - yf) / yf),
        "undershoot": float(-100 * yu / yf) if yu * yf < 0 else 0.0,
        "undershoot_time": float(tu),
        "rise_time": float(t90 - t10),
        "t10": float(t10),
        "t90": float(t90),
        "settling_time": float(tset),
    }


def main():
    out = {"generator": "gen_exact_figures.py (mpmath %s, 30 digits)" % mp.__version__,
           "cases": []}
    for name, num, den in CASES:
        f = figures(num, den)
        f.update({"name": name, "num": num, "den": den})
        out["cases"].append(f)
        print(name, f)
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "exact_figures.json")
    with open(path, "w") as fh:
        json.dump(out, fh, indent=1)
        fh.write("\n")


if __name__ == "__main__":
    main()
