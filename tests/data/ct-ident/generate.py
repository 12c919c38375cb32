"""Reference records for continuous-time identification (docs/identify-ct.md).

A Karagoz18-like axis: the paper's identified Z-axis plant (Eq. 4),
    G_zz(s) = (355600 s + 5468000) / (s^3 + 607.5 s^2 + 344 s + 2643),
driven by a Schroeder multisine and sampled with a zero-order hold by
scipy (cont2discrete 'zoh' + lfilter), independently of fts. Output noise
is white Gaussian (seed 20180601), 25 % of the noise-free output's RMS.

Writes
  zaxis-multisine.csv  t,u,y  (Ts = 2 ms, period 10 s, 4 periods, lines
                       0.1 .. 200 Hz log-spaced on the 0.1 Hz grid)
  zaxis-frd.csv        freq_hz,re,im  G_zz(j w) by scipy.signal.freqs on 200
                       log-spaced points 0.05 .. 200 Hz, plus complex noise
                       of 5 % of each point's magnitude (seed 20180602)
  zaxis-truth.json     the plant, the settings and the noise levels
Run:  python3 generate.py   (numpy, scipy)
"""
import json
import numpy as np
from scipy import signal

NUM = [355600.0, 5468000.0]
DEN = [1.0, 607.5, 344.0, 2643.0]
TS, PERIOD, PERIODS = 0.002, 10.0, 4
NOISE_FRACTION, FRD_NOISE = 0.25, 0.05


def multisine():
    n = int(round(PERIOD / TS))
    df = 1.0 / PERIOD
    lines = np.unique(np.round(np.logspace(np.log10(0.1), np.log10(200.0), 120) / df).astype(int))
    t = np.arange(n) * TS
    k = np.arange(1, len(lines) + 1)
    phi = -np.pi * k * (k - 1) / len(lines)
    one = np.sum(np.sin(2 * np.pi * np.outer(t, lines * df) + phi), axis=1)
    one /= np.max(np.abs(one))
    return np.tile(one, PERIODS), lines * df


def main():
    u, freqs = multisine()
    bd, ad, _ = signal.cont2discrete((NUM, DEN), TS, method="zoh")
    y0 = signal.lfilter(np.ravel(bd), np.ravel(ad), u)
    rng = np.random.default_rng(20180601)
    sd = NOISE_FRACTION * np.sqrt(np.mean(y0 ** 2))
    y = y0 + sd * rng.standard_normal(len(u))
    t = np.arange(len(u)) * TS
    np.savetxt("zaxis-multisine.csv", np.column_stack([t, u, y]), delimiter=",",
               header="t,u,y", comments="", fmt="%.10g")
    f = np.logspace(np.log10(0.05), np.log10(200.0), 200)
    _, h = signal.freqs(NUM, DEN, worN=2 * np.pi * f)
    rng = np.random.default_rng(20180602)
    h_noisy = h + FRD_NOISE * np.abs(h) / np.sqrt(2) * (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f)))
    np.savetxt("zaxis-frd.csv", np.column_stack([f, h_noisy.real, h_noisy.imag]), delimiter=",",
               header="freq_hz,re,im", comments="", fmt="%.12g")
    truth = {"num": NUM, "den": DEN, "ts": TS, "period": PERIOD, "periods": PERIODS,
             "lines": len(freqs), "output_noise_sd": sd, "output_noise_fraction_of_rms": NOISE_FRACTION,
             "frd_noise_fraction": FRD_NOISE,
             "poles": [[p.real, p.imag] for p in np.roots(DEN)]}
    with open("zaxis-truth.json", "w") as fh:
        json.dump(truth, fh, indent=2)
        fh.write("\n")


if __name__ == "__main__":
    main()
