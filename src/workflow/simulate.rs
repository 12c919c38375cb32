//! A closed-loop tracking run: what `fts simulate` does. The controller is
//! the runtime's step, fed by a coefficient file or by one built from the
//! `controller` stages exactly as `fts emit` builds it; the plant is the
//! virtual FTS or a discrete linear model.

use super::contour::DobSettings;
use super::{AntiWindup, Discretisation, SsController, StepError, Validate};
use crate::ident::excite::ExciteError;
use crate::ident::hysteresis::HysteresisModel;
use crate::io::controller_file::{
    ControllerFile, DobBlock, Feedback, Provenance, RepetitiveBlock, StateSpaceBlock,
};
use crate::lti::DiscreteTf;
use crate::lti::response::NoStepInfo;
use crate::lti::ss::StateSpace;
use crate::runtime::SsAntiWindup;
use crate::runtime::{PidSpec, RuntimeController};
use crate::sim::disturbance::{Disturbance, Disturbed};
use crate::sim::experiment::{self, DEFAULT_PID, ExperimentParams, IdentifiedModels};
use crate::sim::reference::{self, Reference, ReferenceTiming, StepTracking};
use crate::sim::virtual_fts::{VirtualFts, VirtualFtsParams};
use crate::sim::{ModelPlant, Plant, closed_loop};
use crate::synth::composite::{FeedbackKind, Stages};
use crate::synth::zpetc::Zpetc;
use serde::{Deserialize, Serialize, Serializer};
use serde_json::json;
use std::fmt;

/// The shape of a generated reference.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReferenceShape {
    /// A sine of `amplitude` at `freq`.
    #[default]
    Sine,
    /// A chirp of `amplitude` from 0 to `f1`.
    Sweep,
    /// The five-leaved trajectory of \[Li21\] Eq. 13, scaled by `scale`.
    FiveLeaf,
    /// A step of `amplitude` from `offset` at `step_time`, with its
    /// rise/settling time and overshoot.
    Step,
}

impl super::Choices for ReferenceShape {
    const CHOICES: &'static [(&'static str, &'static str)] = &[
        ("sine", ""),
        ("sweep", ""),
        ("five-leaf", ""),
        (
            "step",
            "A step of `amplitude` from `offset` at `step_time`, with rise/settling time and overshoot",
        ),
    ];
}

/// Settings of a closed-loop tracking run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Simulate {
    /// Controller stages: `pid`, `pid+hc`, `pid+zpec`, `pid+hc+zpec`, `ss`,
    /// `ss+hc`, `ss+zpec`, `ss+hc+zpec`, `dob[+hc][+zpec]` (the PID, or the
    /// state-space controller when one is given, inside a disturbance
    /// observer on the plant model), or feedforward only (`hc`, `zpec`,
    /// `hc+zpec`); default `pid+hc+zpec`, or `ss` with a state-space
    /// controller.
    pub controller: Option<String>,
    /// Generated reference; default sine.
    pub reference: ReferenceShape,
    /// Amplitude of the sine, sweep or step, um; default 5.
    pub amplitude: f64,
    /// Sine frequency, Hz; default 100.
    pub freq: f64,
    /// Sweep end frequency, Hz; default 1000.
    pub f1: f64,
    /// Centre of the reference, um; default 7 (mid-stroke of the embedded
    /// plant).
    pub offset: f64,
    /// Length of the reference, s; default: sine 20 periods and at least
    /// 0.2 s, sweep 2 s, five-leaf 1 s, step 0.1 s.
    pub duration: Option<f64>,
    /// Time of the step into the evaluated part, s; default 0.01.
    pub step_time: f64,
    /// Scale of the five-leaved trajectory (Eq. 13 as printed spans
    /// +-50 um); default 0.1.
    pub scale: f64,
    /// Noise seed of the plant; default the virtual FTS's own (1 for a
    /// linear model).
    pub seed: Option<u64>,
    /// PID proportional gain, V/um; default \[Li21\]'s 0.02.
    pub kp: f64,
    /// PID integral gain per sample, V/um; default \[Li21\]'s 0.15.
    pub ki: f64,
    /// PID derivative gain per sample, V/um, on the measurement; default 0.
    pub kd: f64,
    /// Lowest command of the feedback controller (PID or state space), V;
    /// default the virtual FTS amplifier's (a state-space controller on a
    /// linear model: none).
    pub output_min: Option<f64>,
    /// Highest command of the feedback controller (PID or state space), V;
    /// default the virtual FTS amplifier's (a state-space controller on a
    /// linear model: none).
    pub output_max: Option<f64>,
    /// Discretisation of a continuous state-space controller; default tustin.
    pub c2d: Discretisation,
    /// Tustin prewarp frequency, Hz; default none.
    pub prewarp: Option<f64>,
    /// State handling of a state-space controller under saturation;
    /// default conditional-update.
    pub ss_anti_windup: AntiWindup,
    /// Disturbance added to the plant's output (um), e.g. a spindle-synchronous
    /// error motion; default none.
    pub output_disturbance: Option<Disturbance>,
    /// Disturbance added to the command at the plant's input (V); default none.
    pub input_disturbance: Option<Disturbance>,
    /// The observer and friction feedforward of a `dob` controller.
    pub dob: DobSettings,
    /// HC by per-sample inversion (docs/math.md §1.6): the `hysteresis`
    /// model is the *forward* model, and the HC block solves `Y(u) = r_f`
    /// each sample on the PID's command range instead of evaluating an
    /// inverse model; default false.
    pub hc_solve: bool,
}

impl Default for Simulate {
    fn default() -> Self {
        Self {
            controller: None,
            reference: ReferenceShape::Sine,
            amplitude: 5.0,
            freq: 100.0,
            f1: 1000.0,
            offset: 7.0,
            duration: None,
            step_time: 0.01,
            scale: 0.1,
            seed: None,
            kp: DEFAULT_PID.kp,
            ki: DEFAULT_PID.ki,
            kd: 0.0,
            output_min: None,
            output_max: None,
            c2d: Discretisation::Tustin,
            prewarp: None,
            ss_anti_windup: AntiWindup::ConditionalUpdate,
            output_disturbance: None,
            input_disturbance: None,
            dob: DobSettings::default(),
            hc_solve: false,
        }
    }
}

impl Validate for Simulate {
    fn validate(&self) -> Result<(), StepError> {
        if let Some(text) = &self.controller {
            Stages::parse(text).map_err(|e| StepError::setting("controller", e.to_string()))?;
        }
        for (field, d) in [
            ("output_disturbance", &self.output_disturbance),
            ("input_disturbance", &self.input_disturbance),
        ] {
            if let Some(d) = d {
                d.validate()
                    .map_err(|e| StepError::setting(field, e.to_string()))?;
            }
        }
        self.check_limits()
    }
}

/// The plant a run drives.
#[derive(Debug, Clone)]
pub enum SimPlant {
    /// The virtual FTS with these parameters
    /// ([`VirtualFtsParams::default_plant`] is the embedded one); the
    /// `seed` setting replaces theirs when given.
    Virtual(VirtualFtsParams),
    /// A discrete linear model, optionally behind a forward hysteresis model.
    Model {
        /// The linear part.
        tf: DiscreteTf,
        /// Forward hysteresis in front of it, if any.
        hysteresis: Option<HysteresisModel>,
        /// The model's name (a file path), for messages.
        source: String,
    },
}

/// Where the controller comes from.
#[derive(Debug, Clone)]
pub enum SimController {
    /// A complete coefficient file, run as it is.
    File {
        /// The file.
        file: ControllerFile,
        /// Its name (a file path), for messages.
        source: String,
    },
    /// Built from the `controller` stages as `fts emit` builds it; models
    /// the stages need and that are not given are identified from the
    /// virtual FTS (simulated measurements only).
    Stages(StageModels),
}

/// The models a stage-built controller is made of, where given.
#[derive(Debug, Clone, Default)]
pub struct StageModels {
    /// State-space feedback controller and its name (a file path).
    pub ss: Option<(StateSpace, String)>,
    /// Inverse hysteresis model for the HC feedforward.
    pub hysteresis: Option<HysteresisModel>,
    /// ZPETC pre-filter.
    pub zpetc: Option<Zpetc>,
    /// Plug-in repetitive compensator, added to any stages.
    pub repetitive: Option<RepetitiveBlock>,
    /// The nominal model of a `dob` controller's observer and its name;
    /// default the plant model (`plant_tf`).
    pub nominal: Option<(DiscreteTf, String)>,
    /// The closed-loop model (loop reference to output), given or
    /// identified with the other models; for learning control.
    pub closed_loop: Option<DiscreteTf>,
    /// Version and input hashes recorded in the controller file.
    pub provenance: Provenance,
}

/// A loop ready to run ([`Simulate::prepare`]).
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The coefficient file.
    pub file: ControllerFile,
    /// Where its models came from.
    pub models: String,
    /// The reference.
    pub reference: Reference,
    /// Whether the reference came from samples rather than a shape.
    pub reference_from_file: bool,
    /// The plant.
    pub plant: SimPlant,
    /// The virtual FTS parameters (also the amplifier limits of a model plant).
    pub vparams: VirtualFtsParams,
    /// The closed-loop model, when the controller was built from stages
    /// whose models were identified or given with one.
    pub closed_loop: Option<DiscreteTf>,
}

/// What [`Simulate::run`] drives.
#[derive(Debug, Clone)]
pub struct SimulateInputs {
    /// The plant.
    pub plant: SimPlant,
    /// The controller.
    pub controller: SimController,
    /// Reference samples at the controller rate and their description
    /// (e.g. `reference r.csv`), replacing the `reference` setting.
    pub reference_samples: Option<(Vec<f64>, String)>,
}

/// The amplifier limits of the PID and of a state-space controller on the
/// virtual FTS: the embedded plant's when the plant is a linear model.
fn amplifier_plant(plant: &SimPlant) -> VirtualFtsParams {
    match plant {
        SimPlant::Virtual(p) => p.clone(),
        SimPlant::Model { .. } => VirtualFtsParams::default_plant(),
    }
}

impl SimPlant {
    /// The plant's sample time, s: the controller's too.
    pub fn ts(&self) -> f64 {
        match self {
            SimPlant::Virtual(p) => p.ts,
            SimPlant::Model { tf, .. } => tf.ts(),
        }
    }
}

impl Simulate {
    /// Runs the loop.
    pub fn run(&self, inputs: SimulateInputs) -> Result<SimulateReport, StepError> {
        self.run_observed(inputs, &mut |_| {})
    }

    /// Runs the loop; `note` hears warnings and of the slow part
    /// (identifying models).
    pub fn run_observed(
        &self,
        inputs: SimulateInputs,
        note: &mut dyn FnMut(&str),
    ) -> Result<SimulateReport, StepError> {
        let prepared = self.prepare(inputs, note)?;
        let trace = self.run_prepared(&prepared, 0, prepared.file.learned_feedforward())?;
        let step = (!prepared.reference_from_file)
            .then(|| self.step_figures(&trace, &prepared.reference))
            .flatten();
        let mut report = SimulateReport::new(
            prepared.file,
            prepared.models,
            prepared.reference,
            trace,
            step,
        );
        if matches!(self.reference, ReferenceShape::Sine) && !prepared.reference_from_file {
            let window = report.reference.evaluated();
            report.harmonics = closed_loop::error_harmonics(&report.trace, window, self.freq, 3);
        }
        Ok(report)
    }

    /// Everything a run needs, resolved once: the coefficient file (built
    /// from the stages, identifying missing models), the reference and the
    /// plant; for repeated runs ([`crate::workflow::learning::Ilc`]).
    pub fn prepare(
        &self,
        inputs: SimulateInputs,
        note: &mut dyn FnMut(&str),
    ) -> Result<Prepared, StepError> {
        self.validate()?;
        let mut vparams = amplifier_plant(&inputs.plant);
        if let Some(seed) = self.seed {
            vparams.seed = seed;
        }
        let ts = inputs.plant.ts();
        if inputs.reference_samples.is_none() {
            // Sized before the models are identified: a reference beyond
            // the sample bound is refused before any work.
            self.reference_samples_bound(ts)?;
        }
        let model_plant = matches!(inputs.plant, SimPlant::Model { .. });
        let mut loop_model = None;
        let (file, models) = match inputs.controller {
            SimController::File { file, source } => (
                checked_file(file, &source, ts)?,
                format!("coefficient file {source}"),
            ),
            SimController::Stages(mut m) => {
                if m.nominal.is_none()
                    && let SimPlant::Model { tf, source, .. } = &inputs.plant
                {
                    m.nominal = Some((tf.clone(), source.clone()));
                }
                let built = self.controller(&mut m, &vparams, ts, model_plant, note)?;
                loop_model = m.closed_loop.take();
                built
            }
        };
        let reference_from_file = inputs.reference_samples.is_some();
        let reference = self.reference(inputs.reference_samples, ts, file.preview())?;
        Ok(Prepared {
            file,
            models,
            reference,
            reference_from_file,
            plant: inputs.plant,
            vparams,
            closed_loop: loop_model,
        })
    }

    /// One run of a prepared loop with the learned feedforward `learned`;
    /// `run` offsets the plant's noise seed, so repeated trials see fresh noise.
    pub fn run_prepared(
        &self,
        prepared: &Prepared,
        run: u64,
        learned: &[f64],
    ) -> Result<closed_loop::Trace, StepError> {
        let mut vparams = prepared.vparams.clone();
        vparams.seed = vparams.seed.wrapping_add(run);
        let file = prepared.file.with_feedforward(learned);
        self.drive(
            prepared.plant.clone(),
            vparams,
            &file,
            &prepared.reference,
            run,
        )
    }

    /// Runs the file's controller on the plant along the reference.
    fn drive(
        &self,
        plant: SimPlant,
        vparams: VirtualFtsParams,
        file: &ControllerFile,
        reference: &Reference,
        run: u64,
    ) -> Result<closed_loop::Trace, StepError> {
        let n = reference.samples.len();
        let ts = plant.ts();
        let sampled = |d: &Option<Disturbance>| d.as_ref().map_or(Vec::new(), |d| d.samples(n, ts));
        let (input, output) = (
            sampled(&self.input_disturbance),
            sampled(&self.output_disturbance),
        );
        match plant {
            SimPlant::Virtual(_) => {
                let plant = VirtualFts::new(vparams)
                    .map_err(|e| StepError::input(format!("plant: {e}")))?;
                run_on(
                    &mut Disturbed::new(plant, input, output),
                    file,
                    reference,
                    None,
                )
            }
            SimPlant::Model {
                tf,
                hysteresis,
                source,
            } => {
                // A rate stage (docs/math.md §1.7) differentiates at its own ts.
                if let Some(rate) = hysteresis.as_ref().and_then(|h| h.rate.as_ref())
                    && (rate.ts - tf.ts()).abs() > 1e-9 * tf.ts()
                {
                    return Err(StepError::input(format!(
                        "{source}: the hysteresis model's rate stage runs at ts {} s, the plant model at {} s",
                        rate.ts,
                        tf.ts()
                    )));
                }
                let limits = file.command_limits();
                let seed = self.seed.unwrap_or(1).wrapping_add(run);
                let plant = ModelPlant::new(&tf, hysteresis, limits, 0.0, seed)
                    .map_err(|e| StepError::input(format!("{source}: {e}")))?;
                let mut plant = Disturbed::new(plant, input, output);
                run_on(&mut plant, file, reference, Some((&tf, &source)))
            }
        }
    }

    /// The stages asked for (default `pid+hc+zpec`, or `ss` with a
    /// state-space controller).
    fn stages(&self, with_ss: bool) -> Result<Stages, StepError> {
        let default = if with_ss { "ss" } else { "pid+hc+zpec" };
        Stages::parse(self.controller.as_deref().unwrap_or(default))
            .map_err(|e| StepError::setting("controller", e.to_string()))
    }

    /// The command limits, each finite when given, the lower below the upper.
    fn check_limits(&self) -> Result<(), StepError> {
        super::check_command_limits(self.output_min, self.output_max, "a finite command in V")
    }

    /// The PID gains, each finite, limited to `output_min`..`output_max`
    /// (default the amplifier's range).
    fn pid(&self, plant: &VirtualFtsParams) -> Result<PidSpec, StepError> {
        for (name, value) in [("kp", self.kp), ("ki", self.ki), ("kd", self.kd)] {
            if !value.is_finite() {
                return Err(StepError::setting(
                    name,
                    format!("expected a finite gain, got {value}"),
                ));
            }
        }
        Ok(PidSpec {
            kp: self.kp,
            ki: self.ki,
            kd: self.kd,
            output_min: self.output_min.unwrap_or(plant.amplifier.input_min_v),
            output_max: self.output_max.unwrap_or(plant.amplifier.input_max_v),
        })
        .and_then(|pid| {
            // One limit given beside the other's default must still leave a range.
            if pid.output_min < pid.output_max {
                Ok(pid)
            } else {
                Err(StepError::setting(
                    if self.output_max.is_some() {
                        "output_max"
                    } else {
                        "output_min"
                    },
                    format!(
                        "the PID's command range {} .. {} V is empty",
                        pid.output_min, pid.output_max
                    ),
                ))
            }
        })
    }

    /// The coefficient file the stages describe, and a note on where its
    /// models came from.
    fn controller(
        &self,
        m: &mut StageModels,
        plant: &VirtualFtsParams,
        ts: f64,
        model_plant: bool,
        note: &mut dyn FnMut(&str),
    ) -> Result<(ControllerFile, String), StepError> {
        let stages = self.stages(m.ss.is_some())?;
        let block = self.feedback_block(stages, m, plant, ts, model_plant)?;
        if let Some((sys, source)) = &m.ss
            && let Some(warning) = fast_poles_warning(sys, ts, source)
        {
            note(&warning);
        }
        let pid = self.pid(plant)?;
        // Built before any identification: a refused observer costs nothing.
        let feedback = match (block, stages.feedback) {
            (outer, FeedbackKind::Dob) => {
                let outer = outer.unwrap_or_else(|| pid_block(&pid));
                Feedback::Dob(self.dob_block(outer, m.nominal.as_ref(), ts)?)
            }
            (Some(k), _) => Feedback::StateSpace(k),
            (None, FeedbackKind::None) => Feedback::None,
            (None, _) => Feedback::Pid(pid),
        };
        let mut origin = match &m.ss {
            Some((_, source)) => format!("state-space controller {source}, models from files"),
            None => String::from("models from files"),
        };
        if self.hc_solve && !(stages.hysteresis_compensation && m.hysteresis.is_some()) {
            return Err(StepError::setting(
                "hc_solve",
                "`hc_solve` inverts a given forward model: it needs an hc stage and `hysteresis`"
                    .to_string(),
            ));
        }
        let missing = (stages.hysteresis_compensation && m.hysteresis.is_none())
            || (stages.zpetc && m.zpetc.is_none());
        if missing {
            if model_plant {
                return Err(StepError::setting(
                    "controller",
                    format!(
                        "`controller` {}: with `plant_tf`, give the models too (`hysteresis` for hc, `zpetc` or `closed_loop` for zpec)",
                        stages.name()
                    ),
                ));
            }
            note(
                "identifying HC and ZPETC models from the virtual FTS (simulated measurements only)...",
            );
            origin = identify_missing(m, plant, pid)?;
        }
        let mut file = experiment::build_controller(
            stages,
            ts,
            feedback,
            m.hysteresis.as_ref(),
            m.zpetc.as_ref(),
            m.provenance.clone(),
        )
        .map_err(StepError::input)?;
        if self.hc_solve {
            solve_hc(&mut file, m.hysteresis.as_ref(), &pid)?;
        }
        if let Some(r) = m.repetitive.clone() {
            file.repetitive = Some(r);
            file.validate("repetitive")
                .map_err(|e| StepError::setting("repetitive", e.to_string()))?;
        }
        Ok((file, origin))
    }

    /// The state-space feedback block, when the stages have one; checks
    /// that the feedback asked for and the one given agree, and that a
    /// ZPETC for a loop other than the PID one is given.
    fn feedback_block(
        &self,
        stages: Stages,
        m: &StageModels,
        plant: &VirtualFtsParams,
        ts: f64,
        model_plant: bool,
    ) -> Result<Option<StateSpaceBlock>, StepError> {
        let name = stages.name();
        let needs_zpetc = stages.zpetc && m.zpetc.is_none();
        let bad = |message: String| Err(StepError::setting("controller", message));
        match (stages.feedback, &m.ss) {
            (FeedbackKind::Pid | FeedbackKind::None, Some(_)) => bad(format!(
                "`controller` {name}: `ss` gives a state-space controller; use `controller` ss[+hc][+zpec] or dob[+hc][+zpec]"
            )),
            (FeedbackKind::Dob, _) if needs_zpetc => bad(format!(
                "`controller` {name}: give the ZPETC of this loop (`zpetc` or `closed_loop`); the one fts identifies is for the PID loop"
            )),
            (FeedbackKind::StateSpace, None) => bad(format!(
                "`controller` {name}: needs the controller (`ss` K.json)"
            )),
            (FeedbackKind::StateSpace, Some(_)) if needs_zpetc => bad(format!(
                "`controller` {name}: give the ZPETC of this loop (`zpetc` or `closed_loop`); the one fts identifies is for the PID loop"
            )),
            (FeedbackKind::None, None) if needs_zpetc => bad(format!(
                "`controller` {name}: give the ZPETC of the loop it feeds (`zpetc` or `closed_loop`); the one fts identifies is for its PID loop"
            )),
            (FeedbackKind::StateSpace | FeedbackKind::Dob, Some((sys, source))) => {
                let limits = if model_plant {
                    (self.output_min, self.output_max)
                } else {
                    (
                        self.output_min.or(Some(plant.amplifier.input_min_v)),
                        self.output_max.or(Some(plant.amplifier.input_max_v)),
                    )
                };
                self.ss_step(limits).block(sys, ts, source).map(Some)
            }
            (FeedbackKind::Pid | FeedbackKind::None | FeedbackKind::Dob, None) => Ok(None),
        }
    }

    /// The disturbance-observer block around `outer` (`synth::dob`), its
    /// nominal model the plant model.
    fn dob_block(
        &self,
        outer: StateSpaceBlock,
        nominal: Option<&(DiscreteTf, String)>,
        ts: f64,
    ) -> Result<DobBlock, StepError> {
        let Some((tf, source)) = nominal else {
            return Err(StepError::setting(
                "controller",
                "`controller` dob: the observer's nominal model is the plant model; give one (`plant_tf`, a discrete model)",
            ));
        };
        self.dob.validate(ts)?;
        let nominal_error =
            |e: String| StepError::setting("plant_tf", format!("{source}: DOB nominal model: {e}"));
        let mut num = vec![0.0; tf.delay()];
        num.extend_from_slice(tf.num().coeffs());
        let g = crate::synth::dob::tf_ss(&num, tf.den().coeffs(), ts).map_err(nominal_error)?;
        let f = crate::synth::dob::design(&g, self.dob.q_hz, self.dob.q_order, ts)
            .map_err(nominal_error)?;
        let d = &self.dob;
        Ok(DobBlock::from_filters(
            outer,
            f,
            (d.coulomb, d.viscous, d.smoothing),
            format!(
                "Q binomial order {} at {} Hz; nominal inverse of {source}",
                d.q_order, d.q_hz
            ),
        ))
    }

    /// The state-space controller settings, with these command limits.
    fn ss_step(&self, limits: (Option<f64>, Option<f64>)) -> SsController {
        SsController {
            ts: None,
            c2d: self.c2d,
            prewarp: self.prewarp,
            ss_anti_windup: self.ss_anti_windup,
            output_min: limits.0,
            output_max: limits.1,
        }
    }

    /// The reference at sample time `ts`; its tail covers the controller's
    /// preview.
    fn reference(
        &self,
        samples: Option<(Vec<f64>, String)>,
        ts: f64,
        preview: usize,
    ) -> Result<Reference, StepError> {
        let timing = ReferenceTiming {
            ts,
            ..ReferenceTiming::default()
        }
        .with_preview(preview);
        if let Some((samples, label)) = samples {
            return Ok(reference::from_samples(samples, &timing, label));
        }
        let excite = |e: ExciteError| StepError::setting(e.field, e.message);
        if matches!(self.reference, ReferenceShape::Sine | ReferenceShape::Sweep)
            && !(self.amplitude.is_finite() && self.amplitude > 0.0)
        {
            // A zero amplitude leaves nothing to track and the error in % of
            // it undefined; a negative one is the same sine shifted by half
            // a period, and is asked for by mistake.
            return Err(StepError::setting(
                "amplitude",
                format!(
                    "expected a positive amplitude in um, got {}",
                    self.amplitude
                ),
            ));
        }
        match self.reference {
            ReferenceShape::Sine => {
                let duration = self.sine_duration()?;
                reference::sine(self.amplitude, self.freq, self.offset, duration, &timing)
            }
            ReferenceShape::Sweep => reference::sweep(
                self.amplitude,
                0.0,
                self.f1,
                self.offset,
                self.duration.unwrap_or(2.0),
                &timing,
            ),
            ReferenceShape::Step => reference::step(
                self.amplitude,
                self.offset,
                self.step_time,
                self.duration.unwrap_or(0.1),
                &timing,
            ),
            ReferenceShape::FiveLeaf => reference::five_leaf(
                self.scale,
                self.offset,
                self.duration.unwrap_or(1.0),
                &timing,
            ),
        }
        .map_err(excite)
    }

    /// The sine's duration: as set, or 20 periods and at least 0.2 s.
    /// Refuses a generated reference of more than
    /// [`crate::ident::excite::MAX_SAMPLES`] samples (docs/formats.md,
    /// Bounds), before anything is generated or identified.
    fn reference_samples_bound(&self, ts: f64) -> Result<(), StepError> {
        let duration = match self.reference {
            ReferenceShape::Sine => self.sine_duration()?,
            ReferenceShape::Sweep => self.duration.unwrap_or(2.0),
            ReferenceShape::Step => self.duration.unwrap_or(0.1),
            ReferenceShape::FiveLeaf => self.duration.unwrap_or(1.0),
        };
        crate::ident::excite::sample_count(duration, ts)
            .map(|_| ())
            .map_err(|e| StepError::setting(e.field, e.message))
    }

    fn sine_duration(&self) -> Result<f64, StepError> {
        match self.duration {
            Some(d) => Ok(d),
            None if self.freq.is_finite() && self.freq > 0.0 => Ok((20.0 / self.freq).max(0.2)),
            // Without a positive frequency there is no default duration,
            // and the frequency is the culprit.
            None => Err(StepError::setting(
                "freq",
                format!(
                    "expected a positive frequency in Hz for a sine reference, got {} (or give `duration`)",
                    self.freq
                ),
            )),
        }
    }

    /// The step figures of a generated step reference (`None` for other
    /// references).
    fn step_figures(
        &self,
        trace: &closed_loop::Trace,
        reference: &Reference,
    ) -> Option<Result<StepTracking, NoStepInfo>> {
        if self.reference != ReferenceShape::Step {
            return None;
        }
        let at = reference.evaluate_from + (self.step_time / trace.ts).round() as usize;
        Some(reference::step_tracking(
            &trace.measurement,
            trace.ts,
            at,
            reference.evaluate_to,
            self.offset,
            self.amplitude,
        ))
    }
}

/// The warning that a continuous controller has poles no discretisation at
/// `ts` reproduces (beyond the Nyquist frequency), if it has.
/// `hc_solve`: the HC block holds the forward `model` and inverts it per
/// sample on the PID's command range; the file is round-tripped, so the
/// block's own checks (a model strictly increasing in its input) apply.
fn solve_hc(
    file: &mut ControllerFile,
    model: Option<&HysteresisModel>,
    pid: &PidSpec,
) -> Result<(), StepError> {
    let Some(model) = model else {
        return Ok(());
    };
    file.hysteresis = Some(crate::io::controller_file::HysteresisBlock::solving(
        model,
        pid.output_min,
        pid.output_max,
    ));
    *file = crate::io::controller_file::parse_controller(&file.to_json_string(), "<emitted>")
        .map_err(|e| StepError::setting("hysteresis", e.to_string()))?;
    Ok(())
}

fn fast_poles_warning(sys: &StateSpace, ts: f64, source: &str) -> Option<String> {
    let fast = SsController::poles_beyond_nyquist(sys, ts);
    let (pole, hz) = fast.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    Some(format!(
        "warning: {source}: {} continuous pole(s) beyond the Nyquist frequency {} Hz of ts = {ts} s, the fastest {}{:+}j rad/s ({hz:.4e} Hz); the discretised controller does not reproduce them: sample faster or reduce the controller",
        fast.len(),
        0.5 / ts,
        pole.re,
        pole.im
    ))
}

/// \[Li21\] Eq. 5's PID as a state-space block on the error (the DOB's
/// outer controller sees only the error, so its derivative acts on the
/// error, not the measurement): `I(k) = I(k-1) + ki e(k)`,
/// `u = kp e + I(k) + kd (e(k) - e(k-1))`; states `I(k-1)` and, with a
/// derivative, `e(k-1)`; conditional update as the PID's conditional
/// integration.
fn pid_block(pid: &PidSpec) -> StateSpaceBlock {
    let (a, b, c) = if pid.kd == 0.0 {
        (vec![1.0], vec![pid.ki], vec![1.0])
    } else {
        (
            vec![1.0, 0.0, 0.0, 0.0],
            vec![pid.ki, 1.0],
            vec![1.0, -pid.kd],
        )
    };
    StateSpaceBlock {
        a,
        b,
        c,
        d: pid.kp + pid.ki + pid.kd,
        output_min: Some(pid.output_min),
        output_max: Some(pid.output_max),
        anti_windup: SsAntiWindup::ConditionalUpdate,
        discretisation: format!(
            "[Li21] Eq. 5 PID kp {} ki {} kd {} per sample (derivative on the error)",
            pid.kp, pid.ki, pid.kd
        ),
    }
}

/// A coefficient file runs at the plant's sample time or not at all.
fn checked_file(file: ControllerFile, source: &str, ts: f64) -> Result<ControllerFile, StepError> {
    if (file.ts - ts).abs() > 1e-12 * ts {
        return Err(StepError::input(format!(
            "{source} field 'ts': {} s, but the plant runs at {ts} s",
            file.ts
        )));
    }
    Ok(file)
}

/// Identifies the models `m` lacks from the virtual FTS run with this PID
/// (simulated measurements only); returns where they came from.
fn identify_missing(
    m: &mut StageModels,
    plant: &VirtualFtsParams,
    pid: PidSpec,
) -> Result<String, StepError> {
    let params = ExperimentParams {
        plant: plant.clone(),
        seed: plant.seed,
        pid,
        ..ExperimentParams::default()
    };
    let models = experiment::identify_models(&params, &mut |_| {})
        .map_err(|e| StepError::computation(e.to_string()))?;
    let origin = identified_origin(&models, &params);
    m.hysteresis = m.hysteresis.take().or(Some(models.inverse.model));
    m.zpetc = m.zpetc.take().or(Some(models.zpetc));
    // Learning control inverts the loop up to Q's cutoff: the wide-band
    // learning model, not the ZPETC's 0-1 kHz one (docs/learning.md).
    let learning = models.learning.map(|l| l.model.tf);
    m.closed_loop = m
        .closed_loop
        .take()
        .or(learning)
        .or(Some(models.closed_loop.tf));
    Ok(origin)
}

/// Where identified models came from, with their fit.
fn identified_origin(models: &IdentifiedModels, params: &ExperimentParams) -> String {
    let learning = models
        .learning
        .as_ref()
        .map(|l| {
            format!(
                ", learning model (0-{} Hz) {} [{} {} {}] simulation fit {:.1} %",
                l.sweep_f1,
                l.model.method,
                l.orders.na,
                l.orders.nb,
                l.orders.nk,
                l.model.chosen_fit().simulation_percent
            )
        })
        .unwrap_or_default();
    format!(
        "models identified from the virtual FTS: inverse {} fit {:.2} % rms, closed loop {} [{} {} {}] simulation fit {:.1} %{learning}",
        models.inverse.model.kind.name(),
        models.inverse.info.fit.rms_percent,
        models.closed_loop.method,
        params.orders.na,
        params.orders.nb,
        params.orders.nk,
        models.closed_loop.arx_fit.simulation_percent
    )
}

/// Runs the file's controller on `plant`; a diverging loop is an error
/// naming when, which signal, and the likely cause.
fn run_on<P: Plant>(
    plant: &mut P,
    file: &ControllerFile,
    reference: &Reference,
    plant_model: Option<(&DiscreteTf, &str)>,
) -> Result<closed_loop::Trace, StepError> {
    let mut rt = RuntimeController::new(&file.runtime_spec())
        .map_err(|e| StepError::input(format!("controller: {e}")))?;
    closed_loop::run_learned(
        plant,
        &mut rt,
        &reference.samples,
        file.learned_feedforward(),
    )
    .map_err(|d| StepError::computation(format!("{d}; {}", likely_cause(file, plant_model))))
}

/// Why a loop most likely diverged, from the stability of the models it is
/// made of: an unstable ZPETC denominator runs away on its own; an unstable
/// plant needs a controller that stabilises it; otherwise the feedback
/// controller destabilises the plant.
fn likely_cause(file: &ControllerFile, plant_model: Option<(&DiscreteTf, &str)>) -> String {
    let unstable = |num: Vec<f64>, den: &[f64]| {
        DiscreteTf::new(num, den.to_vec(), 0, file.ts).is_ok_and(|g| g.is_stable() == Ok(false))
    };
    if let Some(z) = &file.zpetc
        && unstable(vec![1.0], &z.den)
    {
        return "likely cause: the ZPETC filter's denominator has a root outside the unit circle"
            .into();
    }
    if let Some((g, source)) = plant_model
        && g.is_stable() == Ok(false)
    {
        return format!(
            "likely cause: the plant model {source} is unstable and the feedback controller does not stabilise it"
        );
    }
    "likely cause: the feedback controller destabilises the plant (check the loop's margins)".into()
}

/// A tracking run: the controller run, the reference, the trace and its
/// figures over the evaluated window.
#[derive(Debug, Clone)]
pub struct SimulateReport {
    /// The coefficient file that ran.
    pub file: ControllerFile,
    /// Where its models came from.
    pub models: String,
    /// The reference, with its evaluated window.
    pub reference: Reference,
    /// Every signal of the loop, sample by sample.
    pub trace: closed_loop::Trace,
    /// Tracking figures over the evaluated window.
    pub metrics: closed_loop::TrackingMetrics,
    /// Step figures of a step reference (`None` for other references).
    pub step: Option<Result<StepTracking, NoStepInfo>>,
    /// With a repetitive compensator: the largest `|e|` over each of its
    /// whole periods from the run's first sample (the compensator learns
    /// from there on, through the lead-in) to the end of the evaluated
    /// window, how its error contracts.
    pub periods: Option<Vec<f64>>,
    /// For a sine reference: the tracking error's fundamental and its 2nd
    /// and 3rd harmonics over the evaluated window (whole periods).
    pub harmonics: Option<Vec<closed_loop::ErrorHarmonic>>,
}

/// The columns of the simulation trace CSV (`fts simulate -o`), in order:
/// time, reference, filtered reference, feedforward, command, measurement,
/// error.
pub const TRACE_COLUMNS: [&str; 7] = ["t", "r", "r_f", "u_ff", "u", "y", "e"];

impl SimulateReport {
    fn new(
        file: ControllerFile,
        models: String,
        reference: Reference,
        trace: closed_loop::Trace,
        step: Option<Result<StepTracking, NoStepInfo>>,
    ) -> Self {
        let metrics = closed_loop::metrics(&trace, reference.evaluated(), file.command_limits());
        let periods = file.repetitive.as_ref().map(|rc| {
            let period = rc.period as f64 + rc.fraction;
            let error = &trace.error()[..reference.evaluate_to];
            closed_loop::max_error_per_period(error, 0, period)
        });
        Self {
            file,
            models,
            reference,
            trace,
            metrics,
            step,
            periods,
            harmonics: None,
        }
    }

    /// The time of each sample, s.
    pub fn times(&self) -> Vec<f64> {
        (0..self.trace.reference.len())
            .map(|k| k as f64 * self.trace.ts)
            .collect()
    }

    /// Where the evaluated window starts, s.
    pub fn evaluated_from_s(&self) -> f64 {
        self.metrics.start as f64 * self.trace.ts
    }

    /// The trace as CSV, its columns [`TRACE_COLUMNS`].
    pub fn trace_csv(&self) -> String {
        let t = &self.trace;
        crate::io::timeseries::write_csv(
            &TRACE_COLUMNS,
            &[
                &self.times(),
                &t.reference,
                &t.filtered_reference,
                &t.feedforward,
                &t.command,
                &t.measurement,
                &t.error(),
            ],
        )
    }
}

impl Serialize for SimulateReport {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let m = &self.metrics;
        json!({
            "step": self.step.as_ref().map(|s| match s {
                Ok(s) => json!(s),
                Err(e) => json!({"no_step_info": e.to_string()}),
            }),
            "controller": self.file.stages_name(),
            "reference": self.reference.label,
            "max_abs_error": m.max_abs_error,
            "rms_error": m.rms_error,
            "max_error_percent": m.max_error_percent,
            "amplitude": m.amplitude,
            "evaluated_from_s": self.evaluated_from_s(),
            "evaluated_samples": m.samples,
            "saturated_samples": m.saturated_samples,
            "preview": self.file.preview(),
            "ts": self.trace.ts,
            "models": self.models,
            "max_error_per_period": self.periods,
            "error_harmonics": self.harmonics,
        })
        .serialize(s)
    }
}

impl fmt::Display for SimulateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.metrics;
        writeln!(
            f,
            "controller: {} ({})",
            self.file.stages_name(),
            self.models
        )?;
        writeln!(
            f,
            "reference: {}, evaluated from t = {:.3} s ({} samples; lead-in and settling excluded)",
            self.reference.label,
            self.evaluated_from_s(),
            m.samples
        )?;
        if m.max_error_percent.is_finite() {
            writeln!(
                f,
                "tracking error: max {:.4} um, rms {:.4} um, max {:.2} % of the {:.3} um amplitude",
                m.max_abs_error, m.rms_error, m.max_error_percent, m.amplitude
            )?;
        } else {
            // A constant reference (from a file) has no amplitude to relate to.
            writeln!(
                f,
                "tracking error: max {:.4} um, rms {:.4} um (the reference is constant: no % of its amplitude)",
                m.max_abs_error, m.rms_error
            )?;
        }
        if let Some(h) = &self.harmonics {
            let parts: Vec<String> = h
                .iter()
                .map(|h| format!("{:.4} um at {} Hz", h.amplitude, fmt_hz(h.freq)))
                .collect();
            writeln!(f, "error harmonics: {}", parts.join(", "))?;
        }
        match &self.step {
            Some(Ok(s)) => write_step(f, s)?,
            Some(Err(e)) => writeln!(f, "step: no figures: {e}")?,
            None => {}
        }
        if let Some(periods) = &self.periods {
            write_periods(f, periods)?;
        }
        if m.saturated_samples > 0 {
            let (lo, hi) = self.file.command_limits();
            writeln!(
                f,
                "warning: the command sat on its limits ({lo} .. {hi} V) for {} samples: the reference leaves the actuator's range or the loop overshoots",
                m.saturated_samples
            )?;
        }
        Ok(())
    }
}

/// The repetitive compensator's convergence: max |e| per period, ten a line.
fn write_periods(f: &mut fmt::Formatter<'_>, periods: &[f64]) -> fmt::Result {
    let (Some(first), Some(last)) = (periods.first(), periods.last()) else {
        return writeln!(
            f,
            "repetitive: the run is shorter than one period after the lead-in"
        );
    };
    writeln!(
        f,
        "repetitive: max |e| per period from the run's start, {} periods: {first:.4} -> {last:.4} um ({:.1}x)",
        periods.len(),
        first / last
    )?;
    for (row, chunk) in periods.chunks(10).enumerate() {
        let values: Vec<String> = chunk.iter().map(|v| format!("{v:.4}")).collect();
        writeln!(f, "  {:>4}: {}", 10 * row + 1, values.join(" "))?;
    }
    Ok(())
}

/// The step figures' summary line.
fn write_step(f: &mut fmt::Formatter<'_>, s: &StepTracking) -> fmt::Result {
    let i = &s.info;
    let ms =
        |x: Option<f64>, none: &str| x.map_or(none.to_string(), |v| format!("{:.3} ms", v * 1e3));
    writeln!(
        f,
        "step: rise (10-90 %) {}, settling (2 %) {}, overshoot {:.2} %, undershoot {:.2} %, steady-state error {:.4} um",
        ms(i.rise_time, "not reached"),
        ms(i.settling_time, "not settled"),
        i.overshoot,
        i.undershoot,
        s.steady_state_error
    )
}

/// A frequency as `100` or `33.5` (no trailing zeros).
fn fmt_hz(f: f64) -> String {
    let s = format!("{f:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    /// \[Li21\] Eq. 11, the closed loop of PID + hysteresis compensation.
    fn li21_closed_loop() -> DiscreteTf {
        DiscreteTf::new(
            vec![4.154, -9.631, 10.23, -5.511, 1.154],
            vec![1.0, -0.7852, 0.7299, -0.614, 0.05156, 0.03447],
            5,
            1e-4,
        )
        .unwrap()
    }

    fn on_model(tf: DiscreteTf, controller: SimController) -> SimulateInputs {
        SimulateInputs {
            plant: SimPlant::Model {
                tf,
                hysteresis: None,
                source: "g.json".into(),
            },
            controller,
            reference_samples: None,
        }
    }

    pub fn settings_deserialise_with_their_defaults() {
        let s: Simulate = toml::from_str("").unwrap();
        assert_eq!(s, Simulate::default());
        let s: Simulate = toml::from_str("reference = \"five-leaf\"\nkp = 0.03").unwrap();
        assert_eq!(s.reference, ReferenceShape::FiveLeaf);
        assert_eq!(s.kp, 0.03);
        assert!(toml::from_str::<Simulate>("amplitud = 3").is_err());
        let bad = Simulate {
            controller: Some("pid+magic".into()),
            ..Simulate::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(StepError::Input {
                field: Some("controller"),
                ..
            })
        ));
    }

    /// A feedforward-only ZPETC on the closed loop it inverts tracks
    /// exactly (it cancels all of this loop's zeros and poles).
    pub fn zpetc_on_its_closed_loop_tracks_exactly() {
        let g = li21_closed_loop();
        let zpetc = crate::synth::zpetc::design(&g, &Default::default()).unwrap();
        let step = Simulate {
            controller: Some("zpec".into()),
            ..Simulate::default()
        };
        let models = StageModels {
            zpetc: Some(zpetc),
            ..StageModels::default()
        };
        let report = step
            .run(on_model(g, SimController::Stages(models)))
            .unwrap();
        assert_eq!(report.file.stages_name(), "zpec");
        assert!(report.metrics.max_abs_error < 1e-9, "{report}");
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["controller"], "zpec");
        assert!(
            report
                .to_string()
                .starts_with("controller: zpec (models from files)\n")
        );
    }

    /// A loop that runs away is a computation error naming when and why.
    pub fn a_diverging_loop_names_time_and_cause() {
        let unstable = DiscreteTf::new(vec![0.1], vec![1.0, -1.05], 1, 1e-4).unwrap();
        let step = Simulate {
            controller: Some("pid".into()),
            ..Simulate::default()
        };
        let e = step
            .run(on_model(
                unstable,
                SimController::Stages(StageModels::default()),
            ))
            .unwrap_err();
        let StepError::Computation(message) = e else {
            panic!("{e:?}");
        };
        assert!(message.contains("diverged at t = "), "{message}");
        assert!(
            message.contains("plant model g.json is unstable"),
            "{message}"
        );
    }

    /// Models a stage needs must be given on a linear plant: there is no
    /// virtual FTS to identify them from.
    pub fn missing_models_on_a_linear_plant_are_named() {
        let step = Simulate {
            controller: Some("pid+hc".into()),
            ..Simulate::default()
        };
        let e = step
            .run(on_model(
                li21_closed_loop(),
                SimController::Stages(StageModels::default()),
            ))
            .unwrap_err();
        assert!(e.to_string().contains("`hysteresis` for hc"), "{e}");
    }
}
