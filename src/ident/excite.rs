//! Excitation signals for identification experiments (docs/math.md §1.5, §2):
//! triangle waves of several amplitudes for hysteresis \[Li21\], sine sweeps
//! 0-1000 Hz \[Li21\], Schroeder-phased multisines \[Karagoz18\], single sines,
//! and the five-leaved trajectory \[Li21\] Eq. 13.
//!
//! Every generator returns samples `u(k)` at `t = k * ts`, `k = 0..n`.

use std::f64::consts::PI;

/// Why a signal cannot be generated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct ExciteError {
    /// The parameter at fault (named as on the command line).
    pub field: &'static str,
    /// What was expected.
    pub message: String,
}

fn check(ok: bool, field: &'static str, message: impl Into<String>) -> Result<(), ExciteError> {
    if ok {
        Ok(())
    } else {
        Err(ExciteError {
            field,
            message: message.into(),
        })
    }
}

/// The shortest sample time accepted, s (a 1 GHz loop): below it every
/// signal would be too long to generate, and the sample time is the culprit.
pub const MIN_TS: f64 = 1e-9;

fn check_ts(ts: f64) -> Result<(), ExciteError> {
    check(
        ts.is_finite() && ts >= MIN_TS,
        "ts",
        format!("sample time must be a number of seconds of at least {MIN_TS:e}, got {ts:e}"),
    )
}

/// Samples needed to cover `duration` seconds (at least one).
/// The number of samples every generator here makes for `duration` s at
/// `ts`, with the same checks (so a caller can size a signal without
/// generating it).
pub fn sample_count(duration: f64, ts: f64) -> Result<usize, ExciteError> {
    check_ts(ts)?;
    samples(duration, ts)
}

/// The most samples one signal may have: 5e7, i.e. 5000 s at 10 kHz, 400 MB
/// per column. Checked before anything is allocated, so a mistyped duration
/// is an error naming its option, not an out-of-memory abort.
pub const MAX_SAMPLES: f64 = 5e7;

/// The most sine evaluations (lines times samples per period) one multisine
/// period may cost.
pub const MAX_MULTISINE_WORK: f64 = 1e9;

/// Refuses a signal of `n` samples beyond [`MAX_SAMPLES`], blaming `field`.
fn check_total(field: &'static str, n: f64) -> Result<(), ExciteError> {
    check(
        n <= MAX_SAMPLES,
        field,
        format!("the signal would have {n:.3e} samples, more than fts generates ({MAX_SAMPLES:e})"),
    )
}

fn samples(duration: f64, ts: f64) -> Result<usize, ExciteError> {
    check(
        duration.is_finite() && duration > 0.0,
        "duration",
        format!("must be a positive number of seconds, got {duration}"),
    )?;
    let n = (duration / ts).round();
    check_total("duration", n)?;
    Ok((n as usize).max(1))
}

/// Triangle waves of several amplitudes (\[Li21\] hysteresis identification):
/// each amplitude `A` runs `cycles` periods of `offset -> offset + A -> offset`
/// (unipolar, for a 0-10 V amplifier) or, with `bipolar`, `0 -> A -> -A -> 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleParams {
    /// Peak amplitudes, in the order they are played (e.g. 10, 8, 6, 4, 2).
    pub amplitudes: Vec<f64>,
    /// Frequency of each triangle, Hz. Default 1.
    pub freq_hz: f64,
    /// Periods per amplitude. Default 2 (the first settles the memory, the second repeats it).
    pub cycles: usize,
    /// Sample time, s. Default 1e-4 (the Li21 controller rate).
    pub ts: f64,
    /// Constant added to every sample. Default 0.
    pub offset: f64,
    /// Symmetric excursions instead of one-sided ones. Default false.
    pub bipolar: bool,
}

impl Default for TriangleParams {
    fn default() -> Self {
        Self {
            amplitudes: vec![10.0, 8.0, 6.0, 4.0, 2.0],
            freq_hz: 1.0,
            cycles: 2,
            ts: 1e-4,
            offset: 0.0,
            bipolar: false,
        }
    }
}

/// The triangle-wave excitation.
pub fn triangle(p: &TriangleParams) -> Result<Vec<f64>, ExciteError> {
    check_ts(p.ts)?;
    check(
        !p.amplitudes.is_empty(),
        "amplitudes",
        "give at least one amplitude",
    )?;
    check(
        p.amplitudes.iter().all(|a| a.is_finite() && *a > 0.0),
        "amplitudes",
        "every amplitude must be a positive number",
    )?;
    check(
        p.freq_hz.is_finite() && p.freq_hz > 0.0,
        "freq",
        format!("must be a positive frequency in Hz, got {}", p.freq_hz),
    )?;
    check(p.cycles >= 1, "cycles", "at least one period per amplitude")?;
    check(
        p.offset.is_finite(),
        "offset",
        format!("must be finite, got {}", p.offset),
    )?;
    let per_period = samples(1.0 / p.freq_hz, p.ts)?;
    check(
        per_period >= 4,
        "freq",
        "a period must span at least 4 samples",
    )?;
    check_total(
        "cycles",
        per_period as f64 * p.cycles as f64 * p.amplitudes.len() as f64,
    )?;
    let mut out = Vec::with_capacity(per_period * p.cycles * p.amplitudes.len() + 1);
    for &a in &p.amplitudes {
        for _ in 0..p.cycles {
            for k in 0..per_period {
                let phase = k as f64 / per_period as f64; // 0..1
                let shape = if p.bipolar {
                    // 0 -> 1 -> -1 -> 0
                    if phase < 0.25 {
                        4.0 * phase
                    } else if phase < 0.75 {
                        2.0 - 4.0 * phase
                    } else {
                        4.0 * phase - 4.0
                    }
                } else if phase < 0.5 {
                    2.0 * phase
                } else {
                    2.0 - 2.0 * phase
                };
                out.push(p.offset + a * shape);
            }
        }
    }
    out.push(p.offset);
    Ok(out)
}

/// A single sine `offset + amplitude sin(2 pi f t + phase)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SineParams {
    /// Peak amplitude.
    pub amplitude: f64,
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Phase at `t = 0`, rad.
    pub phase: f64,
    /// Constant added.
    pub offset: f64,
    /// Length, s.
    pub duration: f64,
    /// Sample time, s.
    pub ts: f64,
}

/// The sine.
pub fn sine(p: &SineParams) -> Result<Vec<f64>, ExciteError> {
    check_ts(p.ts)?;
    check(
        p.amplitude.is_finite(),
        "amplitude",
        format!("must be finite, got {}", p.amplitude),
    )?;
    let nyquist = 0.5 / p.ts;
    check(
        p.freq_hz.is_finite() && p.freq_hz >= 0.0 && p.freq_hz <= nyquist,
        "freq",
        format!(
            "must lie in [0, {nyquist}] Hz (Nyquist at this sample time), got {}",
            p.freq_hz
        ),
    )?;
    check(
        p.offset.is_finite() && p.phase.is_finite(),
        "offset",
        "offset and phase must be finite",
    )?;
    let n = samples(p.duration, p.ts)?;
    Ok((0..n)
        .map(|k| p.offset + p.amplitude * (2.0 * PI * p.freq_hz * k as f64 * p.ts + p.phase).sin())
        .collect())
}

/// How the instantaneous frequency of a sweep moves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SweepSpacing {
    /// `f(t) = f0 + (f1 - f0) t / T`.
    #[default]
    Linear,
    /// `f(t) = f0 (f1/f0)^(t/T)`; needs `f0 > 0`.
    #[serde(rename = "log")]
    Logarithmic,
}

impl crate::workflow::Choices for SweepSpacing {
    // Listed without help, as the names say it.
    const CHOICES: &'static [(&'static str, &'static str)] = &[("linear", ""), ("log", "")];
}

/// A sine sweep (chirp) from `f0` to `f1` Hz over `duration` s (\[Li21\]: 0-1000 Hz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepParams {
    /// Start frequency, Hz.
    pub f0: f64,
    /// End frequency, Hz (below Nyquist).
    pub f1: f64,
    /// Length, s.
    pub duration: f64,
    /// Peak amplitude.
    pub amplitude: f64,
    /// Constant added.
    pub offset: f64,
    /// Sample time, s.
    pub ts: f64,
    /// Frequency law.
    pub spacing: SweepSpacing,
}

/// The sweep; the phase is the exact integral of the instantaneous frequency.
pub fn sweep(p: &SweepParams) -> Result<Vec<f64>, ExciteError> {
    check_ts(p.ts)?;
    let nyquist = 0.5 / p.ts;
    check(
        p.f0.is_finite() && p.f0 >= 0.0 && p.f0 <= nyquist,
        "f0",
        format!(
            "must lie in [0, {nyquist}] Hz (Nyquist at this sample time), got {}",
            p.f0
        ),
    )?;
    check(
        p.f1.is_finite() && p.f1 > 0.0 && p.f1 <= nyquist,
        "f1",
        format!(
            "must lie in (0, {nyquist}] Hz (Nyquist at this sample time), got {}",
            p.f1
        ),
    )?;
    check(
        p.amplitude.is_finite() && p.offset.is_finite(),
        "amplitude",
        "amplitude and offset must be finite",
    )?;
    let n = samples(p.duration, p.ts)?;
    let t_end = p.duration;
    let phase = |t: f64| match p.spacing {
        SweepSpacing::Linear => 2.0 * PI * (p.f0 * t + 0.5 * (p.f1 - p.f0) * t * t / t_end),
        SweepSpacing::Logarithmic => {
            let k = (p.f1 / p.f0).ln() / t_end;
            2.0 * PI * p.f0 * ((k * t).exp() - 1.0) / k
        }
    };
    if p.spacing == SweepSpacing::Logarithmic {
        check(
            p.f0 > 0.0 && p.f1 != p.f0,
            "f0",
            "a logarithmic sweep needs 0 < f0 != f1",
        )?;
    }
    Ok((0..n)
        .map(|k| p.offset + p.amplitude * phase(k as f64 * p.ts).sin())
        .collect())
}

/// A periodic multisine with Schroeder phases (\[Karagoz18\]; Schroeder 1970):
/// `sum_k a sin(2 pi f_k t + phi_k)`, `phi_k = -pi k (k - 1) / K`, scaled so
/// the peak of the whole record equals `amplitude`. Frequencies are rounded to
/// multiples of `1 / period` so that every period is identical (no leakage in
/// a DFT over whole periods).
#[derive(Debug, Clone, PartialEq)]
pub struct MultisineParams {
    /// Frequencies, Hz (each rounded to the period's grid; duplicates removed).
    pub freqs_hz: Vec<f64>,
    /// Period, s.
    pub period: f64,
    /// Number of periods.
    pub periods: usize,
    /// Peak of the record.
    pub amplitude: f64,
    /// Constant added.
    pub offset: f64,
    /// Sample time, s.
    pub ts: f64,
}

/// The multisine, with the frequencies actually used (after rounding to the grid).
pub fn multisine(p: &MultisineParams) -> Result<(Vec<f64>, Vec<f64>), ExciteError> {
    check_ts(p.ts)?;
    check(
        p.period.is_finite() && p.period > 0.0,
        "period",
        "must be a positive number of seconds",
    )?;
    check(p.periods >= 1, "periods", "at least one period")?;
    check(
        p.amplitude.is_finite() && p.amplitude > 0.0,
        "amplitude",
        "must be positive",
    )?;
    check(
        p.offset.is_finite(),
        "offset",
        format!("must be finite, got {}", p.offset),
    )?;
    let nyquist = 0.5 / p.ts;
    let df = 1.0 / p.period;
    let mut lines: Vec<u64> = Vec::new();
    for &f in &p.freqs_hz {
        check(
            f.is_finite() && f > 0.0 && f < nyquist,
            "freqs",
            format!("every frequency must lie in (0, {nyquist}) Hz, got {f}"),
        )?;
        let line = (f / df).round().max(1.0) as u64;
        if !lines.contains(&line) {
            lines.push(line);
        }
    }
    check(!lines.is_empty(), "freqs", "give at least one frequency")?;
    lines.sort_unstable();
    let per_period = samples(p.period, p.ts)?;
    check_total("periods", per_period as f64 * p.periods as f64)?;
    // One sine per line and sample of a period: bounded like a signal's length.
    check(
        per_period as f64 * lines.len() as f64 <= MAX_MULTISINE_WORK,
        "freqs",
        format!(
            "{} lines over {per_period} samples per period is beyond {MAX_MULTISINE_WORK:e} sine evaluations; use fewer lines or a shorter period",
            lines.len()
        ),
    )?;
    let big_k = lines.len() as f64;
    let one_period: Vec<f64> = (0..per_period)
        .map(|n| {
            let t = n as f64 * p.ts;
            lines
                .iter()
                .enumerate()
                .map(|(i, &line)| {
                    let k = (i + 1) as f64;
                    let phi = -PI * k * (k - 1.0) / big_k;
                    (2.0 * PI * line as f64 * df * t + phi).sin()
                })
                .sum()
        })
        .collect();
    let peak = one_period.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let scale = if peak > 0.0 { p.amplitude / peak } else { 0.0 };
    let mut out = Vec::with_capacity(per_period * p.periods);
    for _ in 0..p.periods {
        out.extend(one_period.iter().map(|v| p.offset + scale * v));
    }
    Ok((out, lines.iter().map(|&l| l as f64 * df).collect()))
}

/// The "five-leaved" trajectory of \[Li21\] Eq. 13, `z(t) = (50 - 10 t) sin(200 pi t)`
/// (um), times `scale`, plus `offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FiveLeafParams {
    /// Length, s. Default 1.
    pub duration: f64,
    /// Factor on the published trajectory. Default 1.
    pub scale: f64,
    /// Constant added. Default 0.
    pub offset: f64,
    /// Sample time, s. Default 1e-4.
    pub ts: f64,
}

impl Default for FiveLeafParams {
    fn default() -> Self {
        Self {
            duration: 1.0,
            scale: 1.0,
            offset: 0.0,
            ts: 1e-4,
        }
    }
}

/// The five-leaved trajectory.
pub fn five_leaf(p: &FiveLeafParams) -> Result<Vec<f64>, ExciteError> {
    check_ts(p.ts)?;
    check(
        p.scale.is_finite() && p.offset.is_finite(),
        "scale",
        "scale and offset must be finite",
    )?;
    let n = samples(p.duration, p.ts)?;
    Ok((0..n)
        .map(|k| p.offset + p.scale * five_leaf_at(k as f64 * p.ts))
        .collect())
}

/// \[Li21\] Eq. 13 at time `t` (s), unscaled: `(50 - 10 t) sin(200 pi t)`,
/// um. Defined for negative `t` too (a lead-in that enters the pattern in
/// motion evaluates it before its start).
pub fn five_leaf_at(t: f64) -> f64 {
    (50.0 - 10.0 * t) * (200.0 * PI * t).sin()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn triangle_shape() {
        let u = triangle(&TriangleParams {
            amplitudes: vec![2.0, 1.0],
            freq_hz: 1.0,
            cycles: 1,
            ts: 0.25,
            offset: 0.0,
            bipolar: false,
        })
        .unwrap();
        assert_eq!(u, vec![0.0, 1.0, 2.0, 1.0, 0.0, 0.5, 1.0, 0.5, 0.0]);
        let b = triangle(&TriangleParams {
            amplitudes: vec![1.0],
            cycles: 1,
            ts: 0.125,
            bipolar: true,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(b, vec![0.0, 0.5, 1.0, 0.5, 0.0, -0.5, -1.0, -0.5, 0.0]);
    }

    pub fn frequencies_beyond_nyquist_and_costly_multisines_are_refused() {
        let sine_at = |freq_hz| {
            sine(&SineParams {
                amplitude: 1.0,
                freq_hz,
                phase: 0.0,
                offset: 0.0,
                duration: 0.01,
                ts: 1e-4,
            })
        };
        assert!(sine_at(5000.0).is_ok());
        let e = sine_at(6000.0).unwrap_err();
        assert_eq!(e.field, "freq");
        assert!(e.message.contains("got 6000"), "{}", e.message);
        let e = sweep(&SweepParams {
            f0: 6000.0,
            f1: 1000.0,
            duration: 0.01,
            amplitude: 1.0,
            offset: 0.0,
            ts: 1e-4,
            spacing: SweepSpacing::Linear,
        })
        .unwrap_err();
        assert_eq!(e.field, "f0");
        // 5000 lines over 1e6 samples per period: 5e9 sine evaluations.
        let e = multisine(&MultisineParams {
            freqs_hz: (1..=5000).map(|k| 0.5 * k as f64).collect(),
            period: 100.0,
            periods: 1,
            amplitude: 1.0,
            offset: 0.0,
            ts: 1e-4,
        })
        .unwrap_err();
        assert_eq!(e.field, "freqs");
        assert!(e.message.contains("sine evaluations"), "{}", e.message);
    }

    pub fn linear_sweep_instantaneous_frequency() {
        // Phase increments equal 2 pi f(t) ts to first order: check near the end.
        let p = SweepParams {
            f0: 0.0,
            f1: 1000.0,
            duration: 1.0,
            amplitude: 1.0,
            offset: 0.0,
            ts: 1e-4,
            spacing: SweepSpacing::Linear,
        };
        let u = sweep(&p).unwrap();
        assert_eq!(u.len(), 10_000);
        assert_eq!(u[0], 0.0);
        // Zero crossings in the last 10 ms: f ~ 995 Hz -> about 2 * 9.95 crossings.
        let crossings = u[9900..]
            .windows(2)
            .filter(|w| w[0].signum() != w[1].signum())
            .count();
        assert!((19..=21).contains(&crossings), "{crossings}");
    }

    pub fn multisine_schroeder_peak_and_grid() {
        let (u, f) = multisine(&MultisineParams {
            freqs_hz: vec![10.0, 20.0, 30.4, 30.0, 1000.0],
            period: 0.1,
            periods: 2,
            amplitude: 1.0,
            offset: 0.0,
            ts: 1e-4,
        })
        .unwrap();
        assert_eq!(f, vec![10.0, 20.0, 30.0, 1000.0]);
        let peak = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((peak - 1.0).abs() < 1e-12);
        assert_eq!(&u[..1000], &u[1000..]);
    }

    pub fn five_leaf_matches_eq13() {
        let u = five_leaf(&FiveLeafParams::default()).unwrap();
        let t = 0.0025; // quarter period of 100 Hz: sin = 1
        assert!((u[25] - (50.0 - 10.0 * t)).abs() < 1e-9);
    }

    pub fn bad_parameters_name_the_field() {
        let e = sweep(&SweepParams {
            f0: 0.0,
            f1: 6000.0,
            duration: 1.0,
            amplitude: 1.0,
            offset: 0.0,
            ts: 1e-4,
            spacing: SweepSpacing::Linear,
        })
        .unwrap_err();
        assert_eq!(e.field, "f1");
        let e = triangle(&TriangleParams {
            amplitudes: vec![-1.0],
            ..Default::default()
        })
        .unwrap_err();
        assert_eq!(e.field, "amplitudes");
    }
}
