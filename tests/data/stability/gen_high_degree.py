"""Reference root counts for tests/suite/exact_stability.rs: high-degree discrete
denominators expanded from lightly damped pole sets.

For seeds 1-3 and degrees 60 to 160, complex pole pairs r e^{+-j theta} are
drawn with r uniform in [0.7, 0.99] and theta in [0, pi] (a 64-bit LCG, the
one of src/lti/stability.rs's tests), and numpy expands them (np.convolve of
the quadratic factors) into the float coefficients a user's file would hold;
a second case moves one pair to a real root at 1.05. Rounding those
coefficients moves roots, at these degrees sometimes far outside the
circle, so the reference is not the drawn poles but the stored
coefficients' own roots: python-flint's rigorous complex root isolation
(Arb balls, fmpq_poly.complex_roots) on the exact rationals of the stored
floats. Each case records how many roots lie strictly inside the unit
circle and the distance of the closest root to it (a ball's midpoint; the
generator stops if a ball straddles |z| = 1).

Continuous cases (`continuous_cases`): for seeds 1-3 and degrees 20 to
120, lightly damped pairs s^2 + 2 zeta w s + w^2 with w log-uniform in
[0.1, 10] rad/s and zeta in [1e-3, 0.1], expanded by numpy, and the same
with one pair's damping negated (a pair in the right half plane); each
records how many roots of the stored coefficients lie in the open left half
plane (python-flint, as above; the generator stops if a ball's real part
straddles 0) and the least |Re| of a root.

Run once: python3 gen_high_degree.py > high_degree.json (numpy, python-flint).
"""
import json
import math
from fractions import Fraction

import flint
import numpy as np


def lcg(seed):
    state = [seed]

    def draw():
        state[0] = (state[0] * 6364136223846793005 + 1442695040888963407) % 2**64
        return (state[0] >> 11) / 2**53
    return draw


def expand(real, pairs):
    c = np.array([1.0])
    for r in real:
        c = np.convolve(c, [1.0, -r])
    for m, theta in pairs:
        c = np.convolve(c, [1.0, -2.0 * m * math.cos(theta), m * m])
    return [float(x) for x in c]


def roots_inside(den):
    p = flint.fmpq_poly([flint.fmpq(*Fraction(x).as_integer_ratio()) for x in reversed(den)])
    inside, closest = 0, math.inf
    for root, mult in p.complex_roots():
        modulus = abs(root)
        if modulus < 1:
            inside += mult
        elif not modulus > 1:
            raise SystemExit(f"a root's modulus straddles 1: {modulus}")
        closest = min(closest, abs(float((modulus - 1).mid())))
    return inside, closest


def roots_left(den):
    p = flint.fmpq_poly([flint.fmpq(*Fraction(x).as_integer_ratio()) for x in reversed(den)])
    left, closest = 0, math.inf
    for root, mult in p.complex_roots():
        re = root.real
        if re < 0:
            left += mult
        elif not re > 0:
            raise SystemExit(f"a root's real part straddles 0: {re}")
        closest = min(closest, abs(float(re.mid())))
    return left, closest


continuous = []
for seed in [1, 2, 3]:
    draw = lcg(100 + seed)
    for n in [20, 40, 60, 80, 100, 120]:
        pairs = [(10 ** (2 * draw() - 1), 10 ** (2 * draw() - 3)) for _ in range(n // 2)]
        for name, flip in [("drawn", False), ("one_pair_right", True)]:
            c = np.array([1.0])
            for i, (w, zeta) in enumerate(pairs):
                z = -zeta if flip and i == 0 else zeta
                c = np.convolve(c, [1.0, 2.0 * z * w, w * w])
            den = [float(x) for x in c]
            left, closest = roots_left(den)
            continuous.append({"seed": seed, "degree": n, "poles": name, "den": den,
                               "roots_left": left, "closest_to_axis": closest})

cases = []
for seed in [1, 2, 3]:
    draw = lcg(seed)
    for n in [60, 80, 100, 120, 140, 160]:
        pairs = [(0.7 + 0.29 * draw(), math.pi * draw()) for _ in range(n // 2)]
        for name, real, kept in [("drawn", [], pairs), ("one_at_1.05", [1.05], pairs[1:])]:
            den = expand(real, kept)
            inside, closest = roots_inside(den)
            cases.append({"seed": seed, "degree": len(den) - 1, "poles": name, "den": den,
                          "roots_inside": inside, "closest_to_circle": closest})
print(json.dumps({"generator": "gen_high_degree.py", "numpy": np.__version__,
                  "python_flint": flint.__version__, "cases": cases,
                  "continuous_cases": continuous}, indent=1))
