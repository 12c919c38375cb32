#!/usr/bin/env python3
"""Writes the MAT-file fixtures of the `fts::io::mat` tests (tests/suite/mat_reader.rs).

    pip install numpy scipy
    python3 tests/data/mat/make_mat_fixtures.py

Files written next to this script:

* record.mat / record_z.mat: MAT v5 (scipy `savemat`, format '5'), without and
  with compression (the latter is what MATLAB's default `-v7` writes): a
  measured-record layout with
  t (N x 1, k * 1e-4), drive_V (N x 1, a sine), pos_um (N x 1, a cubic of
  drive_V), pos_row (1 x N, pos_um as a row), data (N x 3: t, drive_V, pos_um),
  code_i16 (int16), code_i32 (int32), drive_f32 (single), short (N - 1 samples).
* kinds.mat / kinds_z.mat: what the reader must refuse with a clear message:
  z (complex), label (char), params (struct), cells (cell), sp (sparse),
  flag (logical), cube (2 x 3 x 4), empty (0 x 1), bad (a NaN at sample 6),
  neg_inf (-inf at sample 3), plus one good vector `ok` (1, 2, 3).
* v4.mat: a MATLAB v4 file (format '4'), which fts does not read.
* v73.mat: the start of a MATLAB v7.3 file (the 128-byte text header, the
  HDF5 signature at byte 512); not a complete HDF5 file, only what the reader
  looks at to say that it is v7.3.
* expected.csv: the exact values stored (Python `repr`, which round-trips
  bit for bit) of t, drive_V, pos_um, code_i16, code_i32 and drive_f32.

The header text that savemat writes carries the creation date; it is
replaced by a fixed text so that the files are the same on every run (with
the same zlib).
"""

import os

import numpy as np
import scipy.io
import scipy.sparse

HERE = os.path.dirname(os.path.abspath(__file__))
N = 200
HEADER_TEXT = b"MATLAB 5.0 MAT-file, written by tests/data/mat/make_mat_fixtures.py"


def path(name):
    return os.path.join(HERE, name)


def fix_header(name):
    """Replaces the dated 116-byte header text with a fixed one."""
    with open(path(name), "rb") as f:
        raw = bytearray(f.read())
    assert raw[:19] == b"MATLAB 5.0 MAT-file", raw[:40]
    raw[:116] = HEADER_TEXT.ljust(116, b" ")
    with open(path(name), "wb") as f:
        f.write(raw)


def record():
    k = np.arange(N, dtype=np.float64)
    t = k * 1e-4
    drive = 2.5 * np.sin(2.0 * np.pi * k / 40.0)
    pos = 0.8 * drive + 0.05 * drive**3
    code_i16 = np.round(drive * 1000.0).astype(np.int16)
    code_i32 = ((np.arange(N, dtype=np.int64) ** 2 - 5000) * 1000).astype(np.int32)
    drive_f32 = drive.astype(np.float32)
    variables = {
        "t": t.reshape(N, 1),
        "drive_V": drive.reshape(N, 1),
        "pos_um": pos.reshape(N, 1),
        "pos_row": pos.reshape(1, N),
        "data": np.column_stack([t, drive, pos]),
        "code_i16": code_i16.reshape(N, 1),
        "code_i32": code_i32.reshape(N, 1),
        "drive_f32": drive_f32.reshape(N, 1),
        "short": drive[: N - 1].reshape(N - 1, 1),
    }
    columns = {
        "t": t,
        "drive_V": drive,
        "pos_um": pos,
        "code_i16": code_i16.astype(np.float64),
        "code_i32": code_i32.astype(np.float64),
        "drive_f32": drive_f32.astype(np.float64),
    }
    with open(path("expected.csv"), "w") as f:
        f.write(",".join(columns) + "\n")
        for i in range(N):
            f.write(",".join(repr(float(c[i])) for c in columns.values()) + "\n")
    return variables


def kinds():
    bad = np.arange(10, dtype=np.float64)
    bad[5] = np.nan
    neg_inf = np.arange(4, dtype=np.float64)
    neg_inf[2] = -np.inf
    return {
        "ok": np.array([[1.0], [2.0], [3.0]]),
        "z": np.array([[1.0 + 2.0j], [3.0 - 1.0j]]),
        "label": "piezo X",
        "params": {"gain": 2.0, "ts": 1e-4},
        "cells": np.array([np.zeros(2), "x"], dtype=object),
        "sp": scipy.sparse.csc_matrix(np.eye(3)),
        "flag": np.array([[True], [False], [True]]),
        "cube": np.arange(24, dtype=np.float64).reshape(2, 3, 4),
        "empty": np.zeros((0, 1)),
        "bad": bad.reshape(10, 1),
        "neg_inf": neg_inf.reshape(4, 1),
    }


def v73():
    """MATLAB's v7.3 layout: a 512-byte user block whose first 128 bytes are
    the MAT header (version 0x0200), then the HDF5 file."""
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Jan  1 00:00:00 2026 HDF5 schema 1.00 ."
    header = text.ljust(116, b" ") + b" " * 8 + (0x0200).to_bytes(2, "little") + b"IM"
    assert len(header) == 128
    body = header.ljust(512, b"\0") + b"\x89HDF\r\n\x1a\n" + bytes(24)
    with open(path("v73.mat"), "wb") as f:
        f.write(body)


def main():
    for name, variables in (("record", record()), ("kinds", kinds())):
        scipy.io.savemat(path(name + ".mat"), variables, format="5")
        fix_header(name + ".mat")
        scipy.io.savemat(path(name + "_z.mat"), variables, format="5", do_compression=True)
        fix_header(name + "_z.mat")
    scipy.io.savemat(path("v4.mat"), {"t": np.arange(5, dtype=np.float64).reshape(5, 1)}, format="4")
    v73()


if __name__ == "__main__":
    main()
