//! The runtime step on a bare-metal target, as a static library a firmware
//! links: proves that the crate builds without `std` or an allocator, and
//! gives the size of the step (README "Deploy": `.text` of this example's
//! objects). Build it for the target only:
//!
//!     rustup target add thumbv7em-none-eabihf
//!     cargo build -p fts-runtime --release --target thumbv7em-none-eabihf --example bare_metal
//!
//! It exports two C functions: `fts_rs_init` loads a PID + HC + ZPETC
//! controller (the coefficients of `benches/runtime.rs`) into caller-owned
//! storage, `fts_rs_step` runs one sample.

// no_std on the bare-metal target; on the host (where `cargo test` builds
// every example) it links std like any static library.
#![cfg_attr(target_os = "none", no_std)]

use core::mem::MaybeUninit;
use fts_runtime::{
    FeedbackSpec, HysteresisSpec, PidSpec, PlayForm, RuntimeController, RuntimeSpec, ZpetcSpec,
};

const THRESHOLDS: [f64; 10] = [
    0.0, 0.9677, 1.9354, 2.9031, 3.8708, 4.8385, 5.8062, 6.7739, 7.7416, 8.7093,
];
const WEIGHTS: [f64; 10] = [
    0.29, -0.063, 0.0075, -0.0267, -0.0015, -0.0215, 0.021, -0.0253, 0.0115, -0.047,
];

/// Loads the controller into `*storage`; 0 on success, 1 if refused.
///
/// # Safety
/// `storage` must point to writable memory for one `RuntimeController`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fts_rs_init(storage: *mut MaybeUninit<RuntimeController>) -> i32 {
    let spec = RuntimeSpec {
        zpetc: Some(ZpetcSpec {
            preview: 5,
            num: &[0.24073, -0.18902, 0.17571, -0.14781, 0.012412, 0.008298],
            den: &[1.0, -2.31849, 2.46269, -1.32667, 0.277805],
        }),
        hysteresis: Some(HysteresisSpec {
            form: PlayForm::Lower,
            thresholds: &THRESHOLDS,
            weights: &WEIGHTS,
            cbrt_gain: -0.0197,
            offset: 0.0,
            input_offset: 0.0,
            dead_zone_thresholds: &[],
            dead_zone_weights: &[],
            ..HysteresisSpec::EMPTY
        }),
        feedback: FeedbackSpec::Pid(PidSpec {
            kp: 0.05,
            ki: 0.3,
            kd: 0.0,
            output_min: 0.0,
            output_max: 10.0,
        }),
        repetitive: None,
    };
    match RuntimeController::new(&spec) {
        Ok(c) => {
            unsafe { (*storage).write(c) };
            0
        }
        Err(_) => 1,
    }
}

/// One command.
///
/// # Safety
/// `controller` must have been initialised by [`fts_rs_init`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fts_rs_step(
    controller: *mut RuntimeController,
    reference_ahead: f64,
    measurement: f64,
) -> f64 {
    unsafe { (*controller).step(reference_ahead, measurement) }
}

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {}
}
