#!/usr/bin/env python3
"""Reference step and impulse responses for `tests/suite/responses.rs`, computed
with python-control (0.10.2 when generated).

Each case stores a system as state-space matrices (`a`, `b`, `c`, `d`,
`ts` null for continuous time), optionally a controller `k` (same form;
the case is then the closed loop T = feedback(G K, 1) from reference to
output, which python-control computes here and the test rebuilds from G
and K), the time grid (continuous: `numpy.linspace(0, t_final, n)`;
discrete: `n` samples at the sample time), and python-control's answers:

* `step_info(sys, T)` for every output/input channel (None when
  python-control returns NaN or +-inf for a figure);
* the step response `step_response(sys, T)` and impulse response
  `impulse_response(sys, T)` at every `stride`-th sample.

Run once from the repository root: python3 tests/data/responses/gen_step_info.py
It writes tests/data/responses/cases.json next to itself.
"""
import json
import math
import os

import control
import numpy as np


def ss_dict(sys):
    sys = control.ss(sys)
    return {
        "a": sys.A.tolist(),
        "b": sys.B.tolist(),
        "c": sys.C.tolist(),
        "d": sys.D.tolist(),
        "ts": None if sys.dt in (0, None) else float(sys.dt),
    }


def clean(x):
    x = float(x)
    return x if math.isfinite(x) else None


def info_dict(i):
    return {
        "rise_time": clean(i["RiseTime"]),
        "settling_time": clean(i["SettlingTime"]),
        "settling_min": clean(i["SettlingMin"]),
        "settling_max": clean(i["SettlingMax"]),
        "overshoot": clean(i["Overshoot"]),
        "undershoot": clean(i["Undershoot"]),
        "peak": clean(i["Peak"]),
        "peak_time": clean(i["PeakTime"]),
        "steady_state": clean(i["SteadyStateValue"]),
    }


def grid(sys, t_final, n):
    if sys.dt in (0, None):
        return np.linspace(0.0, t_final, n), {"t_final": t_final, "n": n}
    n = int(np.ceil(t_final / sys.dt)) + 1
    return np.arange(n) * sys.dt, {"t_final": t_final, "n": n}


def case(name, g, t_final, n, k=None, stride=None):
    sys = control.feedback(g * k, 1) if k is not None else g
    sys = control.ss(sys)
    T, grid_desc = grid(sys, t_final, n)
    stride = stride or max(1, len(T) // 60)
    stable = bool(np.all(np.abs(sys.poles()) < 1) if sys.dt else np.all(sys.poles().real < 0))
    if stable:
        info = control.step_info(sys, T)
        if sys.issiso():
            info = [[info]]
        info = [[info_dict(i) for i in row] for row in info]
    else:
        # python-control's figures of an unstable response are meaningless
        # (or an IndexError); fts refuses them, and nothing is stored.
        info = None
    step = control.step_response(sys, T, squeeze=False)
    imp = control.impulse_response(sys, T, squeeze=False)
    out = {
        "name": name,
        "g": ss_dict(g),
        "grid": grid_desc,
        "stride": stride,
        "stable": stable,
        "step_info": info,
        "dc_gain": np.atleast_2d(sys.dcgain()).tolist(),
        # outputs x inputs x samples (every stride-th)
        "step": step.outputs[:, :, ::stride].tolist(),
        "impulse": imp.outputs[:, :, ::stride].tolist(),
        "closed_loop_poles": None,
    }
    if k is not None:
        out["k"] = ss_dict(k)
        p = sys.poles()
        out["closed_loop_poles"] = [[float(z.real), float(z.imag)] for z in p]
    return out


def main():
    s = control.tf("s")
    cases = []
    # Continuous.
    cases.append(case("first order 1/(s+1)", 1 / (s + 1), 10.0, 1001))
    cases.append(case("second order wn=3 zeta=0.3", 9 / (s**2 + 1.8 * s + 9), 8.0, 2001))
    cases.append(
        case("non-minimum phase (1-s)/((s+1)(s+2)) x 2", 2 * (1 - s) / ((s + 1) * (s + 2)), 10.0, 2001)
    )
    cases.append(case("negative gain -3/(s^2+s+4)", -3 / (s**2 + s + 4), 15.0, 1501))
    cases.append(
        case(
            "FTS-like 2nd order plant with a zero, 2 kHz mode",
            control.tf([2e3, (2 * np.pi * 2000) ** 2], [1, 2 * 0.05 * 2 * np.pi * 2000, (2 * np.pi * 2000) ** 2]),
            5e-3,
            5001,
        )
    )
    mimo = control.ss([[-1, 0.5], [-0.5, -2]], [[1, 0], [0.3, 1]], [[1, 0], [0.2, 1]], [[0, 0], [0.1, 0]])
    cases.append(case("MIMO 2x2 state space", mimo, 8.0, 801))
    # Continuous closed loop: plant 1/(s(s+1)) style with PI, and a PID with a filtered derivative.
    g = 1 / ((s + 1) * (s + 3))
    k = 4 + 3 / s
    cases.append(case("closed loop: 1/((s+1)(s+3)) with PI 4 + 3/s", g, 10.0, 2001, k=k))
    g2 = control.tf([1.0], [1, 0.5, 0])
    k2 = 2 + 0.5 / s + 1.0 * 20 * s / (s + 20)
    cases.append(case("closed loop: 1/(s(s+0.5)) with filtered PID", g2, 30.0, 3001, k=k2))
    # Discrete.
    z = control.tf([1, 0], [1], 0.1)
    cases.append(case("discrete 0.2/(z - 0.8), ts 0.1", 0.2 / (z - 0.8), 3.0, 0))
    cases.append(
        case("discrete 2nd order, ts 0.1", (0.1 * z + 0.08) / (z**2 - 1.4 * z + 0.58), 8.0, 0)
    )
    li21 = control.tf(
        [4.154, -9.631, 10.23, -5.511, 1.154],
        [1, -0.7852, 0.7299, -0.614, 0.05156, 0.03447, 0, 0, 0, 0],
        1e-4,
    )
    # [Li21] Eq. 11 closed loop (z^-5 num/den): descending powers of z after multiplying by z^9.
    cases.append(case("discrete [Li21] Eq. 11 closed loop, ts 1e-4", li21, 6e-3, 0))
    # Discrete closed loop: Li21-form PID kp + ki/(1 - z^-1) on a first-order plant.
    zd = control.tf([1, 0], [1], 1e-3)
    gd = 0.05 / (zd - 0.95)
    kd = 0.5 + 0.2 * zd / (zd - 1)
    cases.append(case("discrete closed loop: 0.05/(z-0.95) with PI, ts 1e-3", gd, 0.3, 0, k=kd))
    # Unstable: step_info is refused by fts; python-control's numbers are not stored as truth.
    cases.append(case("unstable 1/(s-1)", 1 / (s - 1), 2.0, 201))
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cases.json")
    with open(path, "w") as f:
        json.dump({"generator": "python-control " + control.__version__, "cases": cases}, f, indent=1)
        f.write("\n")
    print(f"wrote {len(cases)} cases to {path}")


if __name__ == "__main__":
    main()
