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

n = 20
A = np.zeros((n, n))
for i in range(10):
    w = 2 * np.pi * (50 + 100 * i)
    s = -0.05 * w
    k = 2 * i
    A[k, k] = A[k + 1, k + 1] = s
    A[k, k + 1] = w
    A[k + 1, k] = -w
B = np.ones((n, 1))
C = np.array([[1.0 if j % 2 == 0 else 0.5 for j in range(n)]])
sys = control.ss(A, B, C, np.zeros((1, 1)))
T = np.linspace(0.0, 0.1, 100_000)

times = []
for _ in range(7):
    t0 = time.perf_counter()
    r = control.step_response(sys, T)
    times.append(time.perf_counter() - t0)
print(f"python-control {control.__version__}: step_response of 20 states x 1e5 samples: "
      f"median {np.median(times) * 1e3:.1f} ms, min {min(times) * 1e3:.1f} ms; "
      f"y[-1] = {r.outputs[-1]:.15g}, y[50000] = {r.outputs[50000]:.15g}")
