"""Reference values for fts contour (tests/suite/contour.rs), computed independently
of fts with numpy and python-control.

Case: the Karagoz18 X/Y/Z plants (Eq. 2-4) under the Table 2 axis PIDs
P + I/s + D N s/(s + N), sample time 1e-6 s (plants ZOH, PIDs Tustin), the
100 um / 75 rad/s sine added at every plant output, on the 5 mm circle
inclined 45 deg about x (start at the origin, centre at -r x), traversed by
one jerk-limited S-curve (v 30000 um/s, a 1.5e6 um/s^2, j 1.5e9 um/s^3).

* Without cross-coupling the axes are independent: y_i = T_i r_i + S_i d_i,
  computed with control.forced_response of the discrete closed loops (a
  different algorithm from fts's sample-by-sample loop).
* With cross-coupling (CC PID 0.4, 0.005, 0.0005, 100 on each component of
  eps = e - (e.t) t, added to the axis command) the loop is stepped here in
  Python with python-control's state-space realisations.

Figures: RMS and max of e_x, e_y, e_z (um) over every sample, of the exact
contour error (distance of the position to the circle) and of |eps|.
Run: python3 make_contour_reference.py  (writes reference.json; ~1 min).
"""
import json
import math

import control
import numpy as np

TS = 1e-6
V, A, J = 30000.0, 1.5e6, 1.5e9
D, INCLINE = 5000.0, math.radians(45.0)
PLANTS = [([56930, 1389], [1, 0.2268, 0.002058]),
          ([548000, 13670], [1, 1.644, 8.198, 0.06571]),
          ([355600, 5468000], [1, 607.5, 344, 2643])]
PIDS = [(1, 0.01, 0.0005, 100), (1.5, 0.01, 0.0005, 100), (1, 0.01, 0.0005, 100)]
CC = (0.4, 0.005, 0.0005, 100)


def scurve(L, v, a, j):
    """7-segment rest-to-rest profile: durations, by the textbook formulas."""
    def acc(v):
        return (a / j, v / a - a / j) if v * j >= a * a else (math.sqrt(v / j), 0.0)
    tj, ta = acc(v)
    if v * (2 * tj + ta) > L:  # not reachable: solve v^2/a + v a/j = L
        v = 0.5 * a * (-a / j + math.sqrt((a / j) ** 2 + 4 * L / a))
        if v * j < a * a:
            v = (L * L * j / 4) ** (1 / 3)
        tj, ta = acc(v)
        tv = 0.0
    else:
        tv = (L - v * (2 * tj + ta)) / v
    return [tj, ta, tj, tv, tj, ta, tj], [1, 0, -1, 0, -1, 0, 1], v


def scurve_eval(t, seg, jerks, j):
    p = np.zeros_like(t); vel = np.zeros_like(t)
    p0 = v0 = a0 = 0.0
    t0 = 0.0
    for d, s in zip(seg, jerks):
        m = (t >= t0) & (t < t0 + d)
        tau = t[m] - t0
        p[m] = p0 + v0 * tau + a0 * tau ** 2 / 2 + s * j * tau ** 3 / 6
        vel[m] = v0 + a0 * tau + s * j * tau ** 2 / 2
        p0 += v0 * d + a0 * d ** 2 / 2 + s * j * d ** 3 / 6
        v0 += a0 * d + s * j * d ** 2 / 2
        a0 += s * j * d
        t0 += d
    p[t >= t0] = p0
    return p, vel, t0


def pid_d(p, i, d, n):
    # State space throughout: discrete transfer-function coefficients at
    # 1 MHz with poles within 1e-8 of z = 1 cannot hold them.
    s = control.tf('s')
    c = control.ss(p + i / s + d * n * s / (s + n))
    return control.sample_system(c, TS, method='tustin')


def main():
    r = D / 2
    seg, jerks, vpeak = scurve(math.pi * D, V, A, J)
    T = sum(seg)
    n = int(math.ceil(T / TS)) + 1
    t = np.arange(n) * TS
    s, _, _ = scurve_eval(t, seg, jerks, J)
    phi = s / r
    u1 = np.array([1.0, 0.0, 0.0]); u2 = np.array([0.0, math.cos(INCLINE), math.sin(INCLINE)])
    R = (r * (np.cos(phi) - 1))[:, None] * u1 + (r * np.sin(phi))[:, None] * u2
    tang = (-np.sin(phi))[:, None] * u1 + np.cos(phi)[:, None] * u2
    dist = 100.0 * np.sin(75.0 * t)

    G = [control.sample_system(control.ss(control.tf(nu, de)), TS, method='zoh') for nu, de in PLANTS]
    K = [pid_d(*g) for g in PIDS]

    def metrics(Y):
        E = R - Y
        eps = E - np.sum(E * tang, axis=1)[:, None] * tang
        dvec = Y + r * u1  # from the centre
        a = dvec @ u1; b = dvec @ u2
        off = dvec - a[:, None] * u1 - b[:, None] * u2
        exact = np.hypot(np.hypot(a, b) - r, np.linalg.norm(off, axis=1))
        est = np.linalg.norm(eps, axis=1)
        rms = lambda x: float(np.sqrt(np.mean(x ** 2)))
        return {"rms": {"x": rms(E[:, 0]), "y": rms(E[:, 1]), "z": rms(E[:, 2]),
                        "contour": rms(exact), "contour_estimate": rms(est)},
                "max": {"x": float(np.max(np.abs(E[:, 0]))), "y": float(np.max(np.abs(E[:, 1]))),
                        "z": float(np.max(np.abs(E[:, 2]))), "contour": float(exact.max()),
                        "contour_estimate": float(est.max())},
                "samples": int(n)}

    # Without cross-coupling: y = T r + S d, by forced_response.
    Y0 = np.zeros((n, 3))
    for i in range(3):
        L = control.series(K[i], G[i])
        Tcl = control.feedback(L, 1)
        Scl = control.feedback(control.ss([], [], [], [[1.0]], dt=TS), L)
        Y0[:, i] = (control.forced_response(Tcl, T=t, U=R[:, i]).outputs
                    + control.forced_response(Scl, T=t, U=dist).outputs)
    base = metrics(Y0)

    # With cross-coupling: the loop, sample by sample.
    def mats(sys):
        m = control.ss(sys)
        return (np.array(m.A), np.array(m.B)[:, 0], np.array(m.C)[0], float(np.array(m.D)[0, 0]))
    Gm = [mats(g) for g in G]; Km = [mats(k) for k in K]; Cm = mats(pid_d(*CC))
    xg = [np.zeros(m[0].shape[0]) for m in Gm]
    xk = [np.zeros(m[0].shape[0]) for m in Km]
    xc = [np.zeros(Cm[0].shape[0]) for _ in range(3)]
    Y1 = np.zeros((n, 3))
    for k in range(n):
        y = np.array([Gm[i][2] @ xg[i] for i in range(3)]) + dist[k]
        e = R[k] - y
        eps = e - (e @ tang[k]) * tang[k]
        for i in range(3):
            A_, B_, C_, D_ = Km[i]
            u = C_ @ xk[i] + D_ * e[i]
            xk[i] = A_ @ xk[i] + B_ * e[i]
            A_, B_, C_, D_ = Cm
            u += C_ @ xc[i] + D_ * eps[i]
            xc[i] = A_ @ xc[i] + B_ * eps[i]
            A_, B_, _, _ = Gm[i]
            xg[i] = A_ @ xg[i] + B_ * u
        Y1[k] = y
    cc = metrics(Y1)
    out = {"description": __doc__.strip().splitlines()[0], "generator": "make_contour_reference.py",
           "python_control": control.__version__, "numpy": np.__version__,
           "ts": TS, "velocity": V, "acceleration": A, "jerk": J, "diameter": D, "incline_deg": 45.0,
           "duration_s": T, "peak_velocity": vpeak,
           "with_cc": cc, "without_cc": base}
    with open("reference.json", "w") as f:
        json.dump(out, f, indent=1)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
