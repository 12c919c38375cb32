//! Shared helpers: property-test configuration, a seeded uniform sequence
//! and the C compiler driver.

use proptest::prelude::ProptestConfig;
use proptest::test_runner::RngSeed;

/// CI runs a fixed seed so that it is reproducible; `FTS_PROPTEST_RANDOM=1`
/// draws a fresh seed (and `PROPTEST_CASES` sets the number of cases) for
/// the long local runs that look for rare bad draws.
pub fn proptest_config(cases: u32) -> ProptestConfig {
    let random = std::env::var("FTS_PROPTEST_RANDOM").is_ok_and(|v| v == "1");
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(cases);
    ProptestConfig {
        cases,
        rng_seed: if random {
            RngSeed::Random
        } else {
            RngSeed::Fixed(20261122)
        },
        ..ProptestConfig::default()
    }
}

/// The library's deterministic white sequence on [0, 1) (64-bit LCG).
pub use fts::internal_checks::unit_uniform;

pub mod cc;
pub mod cmd;
