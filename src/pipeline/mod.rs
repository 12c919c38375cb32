//! Pipeline manifests (`fts.toml`) and `fts build`: declared steps (virtual
//! experiment records, hysteresis and linear identification, ZPETC design,
//! coefficient files) rebuilt in dependency order when their inputs or
//! settings change, like `make`, but by content hash rather than time stamp.
//!
//! * [`manifest`]: the TOML file, validated into a [`Plan`] (errors name
//!   the manifest line and field);
//! * [`hash`]: SHA-256 and the lock file (`fts.lock`) that records, per step,
//!   the hashes of its settings, inputs and outputs;
//! * [`run`]: [`build`] (atomic writes; a failing step changes nothing) and
//!   [`check`] (reports stale outputs, writes nothing).
//!
//! Outputs are byte-identical wherever they are built: no time stamps, paths
//! recorded relative to the manifest, shortest round-trip floats, seeded noise.

pub mod hash;
pub mod manifest;
pub mod run;

pub use hash::{Lock, LockEntry};
pub use manifest::{Plan, Step, parse_manifest};
pub use run::{
    Event, PipelineError, Status, StepReport, build, check, close_journal, folder_of,
    keep_previous, load, stage, sweep_stale_temps, sweep_stranded, write_atomic,
};
