//! Simulation: the embedded virtual FTS and closed-loop runs.

pub mod closed_loop;
pub mod virtual_fts;
