//! Running the built `fts` and checking what it printed: the few calls the
//! suite needs (a command builder, exit and output assertions, text
//! predicates), in-tree so the test build compiles no regex engine for them.

use std::ffi::OsStr;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant};

/// The `fts` binary cargo built for this test run.
pub fn fts_path() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_fts"))
}

/// A command running the built `fts`, stdin closed.
pub fn fts() -> Command {
    Command::from_std(std::process::Command::new(fts_path()))
}

/// Runs `cmd`, asserts it succeeded, and parses its stdout as one JSON value.
pub fn json_of(cmd: &mut Command) -> serde_json::Value {
    let out = cmd.assert().success().get_output().stdout.clone();
    serde_json::from_slice(&out).expect("one JSON object on stdout")
}

/// A command to run, with an optional time limit.
pub struct Command {
    inner: std::process::Command,
    timeout: Option<Duration>,
}

impl Command {
    /// Wraps a `std::process::Command`.
    pub fn from_std(inner: std::process::Command) -> Self {
        Command {
            inner,
            timeout: None,
        }
    }

    /// Adds one argument.
    pub fn arg(&mut self, arg: impl AsRef<OsStr>) -> &mut Self {
        self.inner.arg(arg);
        self
    }

    /// Adds arguments.
    pub fn args<I, S>(&mut self, args: I) -> &mut Self
    where
        I: IntoIterator<Item = S>,
        S: AsRef<OsStr>,
    {
        self.inner.args(args);
        self
    }

    /// Runs in `dir`.
    pub fn current_dir(&mut self, dir: impl AsRef<Path>) -> &mut Self {
        self.inner.current_dir(dir);
        self
    }

    /// Sets an environment variable.
    pub fn env(&mut self, key: impl AsRef<OsStr>, value: impl AsRef<OsStr>) -> &mut Self {
        self.inner.env(key, value);
        self
    }

    /// Kills the process when it runs longer than `limit` (its status then
    /// has no exit code).
    pub fn timeout(&mut self, limit: Duration) -> &mut Self {
        self.timeout = Some(limit);
        self
    }

    /// Runs to the end (or the time limit), capturing stdout and stderr.
    pub fn output(&mut self) -> std::io::Result<Output> {
        let mut child = self
            .inner
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()?;
        let stdout = drain(child.stdout.take());
        let stderr = drain(child.stderr.take());
        let status = match self.timeout {
            None => child.wait()?,
            Some(limit) => wait_at_most(&mut child, limit)?,
        };
        Ok(Output {
            status,
            stdout: stdout.join().expect("stdout reader"),
            stderr: stderr.join().expect("stderr reader"),
        })
    }

    /// Runs it for the assertions of [`Assert`].
    pub fn assert(&mut self) -> Assert {
        let command = format!("{:?}", self.inner);
        let output = self
            .output()
            .unwrap_or_else(|e| panic!("{command}: cannot run: {e}"));
        Assert { command, output }
    }
}

/// Reads a pipe to its end on a thread of its own (both pipes at once, so a
/// full one never blocks the child).
fn drain(pipe: Option<impl Read + Send + 'static>) -> std::thread::JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut pipe) = pipe {
            pipe.read_to_end(&mut bytes).ok();
        }
        bytes
    })
}

fn wait_at_most(child: &mut Child, limit: Duration) -> std::io::Result<std::process::ExitStatus> {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(status);
        }
        if Instant::now() >= deadline {
            child.kill().ok();
            return child.wait();
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// A finished run; each check panics with the command and its output.
pub struct Assert {
    command: String,
    output: Output,
}

impl Assert {
    /// The captured output.
    pub fn get_output(&self) -> &Output {
        &self.output
    }

    fn fail(&self, what: &str) -> ! {
        panic!(
            "{}: {what}\nstatus: {}\n--- stdout\n{}\n--- stderr\n{}",
            self.command,
            self.output.status,
            String::from_utf8_lossy(&self.output.stdout),
            String::from_utf8_lossy(&self.output.stderr)
        )
    }

    /// Exit status 0.
    pub fn success(self) -> Self {
        if !self.output.status.success() {
            self.fail("expected success");
        }
        self
    }

    /// Exit code `code`.
    pub fn code(self, code: i32) -> Self {
        if self.output.status.code() != Some(code) {
            self.fail(&format!("expected exit code {code}"));
        }
        self
    }

    /// Stdout satisfies `text` (a string is an exact match).
    pub fn stdout(self, text: impl Into<Text>) -> Self {
        let ok = text.into().eval_bytes(&self.output.stdout);
        self.check("stdout", ok)
    }

    /// Stderr satisfies `text` (a string is an exact match).
    pub fn stderr(self, text: impl Into<Text>) -> Self {
        let ok = text.into().eval_bytes(&self.output.stderr);
        self.check("stderr", ok)
    }

    fn check(self, stream: &str, verdict: Result<(), String>) -> Self {
        if let Err(wanted) = verdict {
            self.fail(&format!("{stream} is not {wanted}"));
        }
        self
    }
}

/// A condition on printed text.
#[derive(Debug, Clone)]
pub enum Text {
    /// Exactly this.
    Equals(String),
    /// Contains this.
    Contains(String),
    /// Starts with this.
    StartsWith(String),
    /// Both.
    And(Box<Text>, Box<Text>),
    /// Not this.
    Not(Box<Text>),
}

impl Text {
    /// `Ok` when `bytes` (read as UTF-8) satisfy it, else what was wanted.
    fn eval_bytes(&self, bytes: &[u8]) -> Result<(), String> {
        if self.eval(&String::from_utf8_lossy(bytes)) {
            Ok(())
        } else {
            Err(self.describe())
        }
    }

    fn eval(&self, s: &str) -> bool {
        match self {
            Text::Equals(t) => s == t,
            Text::Contains(t) => s.contains(t.as_str()),
            Text::StartsWith(t) => s.starts_with(t.as_str()),
            Text::And(a, b) => a.eval(s) && b.eval(s),
            Text::Not(a) => !a.eval(s),
        }
    }

    fn describe(&self) -> String {
        match self {
            Text::Equals(t) => format!("{t:?}"),
            Text::Contains(t) => format!("containing {t:?}"),
            Text::StartsWith(t) => format!("starting with {t:?}"),
            Text::And(a, b) => format!("{} and {}", a.describe(), b.describe()),
            Text::Not(a) => format!("not {}", a.describe()),
        }
    }

    /// This and `other`.
    pub fn and(self, other: Text) -> Text {
        Text::And(Box::new(self), Box::new(other))
    }

    /// The negation.
    #[allow(clippy::should_implement_trait)]
    pub fn not(self) -> Text {
        Text::Not(Box::new(self))
    }

    /// Itself (a condition is already one type).
    pub fn boxed(self) -> Text {
        self
    }
}

impl From<&str> for Text {
    fn from(s: &str) -> Self {
        Text::Equals(s.to_owned())
    }
}

impl From<String> for Text {
    fn from(s: String) -> Self {
        Text::Equals(s)
    }
}

/// Text conditions under the names the checks read as.
pub mod predicate {
    /// Conditions on text.
    pub mod str {
        use super::super::Text;

        /// Contains `s`.
        pub fn contains(s: impl Into<String>) -> Text {
            Text::Contains(s.into())
        }

        /// Starts with `s`.
        pub fn starts_with(s: impl Into<String>) -> Text {
            Text::StartsWith(s.into())
        }

        /// Empty.
        pub fn is_empty() -> Text {
            Text::Equals(String::new())
        }
    }
}
