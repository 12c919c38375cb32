//! Reading a measured record: a 1e6-row, 3-column comma CSV (t, u, y with
//! full-precision floats, about 60 MB), as `fts identify` reads it (open,
//! stream, parse, check the time column), beside reading the same bytes
//! without parsing (the floor any reader pays) and parsing its numbers
//! alone on one thread. Target: <= 0.3 s.
//! Whole-process figures (`fts identify arx` on the same file, numpy's
//! `loadtxt`, `wc -l`) are in docs/benchmarks.md.

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use fts::io::timeseries::{IoColumns, read_io};
use std::hint::black_box;
use std::io::{BufReader, Write};
use std::time::Duration;

/// Writes the record; returns its size in bytes.
fn write_record(path: &std::path::Path, rows: usize) -> u64 {
    let mut uni = common::uniform();
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    writeln!(out, "t,u,y").unwrap();
    for k in 0..rows {
        writeln!(out, "{},{},{}", k as f64 * 1e-4, uni(), 20.0 * uni()).unwrap();
    }
    out.flush().unwrap();
    std::fs::metadata(path).unwrap().len()
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("record.csv");
    let bytes = write_record(&path, 1_000_000);
    eprintln!("record: 1e6 rows, {:.1} MB", bytes as f64 / 1e6);
    let mut g = c.benchmark_group("read_record_1e6x3");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("fts_read_io", |b| {
        b.iter(|| {
            let file = std::fs::File::open(&path).unwrap();
            let reader = BufReader::with_capacity(1 << 16, file);
            let d = read_io(reader, "record.csv", &IoColumns::default(), 2).unwrap();
            black_box(d)
        })
    });
    g.bench_function("read_bytes_only", |b| {
        b.iter(|| black_box(std::fs::read(&path).unwrap()))
    });
    // The numbers alone, one thread: the floor of parsing every digit
    // (fast-float2, as the reader and polars parse them).
    let text = std::fs::read(&path).unwrap();
    let fields: Vec<&[u8]> = text
        .split(|&b| b == b'\n')
        .skip(1)
        .flat_map(|line| line.split(|&b| b == b','))
        .filter(|f| !f.is_empty())
        .collect();
    eprintln!("numbers: {}", fields.len());
    g.bench_function("parse_numbers_only_one_thread", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for f in &fields {
                sum += fast_float2::parse::<f64, _>(f).unwrap();
            }
            black_box(sum)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
