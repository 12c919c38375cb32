//! The C compiler the C-runtime tests build with, shared by
//! `tests/suite/c_runtime.rs` and `tests/suite/c_runtime_multiaxis.rs`.

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

/// The compilers and dialects the generated C must build with warning-free:
/// `(compiler, -x language, -std)`.
pub const DIALECTS: [(&str, &str, &str); 4] = [
    ("gcc", "c", "-std=c99"),
    ("clang", "c", "-std=c99"),
    ("g++", "c++", "-std=c++11"),
    ("clang++", "c++", "-std=c++11"),
];

/// Whether `cc` runs; a note on stderr when it does not.
pub fn installed(cc: &str) -> bool {
    let found = Command::new(cc).arg("--version").output().is_ok();
    if !found {
        eprintln!("note: {cc} not installed; not checked");
    }
    found
}

/// Compiles `source` with `cc -x lang std extra -Wall -Wextra -pedantic
/// -Werror -c -I include` into `include/out.o`, failing with the
/// compiler's messages on any warning.
pub fn assert_compiles_warning_free(
    (cc, lang, std): (&str, &str, &str),
    extra: &[&str],
    include: &std::path::Path,
    source: &std::path::Path,
) {
    let out = Command::new(cc)
        .args(["-x", lang, std])
        .args(extra)
        .args(["-Wall", "-Wextra", "-pedantic", "-Werror", "-c"])
        .arg("-I")
        .arg(include)
        .arg(source)
        .arg("-o")
        .arg(include.join("out.o"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{cc} -x {lang} {}:\n{}",
        source.display(),
        String::from_utf8_lossy(&out.stderr)
    );
}
