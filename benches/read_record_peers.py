#!/usr/bin/env python3
"""The peers of `fts identify arx` on a long record, measured in one run.

    python3 benches/read_record_peers.py RECORD.csv [FTS_BINARY ...]

RECORD.csv is what `cargo run --release --example write_record -- RECORD.csv
ROWS` writes (`t,u,y`, every float in full precision). Printed, each the
median of several runs after one warm-up:

* polars `read_csv` of the whole file, in this process (its own threads,
  one per core): the read alone, no model;
* numpy `loadtxt`, in this process (read alone);
* for each fts binary given, the whole process `fts identify arx RECORD
  --na 5 --nb 5 --nk 5` (read, ARX, fits, residual tests, report), wall
  time, and its peak resident memory (GNU time's `%M`).

The fts rows are whole processes (start-up included), the Python rows are
the read alone (interpreter and import excluded): the comparison favours
the peers.
"""
import os
import statistics
import subprocess
import sys
import time


def median_time(run, runs):
    run()  # warm-up: page cache, lazy imports
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def process(argv, runs):
    """Median wall time and the largest peak RSS (MiB) of a whole process,
    the peak as GNU time reports it (a forked Python child would carry the
    interpreter's own high-water mark into `wait4`'s figure)."""
    timed = ["/usr/bin/time", "-f", "%M"] + argv
    subprocess.run(argv, stdout=subprocess.DEVNULL, check=True)
    walls, peaks = [], []
    for _ in range(runs):
        start = time.perf_counter()
        done = subprocess.run(timed, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        walls.append(time.perf_counter() - start)
        if done.returncode != 0:
            sys.exit(f"{argv[0]} failed: {done.stderr.strip()}")
        peaks.append(int(done.stderr.strip().splitlines()[-1]) / 1024)
    return statistics.median(walls), max(peaks)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    record, binaries = sys.argv[1], sys.argv[2:]
    size_mb = os.path.getsize(record) / 1e6
    runs = 7
    print(f"record {record}: {size_mb:.1f} MB, {runs} runs each (median)")
    import numpy as np
    import polars as pl

    t = median_time(lambda: pl.read_csv(record), runs)
    print(f"polars {pl.__version__} read_csv, in process: {t:.3f} s ({size_mb / t:.0f} MB/s)")
    t = median_time(lambda: np.loadtxt(record, delimiter=",", skiprows=1), max(3, runs // 2))
    print(f"numpy {np.__version__} loadtxt, in process: {t:.3f} s")
    for binary in binaries:
        argv = [binary, "identify", "arx", record, "--na", "5", "--nb", "5", "--nk", "5"]
        wall, peak = process(argv, runs)
        print(f"{binary} identify arx, whole process: {wall:.3f} s, peak {peak:.1f} MiB")


if __name__ == "__main__":
    main()
