//! The `fts` command: all logic lives in the library's `cli` module.
fn main() -> std::process::ExitCode {
    // Like other Unix filters, end quietly when the reader of stdout goes
    // away (`fts ... | head`) instead of panicking on a broken pipe.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any other
    // thread exists; no Rust invariant depends on it.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    fts::cli::main()
}
