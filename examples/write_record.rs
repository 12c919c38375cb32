//! Writes a synthetic measured record for timing whole-process reads:
//! `cargo run --release --example write_record -- record.csv 1000000`.
//! Columns `t,u,y`: white input, the \[Li21\] Eq. 11 closed loop's output with
//! white measurement noise, at 10 kHz, every float in full precision.

use fts::ident::linear::filter_ab;
use std::io::Write;

fn main() -> std::io::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "record.csv".into());
    let rows: usize = args
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or(1_000_000);
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut uni = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let u: Vec<f64> = (0..rows).map(|_| uni()).collect();
    let b = [4.154, -9.631, 10.23, -5.511, 1.154];
    let a = [1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447];
    let y = filter_ab(&b, &a, 5, &u);
    let mut out = std::io::BufWriter::new(std::fs::File::create(&path)?);
    writeln!(out, "t,u,y")?;
    for k in 0..rows {
        writeln!(out, "{},{},{}", k as f64 * 1e-4, u[k], y[k] + 1e-3 * uni())?;
    }
    out.flush()?;
    eprintln!("wrote {path}: {rows} rows");
    Ok(())
}
