# Generates tests/data/bad_input/cases-bounds.toml (run once; the table is committed).
out = []
def case(args, exit, expect, files=None, comment=None):
    s = ""
    if comment:
        s += "".join(f"# {l}\n" for l in comment.splitlines())
    s += "[[case]]\n"
    s += f"args = '{args}'\n" if isinstance(args, str) else "args = [" + ", ".join(f"'{a}'" for a in args) + "]\n"
    s += f"exit = {exit}\n"
    s += "expect = [" + ", ".join("'" + e.replace("'", "\\'") + "'" if "'" not in e else '"' + e + '"' for e in expect) + "]\n"
    for name, spec in (files or {}).items():
        s += f'files."{name}" = {spec}\n'
    out.append(s)

def delayed(d):
    return '{from = "tf.json", replace = [["\\"delay\\": 5", "\\"delay\\": %d"]]}' % d

out.append("""# Bounded work (docs/formats.md, Bounds): every size a file or option asks
# for is refused before the work, naming the field or option, the value and
# the bound; and output-path conflicts write nothing. Run alone with
# FTS_BAD_INPUT_TABLE=cases-bounds cargo test --test suite bad_input -- newer
""")

# 1. Delays realised as states: at most 200 (docs/formats.md, Bounds).
cmds = [
    ("loop --plant g.json --kp 0.1", "g.json"),
    ("loop --plant tf.json --controller g.json", "g.json"),
    ("response step g.json", "g.json"),
    ("response impulse tf.json --controller g.json", "g.json"),
    ("convert g.json --to ss -o out.json", "g.json"),
    ("minreal g.json -o out.json", "g.json"),
    ("balred g.json --order 2 -o out.json", "g.json"),
    ("d2c g.json -o out.json", "g.json"),
    ("ss-info g.json", "g.json"),
    ("c2d g.json --ts 1e-4 -o out.json", "g.json"),
]
first = True
for d, states in [(197, 201), (1000, 1004), (100000, 100004), (1000000, 1000004)]:
    for args, name in cmds:
        case(args, 2, [name, "'delay'", f"{d} samples", f"{states} states", "at most 200 states"],
             {"g.json": delayed(d)},
             "A delay realised as a dense state matrix: at most 200 states (delay + numerator degree)." if first else None)
        first = False
for args in ["convert g.json --to ss", "zpk g.json", "loop --plant g.json --kp 0.1", "response step g.json"]:
    case(args, 2, ["g.json", "delay", "1000001", "1000000"], {"g.json": delayed(1000001)})

# 2. ss-info and balred: at most 64 states.
def ss_text(n, ts="0.001"):
    row = lambda i: "[" + ",".join("0.5" if i == j else "0" for j in range(n)) + "]"
    a = ",".join(row(i) for i in range(n))
    return "'" + '{"format":"fts.ss/1","ts":%s,"a":[%s],"b":[%s],"c":[[%s]],"d":[[0]]}' % (ts, a, ",".join(["[1]"] * n), ",".join(["1"] * n)) + "'"
def ctf_text(n):
    den = ",".join(["1"] + ["0.5"] * n)
    return "'" + '{"format":"fts.tf/1","var":"s","num":[1],"den":[%s]}' % den + "'"
first = True
for fname, spec, n in [("big.json", ss_text(65), 65), ("big.json", ss_text(65, "null"), 65),
                       ("big.json", ss_text(100), 100), ("big.json", ctf_text(65), 65),
                       ("big.json", ctf_text(300), 300), ("big.json", delayed(100), 104)]:
    for args in ["ss-info big.json", "balred big.json --order 2 -o out.json"]:
        case(args, 2, ["big.json", f"{n} states", "at most 64 states"], {fname: spec},
             "Gramians, Hamiltonian bisections and zero pencils: at most 64 states." if first else None)
        first = False

# 2b. Synthesis: a generalised plant (with mixsyn's weights) of at most 64 states.
def gp_text(n):
    row = lambda i: "[" + ",".join("-1" if i == j else "0" for j in range(n)) + "]"
    a = ",".join(row(i) for i in range(n))
    ones = ",".join(["1"] * n)
    zeros = ",".join(["0"] * n)
    return "'" + '{"format":"fts.ss/1","a":[%s],"b":[%s],"c":[[%s],[%s],[%s]],"d":[[0,0],[0,1],[1,0]]}' % (
        a, ",".join(["[1,1]"] * n), ones, zeros, ones) + "'"
first = True
for n in [65, 128]:
    for args in ["hinf --generalized big.json --nmeas 1 --ncon 1 -o k.json",
                 "h2 --generalized big.json --nmeas 1 --ncon 1 -o k.json"]:
        case(args, 2, ["big.json", f"{n} states", "at most 64 states"], {"big.json": gp_text(n)},
             "Synthesis (Riccati equations, gamma bisection): a generalised plant of at most 64 states." if first else None)
        first = False
for n, total in [(64, 65), (100, 101)]:
    case("mixsyn --plant big.json --ws ws.json -o k.json", 2,
         ["big.json", "augmented plant", f"{total} states", "at most 64 states"], {"big.json": ctf_text(n)})

# 3. identify ct / ct-frd orders and SRIVC work.
frd = "'''\nfreq_hz,re,im\n" + "".join(f"{f},{1/(1+(f/10)**2):.6f},{-(f/10)/(1+(f/10)**2):.6f}\n" for f in range(1, 41)) + "'''"
first = True
for np_ in ["21", "1000", "4000000000"]:
    case(f"identify ct data.csv --np {np_} --nz 0", 2, ["--np", np_, "at most 20"], None,
         "Continuous orders: at most 20 poles; SRIVC work samples x np x max_iterations at most 2e7." if first else None)
    first = False
    case(f"identify ct-frd r.csv --np {np_} --nz 0", 2, ["--np", np_, "at most 20"], {"r.csv": frd})
for args, work in [("--np 2 --nz 0 --max-iterations 1000000", "600000000"),
                   ("--np 20 --nz 0 --max-iterations 10000", "60000000"),
                   ("--np 5 --nz 1 --max-iterations 18446744073709551615", "18446744073709551615")]:
    case(f"identify ct data.csv {args}", 2, ["--max-iterations", "--np", work, "20000000"])
case("identify ct data.csv --np 2 --nz 0 --max-iterations 100000 -o m.json --plot m.svg", 2,
     ["--max-iterations", "60000000", "20000000"])
case("build -f m.toml", 2, ["m.toml", "step.c", "np", "1000", "at most 20"],
     {"m.toml": "'''\n[step.c]\nkind = \"ct\"\ndata = \"data.csv\"\nnp = 1000\nnz = 0\nout = \"c.json\"\n'''"})
case("build -f m.toml", 2, ["m.toml", "step.c", "max_iterations", "20000000"],
     {"m.toml": "'''\n[step.c]\nkind = \"ct\"\ndata = \"data.csv\"\nnp = 3\nnz = 0\nmax_iterations = 100000\nout = \"c.json\"\n'''"})
case("build -f m.toml", 2, ["m.toml", "step.c", "np", "21"],
     {"m.toml": "'''\n[step.c]\nkind = \"ct\"\ndata = \"data.csv\"\nnp = 21\nnz = 0\nout = \"c.json\"\n'''"})

# 4. Samples, points, taps, trials and periods over the other commands.
first = True
for args, expect in [
    ("response step tf.json --duration 1e9", ["--duration", "1000000"]),
    ("response step ctf.json --points 1000001", ["--points", "1000001", "1000000"]),
    ("response step ctf.json --points 1", ["--points", "1"]),
    ("response step ctf.json --duration 1 --points 1000001", ["--points", "1000001"]),
    ("loop --plant tf.json --kp 0.1 --points-per-decade 100000000", ["--points-per-decade", "100000000", "100000"]),
    ("loop --plant ctf.json --kp 0.1 --points-per-decade 100001", ["--points-per-decade", "100001", "100000"]),
    ("trajectory circle --size 1000 --velocity 1e-6 -o t.csv", ["--velocity", "at most 10000000"]),
    ("trajectory circle --size 1000 --ts 1e-9 -o t.csv", ["--ts", "at most 10000000"]),
    ("trajectory square --size 1e6 --ts 1e-6 -o t.csv", ["--ts", "at most 10000000"]),
    ("contour circle --size 100 --ts 1e-9", ["--ts", "at most 1e9"]),
    ("contour square --size 1e9 --ts 1e-4", ["samples"]),
    ("repetitive --tf tf.json --period 1e12", ["--period", "1e12", "16374"]),
    ("repetitive --tf tf.json --period-s 1e9", ["period"]),
    ("repetitive --tf tf.json --period 100 --q-taps 1000000000", ["--q-taps", "1000000000", "32"]),
    ("repetitive --tf tf.json --period 100 --q-taps 33", ["--q-taps", "33", "32"]),
    ("ilc --trials 1000000000 --kp 0.1", ["--trials", "1000000000", "1000"]),
    ("ilc --trials 1001 --kp 0.1", ["--trials", "1001", "1000"]),
    ("ilc --trials 3 --kp 0.1 --q-taps 1000000000", ["--q-taps", "1000000000", "4096"]),
    ("ilc --trials 3 --kp 0.1 --q-taps 4097", ["--q-taps", "4097", "4096"]),
    ("ilc --trials 3 --kp 0.1 --duration 1e9", ["--duration", "5e7"]),
    ("simulate --duration 1e9 --kp 0.1", ["--duration", "5e7"]),
    ("simulate --reference sweep --duration 1e9 --kp 0.1", ["--duration", "5e7"]),
    ("simulate --reference five-leaf --duration 1e9 --kp 0.1", ["--duration", "5e7"]),
    ("simulate --reference step --duration 1e9 --kp 0.1", ["--duration", "5e7"]),
    ("simulate --freq 1e-9 --kp 0.1", ["5e7"]),
    ("simulate --plant-tf tf.json --stages pid --duration 1e9 --kp 0.1", ["--duration", "5e7"]),
    ("virtual sweep --duration 1e9", ["duration", "5e7"]),
    ("virtual triangles --freq 1e-9", ["duration", "5e7"]),
    ("excite sine --freq 10 --duration 1e9", ["--duration", "5e7"]),
]:
    case(args, 2, expect, None, "Signal sizes: 5e7 samples, 1e6 points, 1e7 trajectory rows, 1e9 contour samples, taps and trials." if first else None)
    first = False

# 5. Output-path conflicts: nothing is written.
first = True
for args, expect in [
    ("convert tf.json --to ss -o tf.json", ["tf.json", "input"]),
    ("minreal tf.json -o tf.json", ["tf.json", "input"]),
    ("balred ctf.json --order 1 -o ctf.json", ["ctf.json", "input"]),
    ("convert ctf.json --to tf -o ctf.json", ["ctf.json", "input"]),
    ("c2d ctf.json --ts 1e-4 -o ctf.json", ["ctf.json", "input"]),
    ("identify ct data.csv --np 2 --nz 0 -o data.csv", ["data.csv", "input"]),
    ("identify ct data.csv --np 2 --nz 0 -o m.json --plot m.json", ["m.json"]),
    ("identify ct-frd r.csv --np 2 --nz 0 -o r.csv", ["r.csv", "input"]),
    ("repetitive --tf tf.json --period 100 --gain 0.05 --q-cutoff 200 -o tf.json", ["tf.json", "input"]),
    ("response step tf.json -o x.csv --plot x.csv", ["x.csv"]),
    ("trajectory circle -o t.csv --plot t.csv", ["t.csv"]),
    ("contour circle -o k.json --csv k.json", ["k.json"]),
    ("contour circle -o k.json --plot k.json", ["k.json"]),
    ("simulate --kp 0.1 -o s.csv --plot s.csv", ["s.csv"]),
    ("loop --plant tf.json --kp 0.1 --plot tf.json", ["tf.json", "input"]),
    ("emit --kp 1 --ts 1e-4 --pid-form li21 --zpetc zpetc.json -o zpetc.json", ["zpetc.json", "input"]),
    ("response step tf.json -o tf.json", ["tf.json", "input"]),
    ("identify ct data.csv --np 2 --nz 0 --plot data.csv", ["data.csv", "input"]),
    ("virtual sweep --hysteresis hyst.json -o hyst.json", ["hyst.json", "input"]),
    ("simulate --kp 0.1 --plant-tf tf.json --stages pid -o tf.json", ["tf.json", "input"]),
    ("ss-info ctf.json --json --plot ctf.json", ["--plot"]),
]:
    files = {"r.csv": frd} if "r.csv" in args else None
    case(args, 2, expect, files, "Output-path conflicts: refused before anything is written." if first else None)
    first = False

import os
open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "cases-bounds.toml"), "w").write("\n".join(out))
print(len(out) - 1, "cases")
