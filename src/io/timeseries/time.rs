//! Time columns: names, units and the sample time with its jitter.

use super::Layout;
use crate::io::InputError;

/// The unit of a time column; values are converted to seconds on reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum TimeUnit {
    /// Seconds.
    #[serde(rename = "s")]
    Seconds,
    /// Milliseconds.
    #[serde(rename = "ms")]
    Milliseconds,
    /// Microseconds.
    #[serde(rename = "us")]
    Microseconds,
}

impl TimeUnit {
    /// The names accepted by [`TimeUnit::from_name`].
    pub const NAMES: &'static str = "s, ms, us";

    /// `s`, `ms`, `us` and their usual spellings (`sec`, `msec`, `µs`, …).
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "s" | "sec" | "secs" | "second" | "seconds" => Some(Self::Seconds),
            "ms" | "msec" | "millisecond" | "milliseconds" => Some(Self::Milliseconds),
            "us" | "µs" | "μs" | "usec" | "microsecond" | "microseconds" => {
                Some(Self::Microseconds)
            }
            _ => None,
        }
    }

    /// Seconds per unit.
    pub fn seconds(self) -> f64 {
        match self {
            Self::Seconds => 1.0,
            Self::Milliseconds => 1e-3,
            Self::Microseconds => 1e-6,
        }
    }

    /// The short name (`s`, `ms`, `us`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Seconds => "s",
            Self::Milliseconds => "ms",
            Self::Microseconds => "us",
        }
    }
}

/// Where the unit of the time column came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum UnitSource {
    /// The caller said so ([`Layout::time_unit`], `--time-unit`).
    Given,
    /// The column name (`time_ms`, `t [ms]`).
    Name,
    /// The units row under the header.
    UnitsRow,
    /// Nothing said otherwise: seconds.
    Default,
}

/// Default of [`Layout::time_jitter`]: 5 % of the mean step.
pub const DEFAULT_TIME_JITTER: f64 = 0.05;

/// Sample time and jitter of a time column.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Timing {
    /// The time column's name.
    pub column: String,
    /// Its unit.
    pub unit: TimeUnit,
    /// Where the unit came from.
    pub unit_from: UnitSource,
    /// Mean step in seconds: `(t_last - t_first) / (n - 1)`.
    pub ts: f64,
    /// Largest `|step - ts|` in seconds.
    pub max_jitter: f64,
    /// RMS of `step - ts` in seconds.
    pub rms_jitter: f64,
    /// The accepted `|step - ts| / ts`.
    pub tolerance: f64,
}

impl std::fmt::Display for Timing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "time column '{}' ({}): Ts {:.6e} s (mean step), jitter max {:.3e} s ({:.3} %), rms {:.3e} s",
            self.column,
            self.unit.name(),
            self.ts,
            self.max_jitter,
            100.0 * self.max_jitter / self.ts,
            self.rms_jitter
        )
    }
}

/// Splits `t [ms]`, `Time (us)`, `time_ms`, `t ms` into a base name and a
/// unit text.
pub(super) fn split_unit(name: &str) -> (&str, Option<&str>) {
    let name = name.trim();
    for (open, close) in [('[', ']'), ('(', ')')] {
        if let Some(stripped) = name.strip_suffix(close)
            && let Some(at) = stripped.rfind(open)
        {
            return (stripped[..at].trim(), Some(stripped[at + 1..].trim()));
        }
    }
    for sep in ['_', ' '] {
        if let Some(at) = name.rfind(sep) {
            let unit = &name[at + 1..];
            if TimeUnit::from_name(unit).is_some() {
                return (name[..at].trim(), Some(unit));
            }
        }
    }
    (name, None)
}

/// Whether a column name reads as time (`t`, `time`, `Time`, `time_s`, `t [ms]`, …).
pub fn is_time_name(name: &str) -> bool {
    let base = split_unit(name).0.to_ascii_lowercase();
    matches!(base.as_str(), "t" | "time" | "zeit" | "timestamp")
}

fn unit_error(source: &str, column: &str, unit: &str) -> InputError {
    InputError::new(
        source,
        format!(
            "unknown time unit '{unit}' (known: {}); give the time unit explicitly",
            TimeUnit::NAMES
        ),
    )
    .in_field(column)
}

/// The unit of a time column from the caller, its name or a units row.
pub(super) fn time_unit(
    layout: &Layout,
    name: &str,
    units_row: Option<&str>,
    source: &str,
) -> Result<(TimeUnit, UnitSource), InputError> {
    if let Some(unit) = layout.time_unit {
        return Ok((unit, UnitSource::Given));
    }
    if let (_, Some(text)) = split_unit(name) {
        return TimeUnit::from_name(text)
            .map(|u| (u, UnitSource::Name))
            .ok_or_else(|| unit_error(source, name, text));
    }
    match units_row.map(|u| u.trim_matches(|c| matches!(c, '[' | ']' | '(' | ')'))) {
        Some(text) if !text.is_empty() => TimeUnit::from_name(text)
            .map(|u| (u, UnitSource::UnitsRow))
            .ok_or_else(|| unit_error(source, name, text)),
        _ => Ok((TimeUnit::Seconds, UnitSource::Default)),
    }
}

impl Timing {
    /// Checks that `t` (seconds) increases and steps evenly up to the jitter
    /// `tolerance`, and measures the jitter. A fault is `(row index of the
    /// later sample, message)`: the first non-increasing step, else the step
    /// that deviates most from the mean, so a gap is named rather than the
    /// ordinary steps its length pulls away from the mean.
    pub(super) fn measure(
        t: &[f64],
        column: String,
        (unit, unit_from): (TimeUnit, UnitSource),
        tolerance: f64,
    ) -> Result<Self, (usize, String)> {
        let n = t.len();
        if n < 2 {
            return Err((0, "a time column needs at least 2 samples".to_owned()));
        }
        if let Some(k) = t.windows(2).position(|w| w[1] <= w[0]) {
            let msg = format!("time must increase: {} s follows {} s", t[k + 1], t[k]);
            return Err((k + 1, msg));
        }
        let ts = (t[n - 1] - t[0]) / (n - 1) as f64;
        let (mut worst, mut max, mut sum_sq) = (0, 0.0_f64, 0.0);
        for (k, w) in t.windows(2).enumerate() {
            let dev = (w[1] - w[0]) - ts;
            if dev.abs() > max {
                (worst, max) = (k + 1, dev.abs());
            }
            sum_sq += dev * dev;
        }
        if max > tolerance * ts {
            let step = t[worst] - t[worst - 1];
            return Err((
                worst,
                format!(
                    "time step {step:e} s differs from the mean step {ts:e} s by {:.2} % (more than the {:.2} % of jitter allowed): a {} in the record; resample it, raise the jitter tolerance, or drop the time column and give the sample time",
                    100.0 * max / ts,
                    100.0 * tolerance,
                    if step > ts { "gap" } else { "glitch" }
                ),
            ));
        }
        Ok(Self {
            column,
            unit,
            unit_from,
            ts,
            max_jitter: max,
            rms_jitter: (sum_sq / (n - 1) as f64).sqrt(),
            tolerance,
        })
    }
}
