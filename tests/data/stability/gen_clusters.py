"""Reference verdicts for tests/suite/exact_stability.rs: clustered discrete poles.

Each case is numpy's float expansion of (z - r)^k (np.poly), stored as the
exact floats a user's file would hold; its largest root modulus is computed
from those stored coefficients at 200 significant digits (mpmath), so the
verdict "all roots strictly inside the unit circle" is the truth for the
coefficients as stored, not for the root they were expanded from.

Run once: python3 gen_clusters.py > clusters.json (numpy, mpmath).
"""
import json

import mpmath
import numpy as np

mpmath.mp.dps = 200
cases = []
for r in [0.9, 0.99, 0.999, -0.995, 0.5]:
    for k in [2, 4, 6, 8]:
        den = [float(x) for x in np.poly([r] * k)]
        roots = mpmath.polyroots([mpmath.mpf(x) for x in den], maxsteps=20000, extraprec=8000)
        radius = max(abs(x) for x in roots)
        cases.append({
            "root": r,
            "multiplicity": k,
            "den": den,
            "max_modulus": float(radius),
            "stable": bool(radius < 1),
        })
print(json.dumps({"generator": "gen_clusters.py", "numpy": np.__version__,
                  "mpmath": mpmath.__version__, "cases": cases}, indent=1))
