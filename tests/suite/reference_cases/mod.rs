//! The stored reference cases of the synthesis tests: `tests/data/<dir>/cases.json`,
//! a JSON object whose `cases` array each test reads into its own `Case` type.

use serde::Deserialize;
use serde::de::DeserializeOwned;

#[derive(Deserialize)]
#[serde(bound = "T: DeserializeOwned")]
struct Cases<T> {
    cases: Vec<T>,
}

/// The cases of `tests/data/<dir>/cases.json`.
pub fn load<T: DeserializeOwned>(dir: &str) -> Vec<T> {
    let path = format!("{}/tests/data/{dir}/cases.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str::<Cases<T>>(&text)
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .cases
}
