//! The `Examples:` section of every command's help: realistic command
//! lines on files in the repository (fixtures/, data/, tests/data/,
//! examples/) or on files an earlier line of the same command writes. A
//! test (tests/suite/help_consistency.rs) parses every line and runs them
//! from a folder that holds the repository's data folders.

/// Each (sub)command's path in the tree (`identify arx`) and its example
/// lines, in the order they are meant to run.
pub const EXAMPLES: &[(&str, &[&str])] = &[
    (
        "",
        &[
            "fts demo --out d",
            "fts identify hysteresis tri.csv --model mpi-cbrt -o inverse.json",
            "fts zpetc --tf fixtures/li21-closed-loop.json",
            "fts simulate --plant-tf fixtures/second-order-plant-zoh.json --stages pid --kp 0.5 --ki 0.05 --reference-file fixtures/step-input-disturbance.csv -o trace.csv",
            "fts build -f examples/mixsyn/fts.toml --check",
        ],
    ),
    ("build", &["fts build -f examples/mixsyn/fts.toml --check"]),
    ("demo", &["fts demo --out d"]),
    (
        "excite",
        &[
            "fts excite triangle --amplitudes 10,8,6,4,2 --freq 2 -o tri.csv",
            "fts excite sweep --f0 0 --f1 1000 --duration 1 -o sweep.csv",
        ],
    ),
    (
        "excite triangle",
        &["fts excite triangle --amplitudes 10,8,6,4,2 --freq 2 -o tri.csv"],
    ),
    (
        "excite sine",
        &["fts excite sine --amplitude 5 --freq 100 --duration 0.1 -o sine.csv"],
    ),
    (
        "excite sweep",
        &["fts excite sweep --f0 0 --f1 1000 --duration 1 -o sweep.csv"],
    ),
    (
        "excite multisine",
        &["fts excite multisine --freqs 10,20,50 -o ms.csv"],
    ),
    (
        "excite five-leaf",
        &["fts excite five-leaf --scale 2 -o leaf.csv"],
    ),
    ("trajectory", &["fts trajectory circle -o circle.csv"]),
    (
        "contour",
        &["fts contour circle", "fts contour square --no-disturbance"],
    ),
    (
        "virtual",
        &["fts virtual triangles --freq 2 --amplitudes 9,5 --seed 7 -o slow.csv"],
    ),
    (
        "virtual triangles",
        &[
            "fts virtual triangles --freq 2 --amplitudes 9,5 --seed 7 -o slow.csv",
            "fts virtual triangles --freq 1,10,50,100,200,500 --rate-coefficient 1 -o rt.csv",
        ],
    ),
    ("virtual sweep", &["fts virtual sweep -o sweep.csv"]),
    (
        "identify",
        &[
            "fts identify arx data/daisy-hairdryer/dryer.dat --ts 0.08 --detrend mean --split 0.5 --na 2 --nb 2 --nk 3",
        ],
    ),
    (
        "identify hysteresis",
        &[
            "fts virtual triangles --freq 2 --amplitudes 10,8,6,4,2 -o tri.csv",
            "fts identify hysteresis tri.csv --model mpi-cbrt -o inverse.json",
        ],
    ),
    (
        "identify ct",
        &[
            "fts identify ct tests/data/ct-ident/zaxis-multisine.csv --np 3 --nz 1 --period 10 --skip-periods 2 -o zaxis.json",
        ],
    ),
    (
        "identify ct-frd",
        &[
            "fts identify ct-frd tests/data/ct-ident/zaxis-frd.csv --np 3 --nz 1 --weighting relative",
        ],
    ),
    (
        "identify arx",
        &[
            "fts identify arx data/daisy-hairdryer/dryer.dat --ts 0.08 --detrend mean --split 0.5 --na 2 --nb 2 --nk 3",
            "fts identify arx tests/data/records/dryer.csv --input-col u --output-col y --na 2 --nb 2 --nk 3 -o dryer.json",
        ],
    ),
    (
        "identify oe",
        &[
            "fts identify oe data/daisy-hairdryer/dryer.dat --ts 0.08 --detrend mean --nb 2 --nf 2 --nk 3 -o oe.json",
        ],
    ),
    (
        "identify iv",
        &[
            "fts identify iv data/daisy-hairdryer/dryer.dat --ts 0.08 --detrend mean --na 2 --nb 2 --nk 3",
        ],
    ),
    (
        "identify arx-struct",
        &[
            "fts identify arx-struct data/daisy-hairdryer/dryer.dat --ts 0.08 --detrend mean --split 0.5",
        ],
    ),
    (
        "hysteresis",
        &[
            "fts virtual triangles --freq 2 --amplitudes 10,8,6,4,2 -o tri.csv",
            "fts identify hysteresis tri.csv --model pi --operator play-symmetric -o pi.json",
            "fts hysteresis invert pi.json -o pi-inverse.json",
        ],
    ),
    (
        "hysteresis invert",
        &[
            "fts virtual triangles --freq 2 --amplitudes 10,8,6,4,2 -o tri.csv",
            "fts identify hysteresis tri.csv --model pi --operator play-symmetric -o pi.json",
            "fts hysteresis invert pi.json -o pi-inverse.json",
        ],
    ),
    (
        "hysteresis apply",
        &[
            "fts virtual triangles --freq 2 --amplitudes 9,5 --seed 7 -o slow.csv",
            "fts hysteresis apply fixtures/li21-inverse-mpi.json slow.csv",
        ],
    ),
    (
        "emit",
        &[
            "fts zpetc --tf fixtures/li21-closed-loop.json -o zpetc.json",
            "fts emit --hysteresis fixtures/li21-inverse-mpi.json --zpetc zpetc.json --pid-form li21 --kp 0.02 --ki 0.15 -o controller.json",
            "fts emit --hysteresis fixtures/li21-inverse-mpi.json --zpetc zpetc.json --pid-form li21 --kp 0.02 --ki 0.15 --format c -o controller-c",
        ],
    ),
    (
        "simulate",
        &[
            "fts simulate --plant-tf fixtures/second-order-plant-zoh.json --stages pid --kp 0.5 --ki 0.05 --reference-file fixtures/step-input-disturbance.csv -o trace.csv",
        ],
    ),
    (
        "zpetc",
        &[
            "fts zpetc --tf fixtures/li21-closed-loop.json",
            "fts minreal fixtures/pid-only-loop.json --tol 1e-7 -o loop-minreal.json",
            "fts zpetc --tf loop-minreal.json -o z.json",
        ],
    ),
    (
        "repetitive",
        &[
            "fts repetitive --tf fixtures/li21-closed-loop.json --spindle-hz 100 --q-cutoff 1250 -o rc.json",
        ],
    ),
    (
        "ilc",
        &[
            "fts ilc --hysteresis tests/data/ilc/inverse-hysteresis.json --zpetc tests/data/ilc/zpetc.json --closed-loop tests/data/ilc/closed-loop.json --reference five-leaf --trials 20 -o c.json",
        ],
    ),
    (
        "bode",
        &[
            "fts virtual sweep -o sweep.csv",
            "fts bode sweep.csv --input-col u --output-col y --segment 2048 --fmax 80 -o bode.csv",
        ],
    ),
    ("tf", &["fts tf info fixtures/li21-closed-loop.json"]),
    (
        "tf info",
        &["fts tf info fixtures/li21-closed-loop.json --bode bode.csv"],
    ),
    (
        "hinf",
        &["fts hinf --generalized fixtures/slicot-sb10fd.json --nmeas 2 --ncon 2 -o k.json"],
    ),
    (
        "h2",
        &["fts h2 --generalized fixtures/slicot-sb10fd.json --nmeas 2 --ncon 2 -o k2.json"],
    ),
    (
        "weight",
        &[
            "fts weight --kind ws --m 2 --w0-rad 1500 --a 1e-4 -o ws.json",
            "fts weight --kind makeweight --dc 0.05 --freq-rad 20000 --mag 1 --hf 20 -o wu.json",
        ],
    ),
    (
        "mixsyn",
        &[
            "fts mixsyn --plant fixtures/karagoz18-gxx.json --ws examples/contour-hinf/table1/ws-x.json --wt examples/contour-hinf/table1/wt-x.json --wu fixtures/unit-gain.json -o k.json",
        ],
    ),
    (
        "c2d",
        &["fts c2d fixtures/second-order-plant.json --ts 1e-4 --method zoh -o plant-zoh.json"],
    ),
    ("ss-info", &["fts ss-info fixtures/second-order-plant.json"]),
    (
        "budget",
        &["fts budget fixtures/second-order-plant.json --fmax 1000 --csv budget.csv"],
    ),
    (
        "loop",
        &[
            "fts loop --plant fixtures/karagoz18-gxx.json --kp 1 --ki 0.01 --kd 0.0005 --tf-derivative 100",
        ],
    ),
    (
        "response",
        &[
            "fts response step fixtures/second-order-plant.json",
            "fts response impulse fixtures/light-step.json",
        ],
    ),
    (
        "convert",
        &["fts convert fixtures/second-order-plant.json --to ss -o plant-ss.json"],
    ),
    ("zpk", &["fts zpk fixtures/second-order-plant.json"]),
    (
        "minreal",
        &["fts minreal fixtures/pid-only-loop.json --tol 1e-7 -o loop-minreal.json"],
    ),
    (
        "balred",
        &["fts balred fixtures/balred-two-state.json --order 1"],
    ),
    (
        "d2c",
        &["fts d2c fixtures/second-order-plant-zoh.json -o plant.json"],
    ),
    (
        "mechanism",
        &[
            "fts mechanism hinge --width-mm 10",
            "fts mechanism 3puu --stroke-um 120",
        ],
    ),
    ("mechanism flexure-loss", &["fts mechanism flexure-loss"]),
    ("mechanism hinge", &["fts mechanism hinge --width-mm 10"]),
    (
        "mechanism 3puu",
        &["fts mechanism 3puu --plot workspace.svg"],
    ),
    (
        "mechanism 3puu-track",
        &["fts mechanism 3puu-track --mode task"],
    ),
    (
        "mechanism lever",
        &[
            "fts mechanism lever --input-arm-mm 5 --output-arm-mm 19.35 --hinge-width-mm 10 --kp 200",
        ],
    ),
    ("mechanism bridge", &["fts mechanism bridge"]),
    (
        "mechanism amplifier",
        &[
            "fts mechanism amplifier --angle-deg 10 --link-mm 12 --hinge-width-mm 8 --hinge-length-mm 1 --hinge-thickness-mm 0.3 --hinge-radius-mm 0.5 --input-arm-mm 5 --output-arm-mm 10 --kp 200",
        ],
    ),
    (
        "ding22",
        &["fts ding22", "fts ding22 --sensor-noise 1.36e-9"],
    ),
    (
        "completions",
        &[
            "fts completions bash > fts.bash",
            "fts completions zsh > _fts",
        ],
    ),
    ("man", &["fts man --out man1", "fts man > fts.1"]),
];

/// The lines of `path`'s examples, when it has any.
pub fn lines(path: &str) -> Option<&'static [&'static str]> {
    EXAMPLES.iter().find(|(p, _)| *p == path).map(|(_, l)| *l)
}

/// The `Examples:` section of `path`'s help.
pub fn section(path: &str) -> Option<String> {
    let lines = lines(path)?;
    let body: Vec<String> = lines.iter().map(|l| format!("  $ {l}")).collect();
    Some(format!("Examples:\n{}", body.join("\n")))
}
