#!/usr/bin/env python3
"""python-control's step response of the 20-state system of
benches/response.rs on the same grid (1e5 samples over 0.1 s), timed the
same way (best of the median of several runs), and its final sample so the
two can be checked to agree.

    python3 benches/response_python_control.py
"""
import time

import control
import numpy as np
from twenty_states import twenty_states

sys = twenty_states()
T = np.linspace(0.0, 0.1, 100_000)

times = []
for _ in range(7):
    t0 = time.perf_counter()
    r = control.step_response(sys, T)
    times.append(time.perf_counter() - t0)
print(f"python-control {control.__version__}: step_response of 20 states x 1e5 samples: "
      f"median {np.median(times) * 1e3:.1f} ms, min {min(times) * 1e3:.1f} ms; "
      f"y[-1] = {r.outputs[-1]:.15g}, y[50000] = {r.outputs[50000]:.15g}")
