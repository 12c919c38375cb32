"""Reference values for fts's H-infinity synthesis on badly scaled
mixed-sensitivity problems (issue #13, item 1 and 8): SLICOT SB10AD through
python-control's hinfsyn, and an independent check of what SLICOT's own
controller achieves.

    pip install control slycot
    python3 tests/data/hinf_slicot/gen_cases.py   # writes cases.json beside it

For each case (plant G, weights W1, W2 = w2 (constant), W3 in python-control's
augw convention): SLICOT's gamma (`gam`, its bisection estimate), the
closed-loop poles' largest real part with SLICOT's controller, and that
closed loop's H-infinity norm recomputed by a dense log sweep (inf when the
loop is unstable). `slicot_achieves` says whether the sweep stays within
1e-4 of the claimed gamma; only those cases' gammas are used as a reference.
Transfer functions are stored as descending-power coefficients.
"""
import json
import multiprocessing as mp
import os
import time

import control as ct
import numpy as np
import scipy.linalg as sl
import slycot

W1 = ([0.5, 100.0], [1.0, 0.1])  # (s/2 + 100)/(s + 0.1)
W3 = ([1.0, 50.0], [0.001, 100.0])  # (s + 50)/(0.001 s + 100)
W2S = [1.0, 1e-2, 1e-4, 1e-6]


def plants():
    # Second order with a zero, as in the issue: k (s + 0.05)/(s^2 + 0.3 s + 0.004);
    # k = 2e4 is the quoted case (DC gain 2.5e5 * k / 2e4 ...).
    for k in [1e-3, 1.0, 2e4, 1e6]:
        yield f"second-order k={k:g}", ([k, 0.05 * k], [1.0, 0.3, 0.004])
    # First order: k/(s + 1).
    for k in [1e-3, 1.0, 1e3, 1e6]:
        yield f"first-order k={k:g}", ([k], [1.0, 1.0])


def sweep_norm(sys, n=4000):
    """sigma_max of C (jwI - A)^-1 B + D on a log grid spanning the poles."""
    a, b, c, d = (np.asarray(m, float) for m in (sys.A, sys.B, sys.C, sys.D))
    poles = np.linalg.eigvals(a)
    if np.max(poles.real) >= 0:
        return float("inf")
    # Exact diagonal similarity (powers of two) for stiff loops.
    _, (scale, perm) = sl.matrix_balance(a, permute=False, separate=True)
    ab = (a * scale[None, :]) / scale[:, None]
    bb = b / scale[:, None]
    cb = c * scale[None, :]
    mags = np.abs(poles[np.abs(poles) > 0])
    lo, hi = np.log10(mags.min() / 100), np.log10(mags.max() * 100)
    peak = np.linalg.norm(d, 2)
    eye = np.eye(a.shape[0])
    for w in np.logspace(lo, hi, n):
        g = cb @ np.linalg.solve(1j * w * eye - ab, bb) + d
        peak = max(peak, np.linalg.svd(g, compute_uv=False)[0])
    return float(peak)


TIMEOUT_S = 60


def _worker(p, queue):
    try:
        k, cl, gam, _ = ct.hinfsyn(p, 1, 1)
        queue.put((float(gam), None, int(k.nstates),
                   [np.asarray(m, float).tolist() for m in (cl.A, cl.B, cl.C, cl.D)]))
    except Exception as e:  # SLICOT refuses the problem
        queue.put((None, str(e), None, None))


def synthesise(p):
    """SB10AD in a child process: some badly scaled cases do not return
    within minutes; those are recorded as refused ("timeout") rather than
    holding up the rest."""
    queue = mp.Queue()
    proc = mp.Process(target=_worker, args=(p, queue))
    proc.start()
    try:
        gam, err, k, cl = queue.get(timeout=TIMEOUT_S)
    except Exception:
        proc.kill()
        proc.join()
        return None, f"SB10AD did not return within {TIMEOUT_S} s", None, None
    proc.join()
    if cl is not None:
        cl = ct.ss(*cl)
    return gam, err, k, cl


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    # Resumable: SB10AD takes up to a minute per case on a loaded machine.
    partial = os.path.join(here, "cases.partial.json")
    done = json.load(open(partial)) if os.path.exists(partial) else {}
    cases = []
    for name, (num, den) in plants():
        g = ct.tf(num, den)
        for w2 in W2S:
            key = f"{name}, w2={w2:g}"
            if key in done:
                cases.append(done[key])
                continue
            p = ct.augw(g, ct.tf(*W1), ct.tf([w2], [1.0]), ct.tf(*W3))
            t0 = time.perf_counter()
            gam, err, k, cl = synthesise(p)
            dt = time.perf_counter() - t0
            case = {"name": f"{name}, w2={w2:g}", "g_num": num, "g_den": den,
                    "w1_num": W1[0], "w1_den": W1[1], "w2": w2,
                    "w3_num": W3[0], "w3_den": W3[1],
                    "slicot_gamma": gam, "slicot_error": err, "slicot_seconds": dt}
            if err is None:
                max_re = float(np.max(np.linalg.eigvals(np.asarray(cl.A)).real))
                achieved = sweep_norm(cl)
                case.update({"slicot_closed_loop_max_real_pole": max_re,
                             # null: SLICOT's closed loop is unstable (JSON has no inf)
                             "slicot_achieved_sweep": achieved if np.isfinite(achieved) else None,
                             "slicot_controller_states": k,
                             "slicot_achieves": bool(achieved <= gam * (1 + 1e-4))})
            else:
                case.update({"slicot_achieves": False})
            print(f"{case['name']:32s} gamma {gam} achieved {case.get('slicot_achieved_sweep')}",
                  flush=True)
            cases.append(case)
            done[key] = case
            with open(partial, "w") as f:
                json.dump(done, f)
    out = {"generator": "tests/data/hinf_slicot/gen_cases.py",
           "python_control": ct.__version__, "slycot": slycot.__version__,
           "sweep_points": 4000, "cases": cases}
    with open(os.path.join(here, "cases.json"), "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    os.remove(partial)


if __name__ == "__main__":
    main()
