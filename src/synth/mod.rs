//! Controller and feedforward synthesis.

pub mod zpetc;
