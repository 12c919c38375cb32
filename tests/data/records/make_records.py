"""Writes the DaISy hair-dryer record (data/daisy-hairdryer/dryer.dat,
Ts = 0.08 s) in the layouts users export, for tests/suite/cli_records.rs:

* dryer.csv            comma, header t,u,y, time in seconds
* dryer-ms.csv         comma, header time_ms,u,y (time in milliseconds)
* dryer-semicolon.csv  semicolon, units row under the header, decimal commas
* dryer.mat            MATLAB v5 (scipy.io.savemat): column vectors t, u, y

Every value is written with Python's shortest round-trip repr (or stored as
the same float64), so each file holds exactly the same numbers and must give
byte-identical models. Run from the repository root:
    python3 tests/data/records/make_records.py
"""
import numpy as np
from scipy.io import savemat

data = np.loadtxt("data/daisy-hairdryer/dryer.dat")
u, y = data[:, 0], data[:, 1]
t = np.arange(len(u)) * 0.08
t_ms = np.arange(len(u)) * 80.0
out = "tests/data/records/"

with open(out + "dryer.csv", "w") as f:
    f.write("t,u,y\n")
    for row in zip(t, u, y):
        f.write(",".join(repr(float(v)) for v in row) + "\n")

with open(out + "dryer-ms.csv", "w") as f:
    f.write("time_ms,u,y\n")
    for row in zip(t_ms, u, y):
        f.write(",".join(repr(float(v)) for v in row) + "\n")

with open(out + "dryer-semicolon.csv", "w") as f:
    f.write("t;u;y\ns;V;degC\n")
    for row in zip(t, u, y):
        f.write(";".join(repr(float(v)).replace(".", ",") for v in row) + "\n")

savemat(out + "dryer.mat", {"t": t[:, None], "u": u[:, None], "y": y[:, None]},
        format="5", do_compression=True)
