#!/usr/bin/env python3
"""Reference loops for `tests/suite/loop_margins.rs`, computed with python-control.

For each loop L = G K (negative feedback, SISO) this stores G and K as
transfer-function coefficients (continuous: descending powers of s;
discrete: ascending powers of z^-1 with the sample time, the fts.tf/1
convention) and python-control's answers:

* `stability_margins(L, returnall=False)` -> gm, pm, sm, wpc, wgc, wms
  (rad/s), the method it used ("poly", or "frd" when it falls back), and
  `stability_margins(L, returnall=True)` for the crossover counts;
* `bandwidth(T)` (rad/s; null when it fails). python-control evaluates T
  at z = jw instead of z = e^{jw dt} for discrete systems (its bisection
  then often finds no bracket), so for those the script also stores
  `bandwidth_checked`: the same definition (first -3 dB frequency on its
  sweep, refined by bisection) evaluated on the unit circle;
* peaks of |S| and |T|: the maximum of a dense log sweep (2e5 points),
  refined by a bounded scalar minimiser between the neighbouring points;
* the closed-loop poles (`feedback(L, 1).poles()`).

It also writes virtual-fts-linear.json (the plant of docs/loop.md).

Run: python3 make_loop_cases.py > cases.json   (python-control 0.10, numpy, scipy)
"""
import json
import warnings

import control as ct
import numpy as np
import scipy.optimize as so


def pid_c(kp, ki, kd, n):
    """kp + ki/s + kd n s/(s+n) on one denominator s (s+n)."""
    s = ct.tf("s")
    k = kp + ki / s
    if kd:
        k = k + kd * n * s / (s + n)
    return k


def li21_pid(kp, ki, kd, dt):
    """Kp + Ki/(1-z^-1) + Kd (1-z^-1), per-sample gains ([Li21] Eq. 5)."""
    z = ct.tf([1, 0], [1], dt)
    k = ct.tf([kp], [1], dt)
    if ki:
        k = k + ki * z / (z - 1)
    if kd:
        k = k + kd * (z - 1) / z
    return k


def coeffs(sys):
    num = np.atleast_1d(np.squeeze(sys.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(sys.den[0][0])).astype(float)
    if sys.isdtime(strict=True):
        # Descending z with equal lengths == ascending z^-1.
        n = max(len(num), len(den))
        num = np.concatenate([np.zeros(n - len(num)), num])
        den = np.concatenate([np.zeros(n - len(den)), den])
        return {"var": "z^-1", "ts": sys.dt, "num": num.tolist(), "den": den.tolist()}
    return {"var": "s", "num": num.tolist(), "den": den.tolist()}


def resp(sys, w):
    if sys.isdtime(strict=True):
        return sys(np.exp(1j * w * sys.dt))
    return sys(1j * w)


def sweep_peak(fun, lo, hi):
    w = np.geomspace(lo, hi, 200_000)
    v = fun(w)
    i = int(np.nanargmax(v))
    best_w, best_v = w[i], v[i]
    if 0 < i < len(w) - 1:
        r = so.minimize_scalar(
            lambda x: -fun(np.array([np.exp(x)]))[0],
            bounds=(np.log(w[i - 1]), np.log(w[i + 1])),
            method="bounded",
            options={"xatol": 1e-13},
        )
        if -r.fun > best_v:
            best_w, best_v = float(np.exp(r.x)), float(-r.fun)
    return float(best_v), float(best_w)


def checked_bandwidth(t, dt):
    """python-control's bandwidth definition on the unit circle."""
    dc = t.dcgain()
    if np.isinf(dc):
        return None
    from control.freqplot import _default_frequency_range

    w = _default_frequency_range(t)
    w = w[w < np.pi / dt]
    mag = np.abs(resp(t, w))
    level = np.abs(dc) * 10 ** (-3 / 20)
    idx = np.nonzero(mag - level < 0)[0]
    if idx.shape[0] == 0:
        return None
    return float(
        so.brentq(lambda x: np.abs(resp(t, x)) - level, w[idx[0] - 1], w[idx[0]], xtol=1e-15, rtol=1e-15)
    )


def virtual_fts_linear():
    """fixtures/virtual-fts.json with the hysteresis replaced by its linear
    slope: 10 V/V amplifier with a 3 kHz pole, 0.17 um/V, flexure loss
    200/(200+11.6), first mode 2504.8 Hz (zeta 0.05), ZOH at 10 kHz and one
    sample of delay; input V, output um."""
    s = ct.tf("s")
    wa, wn = 2 * np.pi * 3000.0, 2 * np.pi * 2504.8
    g = 10.0 * 0.17 * 200.0 / 211.6 / (s / wa + 1) * wn**2 / (s**2 + 0.1 * wn * s + wn**2)
    gd = ct.c2d(g, 1e-4, "zoh") * ct.tf([1], [1, 0], 1e-4)
    c = coeffs(gd)
    doc = {"format": "fts.tf/1",
           "description": "Linearised virtual FTS (fixtures/virtual-fts.json, hysteresis replaced by d = 0.17 um/V): amplifier 10 V/V with a 3 kHz pole, flexure loss 200/211.6, mode 2504.8 Hz zeta 0.05, ZOH at 10 kHz, one sample delay. Input V, output um. Written by make_loop_cases.py.",
           **c}
    import os
    with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "virtual-fts-linear.json"), "w") as f:
        json.dump(doc, f, indent=2)
        f.write("\n")
    return gd


def case(name, g, k, note=""):
    L = g * k
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gm, pm, sm, wpc, wgc, wms = ct.stability_margins(L, returnall=False)
        method = "frd" if any("frd" in str(c.message) for c in caught) else "poly"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        all_m = ct.stability_margins(L, returnall=True)
    T = ct.feedback(L, 1)
    S = ct.feedback(ct.tf([1], [1], L.dt), L)
    dt = L.dt if L.isdtime(strict=True) else None
    poles = T.poles()
    stable = bool(np.all(np.abs(poles) < 1) if dt else np.all(poles.real < 0))
    # Sweep range: well beyond every pole and zero, Nyquist for discrete loops.
    feats = np.abs(np.concatenate([L.poles(), L.zeros()]))
    if dt:
        feats = np.abs(np.log(feats[feats > 0] + 0j)) / dt
    feats = feats[feats > 1e-9]
    lo = feats.min() / 1e4 if feats.size else 1e-3
    hi = np.pi / dt if dt else (feats.max() * 1e4 if feats.size else 1e3)
    ps = sweep_peak(lambda w: np.abs(resp(S, w)), lo, hi)
    pt = sweep_peak(lambda w: np.abs(resp(T, w)), lo, hi)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            bw = float(ct.bandwidth(T))
        except ValueError:  # the z = jw evaluation found no bracket
            bw = float("nan")
    out = {
        "name": name,
        "note": note,
        "g": coeffs(g),
        "k": coeffs(k),
        "py_method": method,
        "gm": float(gm),
        "pm": float(pm),
        "sm": float(sm),
        "wpc": float(wpc),
        "wgc": float(wgc),
        "wms": float(wms),
        "n_phase_crossovers": int(len(all_m[3])),
        "n_gain_crossovers": int(len(all_m[4])),
        "all_wpc": [float(x) for x in all_m[3]],
        "all_wgc": [float(x) for x in all_m[4]],
        "bandwidth": bw,
        "bandwidth_checked": checked_bandwidth(T, dt) if dt else bw,
        "peak_s": ps[0],
        "w_peak_s": ps[1],
        "peak_t": pt[0],
        "w_peak_t": pt[1],
        "sweep_rad_s": [float(lo), float(hi)],
        "cl_poles": [[float(p.real), float(p.imag)] for p in poles],
        "cl_stable": stable,
    }
    return {k2: (None if isinstance(v, float) and not np.isfinite(v) else v) for k2, v in out.items()}


def main():
    s = ct.tf("s")
    cases = []
    # --- continuous ---
    cases.append(case("type1_lag_inf_gm", 1 / (s * (s + 1)), ct.tf([1], [1]),
                      "infinite gain margin: the phase never reaches -180"))
    cases.append(case("triple_lag_p", 1 / (s + 1) ** 3, ct.tf([4], [1]), "GM = 2 at w = sqrt(3)"))
    cases.append(case("triple_lag_unstable_cl", 1 / (s + 1) ** 3, ct.tf([10], [1]), "GM < 1: closed loop unstable"))
    cases.append(case("pid_second_order", 1 / (s**2 + 0.4 * s + 1), pid_c(1.2, 0.8, 0.6, 20.0), "filtered PID"))
    cases.append(case("lead_lag", 10 / (s * (s + 2) * (s + 5)),
                      3.0 * (s + 1.5) / (s + 8) * (s + 0.1) / (s + 0.02), "lead-lag"))
    cases.append(case("higher_order_notch", 1 / (s * (s + 1)) * 400 / (s**2 + 4 * s + 400),
                      8.0 * (s + 0.5) * (s**2 + 4 * s + 400) / ((s + 0.01) * (s + 30) * (s**2 + 28 * s + 400)),
                      "fifth-order controller (integral-like, lead, notch on the resonance): the shape mixsyn gives"))
    wz, wp = 8.0, 10.0
    collocated = (wp / wz) ** 2 * (s**2 + 0.02 * wz * s + wz**2) / (s**2 + 0.02 * wp * s + wp**2)
    cases.append(case("multi_gain_crossover", collocated / s, ct.tf([1], [1]),
                      "antiresonance-resonance pair lifts |L| above 1 again: three gain crossovers"))
    cases.append(case("unstable_plant_pd", 1 / ((s - 1) * (s + 5)), 20 * (s + 2) / (s / 50 + 1),
                      "open-loop unstable plant stabilised by a lead: GM < 1 is a gain-decrease margin"))
    cases.append(case("unstable_plant_pid", 1 / ((s - 2) * (s + 10)), pid_c(40.0, 20.0, 2.0, 100.0),
                      "open-loop unstable plant with a filtered PID"))
    cases.append(case("nonminimum_phase_pi", (1 - s) / ((s + 1) * (s + 2)), 0.5 + 0.3 / s, "right-half-plane zero"))
    num, den = ct.pade(0.2, 3)
    cases.append(case("pade_delay_pi", ct.tf(num, den) / (s + 1), 0.8 + 0.9 / s, "third-order Pade delay"))
    wn = 2 * np.pi * 2000
    fts = wn**2 / (s**2 + 2 * 0.05 * wn * s + wn**2)
    cases.append(case("fts_resonance_integral", fts, ct.tf([600], [1, 0]),
                      "FTS-like 2 kHz resonance, integral control: large coefficients"))
    cases.append(case("fts_resonance_pid", fts * 1 / (s / (2 * np.pi * 5000) + 1), pid_c(0.3, 800.0, 1e-5, 2 * np.pi * 8000),
                      "FTS-like plant with amplifier pole and filtered PID"))
    cases.append(case("biproper_loop", (s + 3) / (s + 1), 0.5 * (s + 2) / (s + 4), "no crossovers at all: |L| < 1"))
    # --- discrete ---
    vfts = virtual_fts_linear()
    cases.append(case("vfts_pid", vfts, li21_pid(0.02, 0.15, 0.0, 1e-4),
                      "linearised virtual FTS, [Li21] PID kp 0.02 ki 0.15 (the default)"))
    cases.append(case("vfts_pid_fast", vfts, li21_pid(0.05, 0.3, 0.0, 1e-4),
                      "linearised virtual FTS, [Li21] PID kp 0.05 ki 0.3"))
    g2 = ct.c2d(1 / (s**2 + 0.4 * s + 1), 0.05, "zoh")
    k2 = ct.c2d(pid_c(1.2, 0.8, 0.6, 20.0), 0.05, "tustin")
    cases.append(case("d_pid_second_order", g2, k2, "ZOH plant, Tustin PID"))
    g3 = ct.c2d(10 / (s * (s + 2) * (s + 5)), 0.02, "zoh")
    k3 = ct.c2d(3.0 * (s + 1.5) / (s + 8), 0.02, "tustin")
    cases.append(case("d_lead", g3, k3, "discrete lead"))
    g4 = ct.c2d(1 / ((s - 1) * (s + 5)), 0.01, "zoh")
    k4 = ct.c2d(20 * (s + 2) / (s / 50 + 1), 0.01, "tustin")
    cases.append(case("d_unstable_plant", g4, k4, "open-loop unstable discrete plant"))
    g5 = ct.c2d(collocated / s, 0.02, "zoh")
    cases.append(case("d_multi_gain_crossover", g5, ct.tf([1], [1], 0.02), "discrete, several gain crossovers"))
    g6 = ct.tf([0, 0, 0, 0.2], [1, -0.8, 0, 0], 1e-3)
    cases.append(case("d_delay_pi", g6, li21_pid(0.5, 0.2, 0.0, 1e-3), "three-sample delay, PI"))
    g7 = ct.c2d(fts, 2e-5, "zoh")
    cases.append(case("d_fts_resonance_integral", g7, ct.c2d(ct.tf([600], [1, 0]), 2e-5, "tustin"),
                      "FTS-like resonance at 50 kHz sampling"))
    g8 = ct.tf([0, 0.3], [1, -0.5], 0.1)
    cases.append(case("d_first_order_p", g8, ct.tf([0.8], [1], 0.1), "first order, proportional: no phase crossover below Nyquist"))
    json.dump(cases, fp=__import__("sys").stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
