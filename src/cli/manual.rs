//! `fts completions SHELL` and `fts man`: the shell completion script and
//! the manual pages, both generated from the one clap definition, so they
//! never disagree with `--help`.

use super::common::{Out, bad, stdout_error, write_atomic};
use clap::{Args, Command};
use clap_complete::Shell;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell whose completion script is printed on stdout.
    #[arg(value_enum)]
    shell: Shell,
}

#[derive(Debug, Args)]
pub struct ManArgs {
    /// Write fts.1 and one page per subcommand (fts-identify-arx.1, ...)
    /// into this folder (created if missing); without it, fts.1 goes to stdout.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// Prints the completion script of `shell` for the whole command tree.
pub fn run_completions(args: CompletionsArgs, mut command: Command) -> anyhow::Result<()> {
    clap_complete::generate(args.shell, &mut command, "fts", &mut Out);
    Ok(())
}

/// Writes the manual pages, or prints the top page.
pub fn run_man(args: ManArgs, command: Command) -> anyhow::Result<()> {
    let Some(dir) = &args.out else {
        use std::io::Write as _;
        let page = render(&command)?;
        return Out.write_all(&page).map_err(stdout_error);
    };
    if dir.exists() && !dir.is_dir() {
        return Err(bad(format!(
            "--out: {} is a file; the manual pages are written into a folder",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("{}: cannot create the folder: {e}", dir.display()))?;
    for (name, page) in pages(&command)? {
        write_atomic(&dir.join(format!("{name}.1")), &page)?;
    }
    Ok(())
}

/// The page of `command` and of every subcommand below it, each named by
/// its path (`fts`, `fts-identify`, `fts-identify-arx`).
pub fn pages(command: &Command) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
    let mut out = Vec::new();
    collect(command, command.get_name(), &mut out)?;
    Ok(out)
}

fn collect(command: &Command, name: &str, out: &mut Vec<(String, Vec<u8>)>) -> anyhow::Result<()> {
    let page = command.clone().display_name(name.to_owned());
    out.push((name.to_owned(), render(&page)?));
    for sub in command.get_subcommands().filter(|s| !s.is_hide_set()) {
        collect(sub, &format!("{name}-{}", sub.get_name()), out)?;
    }
    Ok(())
}

/// One roff page.
fn render(command: &Command) -> anyhow::Result<Vec<u8>> {
    let mut page = Vec::new();
    clap_mangen::Man::new(command.clone())
        .render(&mut page)
        .map_err(|e| anyhow::anyhow!("cannot render the manual page: {e}"))?;
    Ok(page)
}

/// Checks of this module's private parts (run by `tests/suite/checks.rs`).
#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn one_page_per_subcommand_each_roff() {
        let command = super::super::command();
        let pages = pages(&command).unwrap();
        let names: Vec<&str> = pages.iter().map(|(n, _)| n.as_str()).collect();
        for sub in command.get_subcommands().filter(|s| !s.is_hide_set()) {
            let name = format!("fts-{}", sub.get_name());
            assert!(names.contains(&name.as_str()), "no page {name}");
        }
        assert!(names.contains(&"fts-identify-arx"), "{names:?}");
        for (name, page) in &pages {
            let text = String::from_utf8_lossy(page).to_uppercase();
            let title = format!(".TH {} ", name.to_uppercase());
            assert!(text.contains(&title), "{name}: no {title}");
        }
    }
}
