//! File contracts (`docs/formats.md`): every reader here parses text
//! it is handed together with a *source name* (normally the file's path) so that
//! each error can name the file, the line and the field. Nothing in this module
//! touches the file system; the CLI reads and writes the bytes.

mod error;
pub mod ss_json;
pub mod tf_json;
pub mod timeseries;

pub use error::InputError;
pub mod controller_file;
pub mod hysteresis_json;
pub mod mat;
pub mod plot;
mod serde_doc;
pub mod zpetc_json;
