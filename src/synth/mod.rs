//! Controller and feedforward synthesis.

pub mod composite;
pub mod pid;
pub mod zpetc;
