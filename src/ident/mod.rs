//! Identification from measured data.

pub mod metrics;
