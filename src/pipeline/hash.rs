//! Content hashes and the lock file (`fts.lock`, format `fts.lock/1`): per
//! step, the hash of its settings and of every input and output file as they
//! were when the step last completed.

use crate::io::InputError;
use serde_json::{Value, json};
use std::collections::BTreeMap;

pub use crate::io::controller_file::sha256_hex;

/// Name and version of the lock file format.
pub const LOCK_FORMAT: &str = "fts.lock/1";

/// What the lock records for one step.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LockEntry {
    /// The step's `kind`.
    pub kind: String,
    /// SHA-256 of the step's canonical settings (includes the fts version).
    pub settings_sha256: String,
    /// Input path (relative to the manifest) -> SHA-256 of its content.
    pub inputs: BTreeMap<String, String>,
    /// Output path -> SHA-256 of the content the step wrote.
    pub outputs: BTreeMap<String, String>,
}

/// The lock file: step name -> entry.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Lock {
    /// Entries by step name.
    pub steps: BTreeMap<String, LockEntry>,
}

impl Lock {
    /// The lock as JSON text: sorted keys, two-space indent, final newline;
    /// no time stamps or absolute paths, so it is the same on every machine.
    pub fn to_json_string(&self) -> String {
        let steps: serde_json::Map<String, Value> = self
            .steps
            .iter()
            .map(|(name, e)| {
                (
                    name.clone(),
                    json!({
                        "kind": e.kind,
                        "settings_sha256": e.settings_sha256,
                        "inputs": e.inputs,
                        "outputs": e.outputs,
                    }),
                )
            })
            .collect();
        let v = json!({
            "format": LOCK_FORMAT,
            "fts_version": env!("CARGO_PKG_VERSION"),
            "steps": steps,
        });
        let mut s = serde_json::to_string_pretty(&v).expect("JSON values serialise");
        s.push('\n');
        s
    }

    /// Parses a lock file; errors name the file and the field.
    pub fn parse(text: &str, source: &str) -> Result<Lock, InputError> {
        let v: Value = serde_json::from_str(text).map_err(|e| {
            InputError::new(
                source,
                format!("not JSON: {e} (delete it or build with `force`)"),
            )
            .at_line(e.line())
        })?;
        let bad = |field: &str, m: &str| {
            InputError::new(source, format!("{m} (delete it or build with `force`)"))
                .in_field(field)
        };
        match v.get("format").and_then(Value::as_str) {
            Some(LOCK_FORMAT) => {}
            Some(other) => {
                return Err(bad(
                    "format",
                    &format!("unknown format {other:?}, expected {LOCK_FORMAT:?}"),
                ));
            }
            None => return Err(bad("format", "missing")),
        }
        let Some(steps) = v.get("steps").and_then(Value::as_object) else {
            return Err(bad("steps", "expected an object"));
        };
        let mut lock = Lock::default();
        for (name, e) in steps {
            let field = |k: &str| format!("steps.{name}.{k}");
            let s = |k: &str| {
                e.get(k)
                    .and_then(Value::as_str)
                    .map(str::to_string)
                    .ok_or_else(|| bad(&field(k), "expected a string"))
            };
            let map = |k: &str| -> Result<BTreeMap<String, String>, InputError> {
                let o = e
                    .get(k)
                    .and_then(Value::as_object)
                    .ok_or_else(|| bad(&field(k), "expected an object"))?;
                o.iter()
                    .map(|(p, h)| {
                        h.as_str()
                            .map(|h| (p.clone(), h.to_string()))
                            .ok_or_else(|| bad(&format!("{}.{p}", field(k)), "expected a hash"))
                    })
                    .collect()
            };
            lock.steps.insert(
                name.clone(),
                LockEntry {
                    kind: s("kind")?,
                    settings_sha256: s("settings_sha256")?,
                    inputs: map("inputs")?,
                    outputs: map("outputs")?,
                },
            );
        }
        Ok(lock)
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn lock_round_trips() {
        let mut lock = Lock::default();
        lock.steps.insert(
            "b".into(),
            LockEntry {
                kind: "zpetc".into(),
                settings_sha256: "00".into(),
                inputs: [("cl.json".to_string(), "11".to_string())].into(),
                outputs: [("z.json".to_string(), "22".to_string())].into(),
            },
        );
        lock.steps.insert("a".into(), LockEntry::default());
        let text = lock.to_json_string();
        assert_eq!(Lock::parse(&text, "fts.lock").unwrap(), lock);
        // Sorted: step "a" before "b".
        assert!(text.find("\"a\"").unwrap() < text.find("\"b\"").unwrap());
    }
}
