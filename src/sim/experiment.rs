//! The \[Li21\] experiment on the virtual FTS, end to end, identified only from
//! simulated measurements (virtual-fts.md rules):
//!
//! 1. open-loop triangle waves of several amplitudes; the inverse MPI-cbrt
//!    model is identified directly (displacement in, command out, \[Li21\]);
//! 2. PID + HC closed loop swept 0-1000 Hz; ARX fitted to (r_f, y), refined
//!    by output error when that improves the simulation fit;
//! 3. ZPETC of the closed-loop model;
//! 4. tracking runs (sines at 10/100/500 Hz, the sweep, the five-leaved
//!    trajectory) with PID, PID+HC and PID+HC+ZPEC, every controller run
//!    through the runtime step loaded from its emitted coefficient file.

use super::closed_loop::{self, TrackingMetrics};
use super::reference::{self, Reference, ReferenceTiming};
use super::virtual_fts::{VirtualFts, VirtualFtsError, VirtualFtsParams};
use crate::ident::arx::{ArxParams, Orders, arx};
use crate::ident::data::{Detrend, detrend};
use crate::ident::excite;
use crate::ident::hysteresis::{Identified, IdentifyParams, identify};
use crate::ident::linear::{Fits, NoiseModel, fits};
use crate::ident::oe::{OeParams, refine_arx};
use crate::io::controller_file::{
    ControllerFile, Feedback, HysteresisBlock, Provenance, Units, ZpetcBlock, parse_controller,
};
use crate::lti::DiscreteTf;
use crate::runtime::{PidSpec, RuntimeController};
use crate::synth::composite::{FeedbackKind, Stages};
use crate::synth::ilc::{self, IlcDesign, IlcParams};
use crate::synth::zpetc::{self, StableInversion, Zpetc, ZpetcParams};

/// The PID of the \[Li21\] loop on the embedded plant: `kp 0.02` V/um, `ki 0.15`
/// V/um per sample, `kd 0`, command 0-10 V. \[Li21\] does not print its gains;
/// these minimise the PID + HC + ZPEC sweep error over `kp` 0-0.05 and `ki`
/// 0.1-0.3 (docs/li21-experiment.md): higher gains reject the residual
/// hysteresis better at low frequency but raise the loop's sensitivity peak
/// at 1-2 kHz, where its harmonics fall.
pub const DEFAULT_PID: PidSpec = PidSpec {
    kp: 0.02,
    ki: 0.15,
    kd: 0.0,
    output_min: 0.0,
    output_max: 10.0,
};

/// Settings of the experiment. Defaults reproduce \[Li21\] on the embedded plant.
#[derive(Debug, Clone)]
pub struct ExperimentParams {
    /// The plant.
    pub plant: VirtualFtsParams,
    /// Noise seed (each run derives its own from it).
    pub seed: u64,
    /// Feedback PID (\[Li21\] Eq. 5). Default [`DEFAULT_PID`].
    pub pid: PidSpec,
    /// Open-loop triangle amplitudes, V. Default 10, 8, 6, 4, 2.
    pub triangle_amplitudes_v: Vec<f64>,
    /// Triangle frequency, Hz. Default 2 (slow against the 2.5 kHz mode, so
    /// the record is quasi-static as rate-independent models assume).
    pub triangle_freq_hz: f64,
    /// Inverse hysteresis identification. Default MPI-cbrt, 10 lower plays.
    pub hysteresis: IdentifyParams,
    /// Amplitude of the identification sweep, um. Default 2: small enough
    /// that the loop stays linear (no command saturation) over 0-1 kHz, where
    /// the loop's sensitivity peak amplifies the HC feedforward.
    pub sweep_amplitude: f64,
    /// Centre of every reference, um (mid-stroke of the embedded plant).
    pub offset: f64,
    /// Sweep length, s.
    pub sweep_duration: f64,
    /// Highest sweep frequency, Hz. Default 1000.
    pub sweep_f1: f64,
    /// ARX orders of the closed-loop model. Default `[5 5 1]`.
    pub orders: Orders,
    /// Try an output-error refinement and keep it when its simulation fit is
    /// better. Default true.
    pub refine_oe: bool,
    /// Near pole-zero cancellations removed from the closed-loop model before
    /// the ZPETC ([`DiscreteTf::minreal`] tolerance). Default `Some(0.02)`:
    /// a pair goes when it changes the model's response by at most 2 % at any
    /// frequency. The PID + HC sweep models carry such a pair near 700 Hz
    /// (pole and zero within 1e-3 of each other, |z| = 0.95-0.97), which
    /// ZPETC would otherwise refuse to cancel (|z| >= rho) and so distort.
    pub minreal_tol: Option<f64>,
    /// ZPETC settings. Default: classical classification (rho 0.95, damping
    /// 0.1) with zeros outside radius 1.25 inverted by the anticausal series.
    pub zpetc: ZpetcParams,
    /// Sine frequencies of the tracking table, Hz. Default 10, 100, 500.
    pub sine_freqs_hz: Vec<f64>,
    /// Sine amplitude, um. Default 5 (\[Li21\]).
    pub sine_amplitude: f64,
    /// Scale of the five-leaved trajectory. Default 0.1: \[Li21\] Eq. 13 as
    /// printed spans +-50 um, beyond a 10 um stroke; a tenth of it is the
    /// 5 um, 100 Hz pattern the paper's 0.3 um result fits.
    pub five_leaf_scale: f64,
    /// Step 5, iterative learning control; `None` leaves it out. Default
    /// [`LearningParams::default`].
    pub learning: Option<LearningParams>,
}

impl Default for ExperimentParams {
    fn default() -> Self {
        Self {
            plant: VirtualFtsParams::default_plant(),
            seed: 1,
            pid: DEFAULT_PID,
            triangle_amplitudes_v: vec![10.0, 8.0, 6.0, 4.0, 2.0],
            triangle_freq_hz: 2.0,
            hysteresis: IdentifyParams::default(),
            sweep_amplitude: 2.0,
            offset: 7.0,
            sweep_duration: 2.0,
            sweep_f1: 1000.0,
            orders: Orders::new(5, 5, 1),
            refine_oe: true,
            minreal_tol: Some(0.02),
            zpetc: ZpetcParams {
                rho: 0.999,
                stable_inversion: Some(StableInversion::default()),
                ..ZpetcParams::default()
            },
            sine_freqs_hz: vec![10.0, 100.0, 500.0],
            sine_amplitude: 5.0,
            five_leaf_scale: 0.1,
            learning: Some(LearningParams::default()),
        }
    }
}

/// Why the experiment stopped.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// Bad plant parameters.
    #[error("plant: {0}")]
    Plant(#[from] VirtualFtsError),
    /// A closed-loop run diverged.
    #[error(transparent)]
    Diverged(#[from] closed_loop::Divergence),
    /// A closed loop sat on its command limits for much of the run (a
    /// limit cycle, or a reference out of the actuator's reach): its record
    /// is no identification data.
    #[error("{0}")]
    NotTracking(String),
    /// A step failed; the message says which and why.
    #[error("{step}: {message}")]
    Step {
        /// The pipeline step.
        step: &'static str,
        /// What went wrong.
        message: String,
    },
}

fn step_err(step: &'static str) -> impl Fn(String) -> ExperimentError {
    move |message| ExperimentError::Step { step, message }
}

/// Which linear model the ZPETC was built from, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoopModel {
    /// The model used for the ZPETC.
    pub tf: DiscreteTf,
    /// `arx` or `oe`.
    pub method: &'static str,
    /// Simulation fit of the ARX model, % (NRMSE).
    pub arx_fit: Fits,
    /// Simulation fit of the OE refinement, if tried.
    pub oe_fit: Option<Fits>,
    /// The ARX model, kept for reports.
    pub arx_tf: DiscreteTf,
    /// Condition number of the ARX regression.
    pub condition_number: f64,
    /// The identified model before near pole-zero cancellations were removed.
    pub identified_tf: DiscreteTf,
    /// The `(zero, pole)` pairs removed (upper half plane for complex pairs).
    pub removed_pairs: Vec<(crate::lti::c64, crate::lti::c64)>,
    /// Which model was chosen and why, in words.
    pub reason: String,
}

impl ClosedLoopModel {
    /// The simulation fit of the model chosen (OE when `method` is `oe`).
    pub fn chosen_fit(&self) -> &Fits {
        match (&self.oe_fit, self.method) {
            (Some(oe), "oe") => oe,
            _ => &self.arx_fit,
        }
    }
}

/// One line of the tracking table.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackingRow {
    /// Reference description.
    pub reference: String,
    /// Controller stages.
    pub controller: &'static str,
    /// The figures.
    pub metrics: TrackingMetrics,
}

/// The models fts identified from the virtual FTS.
#[derive(Debug, Clone)]
pub struct IdentifiedModels {
    /// Open-loop triangle record: command (V) and measured displacement (um).
    pub triangle: (Vec<f64>, Vec<f64>),
    /// The identified inverse hysteresis model.
    pub inverse: Identified,
    /// Sweep record: reference fed to the loop (um) and measurement (um).
    pub sweep: (Vec<f64>, Vec<f64>),
    /// The closed-loop model.
    pub closed_loop: ClosedLoopModel,
    /// The ZPETC.
    pub zpetc: Zpetc,
    /// \[Li21\] Eq. 8's filter on the same model: Tomizuka's ZPETC, whose
    /// zeros that it may not cancel (outside the unit circle, or poorly
    /// damped) get phase cancellation only, where [`Self::zpetc`] inverts
    /// those outside the unit circle exactly. Tracked beside it for the
    /// comparison with the paper; not used by the controller files.
    pub zpetc_eq8: Zpetc,
    /// The learning model, when step 5 is asked for.
    pub learning: Option<LearningModel>,
}

/// Step 5 of the experiment: iterative learning control ([`crate::synth::ilc`])
/// on every reference of the tracking table, on top of PID + HC + ZPEC.
#[derive(Debug, Clone, PartialEq)]
pub struct LearningParams {
    /// Amplitude of the wide-band sweep the learning model is fitted to,
    /// um. Default 1: the loop stays linear up to `sweep_f1`.
    pub sweep_amplitude: f64,
    /// Highest frequency of that sweep, Hz. Default 4500: the learning
    /// filter `L` inverts the loop up to Q's cutoff, where the 0-1 kHz
    /// model of step 2 is wrong (it has a pole at z = -0.999999).
    pub sweep_f1: f64,
    /// Orders of the learning model (ARX refined by OE). Default `[6 6 1]`.
    pub orders: Orders,
    /// The learning law. Default gain 0.7, Q cutoff 4 kHz with 32 taps:
    /// the 2nd and 3rd harmonics of the residual hysteresis (to 3 kHz) are
    /// learned, the model error near Nyquist is not.
    pub ilc: IlcParams,
    /// Trials after the first. Default 10.
    pub trials: usize,
    /// A trial whose max error exceeds the best earlier trial's by this
    /// factor stops the experiment (measured divergence). Default 2.
    pub divergence_factor: f64,
}

impl Default for LearningParams {
    fn default() -> Self {
        Self {
            sweep_amplitude: 1.0,
            sweep_f1: 4500.0,
            orders: Orders::new(6, 6, 1),
            ilc: IlcParams {
                gain: 0.7,
                q_cutoff_hz: 4000.0,
                ..IlcParams::default()
            },
            trials: 10,
            divergence_factor: 2.0,
        }
    }
}

/// The model the learning law inverts, and its record.
#[derive(Debug, Clone)]
pub struct LearningModel {
    /// Wide-band sweep record: reference fed to the loop and measurement (um).
    pub sweep: (Vec<f64>, Vec<f64>),
    /// Its highest frequency, Hz.
    pub sweep_f1: f64,
    /// Its amplitude, um.
    pub sweep_amplitude: f64,
    /// The orders fitted.
    pub orders: Orders,
    /// The fitted closed loop.
    pub model: ClosedLoopModel,
}

/// What learning achieved on each reference.
#[derive(Debug, Clone)]
pub struct LearningResult {
    /// The law and its convergence check on the learning model.
    pub design: IlcDesign,
    /// The condition with the learning model's measured error (Eq. 3 of
    /// [`crate::synth::ilc::robust`]): the prediction the trials test.
    pub prediction: crate::synth::ilc::robust::RobustCheck,
    /// The measured divergence factor the trials were watched with.
    pub divergence_factor: f64,
    /// Per reference of the tracking table.
    pub references: Vec<LearnedReference>,
}

/// Learning on one reference.
#[derive(Debug, Clone)]
pub struct LearnedReference {
    /// The reference's description.
    pub reference: String,
    /// Trial 0 (no learning) to the last.
    pub trials: Vec<TrackingMetrics>,
    /// The feedforward the last trial played, one sample per controller
    /// period from the reference's first sample: a `feedforward_table`.
    pub feedforward: Vec<f64>,
}

impl LearningResult {
    /// Learning trials run after trial 0.
    pub fn trials_run(&self) -> usize {
        self.references
            .first()
            .map_or(0, |r| r.trials.len().saturating_sub(1))
    }

    /// The table's rows: each reference's last trial.
    fn rows(&self) -> Vec<TrackingRow> {
        self.references
            .iter()
            .filter_map(|r| {
                Some(TrackingRow {
                    reference: r.reference.clone(),
                    controller: LEARNED_STAGES,
                    metrics: *r.trials.last()?,
                })
            })
            .collect()
    }
}

/// The table's name for PID + HC + ZPEC with the learned feedforward.
pub const LEARNED_STAGES: &str = "pid+hc+zpec+ilc";

/// Everything the experiment produced.
#[derive(Debug, Clone)]
pub struct ExperimentResult {
    /// The identified models and their records.
    pub models: IdentifiedModels,
    /// The full controller (PID + HC + ZPEC) as emitted.
    pub controller: ControllerFile,
    /// The tracking table.
    pub table: Vec<TrackingRow>,
    /// Step 5, when asked for.
    pub learning: Option<LearningResult>,
}

/// A pipeline stage, reported to the observer as it starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// A step starts.
    Step(&'static str),
    /// A tracking run finished (`done` of `total`).
    Tracking {
        /// Runs finished.
        done: usize,
        /// Runs in all.
        total: usize,
    },
}

/// The composite controller for `stages` as an emitted-then-reloaded file:
/// the runtime sees exactly the numbers a real-time loop would read.
pub fn build_controller(
    stages: Stages,
    ts: f64,
    feedback: impl Into<Feedback>,
    inverse: Option<&crate::ident::hysteresis::HysteresisModel>,
    zpetc: Option<&Zpetc>,
    provenance: Provenance,
) -> Result<ControllerFile, String> {
    let feedback = feedback.into();
    let kind = match feedback {
        Feedback::None => FeedbackKind::None,
        Feedback::Pid(_) | Feedback::ParallelPid(_) => FeedbackKind::Pid,
        Feedback::StateSpace(_) => FeedbackKind::StateSpace,
        Feedback::Dob(_) => FeedbackKind::Dob,
    };
    if kind != stages.feedback {
        return Err(format!(
            "{} needs {}",
            stages.name(),
            match stages.feedback {
                FeedbackKind::Pid => "PID gains, not a state-space controller",
                FeedbackKind::StateSpace => "a state-space controller",
                FeedbackKind::Dob => "a disturbance-observer block",
                FeedbackKind::None => "no feedback controller",
            }
        ));
    }
    let file = ControllerFile {
        ts,
        units: Units::default(),
        zpetc: if stages.zpetc {
            Some(ZpetcBlock::from_zpetc(zpetc.ok_or_else(|| {
                format!("{} needs a ZPETC filter", stages.name())
            })?))
        } else {
            None
        },
        hysteresis: if stages.hysteresis_compensation {
            let inverse = inverse
                .ok_or_else(|| format!("{} needs an inverse hysteresis model", stages.name()))?;
            Some(HysteresisBlock::from_model(inverse))
        } else {
            None
        },
        feedback,
        provenance,
        repetitive: None,
        feedforward_table: None,
    };
    // Round trip through the file format, so simulation runs on exactly the
    // bytes a real-time loop would load.
    parse_controller(&file.to_json_string(), "<emitted>").map_err(|e| e.to_string())
}

fn fresh_plant(params: &ExperimentParams, run: u64) -> Result<VirtualFts, VirtualFtsError> {
    let mut p = params.plant.clone();
    // Distinct, reproducible noise for every run.
    p.seed = params.seed.wrapping_mul(1_000_003).wrapping_add(run);
    VirtualFts::new(p)
}

/// Runs a controller file on a fresh plant along a reference, playing its
/// learned feedforward table if it has one.
pub fn track(
    params: &ExperimentParams,
    run: u64,
    controller: &ControllerFile,
    reference: &Reference,
) -> Result<(closed_loop::Trace, TrackingMetrics), ExperimentError> {
    let mut plant = fresh_plant(params, run)?;
    let mut rt = RuntimeController::new(&controller.runtime_spec())
        .map_err(|e| step_err("controller")(e.to_string()))?;
    let trace = closed_loop::run_learned(
        &mut plant,
        &mut rt,
        &reference.samples,
        controller.learned_feedforward(),
    )?;
    let metrics = closed_loop::metrics(&trace, reference.evaluated(), controller.command_limits());
    Ok((trace, metrics))
}

/// The open-loop triangle record of step 1: the command (V) and the
/// measured displacement (um), unaligned.
pub fn triangle_record(params: &ExperimentParams) -> Result<(Vec<f64>, Vec<f64>), ExperimentError> {
    triangle_record_at(params, &[params.triangle_freq_hz])
}

/// The open-loop triangles played at each of `freqs` in turn (the
/// amplitudes at the first frequency, then at the second, ...) on one fresh
/// plant: one record over several rates (docs/math.md §1.7).
pub fn triangle_record_at(
    params: &ExperimentParams,
    freqs: &[f64],
) -> Result<(Vec<f64>, Vec<f64>), ExperimentError> {
    let mut command = Vec::new();
    for &freq_hz in freqs {
        let part = excite::triangle(&excite::TriangleParams {
            amplitudes: params.triangle_amplitudes_v.clone(),
            freq_hz,
            cycles: 2,
            ts: params.plant.ts,
            offset: 0.0,
            bipolar: false,
        })
        .map_err(|e| step_err("triangle excitation")(e.to_string()))?;
        command.extend(part);
    }
    let mut plant = fresh_plant(params, 0)?;
    let measured = plant.run_open_loop(&command);
    Ok((command, measured))
}

/// The triangle record aligned for the plant's delay (command, displacement),
/// so a quasi-static model sees matching pairs.
pub fn align_triangle_record<'a>(
    params: &ExperimentParams,
    command: &'a [f64],
    measured: &'a [f64],
) -> (&'a [f64], &'a [f64]) {
    let lag = params.plant.delay_samples + 1;
    (&command[..command.len() - lag], &measured[lag..])
}

/// The closed-loop sweep record of step 2: PID + HC (PID alone when
/// `inverse` is `None`) driven by the 0..f1 sweep; returns the filtered
/// reference and the measurement (um) after the lead-in.
pub fn sweep_record(
    params: &ExperimentParams,
    inverse: Option<&crate::ident::hysteresis::HysteresisModel>,
) -> Result<(Vec<f64>, Vec<f64>), ExperimentError> {
    let ts = params.plant.ts;
    let timing = ReferenceTiming {
        ts,
        ..ReferenceTiming::default()
    };
    let stages = if inverse.is_some() { "pid+hc" } else { "pid" };
    let pid_hc = build_controller(
        Stages::parse(stages).expect("valid"),
        ts,
        params.pid,
        inverse,
        None,
        Provenance::default(),
    )
    .map_err(step_err("PID + HC controller"))?;
    let sweep_ref = reference::sweep(
        params.sweep_amplitude,
        0.0,
        params.sweep_f1,
        params.offset,
        params.sweep_duration,
        &timing,
    )
    .map_err(|e| step_err("sweep")(e.to_string()))?;
    let (trace, metrics) = track(params, 1, &pid_hc, &sweep_ref)?;
    check_tracking(&metrics, params.pid)?;
    let window = sweep_ref.evaluated();
    Ok((
        trace.filtered_reference[window.clone()].to_vec(),
        trace.measurement[window].to_vec(),
    ))
}

/// Most saturated samples a closed-loop record may have: the \[Li21\]
/// sweep never saturates, an oscillating loop (gains beyond the stable
/// range) swings between the limits on a large part of its samples.
pub const MAX_SATURATED_FRACTION: f64 = 0.01;

/// Refuses a closed-loop run whose command sat on its limits on more than
/// [`MAX_SATURATED_FRACTION`] of the evaluated samples.
fn check_tracking(metrics: &TrackingMetrics, pid: PidSpec) -> Result<(), ExperimentError> {
    let fraction = metrics.saturated_samples as f64 / metrics.samples.max(1) as f64;
    if fraction <= MAX_SATURATED_FRACTION {
        return Ok(());
    }
    Err(ExperimentError::NotTracking(format!(
        "the closed loop does not track: the command sat on its limits ({} .. {} V) on {:.1} % of the {} samples (at most {} % allowed); the PID gains kp {} ki {} kd {} make the loop oscillate (a limit cycle) or the reference leaves the actuator's range, so no record is written",
        pid.output_min,
        pid.output_max,
        100.0 * fraction,
        metrics.samples,
        100.0 * MAX_SATURATED_FRACTION,
        pid.kp,
        pid.ki,
        pid.kd
    )))
}

/// Steps 1-3: what fts identifies from the virtual FTS (never from its
/// true parameters): the inverse hysteresis model, the PID + HC closed-loop
/// model and its ZPETC.
pub fn identify_models(
    params: &ExperimentParams,
    observer: &mut dyn FnMut(Progress),
) -> Result<IdentifiedModels, ExperimentError> {
    // 1. Open-loop triangles, inverse hysteresis identified directly.
    observer(Progress::Step("open-loop triangle excitation"));
    let (command, measured) = triangle_record(params)?;
    let (u_aligned, y_aligned) = align_triangle_record(params, &command, &measured);
    observer(Progress::Step("inverse hysteresis identification"));
    // [Li21]: the inverse model maps displacement to command.
    let inverse = identify(y_aligned, u_aligned, &params.hysteresis)
        .map_err(|e| step_err("inverse hysteresis identification")(e.to_string()))?;

    // 2. PID + HC closed loop, 0..f1 sweep.
    observer(Progress::Step("closed-loop sweep with PID + HC"));
    let (r, y) = sweep_record(params, Some(&inverse.model))?;
    let closed_loop = fit_closed_loop(params, params.orders, &r, &y, observer)?;

    // 3. ZPETC.
    observer(Progress::Step("ZPETC design"));
    let zpetc = zpetc::design(&closed_loop.tf, &params.zpetc)
        .map_err(|e| step_err("ZPETC")(e.to_string()))?;
    // Its self-check decides before anything uses it (docs/formats.md
    // "Self-checks").
    let failures: Vec<String> = zpetc
        .check(&closed_loop.tf, 2001)
        .map_err(|e| step_err("ZPETC self-check")(e.to_string()))?
        .failures()
        .iter()
        .map(|f| f.to_string())
        .collect();
    if !failures.is_empty() {
        return Err(step_err("ZPETC self-check")(failures.join("; ")));
    }
    let eq8 = ZpetcParams {
        stable_inversion: None,
        ..params.zpetc
    };
    let zpetc_eq8 = zpetc::design(&closed_loop.tf, &eq8)
        .map_err(|e| step_err("ZPETC (Li21 Eq. 8)")(e.to_string()))?;
    let learning = match &params.learning {
        Some(lp) => Some(learning_model(params, lp, &inverse, observer)?),
        None => None,
    };
    Ok(IdentifiedModels {
        triangle: (command, measured),
        inverse,
        sweep: (r, y),
        closed_loop,
        zpetc,
        zpetc_eq8,
        learning,
    })
}

/// The learning model: the same PID + HC loop swept over `lp`'s wider
/// band and fitted by output error, since `L` must invert the loop up to
/// Q's cutoff, where the 0-1 kHz model is wrong (docs/learning.md).
fn learning_model(
    params: &ExperimentParams,
    lp: &LearningParams,
    inverse: &Identified,
    observer: &mut dyn FnMut(Progress),
) -> Result<LearningModel, ExperimentError> {
    observer(Progress::Step("wide-band sweep for the learning model"));
    let wide = ExperimentParams {
        sweep_amplitude: lp.sweep_amplitude,
        sweep_f1: lp.sweep_f1,
        ..params.clone()
    };
    let (r, y) = sweep_record(&wide, Some(&inverse.model))?;
    let model = fit_closed_loop(params, lp.orders, &r, &y, observer)?;
    Ok(LearningModel {
        sweep: (r, y),
        sweep_f1: lp.sweep_f1,
        sweep_amplitude: lp.sweep_amplitude,
        orders: lp.orders,
        model,
    })
}

/// The closed-loop model of a sweep record `(r, y)`: ARX of `orders` by
/// QR, refined by output error when that improves the simulation fit
/// (`params.refine_oe`), near pole-zero cancellations removed
/// (`params.minreal_tol`).
pub fn fit_closed_loop(
    params: &ExperimentParams,
    orders: Orders,
    r: &[f64],
    y: &[f64],
    observer: &mut dyn FnMut(Progress),
) -> Result<ClosedLoopModel, ExperimentError> {
    let ts = params.plant.ts;
    let (mut r, mut y) = (r.to_vec(), y.to_vec());
    observer(Progress::Step("closed-loop ARX identification"));
    detrend(&mut r, Detrend::Mean);
    detrend(&mut y, Detrend::Mean);
    let mut arx_params = ArxParams::new(orders);
    arx_params.ts = ts;
    let est = arx(&r, &y, &arx_params).map_err(|e| step_err("closed-loop ARX")(e.to_string()))?;
    let arx_tf = est
        .model
        .tf()
        .map_err(|e| step_err("closed-loop ARX")(e.to_string()))?;
    let mut chosen = (arx_tf.clone(), "arx");
    let mut reason = String::from("ARX: output-error refinement not requested");
    let (mut arx_fit, mut oe_fit) = (None, None);
    if params.refine_oe {
        observer(Progress::Step("output-error refinement"));
        let mut oe_params = OeParams::new(orders);
        oe_params.ts = ts;
        let refined = refine_arx(&est.model, &r, &y, &oe_params);
        if let (true, Some(Ok(tf))) = (refined.chosen, refined.oe.as_ref().map(|o| o.model.tf())) {
            chosen = (tf, "oe");
        }
        (arx_fit, oe_fit, reason) = (Some(refined.arx_fit), refined.oe_fit, refined.reason);
    }
    let arx_fit = arx_fit.unwrap_or_else(|| fits(&est.model, NoiseModel::Arx, &r, &y));
    let (tf, removed_pairs) = match params.minreal_tol {
        Some(tol) => {
            let m = chosen
                .0
                .minreal(tol)
                .map_err(|e| step_err("closed-loop model reduction")(e.to_string()))?;
            (m.tf, m.removed)
        }
        None => (chosen.0.clone(), Vec::new()),
    };
    Ok(ClosedLoopModel {
        tf,
        method: chosen.1,
        arx_fit,
        oe_fit,
        arx_tf,
        condition_number: est.condition_number,
        identified_tf: chosen.0,
        removed_pairs,
        reason,
    })
}

/// The tracking table's name for PID + HC with \[Li21\] Eq. 8's filter
/// ([`IdentifiedModels::zpetc_eq8`]).
pub const EQ8_STAGES: &str = "pid+hc+zpec(eq8)";

/// Runs the whole experiment: [`identify_models`], then the tracking table.
pub fn run(
    params: &ExperimentParams,
    observer: &mut dyn FnMut(Progress),
) -> Result<ExperimentResult, ExperimentError> {
    let ts = params.plant.ts;
    let timing = ReferenceTiming {
        ts,
        ..ReferenceTiming::default()
    };
    let models = identify_models(params, observer)?;
    let (inverse, zpetc) = (&models.inverse, &models.zpetc);
    // Every reference continues past its evaluated part for longer than the
    // ZPETC looks ahead.
    let timing = timing.with_preview(zpetc.preview);

    // 4. Tracking table.
    let build = |stages: Stages, zpetc: &Zpetc| {
        let inverse = Some(&inverse.model);
        build_controller(
            stages,
            ts,
            params.pid,
            inverse,
            Some(zpetc),
            Provenance::default(),
        )
        .map_err(step_err("controllers"))
    };
    let controllers: Vec<(Stages, ControllerFile)> = ["pid", "pid+hc", "pid+hc+zpec"]
        .iter()
        .map(|s| {
            let stages = Stages::parse(s).expect("valid");
            build(stages, zpetc).map(|c| (stages, c))
        })
        .collect::<Result<_, _>>()?;
    let mut references = Vec::new();
    for &f in &params.sine_freqs_hz {
        // At least 0.2 s and 20 periods.
        let duration = (20.0 / f).max(0.2);
        references.push(
            reference::sine(params.sine_amplitude, f, params.offset, duration, &timing)
                .map_err(|e| step_err("sine reference")(e.to_string()))?,
        );
    }
    references.push(
        reference::sweep(
            params.sine_amplitude,
            0.0,
            params.sweep_f1,
            params.offset,
            params.sweep_duration,
            &timing,
        )
        .map_err(|e| step_err("sweep")(e.to_string()))?,
    );
    references.push(
        reference::five_leaf(params.five_leaf_scale, params.offset, 1.0, &timing)
            .map_err(|e| step_err("five-leaf reference")(e.to_string()))?,
    );
    let eq8 = build(
        Stages::parse("pid+hc+zpec").expect("valid"),
        &models.zpetc_eq8,
    )?;
    let runs: Vec<(&str, &ControllerFile)> = controllers
        .iter()
        .map(|(stages, c)| (stages.name(), c))
        .chain([(EQ8_STAGES, &eq8)])
        .collect();
    let total = references.len() * runs.len();
    let mut table = Vec::with_capacity(total);
    let mut run_id = 10;
    for (i, reference) in references.iter().enumerate() {
        for &(name, controller) in &runs {
            // The Eq. 8 runs draw their own noise, so the other runs keep
            // theirs whether or not the comparison is made.
            let id = if name == EQ8_STAGES {
                1000 + i as u64
            } else {
                run_id += 1;
                run_id - 1
            };
            let (_, metrics) = track(params, id, controller, reference)?;
            table.push(TrackingRow {
                reference: reference.label.clone(),
                controller: name,
                metrics,
            });
            observer(Progress::Tracking {
                done: table.len(),
                total,
            });
        }
    }
    let controller = controllers.into_iter().last().expect("three controllers").1;
    let learning = match (&params.learning, &models.learning) {
        (Some(lp), Some(lm)) => {
            let learned = learn_references(params, lp, lm, &controller, &references, observer)?;
            table.extend(learned.rows());
            Some(learned)
        }
        _ => None,
    };
    Ok(ExperimentResult {
        models,
        controller,
        table,
        learning,
    })
}

/// Step 5: iterative learning control of every reference with the PID +
/// HC + ZPEC controller, `lp.trials` trials each; the law is checked for
/// convergence on the learning model first.
fn learn_references(
    params: &ExperimentParams,
    lp: &LearningParams,
    lm: &LearningModel,
    controller: &ControllerFile,
    references: &[Reference],
    observer: &mut dyn FnMut(Progress),
) -> Result<LearningResult, ExperimentError> {
    observer(Progress::Step("iterative learning control"));
    let design = ilc::design(&lm.model.tf, &lp.ilc).map_err(|e| step_err("ILC")(e.to_string()))?;
    let prediction = predict(lm, &design)?;
    let mut learned = Vec::with_capacity(references.len());
    for (i, reference) in references.iter().enumerate() {
        let mut rows: Vec<TrackingMetrics> = Vec::with_capacity(lp.trials + 1);
        let (feedforward, _) = design.run_trials(
            lp.trials,
            reference.ramp_end,
            |trial, learned| {
                let file = controller.with_feedforward(learned);
                let run = 1000 * (i as u64 + 1) + trial as u64;
                let (trace, metrics) = track(params, run, &file, reference)?;
                rows.push(metrics);
                let errors: Vec<f64> = rows.iter().map(|m| m.max_abs_error).collect();
                if let Some(d) = ilc::last_diverged(&errors, lp.divergence_factor) {
                    return Err(step_err("ILC")(format!(
                        "the learning diverges on {}: trial {} has max error {:.4} um, {:.1} times trial {}'s (divergence factor {})",
                        reference.label, d.trial, errors[d.trial], d.ratio, d.best_trial, lp.divergence_factor
                    )));
                }
                Ok::<_, ExperimentError>(trace)
            },
            closed_loop::Trace::error,
        )?;
        observer(Progress::Tracking {
            done: i + 1,
            total: references.len(),
        });
        learned.push(LearnedReference {
            reference: reference.label.clone(),
            trials: rows,
            feedforward,
        });
    }
    Ok(LearningResult {
        design,
        prediction,
        divergence_factor: lp.divergence_factor,
        references: learned,
    })
}

/// The law's convergence condition with the learning model's error
/// measured on its own identification record ([`ilc::robust`], Eq. 3):
/// a law predicted to diverge is refused.
fn predict(
    lm: &LearningModel,
    design: &ilc::IlcDesign,
) -> Result<ilc::robust::RobustCheck, ExperimentError> {
    let source = format!(
        "the learning model's own {} um 0-{:.0} Hz sweep record",
        lm.sweep_amplitude, lm.sweep_f1
    );
    let error = ilc::robust::ModelError::measure(&lm.model.tf, &lm.sweep.0, &lm.sweep.1, source)
        .map_err(|e| step_err("ILC")(e.to_string()))?;
    let check = ilc::robust::robust_check(design, &lm.model.tf, &error);
    if !check.converges() {
        return Err(step_err("ILC")(check.failure(&error)));
    }
    Ok(check)
}
