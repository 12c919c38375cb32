"""The 20-state continuous system of benches/common/mod.rs (`twenty_states`),
shared by the python-control peers of the Rust benches: ten lightly damped
modes in parallel, block [[s, w], [-w, s]] with w = 2 pi (50 + 100 i) rad/s,
s = -0.05 w; B all ones, C alternating 1, 0.5."""
import control
import numpy as np


def twenty_states():
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
    return control.ss(A, B, C, np.zeros((1, 1)))
