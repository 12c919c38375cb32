# Generates cases-inputs.toml (python3 cases-inputs.py); the table is what the harness reads.
import json
cases = []
def case(args, exit, expect, files=None, comment=None):
    cases.append((args, exit, expect, files or {}, comment))

def tq(s):
    # TOML string: literal if possible, else basic with escapes.
    if "'" not in s and "\n" not in s and all(ord(c) >= 0x20 for c in s):
        return "'" + s + "'"
    return json.dumps(s)

def mtq(s):
    if "'''" not in s and all(ord(c) >= 0x20 or c in "\n\t" for c in s):
        return "'''\n" + s + "'''"
    return json.dumps(s)

# ---------------------------------------------------------------- --plot
PLOT = [
    ("simulate --stages pid --plot {p}", "--plot"),
    ("trajectory circle --plot {p}", "--plot"),
    ("contour circle --plot {p}", "--plot"),
    ("bode data.csv --plot {p}", "--plot"),
    ("identify ct data.csv --np 1 --nz 0 --plot {p}", "--plot"),
    ("identify ct-frd h.csv --np 1 --nz 0 --plot {p}", "--plot"),
    ("identify arx data.csv --na 1 --nb 1 --nk 1 --plot {p}", "--plot"),
    ("identify arx data.csv --na 1 --nb 1 --nk 1 --plot-compare {p}", "--plot-compare"),
    ("identify hysteresis data.csv --plot {p}", "--plot"),
    ("zpetc --tf tf.json --plot {p}", "--plot"),
    ("response step ctf.json --plot {p}", "--plot"),
    ("loop --plant tf.json --kp 0.01 --plot {p}", "--plot"),
    ("ding22 --plot {p}", "--plot"),
    ("mechanism 3puu --plot {p}", "--plot"),
]
H = {"h.csv": "freq_hz,re,im\n1,1,-0.1\n2,0.8,-0.4\n5,0.3,-0.6\n10,0.1,-0.4\n"}
bad_ext = ["x.pdf", "x", "x.jpg", "x.svgz", "x.png.txt", "plot.eps"]
for i, (cmd, opt) in enumerate(PLOT):
    # Two bad names per command, rotating through the list.
    for p in (bad_ext[i % len(bad_ext)], bad_ext[(i + 3) % len(bad_ext)]):
        files = H if "h.csv" in cmd else None
        case(cmd.format(p=p), 2, [opt, p, ".svg, .png"], files)
case("ilc --plot x.jpg", 2, ["--plot", "x.jpg", ".svg, .png"])
case("ilc --plot x.pdf", 2, ["--plot", "x.pdf", ".svg, .png"])

# ---------------------------------------------------------------- simulate
for a, shown in [("0", "0"), ("-1", "-1"), ("nan", "NaN"), ("inf", "inf"), ("-inf", "-inf")]:
    case(f"simulate --stages pid --amplitude {a}", 2, ["--amplitude", shown])
case("simulate --stages pid --reference sweep --amplitude 0", 2, ["--amplitude", "0"])
case("simulate --stages pid --output-min nan", 2, ["--output-min", "NaN"])
case("simulate --stages pid --output-max inf", 2, ["--output-max", "inf"])
case("simulate --stages pid --output-min 5 --output-max 5", 2, ["--output-max", "5"])
case("simulate --stages pid --output-min 11", 2, ["--output-min", "11"])
case("simulate --stages pid --output-max -1", 2, ["--output-max", "-1"])
case("simulate --controller controller.json --output-max 5", 2, ["--output-max", "--controller"])
REF = "simulate --stages pid --reference-file r.csv"
case(REF, 2, ["r.csv", "'time'", "samples"], {"r.csv": "time,r\n0,1\n100000,2\n"})
case(REF, 2, ["r.csv", "'t_ms'", "samples"], {"r.csv": "t_ms,r\n0,1\n1e12,2\n"})
case(REF, 2, ["r.csv", "line 4", "t"], {"r.csv": "t,r\n0,1\n0.001,2\n0.0005,3\n"})
case(REF, 2, ["r.csv", "line 5", "t"], {"r.csv": "t,r\n0,1\n0.001,2\n0.002,3\n0.009,3\n0.010,3\n"})
case(REF, 2, ["r.csv", "line 3", "r", "NaN"], {"r.csv": "t,r\n0,1\n0.001,NaN\n"})
case(REF, 2, ["r.csv", "line 3", "t", "empty"], {"r.csv": "t,r\n0,1\n,2\n"})
case(REF, 2, ["r.csv", "too few"], {"r.csv": "t,r\n0,1\n"})
case(REF, 2, ["r.csv", "missing column 'r'"], {"r.csv": "t,x\n0,1\n0.001,2\n"})
case(REF, 2, ["r.csv", "binary"], {"r.csv": "t,r\n0,1\n\u0000\u0001\u0002\n"})
case(REF, 2, ["r.csv", "no data rows"], {"r.csv": ""})
case("simulate --stages pid --reference-file v4.mat", 2, ["v4.mat", "MATLAB v4"])
case("simulate --stages pid --reference-file v73.mat", 2, ["v73.mat", "v7.3"])
case("simulate --stages pid --reference-file record.mat", 2, ["record.mat", "'r'"])
case("simulate --stages pid --reference-file r.csv --reference-column 0", 2, ["--reference-column", "0", "1-based"], {"r.csv": "t,r\n0,1\n0.001,2\n"})
case("simulate --stages pid --reference-file r.csv --reference-column 9", 2, ["r.csv", "line 2", "column 9"], {"r.csv": "t,r\n0,1\n0.001,2\n"})
case("simulate --stages pid --reference-file nope.csv", 2, ["nope.csv", "cannot read"])
case("simulate --stages pid --input-disturbance file:v4.mat", 2, ["v4.mat", "MATLAB v4"])
case("simulate --stages pid --output-disturbance file:d.csv", 2, ["d.csv", "binary"], {"d.csv": "d\n1\n\u0007\n"})

# ---------------------------------------------------------------- virtual
case("virtual sweep --kp 5 -o s.csv", 1, ["does not track", "limit cycle", "kp 5"])
case("virtual sweep --kp 0.5 --ki 1 -o s.csv", 1, ["does not track"])
case("virtual sweep --offset 40 -o s.csv", 1, ["does not track", "actuator"])
case("virtual sweep --kp nan", 2, ["--kp", "NaN"])
case("virtual sweep --output-min 5 --output-max 5", 2, ["--output-max", "5"])
case("virtual sweep --output-min 3 --output-max 1", 2, ["--output-max", "1"])
case("virtual sweep --amplitude 0", 2, ["--amplitude", "0"])
case("virtual sweep --duration -1", 2, ["--duration", "-1"])
case("virtual sweep --f1 0", 2, ["--f1", "0"])
case("virtual sweep --hysteresis v4.mat", 2, ["v4.mat"])
case("virtual triangles --freq 0", 2, ["--freq", "0"])
case("virtual triangles --amplitudes 1,x", 2, ["--amplitudes", "x"])
case("virtual triangles --seed -1", 2, ["--seed", "-1"])

# ---------------------------------------------------------------- identify ct
CT = "identify ct {f} --np 2 --nz 0"
case(CT.format(f="v4.mat"), 2, ["v4.mat", "MATLAB v4"])
case(CT.format(f="v73.mat"), 2, ["v73.mat", "v7.3"])
case(CT.format(f="kinds.mat"), 2, ["kinds.mat"])
case(CT.format(f="b.csv"), 2, ["b.csv", "binary", "0x00"], {"b.csv": "t,u,y\n0,1,2\n\u0000\u0000\n"})
case(CT.format(f="b.csv"), 2, ["b.csv", "binary", "0x1b"], {"b.csv": "\u001b[31mt,u,y\n"})
case(CT.format(f="d.csv"), 2, ["d.csv", "line 4", "t"], {"d.csv": "t,u,y\n0,1,2\n0.1,1,2\n0.1,1,2\n0.3,1,2\n"})
case(CT.format(f="d.csv"), 2, ["d.csv", "line 3", "y", "inf"], {"d.csv": "t,u,y\n0,1,2\n0.1,1,inf\n"})
case(CT.format(f="d.csv") + " --time-unit hours", 2, ["--time-unit", "hours"], {"d.csv": "t,u,y\n0,1,2\n"})
case(CT.format(f="data.csv") + " --delay -1", 2, ["--delay", "-1"])
case(CT.format(f="data.csv") + " --delay nan", 2, ["--delay", "NaN"])
case(CT.format(f="data.csv") + " --period -1", 2, ["--period", "-1"])
case("identify ct data.csv --np 0 --nz 0", 2, ["--np", "0"])
case(CT.format(f="data.csv") + " --input-col volts", 2, ["data.csv", "volts"])
case(CT.format(f="data.csv") + " --validate v4.mat", 2, ["v4.mat", "MATLAB v4"])

# ---------------------------------------------------------------- identify ct-frd
FRD = "identify ct-frd h.csv --np 1 --nz 0"
def frd(row):
    return {"h.csv": "freq_hz,re,im\n1,1,-0.1\n2,0.8,-0.4\n" + row + "\n10,0.1,-0.4\n"}
case(FRD, 2, ["h.csv line 4", "freq_hz", "-5"], frd("-5,0.3,-0.6"))
case(FRD, 2, ["h.csv line 4", "freq_hz", "inf"], frd("inf,0.3,-0.6"))
case(FRD, 2, ["h.csv line 4", "freq_hz", "-inf"], frd("-inf,0.3,-0.6"))
case(FRD, 2, ["h.csv line 4", "freq_hz", "NaN"], frd("NaN,0.3,-0.6"))
case(FRD, 2, ["h.csv line 4", "freq_hz", "empty"], frd(",0.3,-0.6"))
case(FRD, 2, ["h.csv line 4", "'re'", "inf"], frd("5,inf,-0.6"))
case(FRD, 2, ["h.csv line 4", "'im'", "-inf"], frd("5,0.3,-inf"))
case(FRD, 2, ["h.csv line 4", "'re'", "not a number", "x"], frd("5,x,-0.6"))
case(FRD, 2, ["h.csv", "no column named 'im'"], {"h.csv": "freq_hz,re\n1,1\n"})
case(FRD, 2, ["h.csv", "no row with a positive frequency"], {"h.csv": "freq_hz,re,im\n0,1,0\n5,NaN,1\n"})
case("identify ct-frd v4.mat --np 1 --nz 0", 2, ["v4.mat"])
case(FRD + " --delay -1", 2, ["--delay", "-1"], H)
case(FRD + " --fmin 100 --fmax 1", 2, ["--fmax", "1"], H)

# ---------------------------------------------------------------- trajectory / contour
case("trajectory circle --size 0", 2, ["--size", "0"])
case("trajectory circle --velocity -1", 2, ["--velocity", "-1"])
case("trajectory circle --ts 0", 2, ["--ts", "0"])
case("trajectory circle --incline nan", 2, ["--incline", "NaN"])
case("trajectory circle --jerk 0", 2, ["--jerk", "0"])
case("contour circle --pid-x 1,2", 2, ["--pid-x", "four numbers", "got 2"])
case("contour circle --cc 1,0,0,0", 2, ["P,I,D,N", "N > 0", "1,0,0,0"])
case("contour circle --plant-x v4.mat", 2, ["v4.mat"])
case("contour circle --ts 0", 2, ["--ts", "0"])
case("contour circle --settle -1", 2, ["--settle", "-1"])
case("contour circle --output-disturbance file:d.csv", 2, ["--output-disturbance"])

# ---------------------------------------------------------------- mechanism
case("mechanism 3puu --samples 0", 2, ["--samples", "0"])
case("mechanism 3puu --rod-mm -1", 2, ["--rod-mm", "-1"])
case("mechanism hinge --e-gpa 200", 2, ["--width-mm"])
case("mechanism lever --input-arm-mm 0", 2, ["--input-arm-mm", "0"])
case("mechanism flexure-loss --kp -1", 2, ["--kp", "-1"])
# Three-axis control of the 3-PUU stage: a pose outside the workspace,
# three values x,y,z, times, the plant file, the laws.
case("mechanism 3puu-track --amplitude-um 0,0,60", 2, ["leaves the workspace", "115.045", "--travel-um", "--amplitude-um"])
case("mechanism 3puu-track --center-um 100000,0,0 --amplitude-um 0,0,0", 2, ["leaves the workspace", "a rod cannot reach"])
case("mechanism 3puu-track --center-um 1,2", 2, ["--center-um", "three values", "got 2"])
case("mechanism 3puu-track --amplitude-um 1,2,3,4", 2, ["--amplitude-um", "got 4"])
case("mechanism 3puu-track --amplitude-um nan,0,0", 2, ["--amplitude-um", "NaN"])
case("mechanism 3puu-track --freq 0", 2, ["--freq", "0"])
case("mechanism 3puu-track --freq 600", 2, ["--freq", "600", "Nyquist"])
case("mechanism 3puu-track --duration 601", 2, ["--duration", "601"])
case("mechanism 3puu-track --settle 3", 2, ["--settle", "3"])
case("mechanism 3puu-track --travel-um 0", 2, ["--travel-um", "0"])
case("mechanism 3puu-track --home-um -1", 2, ["--home-um", "-1"])
case("mechanism 3puu-track --kp inf", 2, ["--kp", "inf"])
case("mechanism 3puu-track --mode task --joints ideal", 2, ["--joints", "--mode"])
case("mechanism 3puu-track --mode both", 2, ["--mode", "both"])
case("mechanism 3puu-track --plant missing.json", 2, ["missing.json"])
case("mechanism 3puu-track --plant tf.json", 2, ["tf.json"])
case("mechanism 3puu-track --plant p.json", 2, ["p.json", "mode_hz"],
     {"p.json": json.dumps({**json.load(open(__file__.replace("cases-inputs.py", "../../../fixtures/tang17-3puu.json"))),
                            "flexure": {"piezo_stiffness_n_per_um": 200.0, "flexure_stiffness_n_per_um": 11.6,
                                        "mode_hz": 0.0, "damping_ratio": 0.05}})})

# ---------------------------------------------------------------- excite
case("excite sine --freq -1", 2, ["--freq", "-1"])
case("excite sine --freq 6000", 2, ["--freq", "6000"])
case("excite sweep --f1 nan", 2, ["--f1", "NaN"])
case("excite multisine --lines 0", 2, ["--lines", "0"])
case("excite triangle --amplitudes x", 2, ["--amplitudes", "x"])
case("excite sine --ts 0", 2, ["--ts", "0"])
case("excite sine --duration 1e12", 2, ["--duration"])

# ---------------------------------------------------------------- bode
case("bode v4.mat", 2, ["v4.mat", "MATLAB v4"])
case("bode b.csv", 2, ["b.csv", "binary"], {"b.csv": "u,y\n1,2\n\u0003\n"})
case("bode data.csv --fmax -1", 2, ["--fmax", "-1"])
case("bode data.csv --overlap 1", 2, ["data.csv", "overlap", "1"])
case("bode data.csv --time-col zeit", 2, ["data.csv", "zeit"])
case("bode data.csv --time-jitter 2", 2, ["jitter", "2"])

# ---------------------------------------------------------------- continuous delay readers
D = {"gd.json": '{"format": "fts.tf/1", "var": "s", "num": [1000], "den": [1, 100], "delay": 0.001}'}
case("response step gd.json", 2, ["gd.json", "delay", "0.001"], D)
case("c2d gd.json --ts 1e-4", 2, ["gd.json", "delay", "0.001"], D)
case("convert gd.json --to ss", 2, ["gd.json", "delay"], D)
case("zpk gd.json", 2, ["gd.json", "delay"], D)
case("minreal gd.json", 2, ["gd.json", "delay"], D)
case("ss-info gd.json", 2, ["gd.json", "delay"], D)
case("simulate --ss gd.json", 2, ["gd.json", "delay"], D)
case("emit --ss gd.json --ts 1e-4", 2, ["gd.json", "delay"], D)
case("contour circle --plant-x gd.json", 2, ["gd.json", "delay"], D)
case("loop --plant gd.json --kp 1", 2, ["gd.json", "delay"],
     {"gd.json": '{"format": "fts.tf/1", "var": "s", "num": [1000], "den": [1, 100], "delay": -0.001}'})
case("tf info gd.json", 2, ["gd.json", "delay"],
     {"gd.json": '{"format": "fts.tf/1", "var": "s", "num": [1000], "den": [1, 100], "delay": "1 ms"}'})

# ---------------------------------------------------------------- manifests with contradictions
def manifest(body):
    return {"m.toml": body}
MA = '[step.m]\nkind = "multiaxis"\nout = "k3.json"\n'
for axis, key in [("x", "pid_x"), ("y", "pid_y"), ("z", "pid_z"), ("cross", "cross_coupling")]:
    case("build -f m.toml", 2, ["m.toml line 5", f"step.m.{key}", f"`{axis}` (line 4)"],
         manifest(MA + f'{axis} = "K.json"\n{key} = [1, 0.01, 0.0005, 100]\n'))
case("build -f m.toml", 2, ["m.toml line 4", "step.m.cross", "coupled = false` (line 5)"],
     manifest(MA + 'cross = "K.json"\ncoupled = false\n'))
case("build -f m.toml", 2, ["m.toml line 5", "step.m.cross_coupling", "coupled = false` (line 4)"],
     manifest(MA + 'coupled = false\ncross_coupling = [1, 0, 0, 100]\n'))
case("build -f m.toml", 1, ["m.toml", "does not track"],
     manifest('[step.s]\nkind = "virtual-sweep"\nkp = 5\nout = "s.csv"\n'))
case("build -f m.toml", 2, ["m.toml", "v4.mat", "MATLAB v4"],
     manifest('[step.c]\nkind = "ct"\ndata = "v4.mat"\nnp = 2\nnz = 0\nout = "g.json"\n'))
case("build -f m.toml", 2, ["m.toml line 3", "step.c.delay"],
     manifest('[step.c]\nkind = "ct"\ndelay = -1\ndata = "data.csv"\nnp = 2\nnz = 0\nout = "g.json"\n'))

# Contour command limits (docs/contouring.md "The loop").
for args, expect in [
    ("contour circle --output-min 1 --output-max -1", ["--output-max (-1) must exceed --output-min (1)"]),
    ("contour circle --output-min 2 --output-max 2", ["--output-max (2) must exceed --output-min (2)"]),
    ("contour circle --output-min nan", ["--output-min", "NaN"]),
    ("contour circle --output-max inf", ["--output-max", "inf"]),
    ("contour circle --controller k3.json --output-min -1", ["--output-min", "--controller"]),
]:
    case(args, 2, expect)
case("build -f m.toml", 2, ["m.toml", "step.m.output_max", "must exceed", "'output_min'"],
     manifest(MA + 'output_min = 3\noutput_max = 1\n'))
# Disturbance files: a time column is read, never played as data.
case("simulate --output-disturbance file:t.csv", 2, ["t.csv", "column 2"], {"t.csv": "t\n0\n1\n"})
case("simulate --output-disturbance file:d.csv", 2, ["d.csv", "line 3"], {"d.csv": "t,d\n0,1\n0,2\n"})
case("simulate --input-disturbance file:d.csv", 2, ["d.csv"], {"d.csv": "time_ms,d\n0,1\n-1,2\n"})

# The disturbance-observer block (contour axes, simulate's dob stages).
case("contour circle --axis-controller dob --dob-q-hz 0", 2, ["--dob-q-hz", "Nyquist", "got 0"])
case("contour circle --axis-controller dob --dob-q-order 0", 2, ["--dob-q-order", "got 0"])
case("contour circle --axis-controller dob --dob-smoothing -1", 2, ["--dob-smoothing", "-1"])
case("contour circle --friction-viscous -1", 2, ["--friction-viscous", "-1"])
case("contour circle --axis-controller dob --plant-x rel3.json --pid-x 1,0,0,100", 2,
     ["axis x", "not minimum phase", "-3.732048009"])
PLANT = '{"format": "fts.tf/1", "var": "z^-1", "ts": 0.0001, "num": [0.5], "den": [1, -0.5], "delay": 1}'
NMP = '{"format": "fts.tf/1", "var": "z^-1", "ts": 0.0001, "num": [0.5, 1], "den": [1, -0.5], "delay": 1}'
for opt, value, expect in [
    ("--dob-q-hz", "0", ["Nyquist", "got 0"]),
    ("--dob-q-hz", "6000", ["Nyquist", "got 6000"]),
    ("--dob-q-order", "0", ["got 0"]),
    ("--dob-smoothing", "-1", ["-1"]),
    ("--dob-coulomb", "nan", ["NaN"]),
    ("--dob-viscous", "inf", ["inf"]),
]:
    case(f"simulate --plant-tf p.json --stages dob {opt} {value}", 2, [opt] + expect, {"p.json": PLANT})
case("simulate --plant-tf p.json --stages dob", 2, ["--plant-tf", "p.json", "not minimum phase"], {"p.json": NMP})
case("simulate --stages dob", 2, ["--stages dob", "--plant-tf"])
case("simulate --stages dob+ss", 2, ["--controller", "out of order"])

out = ["# Time bases, units and settings read, never assumed; contradictions",
       "# refused (issue #27 item 6): --plot extensions, reference and record",
       "# files (binary, MATLAB v4, time columns), frequency-response rows,",
       "# command limits, continuous delays in readers that cannot hold them,",
       "# multi-axis manifests. Format: see cases.toml.", ""]
for args, exit, expect, files, comment in cases:
    out.append("[[case]]")
    out.append("args = " + tq(args))
    out.append(f"exit = {exit}")
    out.append("expect = [" + ", ".join(tq(e) for e in expect) + "]")
    for name, text in files.items():
        out.append(f'files."{name}" = ' + mtq(text))
    out.append("")
open(__file__.replace(".py", ".toml"), "w").write("\n".join(out))
print(len(cases))
