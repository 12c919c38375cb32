//! A minimal external real-time loop driven by an fts coefficient file.
//!
//! The loop owns the timing and the I/O; fts only supplies the numbers
//! (`fts.controller/1`) and the allocation-free step of the `fts-runtime`
//! crate, which is all a firmware depends on (no_std, no dependencies; the
//! file is parsed here on the host with `fts`, and on a target the
//! coefficients come in as slices). Here a simulated virtual FTS stands in
//! for the DAC/ADC: replace `plant.measure()` and `plant.advance(u)` with
//! your hardware calls. The C twin of this loop is `examples/c/fts_loop.c`.
//!
//!     fts emit --hysteresis fixtures/li21-inverse-mpi.json \
//!         --closed-loop fixtures/li21-closed-loop.json \
//!         --pid-form li21 --kp 0.02 --ki 0.15 -o controller.json
//!     cargo run --release --example realtime_loop -- controller.json

use fts::io::controller_file::parse_controller;
use fts::sim::virtual_fts::{VirtualFts, VirtualFtsParams};
use fts_runtime::RuntimeController;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "controller.json".into());
    let text = std::fs::read_to_string(&path)?;
    // Parsing and validation happen once, before the loop starts.
    let file = parse_controller(&text, &path)?;
    let mut controller = RuntimeController::new(&file.runtime_spec())?;
    let preview = controller.preview();

    // The trajectory is known ahead (an FTS cuts a programmed surface), so the
    // loop can hand the controller r(k + preview).
    let n = 20_000;
    let reference: Vec<f64> = (0..n + preview)
        .map(|k| 7.0 + 3.0 * (2.0 * std::f64::consts::PI * 50.0 * k as f64 * file.ts).sin())
        .collect();

    let mut plant = VirtualFts::new(VirtualFtsParams::default_plant())?;
    let mut worst: f64 = 0.0;
    for k in 0..n {
        let y = plant.measure(); // ADC read
        let u = controller.step(reference[k + preview], y); // no allocation, no I/O
        plant.advance(u); // DAC write, then wait for the next tick
        if k > n / 2 {
            worst = worst.max((reference[k] - y).abs());
        }
    }
    println!(
        "{}: {} blocks, preview {preview} samples; max tracking error over the second half {worst:.4} {}",
        path,
        file.block_names().join(" -> "),
        file.units.reference
    );
    Ok(())
}
