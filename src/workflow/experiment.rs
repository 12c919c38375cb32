//! Records of the embedded virtual FTS, the first and third steps of the
//! \[Li21\] experiment: open-loop triangles ([`VirtualTriangles`]) and the
//! closed-loop sweep ([`VirtualSweep`]). What `fts virtual triangles|sweep`
//! and the manifest's `virtual-triangles` and `virtual-sweep` kinds write;
//! `fts demo` records the same through [`crate::sim::experiment`].

use super::{StepError, Validate, positive, whole_number};
use crate::ident::hysteresis::HysteresisModel;
use crate::io::timeseries::{time_column, write_csv};
use crate::runtime::PidSpec;
use crate::sim::experiment::{
    DEFAULT_PID, ExperimentError, ExperimentParams, align_triangle_record, sweep_record,
    triangle_record_at,
};
use crate::sim::virtual_fts::RateDependence;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Open-loop triangle waves on the virtual FTS: the command (V) and the
/// measured displacement (um), aligned for the plant's delay so that a
/// quasi-static model sees matching pairs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VirtualTriangles {
    /// Noise seed of the virtual FTS; default 1.
    #[serde(deserialize_with = "seed")]
    pub seed: u64,
    /// Peak amplitudes of the command, V, played in order; default 10, 8,
    /// 6, 4, 2.
    pub amplitudes: Vec<f64>,
    /// Triangle frequencies, Hz, played in order (all amplitudes at each);
    /// one number or a list; default 2.
    #[serde(deserialize_with = "one_or_many")]
    pub freq: Vec<f64>,
    /// Rate dependence of the plant's loop, `alpha (1 + c |v'| / v'_ref)`
    /// (docs/virtual-fts.md): `c`, >= 0; default 0 (rate independent).
    pub rate_coefficient: f64,
    /// `v'_ref` of the rate dependence, V/s (amplifier output); default 1e5.
    pub rate_reference: f64,
}

/// A number or a list of numbers.
fn one_or_many<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum OneOrMany {
        One(f64),
        Many(Vec<f64>),
    }
    Ok(match OneOrMany::deserialize(d)? {
        OneOrMany::One(x) => vec![x],
        OneOrMany::Many(v) => v,
    })
}

impl Default for VirtualTriangles {
    fn default() -> Self {
        let p = ExperimentParams::default();
        Self {
            seed: p.seed,
            amplitudes: p.triangle_amplitudes_v,
            freq: vec![p.triangle_freq_hz],
            rate_coefficient: 0.0,
            rate_reference: 1e5,
        }
    }
}

impl VirtualTriangles {
    /// The experiment's settings with these changed.
    pub fn params(&self) -> ExperimentParams {
        let mut p = ExperimentParams {
            seed: self.seed,
            triangle_amplitudes_v: self.amplitudes.clone(),
            triangle_freq_hz: self.freq.first().copied().unwrap_or(f64::NAN),
            ..ExperimentParams::default()
        };
        if self.rate_coefficient > 0.0 {
            p.plant.piezo.rate_dependence = Some(RateDependence {
                coefficient: self.rate_coefficient,
                reference_rate_v_per_s: self.rate_reference,
            });
        }
        p
    }

    /// Records the triangles.
    pub fn run(&self) -> Result<VirtualRecord, StepError> {
        self.validate()?;
        let p = self.params();
        let (command, measured) =
            triangle_record_at(&p, &self.freq).map_err(|e| StepError::input(e.to_string()))?;
        let (u, y) = align_triangle_record(&p, &command, &measured);
        Ok(VirtualRecord::new(p.plant.ts, u.to_vec(), y.to_vec()))
    }
}

impl Validate for VirtualTriangles {
    fn validate(&self) -> Result<(), StepError> {
        if let Some((i, a)) = self
            .amplitudes
            .iter()
            .enumerate()
            .find(|(_, a)| !(a.is_finite() && **a > 0.0))
        {
            return Err(StepError::setting(
                "amplitudes",
                format!(
                    "item {i}: expected a positive number of volts, got {}",
                    super::fmt_value(*a)
                ),
            ));
        }
        if self.freq.is_empty() {
            return Err(StepError::setting("freq", "give at least one frequency"));
        }
        for (i, &f) in self.freq.iter().enumerate() {
            if !(f.is_finite() && f > 0.0) {
                return Err(StepError::setting(
                    "freq",
                    format!(
                        "item {i}: expected a positive number of Hz, got {}",
                        super::fmt_value(f)
                    ),
                ));
            }
        }
        if !(self.rate_coefficient.is_finite() && self.rate_coefficient >= 0.0) {
            return Err(StepError::setting(
                "rate_coefficient",
                format!(
                    "expected a finite number >= 0, got {}",
                    super::fmt_value(self.rate_coefficient)
                ),
            ));
        }
        positive("rate_reference", self.rate_reference).map(|_| ())
    }
}

/// The closed-loop sweep on the virtual FTS: the \[Li21\] PID (+ HC when an
/// inverse hysteresis model is given) driven by a 0..`f1` sweep; the
/// filtered reference and the measurement (um) after the lead-in.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VirtualSweep {
    /// Noise seed of the virtual FTS; default 1.
    #[serde(deserialize_with = "seed")]
    pub seed: u64,
    /// PID proportional gain, V/um; default [`DEFAULT_PID`]'s 0.02.
    pub kp: f64,
    /// PID integral gain, V/um per sample; default 0.15.
    pub ki: f64,
    /// PID derivative gain, V/um per sample; default 0.
    pub kd: f64,
    /// Lowest command, V; default 0.
    pub output_min: f64,
    /// Highest command, V; default 10.
    pub output_max: f64,
    /// Sweep amplitude, um; default 2.
    pub amplitude: f64,
    /// Centre of the sweep, um; default 7 (mid-stroke).
    pub offset: f64,
    /// Sweep length, s; default 2.
    pub duration: f64,
    /// Highest sweep frequency, Hz; default 1000.
    pub f1: f64,
}

impl Default for VirtualSweep {
    fn default() -> Self {
        let p = ExperimentParams::default();
        Self {
            seed: p.seed,
            kp: DEFAULT_PID.kp,
            ki: DEFAULT_PID.ki,
            kd: DEFAULT_PID.kd,
            output_min: DEFAULT_PID.output_min,
            output_max: DEFAULT_PID.output_max,
            amplitude: p.sweep_amplitude,
            offset: p.offset,
            duration: p.sweep_duration,
            f1: p.sweep_f1,
        }
    }
}

impl VirtualSweep {
    /// The experiment's settings with these changed.
    pub fn params(&self) -> ExperimentParams {
        ExperimentParams {
            seed: self.seed,
            pid: PidSpec {
                kp: self.kp,
                ki: self.ki,
                kd: self.kd,
                output_min: self.output_min,
                output_max: self.output_max,
            },
            sweep_amplitude: self.amplitude,
            offset: self.offset,
            sweep_duration: self.duration,
            sweep_f1: self.f1,
            ..ExperimentParams::default()
        }
    }

    /// Records the sweep, with the inverse hysteresis feedforward when
    /// `hysteresis` is given.
    pub fn run(&self, hysteresis: Option<&HysteresisModel>) -> Result<VirtualRecord, StepError> {
        self.validate()?;
        let p = self.params();
        let (r, y) = sweep_record(&p, hysteresis).map_err(|e| match e {
            ExperimentError::NotTracking(m) => StepError::computation(m),
            other => StepError::input(other.to_string()),
        })?;
        Ok(VirtualRecord::new(p.plant.ts, r, y))
    }
}

impl Validate for VirtualSweep {
    fn validate(&self) -> Result<(), StepError> {
        for (key, value) in [
            ("kp", self.kp),
            ("ki", self.ki),
            ("kd", self.kd),
            ("output_min", self.output_min),
            ("output_max", self.output_max),
            ("offset", self.offset),
        ] {
            if !value.is_finite() {
                return Err(StepError::setting(
                    key,
                    format!("expected a finite number, got {value}"),
                ));
            }
        }
        super::check_limit_order(Some(self.output_min), Some(self.output_max))?;
        positive("amplitude", self.amplitude)?;
        positive("duration", self.duration)?;
        positive("f1", self.f1).map(|_| ())
    }
}

/// A record of the virtual FTS: input `u` and output `y` at sample time `ts`.
#[derive(Debug, Clone, PartialEq)]
pub struct VirtualRecord {
    /// Sample time, s.
    pub ts: f64,
    /// The input column (command V, or filtered reference um).
    pub u: Vec<f64>,
    /// The output column (displacement or measurement, um).
    pub y: Vec<f64>,
}

impl VirtualRecord {
    fn new(ts: f64, u: Vec<f64>, y: Vec<f64>) -> Self {
        Self { ts, u, y }
    }

    /// The `t,u,y` CSV (time in seconds from 0).
    pub fn to_csv(&self) -> String {
        let t = time_column(self.u.len(), self.ts);
        write_csv(&["t", "u", "y"], &[&t, &self.u, &self.y])
    }
}

impl Serialize for VirtualRecord {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        serde_json::json!({"samples": self.u.len(), "ts": self.ts}).serialize(s)
    }
}

impl fmt::Display for VirtualRecord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} samples, ts = {} s", self.u.len(), self.ts)
    }
}

/// A noise seed: a non-negative whole number.
fn seed<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u64, D::Error> {
    whole_number(d).map(|n| n as u64)
}
