//! The C compiler the C-runtime tests build with, shared by
//! `tests/c_runtime.rs` and `tests/c_runtime_multiaxis.rs`.

use std::process::Command;

/// `$CC` (default `cc`) if it runs; otherwise `None`, with a loud note on
/// stderr naming what is then not checked.
pub fn compiler(not_checked: &str) -> Option<String> {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    match Command::new(&cc).arg("--version").output() {
        Ok(o) if o.status.success() => Some(cc),
        _ => {
            eprintln!(
                "\n*** SKIPPED: no C compiler ({cc}) found; {not_checked} is NOT checked ***\n"
            );
            None
        }
    }
}
