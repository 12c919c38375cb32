//! Identification from measured data.

pub mod excite;
pub mod ls;
pub mod metrics;
