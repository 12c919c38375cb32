#!/usr/bin/env python3
"""Reference conversions for `tests/suite/conversions.rs`, computed with
python-control (with slycot) and scipy.

* `tf2ss` / `ss2tf`: state-space realisations are not unique, so the test
  compares frequency responses; stored are the systems and python-control's
  responses at a few frequencies (rad/s; for discrete systems
  `z = exp(j w ts)`), per channel for MIMO systems (`ss2tf` per channel).
* `zpk`: `scipy.signal.tf2zpk` of each channel's transfer function (descending
  powers of s, or of z for discrete systems): zeros, poles, gain.
* `minreal`: the minimal order from slycot `tb01pd` (and `control.minreal`'s,
  which differs on the unobservable case: it passes tol=0).
* `balred`: `control.hsvd` Hankel singular values, `control.balred(sys,
  r, method="truncate")` and the bound 2 sum(hsv[r:]); the reduced model's
  frequency response at the stored frequencies. Discrete: Gramians by scipy,
  the reduction and the stored singular values by slycot `ab09ad` with `dico='D'` (python-control's balred
  treats every system as continuous).
* `d2c`: python-control has no d2c; the continuous A, B are
  `scipy.linalg.logm([[Ad, Bd], [0, I]]) / ts` (the MATLAB-equivalent ZOH
  inverse), with Ad, Bd from `control.c2d(sys, ts, "zoh")`.

Run once from the repository root: python3 tests/data/responses/gen_conversions.py
"""
import json
import os

import control
import numpy as np
import scipy
import scipy.linalg
import scipy.signal
import slycot

W = [0.01, 0.3, 1.0, 3.0, 10.0, 30.0]


def ss_dict(sys):
    sys = control.ss(sys)
    return {
        "a": np.atleast_2d(sys.A).tolist() if sys.nstates else [],
        "b": np.atleast_2d(sys.B).tolist() if sys.nstates else [],
        "c": np.atleast_2d(sys.C).tolist() if sys.nstates else [[] for _ in range(sys.noutputs)],
        "d": np.atleast_2d(sys.D).tolist(),
        "ts": None if sys.dt in (0, None) else float(sys.dt),
    }


def freqresp(sys, ws):
    """outputs x inputs x len(ws) x [re, im]."""
    out = []
    for w in ws:
        x = 1j * w if sys.dt in (0, None) else np.exp(1j * w * sys.dt)
        out.append(np.atleast_2d(sys(x)))
    out = np.array(out)  # len(ws) x ny x nu
    return [[[[float(v.real), float(v.imag)] for v in out[:, i, j]] for j in range(out.shape[2])]
            for i in range(out.shape[1])]


def pairs(v):
    v = sorted(np.atleast_1d(v), key=lambda z: (round(z.real, 9), z.imag))
    return [[float(z.real), float(z.imag)] for z in v]


def discrete_ws(ts):
    nyq = np.pi / ts
    return [f * nyq for f in [0.001, 0.01, 0.1, 0.3, 0.7, 0.95]]


def siso_tf_case(name, num, den, ts=None):
    g = control.tf(num, den) if ts is None else control.tf(num, den, ts)
    ws = W if ts is None else discrete_ws(ts)
    z, p, k = scipy.signal.tf2zpk(num, den)
    return {
        "name": name,
        "num": list(map(float, num)),
        "den": list(map(float, den)),
        "ts": ts,
        "w": ws,
        "response": freqresp(g, ws),
        "zeros": pairs(z),
        "poles": pairs(p),
        "gain": float(k),
    }


def ss_case(name, sys):
    ws = W if sys.dt in (0, None) else discrete_ws(sys.dt)
    chans = []
    for i in range(sys.noutputs):
        for j in range(sys.ninputs):
            num, den = scipy.signal.ss2tf(sys.A, sys.B, sys.C, sys.D, input=j)
            num = num[i]
            z, p, k = scipy.signal.tf2zpk(num, den)
            chans.append({"output": i + 1, "input": j + 1, "zeros": pairs(z), "poles": pairs(p),
                          "gain": float(k)})
    return {"name": name, "sys": ss_dict(sys), "w": ws, "response": freqresp(sys, ws), "zpk": chans}


def main():
    s = control.tf("s")
    out = {"generator": f"python-control {control.__version__}, scipy {scipy.__version__}"}
    # tf -> ss (frequency responses), zpk of tfs.
    out["tf"] = [
        siso_tf_case("3rd order with two zeros", [2.0, 3.0, 4.0], [1.0, 6.0, 11.0, 6.0]),
        siso_tf_case("biproper with gain 0.5", [0.5, 1.0], [1.0, 4.0]),
        siso_tf_case("lightly damped mode", [1e4], [1.0, 2.0, 1e4]),
        siso_tf_case("discrete z^-1 form (descending z: 0.5 z + 0.2 over z^2 - 1.2 z + 0.5)",
                     [0.5, 0.2], [1.0, -1.2, 0.5], ts=0.01),
        siso_tf_case("discrete with zero at origin (z over z - 0.5)", [1.0, 0.0], [1.0, -0.5], ts=0.1),
    ]
    # ss -> tf per channel.
    mimo = control.ss([[-1, 0.5, 0], [-0.5, -2, 1], [0, 0, -3]],
                      [[1, 0], [0.3, 1], [0, 2]],
                      [[1, 0, 0.5], [0.2, 1, 0]],
                      [[0, 0], [0.1, 0]])
    siso = control.ss([[-0.2, 5.0], [-5.0, -0.2]], [[1.0], [0.5]], [[0.3, 1.0]], [[0.0]])
    dmimo = control.c2d(mimo, 0.05, "zoh")
    out["ss"] = [ss_case("MIMO 2x3x2 continuous", mimo), ss_case("SISO oscillator", siso),
                 ss_case("MIMO discrete (zoh of the continuous one, ts 0.05)", dmimo)]
    # minreal: parallel duplicates and a pole-zero cancellation.
    g1 = control.ss(control.tf([1.0], [1.0, 3.0, 2.0]))
    dup = control.parallel(g1, g1)
    # (s+1)/((s+1)(s+2)(s+3)) in controllable canonical form (3 states, one unobservable);
    # control.ss(tf) would already be minimal.
    canc = control.ss(*scipy.signal.tf2ss([1.0, 1.0], [1.0, 6.0, 11.0, 6.0]))
    unobs = control.ss([[-1, 0, 0], [0, -2, 0], [0, 0, -5]], [[1], [1], [1]], [[1, 1, 0]], [[0]])
    out["minreal"] = []
    for name, sys in [("parallel duplicate", dup), ("pole-zero cancellation (s+1)", canc),
                      ("unobservable mode at -5", unobs)]:
        m = control.minreal(sys, verbose=False)
        # slycot tb01pd with its default tolerance; python-control's minreal
        # passes tol=0 and keeps the unobservable mode of the third case.
        nr = slycot.tb01pd(sys.nstates, sys.ninputs, sys.noutputs, sys.A, sys.B, sys.C)[3]
        out["minreal"].append({"name": name, "sys": ss_dict(sys), "order": int(nr),
                               "python_control_order": int(m.nstates),
                               "w": W, "response": freqresp(sys, W)})
    # balred.
    big = control.ss(1 / ((s + 1) * (s + 10) * (s + 100)) + 0.01 / (s + 0.5)
                     + 2 / (s**2 + 0.4 * s + 4))
    dbig = control.c2d(big, 0.05, "zoh")
    out["balred"] = []
    for name, sys in [("continuous 6 states", big), ("discrete 6 states, ts 0.05", dbig)]:
        ws = W if sys.dt in (0, None) else discrete_ws(sys.dt)
        if sys.dt in (0, None):
            hsv = control.hsvd(sys)
        else:
            # python-control's hsvd is continuous-only: discrete Gramians by scipy.
            P = scipy.linalg.solve_discrete_lyapunov(sys.A, sys.B @ sys.B.T)
            Q = scipy.linalg.solve_discrete_lyapunov(sys.A.T, sys.C.T @ sys.C)
            hsv = np.sort(np.sqrt(np.abs(np.linalg.eigvals(P @ Q))))[::-1]
        for r in [2, 4]:
            if sys.dt in (0, None):
                red = control.balred(sys, r, method="truncate")
            else:
                # python-control 0.10.2's balred passes dico='C' for every
                # system (its reduced discrete models are wrong): slycot
                # ab09ad with dico='D' directly.
                nr, ar, br, cr, hsv_d = slycot.ab09ad("D", "B", "N", sys.nstates, sys.ninputs,
                                                      sys.noutputs, sys.A, sys.B, sys.C, nr=r)
                # scipy's sqrt(eig(P Q)) agrees to 1e-9 absolute; slycot's
                # square-root method resolves the small ones better: stored.
                assert np.allclose(hsv_d, hsv, rtol=1e-6, atol=1e-9), (hsv_d, hsv)
                hsv = hsv_d
                red = control.ss(ar[:nr, :nr], br[:nr, :], cr[:, :nr], sys.D, sys.dt)
            resp = freqresp(red, ws)
            out["balred"].append({"name": f"{name}, order {r}", "sys": ss_dict(sys), "order": r,
                                  "hsv": list(map(float, hsv)),
                                  "bound": float(2 * np.sum(hsv[r:])),
                                  "w": ws, "response": resp})
    # d2c: logm of the augmented matrix.
    out["d2c"] = []
    for name, sys, ts in [("oscillator + real pole", control.ss([[0, 1, 0], [-25, -1, 0.5], [0, 0, -3]],
                                                                [[0], [1], [2]], [[1, 0, 1]], [[0]]), 0.02),
                          ("MIMO 2x3x2", mimo, 0.05),
                          ("double real pole (defective A)", control.ss(control.tf([4.0], [1.0, 4.0, 4.0])), 0.1)]:
        d = control.c2d(sys, ts, "zoh")
        n, m = d.nstates, d.ninputs
        big_m = np.block([[d.A, d.B], [np.zeros((m, n)), np.eye(m)]])
        lg = scipy.linalg.logm(big_m).real / ts
        out["d2c"].append({"name": name, "discrete": ss_dict(d), "a": lg[:n, :n].tolist(),
                           "b": lg[:n, n:].tolist()})
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "conversions.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
