//! Identification from measured data.
//!
//! Linear (polynomial) models, docs/math.md §2: [`arx`] (QR least squares),
//! [`iv`] (refined instrumental variables), [`oe`] (output error by
//! Levenberg–Marquardt), [`structure`] (order and delay selection),
//! [`freq`] (empirical frequency response; [`periodic`] for a repeating
//! input), sharing [`linear`] (model,
//! fits, residual tests), [`ls`] (the streaming QR least-squares engine) and [`data`]
//! (detrending, splits).

pub mod arx;
pub(crate) mod correlation;
pub mod ct;
pub mod data;
pub mod excite;
mod fork;
pub mod freq;
pub mod hysteresis;
pub mod iv;
pub mod linear;
pub mod ls;
pub mod metrics;
pub mod oe;
pub mod periodic;
pub mod structure;
#[cfg(feature = "checks")]
pub(crate) mod testutil;
