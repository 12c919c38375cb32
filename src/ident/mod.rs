//! Identification from measured data.

pub mod excite;
pub mod hysteresis;
pub mod ls;
pub mod metrics;
