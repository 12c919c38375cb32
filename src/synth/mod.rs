//! Controller and feedforward synthesis.

pub mod pid;
pub mod zpetc;
