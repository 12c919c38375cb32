import json, os, shutil, subprocess, sys, tempfile
# Run from anywhere: FTS=path/to/fts python3 gen_selfcheck.py [-v] [--write]
# checks every case against that binary (and --write writes the table).
HERE = os.path.dirname(os.path.abspath(__file__))
BASE = os.path.join(HERE, 'base')
FTS = os.environ.get('FTS', 'fts')

def tf(num, den, delay=1, ts=1e-4, var='z^-1'):
    d = {"format": "fts.tf/1", "var": var, "num": num, "den": den}
    if var != 's':
        d["ts"] = ts; d["delay"] = delay
    return json.dumps(d)

z0, p0 = 1 - 1e-7, 1 - 2e-7
PAIR = tf([0.3, 0.1 - 0.3 * z0, -0.1 * z0], [1.0, -p0 - 0.6, 0.6 * p0])
# zero 0.99 kept (|z| >= rho): |G_z G_c| = 39601
KEPT99 = tf([1.0, -0.99], [1.0, -0.5])
KEPT995 = tf([1.0, -0.995], [1.0, -0.5])
TRAP = tf([0.5, -0.1], [1.0, 0.499999, -0.4999995])
ONE = tf([1.0], [1.0], delay=0)
# 1e7 / ((s + 1)^2 (s + 1e8)), nearly: the discarded Hankel singular value is
# 5.0e-18 (40-digit Kronecker Lyapunov solve), the order-2 model's rounding
# 2.5e-10 on the grid.
STIFF = tf([1e7], [1.0, 1e8, 2e8, 1e8], var='s')
UNSTABLE = tf([1.0, -0.5], [1.0, -1.5])
DCZERO = tf([1.0, -1.0], [1.0, -0.5])
OUTSIDE = tf([1.0, -1.0000002], [1.0, -0.5])

cases = []
def case(args, exit, expect, files=None):
    cases.append(dict(args=args, exit=exit, expect=expect, files=files or {}))

# ---------------- zpetc: option values
for flag, v, exp in [
    ('--rho', '0', ['--rho', '0']), ('--rho', '1.5', ['--rho', '1.5']), ('--rho', '-0.5', ['--rho', '-0.5']),
    ('--rho', 'nan', ['--rho', 'NaN']), ('--rho', 'inf', ['--rho', 'inf']),
    ('--min-damping', '-0.1', ['--min-damping', '-0.1']), ('--min-damping', '1.5', ['--min-damping', '1.5']),
    ('--min-damping', 'nan', ['--min-damping', 'NaN']),
    ('--stable-inversion', '1.0', ['--stable-inversion', '1']), ('--stable-inversion', '0.5', ['--stable-inversion', '0.5']),
    ('--stable-inversion', 'inf', ['--stable-inversion', 'inf']), ('--stable-inversion', 'nan', ['--stable-inversion', 'NaN']),
    ('--minreal', '0', ['--minreal', '0']), ('--minreal', '1', ['--minreal', '1']),
    ('--minreal', '-1e-6', ['--minreal', '-0.000001']), ('--minreal', 'nan', ['--minreal', 'NaN']),
    ('--rho', 'abc', ['--rho', 'abc']), ('--minreal', '', ['--minreal']),
]:
    case(['zpetc', '--tf', 'tf.json', flag, v, '-o', 'z.json'], 2, exp)
case('zpetc --tf tf.json --stable-inversion 1.5 --series-tol 0 -o z.json', 2, ['--series-tol', '0'])
case('zpetc --tf tf.json --stable-inversion 1.5 --series-tol 1 -o z.json', 2, ['--series-tol', '1'])
case('zpetc --tf tf.json --stable-inversion 1.5 --series-tol nan -o z.json', 2, ['--series-tol', 'NaN'])
case('zpetc --tf tf.json --series-tol 0.001 -o z.json', 2, ['--stable-inversion', 'required'])
case('zpetc --tf tf.json --rho 0.9 --rho 0.8 -o z.json', 2, ['--rho'])
case('zpetc --tf tf.json -o tf.json', 2, ['tf.json'])
case('zpetc --tf tf.json -o z.json --plot z.json', 2, ['z.json'])
# ---------------- zpetc: models that trip its self-check (exit 1)
case('zpetc --tf CL.json -o z.json', 1, ['CL.json', 'fails its self-check', 'zero 0.9999999 with pole 0.9999998', 'fts minreal CL.json --tol 1e-7 -o CL-minreal.json'], {'CL.json': PAIR})
case('zpetc --tf CL.json -o z.json --plot b.svg', 1, ['CL.json', 'rounding error', 'fts minreal CL.json'], {'CL.json': PAIR})
case('zpetc --tf CL.json --json -o z.json', 1, ['CL.json', 'fails its self-check'], {'CL.json': PAIR})
case('zpetc --tf CL.json --min-damping 0 -o z.json', 1, ['CL.json', '|G_z G_c| reaches', 'fts minreal'], {'CL.json': PAIR})
case('zpetc --tf CL.json --minreal 0.1 -o z.json', 1, ['CL.json', 'fails its self-check', 'fts minreal'], {'CL.json': PAIR})
case('zpetc --tf CL.json --rho 1 -o z.json', 2, ['--rho', 'would cancel the zero'], {'CL.json': PAIR})
case('zpetc --tf K.json -o z.json', 1, ['K.json', '|G_z G_c| reaches 3.96e4', 'cancel it with --rho above 0.990000'], {'K.json': KEPT99})
case('zpetc --tf K.json --rho 0.99 -o z.json', 1, ['K.json', '|G_z G_c| reaches', '--rho above 0.995000'], {'K.json': KEPT995})
case('zpetc --tf K.json --rho 0.5 --plot b.svg', 1, ['K.json', 'limit 1e4'], {'K.json': KEPT99})
case('zpetc --tf U.json -o z.json', 2, ['U.json', 'unstable', '1.5'], {'U.json': UNSTABLE})
case('zpetc --tf D.json -o z.json', 2, ['D.json', 'zero at z = 1'], {'D.json': DCZERO})
case('zpetc --tf O.json --stable-inversion 1.0000001 -o z.json', 2, ['O.json', 'more than 1000 terms'], {'O.json': OUTSIDE})
case('zpetc --tf ctf.json -o z.json', 2, ['ctf.json', 'discrete'])
case('zpetc --tf S.json -o z.json', 2, ['S.json', 'discrete'], {'S.json': STIFF})
# ---------------- repetitive
R = 'repetitive --tf tf.json'
case(f'{R} -o rc.json', 2, ['--period'])
case(f'{R} --period 1 -o rc.json', 2, ['--period', '1'])
case(f'{R} --period 100 --period-s 0.01 -o rc.json', 2, ['--period', '--period-s', 'cannot be used'])
case(f'{R} --period 100 --spindle-hz 100 -o rc.json', 2, ['--period', '--spindle-hz', 'cannot be used'])
case(f'{R} --spindle-hz 0 -o rc.json', 2, ['--spindle-hz', '0'])
case(f'{R} --spindle-hz -5 -o rc.json', 2, ['--spindle-hz', '-5'])
case(f'{R} --spindle-hz nan -o rc.json', 2, ['--spindle-hz', 'NaN'])
case(f'{R} --period-s inf -o rc.json', 2, ['--period-s', 'inf'])
case(f'{R} --period 100 --gain 0 -o rc.json', 2, ['--gain', '0'])
case(f'{R} --period 100 --gain -1 -o rc.json', 2, ['--gain', '-1'])
case(f'{R} --period 100 --gain nan -o rc.json', 2, ['--gain', 'NaN'])
case(f'{R} --period 100 --gain inf -o rc.json', 2, ['--gain', 'inf'])
case(f'{R} --period 100 --q-cutoff 6000 -o rc.json', 2, ['--q-cutoff', '6000', 'Nyquist'])
case(f'{R} --period 100 --q-cutoff 0 -o rc.json', 2, ['--q-cutoff', '0'])
case(f'{R} --period 100 --q 1 --q-cutoff 100 -o rc.json', 2, ['--q', '--q-cutoff'])
case(f'{R} --period 100 --q 0.5,nan -o rc.json', 2, ['--q', 'finite'])
case(f'{R} --period 100 --q-taps 0 -o rc.json', 2, ['--q-taps', '0'])
case(f'{R} --period 100 --q-taps 100000 -o rc.json', 2, ['--q-taps', '100000'])
case(f'{R} --period 20 --lead 15 -o rc.json', 2, ['--lead', '20 samples'])
case(f'{R} --period 1e9 -o rc.json', 2, ['--period', '1e9'])
case(f'{R} --period abc -o rc.json', 2, ['--period', 'abc'])
case(f'{R} --period 100 --lead -1 -o rc.json', 2, ['--lead', '-1'])
case('repetitive --tf T.json --period 100 --q 1 --lead 0 -o T.json', 2, ['T.json', 'onto an input'], {'T.json': ONE})
case('repetitive --tf ctf.json --period 100 -o rc.json', 2, ['ctf.json'])
# models and settings that trip its stability condition (exit 1)
case('repetitive --tf T.json --spindle-hz 100 -o rc.json', 1, ['stability condition fails', 'pole -0.999999', 'neither a gain nor a Q cutoff'], {'T.json': TRAP})
case('repetitive --tf T.json --period 100 --json -o rc.json', 1, ['at 5000.0 Hz', 'no setting here mends'], {'T.json': TRAP})
case('repetitive --tf T.json --period 100 --q 1 --lead 0 --gain 2.5 -o rc.json', 1, ['= 1.5000 >= 1', '--gain 1.25 (rho 0.250)'], {'T.json': ONE})
case('repetitive --tf T.json --period 100 --q 1 --lead 0 --gain 3 -o rc.json', 1, ['= 2.0000 >= 1', '--gain 1.5 (rho 0.500)'], {'T.json': ONE})
case('repetitive --tf T.json --period 100 --q 2 --lead 0 --gain 0.5 -o rc.json', 1, ['= 1.0000 >= 1'], {'T.json': ONE})
# ---------------- minreal
for v, exp in [('0', ['--tol', '0']), ('1', ['--tol', '1']), ('-1', ['--tol', '-1']), ('nan', ['--tol', 'NaN']), ('inf', ['--tol', 'inf']), ('x', ['--tol', 'x'])]:
    case(['minreal', 'tf.json', '--tol', v, '-o', 'm.json'], 2, exp)
case('minreal CL.json --tol 0.6 -o m.json', 1, ['CL.json', 'fails its self-check', 'smaller --tol'], {'CL.json': PAIR})
case('minreal CL.json --tol 0.6 --json', 1, ['CL.json', 'fails its self-check'], {'CL.json': PAIR})
case('minreal CL.json --tol 0.9 -o m.json', 1, ['CL.json', 'fails its self-check'], {'CL.json': PAIR})
case('minreal missing.json -o m.json', 2, ['missing.json'])
case('minreal CL.json -o CL.json', 2, ['CL.json'], {'CL.json': PAIR})
case('minreal g.json -o m.json', 2, ['g.json', 'den'], {'g.json': tf([1.0], [0.0, 1.0])})
# ---------------- balred
case('balred tf.json -o b.json', 2, ['--order'])
case('balred tf.json --order -1 -o b.json', 2, ['--order', '-1'])
case('balred tf.json --order x -o b.json', 2, ['--order', 'x'])
case('balred tf.json --order 50 -o b.json', 2, ['--order', '50'])
case('balred U.json --order 1 -o b.json', 2, ['U.json', 'unstable'], {'U.json': UNSTABLE})
case('balred S.json --order 2 -o b.json', 1, ['S.json', 'cannot be trusted', 'allow-degradation'], {'S.json': STIFF})
case('balred S.json --order 2 --json', 1, ['S.json', 'cannot be trusted'], {'S.json': STIFF})
case('balred T.json --order 1 -o b.json', 2, ['T.json', 'unstable'], {'T.json': tf([1.0], [1.0, -1.0])})
# ---------------- zpk
case('zpk missing.json', 2, ['missing.json'])
case('zpk g.json', 2, ['g.json', 'num'], {'g.json': '{"format": "fts.tf/1", "var": "z^-1", "ts": 0.0001, "num": [], "den": [1.0], "delay": 0}'})
case('zpk g.json', 2, ['g.json', 'ts'], {'g.json': '{"format": "fts.tf/1", "var": "z^-1", "ts": 0, "num": [1.0], "den": [1.0], "delay": 0}'})
case('zpk CL.json -o z.json', 2, ['-o'], {'CL.json': PAIR})
case('zpk CL.json --tol 1e-6', 2, ['--tol'], {'CL.json': PAIR})
# ---------------- tf info on such models
case('tf info CL.json --freq -1', 2, ['--freq', '-1'], {'CL.json': PAIR})
case('tf info CL.json --freq nan -o b.csv', 2, ['--freq', 'NaN'], {'CL.json': PAIR})
case('tf info T.json --freq inf', 2, ['--freq', 'inf'], {'T.json': TRAP})
case('tf info T.json --points 0 -o b.csv', 2, ['--points'], {'T.json': TRAP})
case('tf info T.json -o T.json', 2, ['T.json'], {'T.json': TRAP})
case('tf info CL.json --points x', 2, ['--points', 'x'], {'CL.json': PAIR})

def run(c):
    d = tempfile.mkdtemp()
    for f in os.listdir(BASE):
        shutil.copy(os.path.join(BASE, f), d)
    for n, t in c['files'].items():
        open(os.path.join(d, n), 'w').write(t)
    before = sorted(os.listdir(d))
    args = c['args'] if isinstance(c['args'], list) else c['args'].split()
    p = subprocess.run([FTS] + args, cwd=d, capture_output=True, text=True, timeout=60)
    after = sorted(os.listdir(d))
    problems = []
    if p.returncode != c['exit']: problems.append(f"exit {p.returncode}")
    if p.stdout: problems.append("stdout")
    lines = p.stderr.splitlines()
    if len(lines) != 1 or not lines[0].startswith('fts: error: '): problems.append("stderr lines")
    for e in c['expect']:
        if e not in p.stderr: problems.append(f"missing {e!r}")
    if before != after: problems.append("files changed")
    shutil.rmtree(d)
    return problems, p.stderr.strip()

def toml_str(s):
    if "'" not in s and '\n' not in s:
        return "'" + s + "'"
    return json.dumps(s)

if __name__ == '__main__':
    bad = 0
    for c in cases:
        probs, err = run(c)
        if probs or '-v' in sys.argv:
            bad += bool(probs)
            print(c['args'], probs, err[:400])
    print(len(cases), 'cases,', bad, 'failing')
    if '--write' in sys.argv:
        out = ['# Self-checks that act (issue #27; docs/formats.md "Exit codes", "Model checks"):',
               '# zpetc, repetitive, minreal, balred, zpk and tf info on bad values,',
               '# contradictory options, and models that trip the self-checks (exit 1,',
               '# nothing written). Written by tests/data/bad_input/gen_selfcheck.py --write.', '']
        for c in cases:
            out.append('[[case]]')
            if isinstance(c['args'], list):
                out.append('args = [' + ', '.join(toml_str(a) for a in c['args']) + ']')
            else:
                out.append('args = ' + toml_str(c['args']))
            out.append(f"exit = {c['exit']}")
            out.append('expect = [' + ', '.join(toml_str(e) for e in c['expect']) + ']')
            for n, t in c['files'].items():
                out.append(f'files."{n}" = ' + toml_str(t))
            out.append('')
        open(os.path.join(HERE, 'cases-selfcheck.toml'), 'w').write('\n'.join(out))
