//! Bounded fuzzing of every file parser, in process: valid files are mutated
//! (byte flips, truncation, spliced huge numbers, `NaN` text, deep nesting,
//! repeated slices, 32-bit size fields set to huge values) and each parser
//! must return `Ok` or `Err`, never panic, within [`MAX_CALL`]. The case
//! count is fixed ([`CASES`] per parser, seeded), so CI time stays bounded;
//! each parser prints its runs and the time taken (`--nocapture`).

use fts::io::mat::{self, MatColumn};
use fts::io::timeseries::{ColumnRef, IoColumns, read_io};
use fts::io::{controller_file, hysteresis_json, ss_json, tf_json, zpetc_json};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Mutated inputs per parser.
const CASES: u32 = 5000;
/// The longest one parse may take (debug build, loaded CI machine).
const MAX_CALL: Duration = Duration::from_secs(5);

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn seeds(paths: &[&str]) -> Vec<Vec<u8>> {
    paths
        .iter()
        .map(|p| std::fs::read(root().join(p)).unwrap_or_else(|e| panic!("{p}: {e}")))
        .collect()
}

#[derive(Debug, Clone)]
enum Mutation {
    Flip { at: usize, byte: u8 },
    Truncate { at: usize },
    Splice { at: usize, text: &'static str },
    Nest { at: usize, depth: usize },
    Repeat { at: usize, len: usize, times: usize },
    HugeU32 { at: usize, value: u32 },
}

const SPLICES: &[&str] = &[
    "1e308",
    "-1e308",
    "1e999",
    "NaN",
    "nan",
    "inf",
    "-Infinity",
    "4.9e-324",
    "18446744073709551616",
    "-0",
    "\"",
    ",",
    "]",
    "}",
    "\n",
    "\u{0}",
    "é",
    ";;;",
    "[[]]",
    "{}",
    "null",
    "true",
    "9999999999",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Mutation::Flip { at, byte }),
        2 => any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        4 => (any::<usize>(), prop::sample::select(SPLICES)).prop_map(|(at, text)| Mutation::Splice { at, text }),
        1 => (any::<usize>(), 1usize..5000).prop_map(|(at, depth)| Mutation::Nest { at, depth }),
        1 => (any::<usize>(), 1usize..64, 1usize..2000).prop_map(|(at, len, times)| Mutation::Repeat { at, len, times }),
        2 => (any::<usize>(), prop::sample::select(vec![u32::MAX, 0x7fff_ffff, 0x8000_0000, 1 << 20, 0]))
            .prop_map(|(at, value)| Mutation::HugeU32 { at, value }),
    ]
}

fn apply(mut bytes: Vec<u8>, mutations: &[Mutation]) -> Vec<u8> {
    for m in mutations {
        let n = bytes.len().max(1);
        match *m {
            Mutation::Flip { at, byte } => {
                if !bytes.is_empty() {
                    bytes[at % n] = byte;
                }
            }
            Mutation::Truncate { at } => bytes.truncate(at % n),
            Mutation::Splice { at, text } => {
                let at = at % n;
                bytes.splice(at.min(bytes.len())..at.min(bytes.len()), text.bytes());
            }
            Mutation::Nest { at, depth } => {
                let at = (at % n).min(bytes.len());
                let open = "[".repeat(depth) + &"]".repeat(depth);
                bytes.splice(at..at, open.bytes());
            }
            Mutation::Repeat { at, len, times } => {
                let at = (at % n).min(bytes.len());
                let end = (at + len).min(bytes.len());
                let slice = bytes[at..end].repeat(times);
                bytes.splice(end..end, slice);
            }
            Mutation::HugeU32 { at, value } => {
                // Aligned like MAT-file tags, so size fields get hit.
                let at = (at % n) & !3;
                if at + 4 <= bytes.len() {
                    bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
                }
            }
        }
    }
    bytes
}

/// Runs `parse` on [`CASES`] mutations of the seeds; any panic or a call
/// slower than [`MAX_CALL`] fails with the input that caused it.
fn fuzz(name: &str, seed_paths: &[&str], parse: impl Fn(&[u8])) {
    let seeds = seeds(seed_paths);
    let config = Config {
        cases: CASES,
        failure_persistence: None,
        ..Config::default()
    };
    // Fixed seed: the same inputs on every run, so CI is reproducible.
    let mut digest = [0u8; 32];
    for (i, b) in name.bytes().enumerate() {
        digest[i % 32] ^= b;
    }
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &digest);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let strategy = (0..seeds.len(), prop::collection::vec(mutation(), 0..5));
    let started = Instant::now();
    runner
        .run(&strategy, |(seed, mutations)| {
            let input = apply(seeds[seed].clone(), &mutations);
            let started = Instant::now();
            parse(&input);
            let took = started.elapsed();
            prop_assert!(
                took < MAX_CALL,
                "{name}: {took:?} on {mutations:?} of seed {seed}"
            );
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    eprintln!(
        "parser fuzz {name}: {CASES} runs in {:.2} s",
        started.elapsed().as_secs_f64()
    );
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn tf_json_never_panics() {
    fuzz(
        "tf",
        &[
            "fixtures/li21-closed-loop.json",
            "fixtures/second-order-plant.json",
            "fixtures/second-order-plant-zoh.json",
        ],
        |b| {
            let _ = tf_json::parse_tf(&text(b), "g.json");
        },
    );
}

#[test]
fn ss_json_never_panics() {
    fuzz(
        "ss",
        &[
            "examples/mixsyn/K.json",
            "examples/mixsyn/P.json",
            "examples/mixsyn/ws.json",
            "fixtures/second-order-plant.json",
        ],
        |b| {
            let _ = ss_json::parse_system(&text(b), "k.json");
        },
    );
}

#[test]
fn zpetc_json_never_panics() {
    fuzz("zpetc", &["tests/data/bad_input/base/zpetc.json"], |b| {
        let _ = zpetc_json::parse_zpetc(&text(b), "z.json");
    });
}

#[test]
fn hysteresis_json_never_panics() {
    fuzz(
        "hysteresis",
        &[
            "fixtures/li21-inverse-mpi.json",
            "tests/data/bad_input/base/hyst.json",
        ],
        |b| {
            let _ = hysteresis_json::parse_model(&text(b), "h.json");
        },
    );
}

#[test]
fn controller_json_never_panics() {
    fuzz(
        "controller",
        &[
            "examples/mixsyn/controller.json",
            "tests/data/bad_input/base/controller.json",
        ],
        |b| {
            let _ = controller_file::parse_controller(&text(b), "c.json");
        },
    );
}

#[test]
fn multiaxis_controller_json_never_panics() {
    fuzz(
        "multiaxis",
        &["examples/contour-hinf/controller-3axis.json"],
        |b| {
            let _ = controller_file::parse_multiaxis(&text(b), "k3.json");
        },
    );
}

#[test]
fn repetitive_json_never_panics() {
    fuzz("repetitive", &["tests/data/fuzz/repetitive.json"], |b| {
        if let Ok(file) = fts::workflow::learning::RepetitiveFile::parse(&text(b), "rc.json") {
            let _ = file.block_at(1e-4, "rc.json");
        }
    });
}

/// The one-line specifications options take: disturbances
/// (`spindle:1@100,0.5`) and Ding22's sweep (`k2=1e5:1e6:5`).
#[test]
fn option_specs_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let seeds = dir.path().join("specs");
    std::fs::create_dir(&seeds).unwrap();
    let specs = [
        "spindle:1@100,0.5,0.25",
        "sines:0.5@37,0.1@300",
        "k2=1e5:1e6:5,c2=100:300:3",
    ];
    let mut paths = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        let p = seeds.join(format!("{i}.txt"));
        std::fs::write(&p, s).unwrap();
        paths.push(p.to_string_lossy().into_owned());
    }
    let refs: Vec<&str> = paths.iter().map(String::as_str).collect();
    fuzz("option specs", &refs, |b| {
        let spec = text(b);
        let _ = fts::sim::disturbance::Disturbance::parse(&spec);
        let _ = fts::workflow::ding22::parse_sweep(&spec);
    });
}

#[test]
fn c_header_never_panics() {
    fuzz(
        "c-header",
        &[
            "examples/mixsyn/controller.h",
            "tests/data/bad_input/base/controller.h",
        ],
        |b| {
            let _ = controller_file::parse_c_header(&text(b), "c.h");
        },
    );
}

#[test]
fn time_series_reader_never_panics() {
    fuzz(
        "timeseries",
        &[
            "tests/data/bad_input/base/data.csv",
            "tests/data/bad_input/base/semicolon.csv",
            "tests/data/bad_input/base/dryer.dat",
        ],
        |b| {
            let _ = read_io(b, "d.csv", &IoColumns::default(), 2);
            let cols = IoColumns {
                input: Some(ColumnRef::parse("2")),
                output: Some(ColumnRef::parse("y")),
                ..IoColumns::default()
            };
            let _ = read_io(b, "d.csv", &cols, 2);
        },
    );
}

#[test]
fn manifest_never_panics() {
    let manifest = root().join("examples/pipeline/fts.toml");
    fuzz(
        "manifest",
        &["examples/pipeline/fts.toml", "examples/mixsyn/fts.toml"],
        |b| {
            let _ = fts::pipeline::parse_manifest(&text(b), Path::new(&manifest));
        },
    );
}

#[test]
fn mat_reader_never_panics() {
    let cols = [MatColumn::parse("u"), MatColumn::parse("y")];
    fuzz(
        "mat",
        &[
            "tests/data/mat/record.mat",
            "tests/data/mat/record_z.mat",
            "tests/data/mat/kinds.mat",
            "tests/data/mat/kinds_z.mat",
        ],
        |b| {
            if mat::is_mat(b) {
                let _ = mat::variables(b, "r.mat");
                let _ = mat::read_columns(b, "r.mat", &cols);
            }
        },
    );
}
