"""Reference coherence of the DaISy robot arm record (data/daisy-robot-arm)
from scipy.signal.coherence (Hann window, half overlap, segment mean removed,
as fts's Welch estimate), for the record's first half (the estimation part
of `--split 0.5`) and the whole record, at every power-of-two segment length
from 64 to N/2. The median is over the bins with input power (above 1e-12
of the input spectrum's peak, DC excluded), as fts's median coherence
counts: the record's input leaves some bins without power at N/2, where
scipy's coherence of 0/0-like bins would otherwise enter the median.
Writes robot_arm_coherence.json next to this file.

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
        # The input's power per bin, summed over the same Hann segments.
        window = signal.get_window("hann", length)
        puu = sum(np.abs(np.fft.rfft((seg - seg.mean()) * window)) ** 2
                  for seg in (u[k:k + length]
                              for k in range(0, n - length + 1, length // 2)))
        excited = puu > 1e-12 * puu.max()
        excited[0] = False
        medians[str(length)] = float(np.median(c[excited]))
        length *= 2
    cases.append({"samples": n, "median_coherence_excited": medians})
out = {"scipy": scipy.__version__, "record": "data/daisy-robot-arm/robot_arm.dat",
       "cases": cases}
(here / "robot_arm_coherence.json").write_text(json.dumps(out, indent=1) + "\n")
