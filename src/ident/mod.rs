//! Identification from measured data.

pub mod hysteresis;
pub mod metrics;
