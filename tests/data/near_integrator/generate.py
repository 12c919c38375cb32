"""SLICOT SB10AD's gammas (through python-control's mixsyn, slycot) for the
DC-servo mixed-sensitivity family of tests/suite/hinf_near_integrator.rs:
G = 11.2 / ((s + 0.12)(s + 1e-6)), W_s = (s/1.5 + 20)/(s + p), W_u = 1.
Run once (python-control 0.10.2, slycot 0.7.1); the values are committed in
sb10ad.csv. SB10AD's gamma is a peer's claim (its own controllers can miss
it), so the test compares fts's bisection bound with it and checks fts's
controllers on their own.
"""
import control as ct
import warnings

warnings.simplefilter("ignore")
s = ct.tf("s")
g = 11.2 / ((s + 0.12) * (s + 1e-6))
print("p,gamma_sb10ad")
for p in [2e-7, 2e-6, 2e-5, 2e-4, 2e-3, 2e-2, 2e-1, 2.0]:
    ws = (s / 1.5 + 20) / (s + p)
    _, _, info = ct.mixsyn(ct.ss(g), ct.ss(ws), ct.ss(ct.tf(1, 1)), None)
    print(f"{p:g},{info[0]:.12g}")
