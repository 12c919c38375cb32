"""Reference coherence of the DaISy robot arm record (data/daisy-robot-arm)
from scipy.signal.coherence (Hann window, half overlap, segment mean removed,
as fts's Welch estimate), for the record's first half (the estimation part
of `--split 0.5`) and the whole record, at every power-of-two segment length
from 64 to N/2. Writes robot_arm_coherence.json next to this file.

    python3 tests/data/welch/generate.py
"""
import json
import pathlib

import numpy as np
import scipy
import scipy.signal as signal

here = pathlib.Path(__file__).parent
record = here.parents[2] / "data" / "daisy-robot-arm" / "robot_arm.dat"
data = np.loadtxt(record)
u, y = data[:, 0], data[:, 1]
cases = []
for n in (512, 1024):
    medians = {}
    length = 64
    while length <= n // 2:
        f, c = signal.coherence(u[:n], y[:n], fs=1.0, window="hann",
                                nperseg=length, noverlap=length // 2,
                                detrend="constant")
        medians[str(length)] = float(np.median(c[1:]))
        length *= 2
    cases.append({"samples": n, "median_coherence_without_dc": medians})
out = {"scipy": scipy.__version__, "record": "data/daisy-robot-arm/robot_arm.dat",
       "cases": cases}
(here / "robot_arm_coherence.json").write_text(json.dumps(out, indent=1) + "\n")
