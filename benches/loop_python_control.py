#!/usr/bin/env python3
"""python-control's analysis of the loop of benches/loop_margins.rs: the
20-state plant of benches/response.rs under K(s) = 0.2 + 100/s, with
stability_margins, bandwidth, S and T on the same 1000 frequencies (1 Hz to
10 kHz) and their peaks, and the closed-loop poles; timed as the median of
several runs.

    python3 benches/loop_python_control.py
"""
import time

import control
import numpy as np
from twenty_states import twenty_states

G = twenty_states()
K = control.tf([0.2, 100.0], [1.0, 0.0])
f = np.logspace(0, 4, 1000)
omega = 2 * np.pi * f


def analyse():
    L = control.series(K, G)
    gm, pm, sm, wpc, wgc, wms = control.stability_margins(L)
    S = control.feedback(control.ss([], [], [], [[1.0]]), L)
    T = control.feedback(L, 1)
    s_mag = np.abs(S(1j * omega)).ravel()
    t_mag = np.abs(T(1j * omega)).ravel()
    bw = control.bandwidth(T)
    poles = T.poles()
    return gm, pm, s_mag.max(), f[s_mag.argmax()], t_mag.max(), bw, poles


times = []
for _ in range(7):
    t0 = time.perf_counter()
    r = analyse()
    times.append(time.perf_counter() - t0)
gm, pm, s_peak, s_at, t_peak, bw, poles = r
print(f"python-control {control.__version__}: margins, S/T on 1000 frequencies, bandwidth, poles "
      f"of the 20-state loop: median {np.median(times) * 1e3:.1f} ms, min {min(times) * 1e3:.1f} ms; "
      f"GM {gm:.9g}, PM {pm:.9g} deg, peak |S| {s_peak:.9g} at {s_at:.6g} Hz (grid), "
      f"bandwidth {bw / (2 * np.pi):.9g} Hz, max Re(pole) {max(p.real for p in poles):.6g}")
