//! Splits `fts identify arx RECORD --na 5 --nb 5 --nk 5` into its two
//! parts, timed in process: reading the record (`read_io`, as the command
//! reads it) and identifying from it (the `IdentifyArx` step: the ARX fit,
//! its fits and residual tests).
//! `cargo run --release --example time_identify_arx -- record.csv`; each
//! part is run five times and its median printed.

use fts::io::timeseries::{IoColumns, IoData, read_io};
use fts::workflow::identify::{IdentifyArx, LinearInputs};
use std::time::Instant;

fn read(path: &str) -> IoData {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let reader = std::io::BufReader::with_capacity(1 << 16, file);
    read_io(reader, path, &IoColumns::default(), 2).unwrap_or_else(|e| panic!("{e}"))
}

fn median(mut seconds: Vec<f64>) -> f64 {
    seconds.sort_by(f64::total_cmp);
    seconds[seconds.len() / 2]
}

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "record.csv".into());
    let step = IdentifyArx {
        na: Some(5),
        nb: Some(5),
        nk: Some(5),
        ..Default::default()
    };
    let bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
    let (mut reads, mut fits) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let start = Instant::now();
        let data = read(&path);
        reads.push(start.elapsed().as_secs_f64());
        let inputs = LinearInputs {
            data,
            source: path.clone(),
            validation: None,
        };
        let start = Instant::now();
        let report = step.run(inputs).unwrap_or_else(|e| panic!("{e}"));
        fits.push(start.elapsed().as_secs_f64());
        assert!(report.fit_percent.is_finite());
    }
    let read_s = median(reads);
    println!(
        "read {read_s:.3} s ({:.0} MB/s), identify {:.3} s (medians of 5)",
        bytes as f64 / 1e6 / read_s,
        median(fits)
    );
}
