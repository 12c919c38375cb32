//! `fts build [-f fts.toml] [--check] [--force] [--json]`: regenerate every
//! output of a pipeline manifest whose inputs or settings changed, or, with
//! `--check`, report the stale ones without writing anything (exit 1).

use super::common::{bad, print_json};
use crate::pipeline::{self, Event, PipelineError, Status, StepReport};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct BuildArgs {
    /// The manifest; paths in it are relative to its folder, and the lock
    /// file (`<stem>.lock`) sits beside it.
    #[arg(
        short = 'f',
        long = "manifest",
        value_name = "FTS.toml",
        default_value = "fts.toml"
    )]
    manifest: PathBuf,
    /// Write nothing; exit 1 naming every stale output and why.
    #[arg(long, conflicts_with = "force")]
    check: bool,
    /// Rebuild every step, whatever the lock file says.
    #[arg(long)]
    force: bool,
    /// Print one JSON object on stdout instead of the per-step lines.
    #[arg(long)]
    json: bool,
}

/// A pipeline message with the build settings it names (`` `force` ``)
/// written as this command's options; other quoted words stay as written.
fn options(message: &str) -> String {
    crate::workflow::render_settings(message, |key| match key {
        "force" | "check" => format!("--{key}"),
        other => format!("`{other}`"),
    })
}

fn map_err(e: PipelineError) -> anyhow::Error {
    match e {
        PipelineError::BadInput(m) => bad(options(&m)),
        PipelineError::Failure(m) => anyhow::anyhow!(options(&m)),
    }
}

fn reasons(r: &StepReport) -> Vec<String> {
    r.reasons.iter().map(|m| options(m)).collect()
}

fn line(r: &StepReport) -> String {
    let mut s = format!(
        "{:<12} {:<20} {}",
        r.status.label(),
        r.name,
        r.outputs.join(", ")
    );
    if r.status == Status::Built {
        s.push_str(&format!(" ({:.2} s)", r.seconds));
    }
    if r.status != Status::UpToDate && !r.reasons.is_empty() {
        s.push_str(&format!("\n{:<12} because {}", "", reasons(r).join("; ")));
    }
    s
}

pub fn run(args: BuildArgs) -> anyhow::Result<()> {
    let plan = pipeline::load(&args.manifest).map_err(map_err)?;
    let start = std::time::Instant::now();
    let reports = run_steps(&plan, &args)?;
    let count = |s: Status| reports.iter().filter(|r| r.status == s).count();
    if args.json {
        print_json(&summary_json(
            &plan,
            args.check,
            &reports,
            start.elapsed().as_secs_f64(),
        ))?;
    } else if args.check {
        say!(
            "{}: {} of {} steps up to date",
            plan.manifest.display(),
            count(Status::UpToDate),
            reports.len()
        );
    } else {
        say!(
            "{}: {} built, {} up to date, {:.2} s; lock {}",
            plan.manifest.display(),
            count(Status::Built),
            count(Status::UpToDate),
            start.elapsed().as_secs_f64(),
            plan.lock.display()
        );
    }
    refuse_stale(&plan, &reports)
}

/// Checks or builds the plan's steps, with a spinner on stderr and, unless
/// `--json`, one line per step as it finishes.
fn run_steps(plan: &pipeline::Plan, args: &BuildArgs) -> anyhow::Result<Vec<StepReport>> {
    let bar = ProgressBar::new_spinner();
    bar.set_style(ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").expect("valid"));
    let quiet = args.json;
    let mut observer = |e: Event<'_>| match e {
        Event::Start(step) => {
            bar.set_message(format!("{} ({})", step.name, step.kind));
            bar.enable_steady_tick(std::time::Duration::from_millis(120));
        }
        Event::Done(r) => {
            if !quiet {
                use std::io::Write as _;
                // Held with the rest of the run's stdout: printed only when
                // the whole build has succeeded.
                let _ = writeln!(super::common::Out, "{}", line(r));
            }
        }
    };
    let result = if args.check {
        pipeline::check(plan, &mut observer)
    } else {
        pipeline::build(plan, args.force, &mut observer)
    };
    bar.finish_and_clear();
    result.map_err(map_err)
}

/// The `--json` summary: the run's counts and every step's status.
fn summary_json(
    plan: &pipeline::Plan,
    check: bool,
    reports: &[StepReport],
    seconds: f64,
) -> serde_json::Value {
    let count = |s: Status| reports.iter().filter(|r| r.status == s).count();
    json!({
        "manifest": plan.manifest.display().to_string(),
        "lock": plan.lock.display().to_string(),
        "check": check,
        "seconds": seconds,
        "built": count(Status::Built),
        "up_to_date": count(Status::UpToDate),
        "stale": count(Status::Stale),
        "steps": reports.iter().map(|r| json!({
            "name": r.name,
            "kind": r.kind,
            "status": r.status.label(),
            "reasons": reasons(r),
            "outputs": r.outputs,
            "seconds": r.seconds,
        })).collect::<Vec<_>>(),
    })
}

/// Exit 1 naming every stale output and why (`--check`).
fn refuse_stale(plan: &pipeline::Plan, reports: &[StepReport]) -> anyhow::Result<()> {
    let stale: Vec<String> = reports
        .iter()
        .filter(|r| r.status == Status::Stale)
        .map(|r| format!("{} ({})", r.outputs.join(", "), reasons(r).join("; ")))
        .collect();
    if stale.is_empty() {
        return Ok(());
    }
    Err(anyhow::anyhow!(
        "stale outputs: {}; run `fts build -f {}`",
        stale.join("; "),
        plan.manifest.display()
    ))
}
