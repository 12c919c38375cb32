//! Docs are output (docs/README.md "Transcripts"): every transcript in
//! README.md and docs/*.md, a code block whose lines start with `$ fts`,
//! is run with this build and its output compared with what the page
//! quotes. A figure may be quoted with fewer digits than fts prints; it
//! must then be what fts prints rounded to the quoted digits. `...` on a
//! line of its own stands for any number of lines, inside a line for any
//! text. A transcript with an `fts: error:` line expects a failing exit,
//! any other success. The commands of one page run in order in one
//! folder (so a page can use the files an earlier command wrote), beside
//! links to the repository's data folders.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

mod transcript {
    /// One `$ fts ...` command and the output the page quotes.
    #[derive(Debug, Clone, PartialEq)]
    pub struct Transcript {
        /// 1-based line of the `$` in the page.
        pub line: usize,
        /// The command's words after `fts`.
        pub args: Vec<String>,
        /// The quoted output lines.
        pub expected: Vec<String>,
    }

    /// The code blocks of a Markdown page (fenced or indented by four
    /// spaces or more, also inside list items), each as its lines with the
    /// common indentation removed and the 1-based line of its first line.
    fn code_blocks(page: &str) -> Vec<(usize, Vec<String>)> {
        let lines: Vec<&str> = page.lines().collect();
        let mut blocks = Vec::new();
        let mut i = 0;
        while i < lines.len() {
            let trimmed = lines[i].trim_start();
            if trimmed.starts_with("```") {
                let indent = lines[i].len() - trimmed.len();
                let start = i + 1;
                let mut j = start;
                while j < lines.len() && !lines[j].trim_start().starts_with("```") {
                    j += 1;
                }
                blocks.push((start + 1, dedent(&lines[start..j], indent)));
                i = j + 1;
            } else if is_indented_dollar(lines[i]) {
                let indent = lines[i].len() - trimmed.len();
                let start = i;
                let mut j = i;
                while j < lines.len() && lines[j].len() - lines[j].trim_start().len() >= indent {
                    if lines[j].trim().is_empty() {
                        break;
                    }
                    j += 1;
                }
                blocks.push((start + 1, dedent(&lines[start..j], indent)));
                i = j;
            } else {
                i += 1;
            }
        }
        blocks
    }

    fn is_indented_dollar(line: &str) -> bool {
        let trimmed = line.trim_start();
        line.len() - trimmed.len() >= 4 && trimmed.starts_with("$ ")
    }

    /// The lines with up to `indent` leading blanks removed.
    fn dedent(lines: &[&str], indent: usize) -> Vec<String> {
        lines
            .iter()
            .map(|line| {
                let n = line.len() - line.trim_start().len();
                line[n.min(indent)..].to_owned()
            })
            .collect()
    }

    /// The transcripts of a page: blocks whose first line is `$ fts ...`
    /// and whose every `$` line runs fts.
    pub fn parse(page: &str) -> Vec<Transcript> {
        let mut out = Vec::new();
        for (first, body) in code_blocks(page) {
            let is_transcript = body.first().is_some_and(|l| l.starts_with("$ fts "))
                && body
                    .iter()
                    .filter(|l| l.starts_with("$ "))
                    .all(|l| l.starts_with("$ fts "));
            if !is_transcript {
                continue;
            }
            for (k, l) in body.iter().enumerate() {
                if let Some(cmd) = l.strip_prefix("$ fts ") {
                    out.push(Transcript {
                        line: first + k,
                        args: split_words(cmd),
                        expected: Vec::new(),
                    });
                } else if let Some(t) = out.last_mut() {
                    t.expected.push(l.clone());
                }
            }
        }
        out
    }

    /// Shell words: blanks separate, `'..'` and `".."` quote.
    pub fn split_words(text: &str) -> Vec<String> {
        let mut words = Vec::new();
        let mut word = String::new();
        let mut in_word = false;
        let mut quote: Option<char> = None;
        for c in text.chars() {
            match quote {
                Some(q) if c == q => quote = None,
                Some(_) => word.push(c),
                None if c == '\'' || c == '"' => {
                    quote = Some(c);
                    in_word = true;
                }
                None if c.is_whitespace() => {
                    if in_word {
                        words.push(std::mem::take(&mut word));
                        in_word = false;
                    }
                }
                None => {
                    word.push(c);
                    in_word = true;
                }
            }
        }
        if in_word {
            words.push(word);
        }
        words
    }

    /// A piece of a line: one character of text, a number with the
    /// half-unit of its last printed digit, or (expected only) `...`.
    #[derive(Debug, Clone, PartialEq)]
    pub enum Atom {
        Char(char),
        Num { value: f64, half_unit: f64 },
        Any,
    }

    /// The atoms of a line, whitespace runs collapsed to one space and
    /// ends trimmed; `...` becomes [`Atom::Any`] when `elide`.
    pub fn atoms(line: &str, elide: bool) -> Vec<Atom> {
        let chars: Vec<char> = line
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
            .chars()
            .collect();
        let mut out = Vec::with_capacity(chars.len());
        let mut i = 0;
        while i < chars.len() {
            if elide && chars[i..].starts_with(&['.', '.', '.']) {
                out.push(Atom::Any);
                i += 3;
                continue;
            }
            if let Some((len, atom)) = number_at(&chars, i) {
                out.push(atom);
                i += len;
                continue;
            }
            out.push(Atom::Char(chars[i]));
            i += 1;
        }
        out
    }

    /// A decimal number starting at `i` (sign only when not after a digit
    /// or letter, so `1-2` and `z^-1` read as text around numbers).
    fn number_at(chars: &[char], i: usize) -> Option<(usize, Atom)> {
        let mut j = i;
        let after_word = i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '_');
        if after_word && chars[i].is_ascii_digit() {
            return None;
        }
        if (chars[j] == '-' || chars[j] == '+') && !after_word {
            j += 1;
        }
        let int_start = j;
        while j < chars.len() && chars[j].is_ascii_digit() {
            j += 1;
        }
        if j == int_start {
            return None;
        }
        let mut decimals = 0i32;
        if j + 1 < chars.len() && chars[j] == '.' && chars[j + 1].is_ascii_digit() {
            j += 1;
            while j < chars.len() && chars[j].is_ascii_digit() {
                j += 1;
                decimals += 1;
            }
        }
        let mut exponent = 0i32;
        if j + 1 < chars.len() && (chars[j] == 'e' || chars[j] == 'E') {
            let mut k = j + 1;
            if k < chars.len() && (chars[k] == '-' || chars[k] == '+') {
                k += 1;
            }
            let exp_start = k;
            while k < chars.len() && chars[k].is_ascii_digit() {
                k += 1;
            }
            if k > exp_start {
                let text: String = chars[j + 1..k].iter().collect();
                exponent = text.parse().ok()?;
                j = k;
            }
        }
        let text: String = chars[i..j].iter().collect();
        let value: f64 = text.parse().ok()?;
        let half_unit = 0.5 * 10f64.powi(exponent - decimals);
        Some((j - i, Atom::Num { value, half_unit }))
    }

    /// Whether an expected atom accepts an actual one: text equal, a
    /// number equal to the quoted one at the quoted digits.
    pub fn accepts(expected: &Atom, actual: &Atom) -> bool {
        match (expected, actual) {
            (Atom::Char(a), Atom::Char(b)) => a == b,
            (
                Atom::Num {
                    value: e,
                    half_unit,
                },
                Atom::Num { value: a, .. },
            ) => {
                // Rounding the printed value to the quoted digits gives the
                // quoted value; 1e-9 of a unit absorbs binary rounding.
                (a - e).abs() <= half_unit * (1.0 + 1e-9) + 1e-12 * e.abs()
            }
            _ => false,
        }
    }

    /// Glob matching: `Any` takes any run of items.
    fn glob<E, A>(
        expected: &[E],
        actual: &[A],
        is_any: impl Fn(&E) -> bool,
        eq: impl Fn(&E, &A) -> bool,
    ) -> bool {
        // reach[j]: expected[..i] matches actual[..j].
        let mut reach = vec![false; actual.len() + 1];
        reach[0] = true;
        for e in expected {
            let mut next = vec![false; actual.len() + 1];
            if is_any(e) {
                let mut any = false;
                for j in 0..=actual.len() {
                    any |= reach[j];
                    next[j] = any;
                }
            } else {
                for j in 0..actual.len() {
                    next[j + 1] = reach[j] && eq(e, &actual[j]);
                }
            }
            reach = next;
        }
        reach[actual.len()]
    }

    /// Whether one actual line is what the quoted line says.
    pub fn line_matches(expected: &str, actual: &str) -> bool {
        glob(
            &atoms(expected, true),
            &atoms(actual, false),
            |a| *a == Atom::Any,
            accepts,
        )
    }

    /// Whether the actual output is what the quoted lines say (a line
    /// `...` takes any number of lines).
    pub fn output_matches(expected: &[String], actual: &[String]) -> bool {
        glob(
            expected,
            actual,
            |e| e.trim() == "...",
            |e, a| line_matches(e, a),
        )
    }
}

use std::collections::HashMap;
use transcript::{
    Atom, Transcript, accepts, atoms, line_matches, output_matches, parse, split_words,
};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The pages whose transcripts are checked.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![repo().join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(repo().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    // `FTS_DOC_PAGES=robust.md,mechanism.md` checks only those pages (for
    // editing one page; CI leaves it unset and checks every page).
    if let Ok(only) = std::env::var("FTS_DOC_PAGES") {
        let only: Vec<&str> = only.split(',').map(str::trim).collect();
        pages.retain(|p| only.iter().any(|o| p.ends_with(o)));
    }
    pages
}

/// A folder for one page's commands: links to the repository's folders
/// (read-only use), nothing else.
fn workdir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "fixtures", "tests", "examples", "assets", "docs", "crates", "benches", "data",
    ] {
        let target = repo().join(name);
        if target.exists() {
            #[cfg(unix)]
            std::os::unix::fs::symlink(&target, dir.path().join(name)).unwrap();
        }
    }
    dir
}

/// Runs `fts args` in `dir`: its exit success and its stdout and stderr
/// as one stream of lines, in the order a terminal shows them.
fn run(dir: &Path, args: &[String]) -> (bool, Vec<String>) {
    let log = dir.join(".transcript-output");
    let file = std::fs::File::create(&log).unwrap();
    let status = Command::new(crate::common::cmd::fts_path())
        .current_dir(dir)
        .args(args)
        .stdin(Stdio::null())
        .stdout(file.try_clone().unwrap())
        .stderr(file)
        .status()
        .unwrap();
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    std::fs::remove_file(&log).ok();
    (status.success(), text.lines().map(str::to_owned).collect())
}

/// Whether a transcript's run is what its page quotes; `Err` says how not.
fn check(t: &Transcript, success: bool, actual: &[String]) -> Result<(), String> {
    let expects_error = t.expected.iter().any(|l| l.starts_with("fts: error:"));
    if success == expects_error {
        return Err(format!(
            "exit {} but the page quotes {}",
            if success { "0" } else { "non-zero" },
            if expects_error {
                "an error"
            } else {
                "a success"
            }
        ));
    }
    if output_matches(&t.expected, actual) {
        return Ok(());
    }
    Err(format!(
        "output differs from the page\n--- quoted\n{}\n--- printed\n{}",
        t.expected.join("\n"),
        actual.join("\n")
    ))
}

/// The numbers of the `fts` column of docs/reference-values.md's verdict
/// table that the linked page's transcripts do not print (`printed`: every
/// output line of each page's transcripts, by file name).
fn unprinted_verdict_figures(printed: &HashMap<String, Vec<String>>) -> Vec<String> {
    let page = std::fs::read_to_string(repo().join("docs/reference-values.md")).unwrap();
    let mut missing = Vec::new();
    let mut rows = 0;
    for (n, line) in page.lines().enumerate() {
        let cells: Vec<&str> = line.split(" | ").collect();
        if !line.starts_with("| [") || cells.len() != 6 {
            continue;
        }
        let link = cells[4]
            .split_once("](")
            .and_then(|(_, rest)| rest.split_once(')'));
        let Some((target, _)) = link.filter(|(t, _)| t.ends_with(".md")) else {
            continue;
        };
        rows += 1;
        if std::env::var_os("FTS_DOC_PAGES").is_some() && !printed.contains_key(target) {
            continue; // a page left out by the filter
        }
        let lines = printed.get(target).map(Vec::as_slice).unwrap_or_default();
        let numbers: Vec<Atom> = lines
            .iter()
            .flat_map(|l| atoms(l, false))
            .filter(|a| matches!(a, Atom::Num { .. }))
            .collect();
        for figure in atoms(cells[3], false) {
            let is_number = matches!(figure, Atom::Num { .. });
            if is_number && !numbers.iter().any(|a| accepts(&figure, a)) {
                missing.push(format!(
                    "docs/reference-values.md line {}: {figure:?} of `{}` is not printed by {target}'s transcripts",
                    n + 1,
                    cells[3]
                ));
            }
        }
    }
    assert!(rows >= 15, "only {rows} verdict rows with a page");
    missing
}

/// What one page's transcripts did: how many ran, how each that differs
/// differs, and every output line (for the verdict table's check).
struct PageRun {
    count: usize,
    failures: Vec<String>,
    printed: Vec<String>,
}

/// Runs one page's transcripts in order in a folder of their own.
fn run_page(page: &Path) -> PageRun {
    let text = std::fs::read_to_string(page).unwrap();
    let dir = workdir();
    let name = page.strip_prefix(repo()).unwrap().display().to_string();
    let mut run_of_page = PageRun {
        count: 0,
        failures: Vec::new(),
        printed: Vec::new(),
    };
    for t in &parse(&text) {
        run_of_page.count += 1;
        let (success, actual) = run(dir.path(), &t.args);
        if let Err(why) = check(t, success, &actual) {
            run_of_page.failures.push(format!(
                "{name} line {}: fts {}: {why}",
                t.line,
                t.args.join(" ")
            ));
        }
        run_of_page.printed.extend(actual);
    }
    run_of_page
}

/// Every page's run, the pages shared out over the machine's cores (pages
/// are independent: each has its own folder), in page order.
fn run_pages(pages: &[PathBuf]) -> Vec<PageRun> {
    let workers = std::thread::available_parallelism().map_or(1, usize::from);
    let next = AtomicUsize::new(0);
    let runs: Mutex<Vec<Option<PageRun>>> = Mutex::new(pages.iter().map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..workers.min(pages.len()) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(page) = pages.get(i) else { break };
                    let page_run = run_page(page);
                    runs.lock().unwrap()[i] = Some(page_run);
                }
            });
        }
    });
    runs.into_inner()
        .unwrap()
        .into_iter()
        .map(|r| r.expect("every page ran"))
        .collect()
}

#[test]
fn every_transcript_in_the_docs_prints_what_the_page_quotes() {
    let started = Instant::now();
    let pages = pages();
    let runs = run_pages(&pages);
    let mut failures = Vec::new();
    let mut printed: HashMap<String, Vec<String>> = HashMap::new();
    let mut count = 0;
    for (page, page_run) in pages.iter().zip(runs) {
        count += page_run.count;
        failures.extend(page_run.failures);
        let file = page.file_name().unwrap().to_string_lossy().into_owned();
        printed.entry(file).or_default().extend(page_run.printed);
    }
    eprintln!(
        "doc transcripts: {count} commands in {:.1} s, {} differ",
        started.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(count >= 10, "only {count} transcripts found");
    failures.extend(unprinted_verdict_figures(&printed));
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// The check fails on an edited figure, at the quoted digits and only
/// there: the harness can fail.
#[test]
fn an_edited_figure_fails_the_check() {
    let printed = "gain margin:     2.598165 (+8.293 dB) at 1676.960324 Hz";
    assert!(line_matches(printed, printed));
    // Fewer digits: what fts prints, rounded.
    assert!(line_matches(
        "gain margin: 2.598 (+8.29 dB) at 1677 Hz",
        printed
    ));
    assert!(line_matches("gain margin: 2.60 ... at 1676.96 Hz", printed));
    // One digit off at the quoted precision, a wrong sign, other text.
    assert!(!line_matches(
        "gain margin: 2.599 (+8.29 dB) at 1677 Hz",
        printed
    ));
    assert!(!line_matches(
        "gain margin: 2.598165 (+8.294 dB) at 1676.960324 Hz",
        printed
    ));
    assert!(!line_matches(
        "gain margin: 2.598165 (-8.293 dB) at 1676.960324 Hz",
        printed
    ));
    assert!(!line_matches(
        "gain margin: 2.598165 (+8.293 dB) at 1676.960324 rad/s",
        printed
    ));
    assert!(!line_matches(
        "gain margin: 2.598165e1 (+8.293 dB) at 1676.960324 Hz",
        printed
    ));
    // Lines: `...` elides, anything else must be there in order.
    let out: Vec<String> = ["a 1", "b 2", "c 3"].map(String::from).to_vec();
    let quote = |q: &[&str]| q.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(output_matches(&quote(&["a 1", "...", "c 3"]), &out));
    assert!(output_matches(&quote(&["...", "c 3.0"]), &out));
    assert!(!output_matches(&quote(&["a 1", "c 3"]), &out));
    assert!(!output_matches(&quote(&["a 1", "b 2", "c 4"]), &out));
    // A page transcript: the `$` line, its output, the exit it implies.
    let page =
        "text\n\n    $ fts loop --plant 'a b.json' --kp 0.1\n    gain margin: 2.6 ...\n\nmore\n";
    let t = &parse(page)[0];
    assert_eq!((t.line, t.args.len()), (3, 5));
    assert_eq!(t.args[2], "a b.json");
    assert!(check(t, true, &[printed.to_owned()]).is_ok());
    assert!(check(t, false, &[printed.to_owned()]).is_err());
    let edited = page.replace("2.6", "2.7");
    assert!(check(&parse(&edited)[0], true, &[printed.to_owned()]).is_err());
    assert_eq!(split_words(r#"a "b c" 'd'"#), ["a", "b c", "d"]);
}
