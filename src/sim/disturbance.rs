//! Disturbances added to a simulated plant: a sum of sines, a
//! spindle-synchronous periodic signal, or recorded samples, at the plant's
//! input (added to the command, volts) or its output (added to the
//! displacement the sensor reads and the tool makes, um).
//!
//! A spec is written as one string (`fts simulate --output-disturbance`):
//! `sines:A@F[@PHASE],A@F..` (amplitude, Hz, phase in degrees),
//! `spindle:A@F[,h2,h3,..]` (a periodic signal at the spindle frequency `F`
//! whose harmonics 2, 3, .. have the relative amplitudes `h2, h3, ..`,
//! scaled so its peak is `A`), or samples read from a file by the caller.

use super::Plant;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// One sine: `amplitude sin(2 pi freq_hz t + phase)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sine {
    /// Amplitude, in the signal's unit.
    pub amplitude: f64,
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Phase, degrees.
    #[serde(default)]
    pub phase_deg: f64,
}

/// A disturbance signal, sampled at the controller's rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Disturbance {
    /// A sum of sines.
    Sines {
        /// The components.
        components: Vec<Sine>,
    },
    /// A spindle-synchronous periodic signal: harmonics `h = 1, 2, ..` of
    /// `freq_hz` with relative amplitudes `harmonics[h - 1]` (the first is
    /// the fundamental's, 1 unless given) and phases `30 (h - 1)` degrees,
    /// scaled so that the peak over a period is `amplitude`.
    Spindle {
        /// Peak value, in the signal's unit.
        amplitude: f64,
        /// Spindle frequency, Hz.
        freq_hz: f64,
        /// Relative amplitudes of harmonics 1, 2, ..
        harmonics: Vec<f64>,
    },
    /// Recorded samples, 0 past their end: one per controller sample from
    /// the run's start, or at the times `time_s` (linearly interpolated at
    /// the controller's samples, the first time being the run's start).
    Samples {
        /// The values.
        values: Vec<f64>,
        /// Their times, s (increasing, one per value); `None`: one value
        /// per controller sample.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        time_s: Option<Vec<f64>>,
    },
}

/// Why a disturbance spec cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct DisturbanceError(pub String);

fn number(text: &str, what: &str) -> Result<f64, DisturbanceError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| DisturbanceError(format!("{what} {text:?} is not a finite number")))
}

impl Disturbance {
    /// Parses `sines:..` or `spindle:..` (the caller reads `file:PATH` into
    /// [`Disturbance::Samples`]).
    pub fn parse(spec: &str) -> Result<Self, DisturbanceError> {
        let (kind, rest) = spec.split_once(':').ok_or_else(|| {
            DisturbanceError(format!(
                "{spec:?}: expected sines:A@F[,A@F..], spindle:A@F[,h2,h3..] or file:PATH"
            ))
        })?;
        let d = match kind {
            "sines" => Self::Sines {
                components: rest
                    .split(',')
                    .map(|c| {
                        let parts: Vec<&str> = c.split('@').collect();
                        if !(2..=3).contains(&parts.len()) {
                            return Err(DisturbanceError(format!(
                                "sine {c:?}: expected AMPLITUDE@HZ or AMPLITUDE@HZ@PHASE_DEG"
                            )));
                        }
                        Ok(Sine {
                            amplitude: number(parts[0], "amplitude")?,
                            freq_hz: number(parts[1], "frequency")?,
                            phase_deg: parts.get(2).map_or(Ok(0.0), |p| number(p, "phase"))?,
                        })
                    })
                    .collect::<Result<_, _>>()?,
            },
            "spindle" => {
                let mut parts = rest.split(',');
                let head = parts.next().unwrap_or("");
                let (a, f) = head.split_once('@').ok_or_else(|| {
                    DisturbanceError(format!("spindle {head:?}: expected AMPLITUDE@HZ"))
                })?;
                let mut harmonics = vec![1.0];
                for h in parts {
                    harmonics.push(number(h, "harmonic amplitude")?);
                }
                Self::Spindle {
                    amplitude: number(a, "amplitude")?,
                    freq_hz: number(f, "frequency")?,
                    harmonics,
                }
            }
            _ => {
                return Err(DisturbanceError(format!(
                    "unknown disturbance kind {kind:?}; expected sines, spindle or file"
                )));
            }
        };
        d.validate()?;
        Ok(d)
    }

    /// Checks frequencies (positive), amplitudes and samples (finite).
    pub fn validate(&self) -> Result<(), DisturbanceError> {
        let bad = |m: &str| Err(DisturbanceError(m.to_owned()));
        match self {
            Self::Sines { components } => {
                if components.is_empty() {
                    return bad("a sum of sines needs at least one component");
                }
                for s in components {
                    let fine = s.freq_hz.is_finite()
                        && s.freq_hz >= 0.0
                        && s.amplitude.is_finite()
                        && s.phase_deg.is_finite();
                    if !fine {
                        return bad(
                            "sine components need finite amplitudes and phases and frequencies >= 0 Hz",
                        );
                    }
                }
            }
            Self::Spindle {
                amplitude,
                freq_hz,
                harmonics,
            } => {
                if !(freq_hz.is_finite() && *freq_hz > 0.0 && amplitude.is_finite()) {
                    return bad(
                        "a spindle disturbance needs a frequency > 0 Hz and a finite amplitude",
                    );
                }
                if harmonics.is_empty()
                    || harmonics.iter().any(|h| !h.is_finite())
                    || harmonics.iter().all(|h| *h == 0.0)
                {
                    return bad("spindle harmonics must be finite and not all zero");
                }
            }
            Self::Samples { values, time_s } => {
                if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                    return Err(DisturbanceError(format!(
                        "disturbance sample {} is not finite",
                        i + 1
                    )));
                }
                if let Some(t) = time_s {
                    check_times(t, values.len())?;
                }
            }
        }
        Ok(())
    }

    /// The samples `d(0), .., d(n - 1)` at sample time `ts`.
    pub fn samples(&self, n: usize, ts: f64) -> Vec<f64> {
        match self {
            Self::Sines { components } => (0..n)
                .map(|k| {
                    let t = k as f64 * ts;
                    components
                        .iter()
                        .map(|s| {
                            s.amplitude
                                * (2.0 * PI * s.freq_hz * t + s.phase_deg.to_radians()).sin()
                        })
                        .sum()
                })
                .collect(),
            Self::Spindle {
                amplitude,
                freq_hz,
                harmonics,
            } => {
                let shape = |t: f64| -> f64 {
                    harmonics
                        .iter()
                        .enumerate()
                        .map(|(i, c)| {
                            let h = (i + 1) as f64;
                            c * (2.0 * PI * h * freq_hz * t + (30.0 * i as f64).to_radians()).sin()
                        })
                        .sum()
                };
                // The peak over one period, on a grid fine for every harmonic.
                let grid = 64 * harmonics.len();
                let peak = (0..grid)
                    .map(|i| shape(i as f64 / (grid as f64 * freq_hz)).abs())
                    .fold(0.0, f64::max);
                let scale = if peak > 0.0 { amplitude / peak } else { 0.0 };
                (0..n).map(|k| scale * shape(k as f64 * ts)).collect()
            }
            Self::Samples {
                values,
                time_s: None,
            } => (0..n)
                .map(|k| values.get(k).copied().unwrap_or(0.0))
                .collect(),
            Self::Samples {
                values,
                time_s: Some(t),
            } => interpolate(t, values, n, ts),
        }
    }
}

/// `time_s` increasing, finite, one per value (at least two).
fn check_times(t: &[f64], values: usize) -> Result<(), DisturbanceError> {
    if t.len() != values {
        return Err(DisturbanceError(format!(
            "{} times for {values} disturbance samples: one time per sample",
            t.len()
        )));
    }
    if values < 2 {
        return Err(DisturbanceError(format!(
            "a timed disturbance needs at least two samples, found {values}"
        )));
    }
    if let Some(i) = (1..t.len()).find(|&i| !(t[i].is_finite() && t[i] > t[i - 1])) {
        return Err(DisturbanceError(format!(
            "disturbance time {} ({}) does not follow {} ({}): times must increase",
            i + 1,
            t[i],
            i,
            t[i - 1]
        )));
    }
    Ok(())
}

/// `d(k ts)` for `k < n`, `t` measured from `t[0]`: linear between the two
/// recorded samples around it, 0 past the last.
fn interpolate(t: &[f64], values: &[f64], n: usize, ts: f64) -> Vec<f64> {
    let mut j = 0;
    (0..n)
        .map(|k| {
            let tk = t[0] + k as f64 * ts;
            // The last time counts when it falls on the grid within rounding.
            let last = t[t.len() - 1];
            if tk > last + 1e-9 * ts {
                return 0.0;
            }
            while j + 2 < t.len() && t[j + 1] < tk {
                j += 1;
            }
            let w = ((tk - t[j]) / (t[j + 1] - t[j])).clamp(0.0, 1.0);
            values[j] + w * (values[j + 1] - values[j])
        })
        .collect()
}

/// A plant with disturbances: `input[k]` is added to the command applied
/// at sample `k`, `output[k]` to the displacement at sample `k` (the
/// sensor reads it, and it is the tool's true position). Past the end of a
/// sequence its disturbance is 0.
#[derive(Debug, Clone)]
pub struct Disturbed<P> {
    plant: P,
    input: Vec<f64>,
    output: Vec<f64>,
    k: usize,
}

impl<P: Plant> Disturbed<P> {
    /// Wraps `plant`.
    pub fn new(plant: P, input: Vec<f64>, output: Vec<f64>) -> Self {
        Self {
            plant,
            input,
            output,
            k: 0,
        }
    }

    /// The plant inside.
    pub fn inner(&self) -> &P {
        &self.plant
    }

    fn output_now(&self) -> f64 {
        self.output.get(self.k).copied().unwrap_or(0.0)
    }
}

impl<P: Plant> Plant for Disturbed<P> {
    fn ts(&self) -> f64 {
        self.plant.ts()
    }
    fn measure(&mut self) -> f64 {
        self.plant.measure() + self.output_now()
    }
    fn advance(&mut self, command: f64) {
        let d = self.input.get(self.k).copied().unwrap_or(0.0);
        self.plant.advance(command + d);
        self.k += 1;
    }
    fn true_output(&self) -> f64 {
        self.plant.true_output() + self.output_now()
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn specs_parse_and_sample_as_written() {
        let d = Disturbance::parse("sines:1@100,0.5@250@90").unwrap();
        let s = d.samples(41, 1e-4);
        // t = 1 ms: sin(0.2 pi) + 0.5 sin(0.5 pi + pi/2).
        let t: f64 = 10.0 * 1e-4;
        let want = (2.0 * PI * 100.0 * t).sin() + 0.5 * (2.0 * PI * 250.0 * t + PI / 2.0).sin();
        assert!((s[10] - want).abs() < 1e-15);
        let d = Disturbance::parse("spindle:1@100,0.5,0.25").unwrap();
        let s = d.samples(1000, 1e-4);
        let peak = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((peak - 1.0).abs() < 2e-3, "{peak}");
        // Periodic with 100 samples.
        for k in 0..900 {
            assert!((s[k] - s[k + 100]).abs() < 1e-12);
        }
        for bad in [
            "sines:",
            "sines:1@x",
            "spindle:1",
            "spindle:1@0",
            "chirp:1@2",
            "x",
        ] {
            assert!(Disturbance::parse(bad).is_err(), "{bad}");
        }
    }

    pub fn disturbed_plant_adds_at_input_and_output() {
        use crate::lti::DiscreteTf;
        let g = DiscreteTf::new(vec![1.0], vec![1.0], 1, 1e-4).unwrap();
        let inner = crate::sim::ModelPlant::new(&g, None, (-1e9, 1e9), 0.0, 1).unwrap();
        let mut p = Disturbed::new(inner, vec![1.0, 2.0], vec![0.5, 0.5, 0.5]);
        assert_eq!(p.measure(), 0.5);
        p.advance(10.0); // y(1) = 11
        assert_eq!(p.measure(), 11.5);
        p.advance(10.0); // y(2) = 12
        assert_eq!(p.true_output(), 12.5);
        p.advance(10.0); // past both ends
        assert_eq!(p.measure(), 10.0);
    }

    /// A recorded 8 Hz sine at 1 ms, played at 0.1 ms, stays 8 Hz: each
    /// sample is the linear interpolant of the record (a chord of the sine,
    /// within h^2/8 max|d''| of it), and the run is 0 past the last time.
    pub fn timed_samples_keep_their_frequency() {
        let w = 2.0 * PI * 8.0;
        let t: Vec<f64> = (0..=100).map(|k| 2.0 + k as f64 * 1e-3).collect();
        let values: Vec<f64> = t.iter().map(|t| (w * (t - 2.0)).sin()).collect();
        let d = Disturbance::Samples {
            values,
            time_s: Some(t),
        };
        d.validate().unwrap();
        let s = d.samples(1200, 1e-4);
        let chord = 1e-6 / 8.0 * w * w;
        for (k, v) in s.iter().enumerate().take(1001) {
            let exact = (w * k as f64 * 1e-4).sin();
            assert!(
                (v - exact).abs() <= chord * (1.0 + 1e-9),
                "{k}: {v} vs {exact}"
            );
        }
        assert!(s[1001..].iter().all(|v| *v == 0.0));
        for (time, why) in [
            (vec![0.0, 1e-3], "one time per sample"),
            (vec![0.0], "one time per sample"),
            (vec![0.0, 1e-3, 1e-3], "must increase"),
            (vec![0.0, f64::NAN, 2e-3], "must increase"),
        ] {
            let d = Disturbance::Samples {
                values: vec![1.0; 3],
                time_s: Some(time),
            };
            assert!(d.validate().unwrap_err().0.contains(why));
        }
        let one = Disturbance::Samples {
            values: vec![1.0],
            time_s: Some(vec![0.0]),
        };
        assert!(one.validate().unwrap_err().0.contains("at least two"));
    }
}
