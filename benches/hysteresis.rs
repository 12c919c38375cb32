//! Identification cost (regressor + least squares) on long records.
//!
//! `cargo bench --bench hysteresis`. Target (issue 3): 1e6 samples x 10
//! operators in <= 60 ms, scaling linearly in samples (compare the 250k and
//! 1M figures).
//!
//! * `regressor_qr_{pi,mpi_cbrt}` — the identification core: play operators streamed into
//!   the blocked Householder QR (`ident::ls::StreamingQr`) and the solve
//!   (`Regressor::qr` + `solve_from_r`).
//! * `identify` — the whole `identify()` call: the core plus a sample-by-sample
//!   simulation of the identified model for the fit report.
//! * `rows_into_ident_ls` — for comparison, the same regression pushed row by
//!   row into `ident::ls::StreamingLstsq` (the same kernel, rows buffered into
//!   blocks), 250k samples only.
//!
//! Group `hysteresis_gd` (issue #30): gradient identification of the real
//! piezo record (data/piezo-smarthysteresis, 33,715 samples from row 16286,
//! PI and MPI-cbrt with ten lower play operators), beside its peer
//! `benches/hysteresis_gd_scipy.py` (scipy's L-BFGS-B on the same data,
//! operators, scaling and stopping rule; run it in the same session):
//!
//! * `lbfgs_{pi,mpi_cbrt}` — the solver alone (`gd_lstsq` on the factor of
//!   `[Phi | y]`), against the script's `factor` rows;
//! * `identify_gd_{pi,mpi_cbrt}` — the whole `identify()` with `Method::Gd`
//!   (regressor, QR, L-BFGS, the fit's simulation), against its rows.
//!
//! Before timing, each model is checked to reach the least-squares cost to
//! 1e-13, and the heap allocations of a whole solve are printed beside those
//! of a solve capped at one iteration (equal: the iterations allocate nothing).

use criterion::{Criterion, criterion_group, criterion_main};
use fts::ident::hysteresis::gd::{GdParams, Silent, TriangularLeastSquares, gd_lstsq};
use fts::ident::hysteresis::identify::Regressor;
use fts::ident::hysteresis::lsq::solve_from_r;
use fts::ident::hysteresis::operators::uniform_thresholds;
use fts::ident::hysteresis::{IdentifyParams, Method, ModelKind, PlayOperator, identify};
use fts::ident::ls::{LstsqParams, StreamingLstsq};
use fts::io::timeseries::{ColumnRef, HeaderMode, IoColumns, Layout as RecordLayout, read_io};
use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::sync::atomic::{AtomicU64, Ordering};

/// The system allocator, counting allocations (for the per-iteration figure).
struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The SmartHysteresis record as the README's `fts identify hysteresis`
/// reads it, through the same reader: headerless, input = column 4 (V),
/// output = column 3 (um), from sample 16286.
fn piezo_record() -> (Vec<f64>, Vec<f64>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/piezo-smarthysteresis/hysteresis_v_150_1hz.csv"
    );
    let file = std::fs::File::open(path).expect("the piezo record");
    let columns = IoColumns {
        input: Some(ColumnRef::Index(4)),
        output: Some(ColumnRef::Index(3)),
        layout: RecordLayout {
            header: HeaderMode::Absent,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut record = read_io(std::io::BufReader::new(file), path, &columns, 2).unwrap();
    record.keep_rows(16286, None).unwrap();
    (record.input, record.output)
}

/// A triangle of growing amplitude (many loops) through a static nonlinearity:
/// every operator is excited.
fn record(n: usize) -> (Vec<f64>, Vec<f64>) {
    let u: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let phase = (t * 40.0).fract();
            let tri = if phase < 0.5 {
                4.0 * phase - 1.0
            } else {
                3.0 - 4.0 * phase
            };
            (0.3 + 0.7 * t) * 10.0 * tri
        })
        .collect();
    let y: Vec<f64> = u
        .iter()
        .map(|x| 0.8 * x + 0.05 * x.cbrt() + 0.01 * x * x.abs())
        .collect();
    (u, y)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("hysteresis_ls");
    group.sample_size(20);
    for &n in &[250_000usize, 1_000_000] {
        let (u, y) = record(n);
        let max_abs = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (name, cbrt) in [("pi", false), ("mpi_cbrt", true)] {
            let regressor = Regressor {
                offset: true,
                cbrt,
                operator: PlayOperator::Lower,
                thresholds: uniform_thresholds(10, max_abs),
                rate: None,
            };
            group.bench_function(format!("regressor_qr_{name}/{n}x10"), |b| {
                b.iter(|| {
                    let acc = regressor.qr(black_box(&u), black_box(&y));
                    solve_from_r(acc.r(), regressor.cols() + 1, regressor.free(), None).unwrap()
                })
            });
        }
        let regressor = Regressor {
            offset: true,
            cbrt: true,
            operator: PlayOperator::Lower,
            thresholds: uniform_thresholds(10, max_abs),
            rate: None,
        };
        let params = IdentifyParams {
            kind: ModelKind::MpiCbrt,
            operators: 10,
            ..Default::default()
        };
        group.bench_function(format!("identify/{n}x10"), |b| {
            b.iter(|| identify(black_box(&u), black_box(&y), &params).unwrap())
        });
        if n > 250_000 {
            continue;
        }
        group.bench_function(format!("rows_into_ident_ls/{n}x10"), |b| {
            b.iter(|| {
                let mut ls = StreamingLstsq::new(regressor.cols(), &LstsqParams::default());
                let mut states = [0.0; 10];
                let mut row = vec![0.0; regressor.cols()];
                for (&x, &yk) in u.iter().zip(&y) {
                    row[0] = 1.0;
                    row[1] = x.cbrt();
                    for (i, (s, &r)) in states.iter_mut().zip(&regressor.thresholds).enumerate() {
                        *s = PlayOperator::Lower.step(r, x, *s);
                        row[2 + i] = *s;
                    }
                    ls.push_row(&row, yk);
                }
                ls.finish().unwrap()
            })
        });
    }
    group.finish();
}

fn bench_gd(c: &mut Criterion) {
    let (u, y) = piezo_record();
    let max_abs = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut group = c.benchmark_group("hysteresis_gd");
    group.sample_size(30);
    for (name, kind) in [("pi", ModelKind::Pi), ("mpi_cbrt", ModelKind::MpiCbrt)] {
        let regressor = Regressor {
            offset: true,
            cbrt: kind == ModelKind::MpiCbrt,
            operator: PlayOperator::Lower,
            thresholds: uniform_thresholds(10, max_abs),
            rate: None,
        };
        let factor = regressor.qr(&u, &y);
        let problem = TriangularLeastSquares::from_factor(factor.r(), u.len());
        let ls = solve_from_r(factor.r(), regressor.cols() + 1, regressor.free(), None).unwrap();
        let ls_cost = 0.5 * ls.residual_norm.powi(2) / u.len() as f64;
        let solve = |max_iters| {
            let params = GdParams {
                max_iters,
                ..Default::default()
            };
            let before = ALLOCATIONS.load(Ordering::Relaxed);
            let (w, info) = gd_lstsq(&problem, &params, None, Silent).unwrap();
            (w, info, ALLOCATIONS.load(Ordering::Relaxed) - before)
        };
        let (w, info, allocations) = solve(GdParams::default().max_iters);
        let (_, _, allocations_at_one) = solve(1);
        let largest = ls.x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let weight_error = w
            .iter()
            .zip(&ls.x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            (info.cost - ls_cost).abs() <= 1e-13 * ls_cost,
            "{name}: gd cost {} vs least squares {ls_cost}",
            info.cost
        );
        eprintln!(
            "{name}: {} iterations, cost {:.15e} (least squares {ls_cost:.15e}), \
             max|w - w_ls| / max|w_ls| {:.1e}; {allocations} allocations per solve, \
             {allocations_at_one} when capped at one iteration",
            info.iterations,
            info.cost,
            weight_error / largest,
        );
        group.bench_function(format!("lbfgs_{name}/{}", u.len()), |b| {
            b.iter(|| gd_lstsq(black_box(&problem), &GdParams::default(), None, Silent).unwrap())
        });
        let params = IdentifyParams {
            kind,
            operators: 10,
            method: Method::Gd,
            ..Default::default()
        };
        group.bench_function(format!("identify_gd_{name}/{}", u.len()), |b| {
            b.iter(|| identify(black_box(&u), black_box(&y), &params).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench, bench_gd);
criterion_main!(benches);
