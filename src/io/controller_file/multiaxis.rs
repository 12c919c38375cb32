//! The multi-axis controller file `fts.multiaxis-controller/1`
//! (docs/formats.md, docs/contouring.md): the three axis feedback
//! controllers and the cross-coupling controller of
//! [`crate::runtime::CrossCoupledStep`], with the sample time, units and
//! provenance; and its C header with the loader of `fts_multiaxis_init`.
//!
//! Each controller is a block of the single-axis file (`pid`, either form,
//! or `state_space`), written and checked by the same code, so a block
//! moves between the two files unchanged. Keys are in alphabetical order and
//! floats in their shortest round-trip form, so the same inputs give the
//! same bytes.

use super::c_header::{c_array, c_double, write_defines};
use super::document::{Block, feedback_block, read_feedback};
use super::{Feedback, Provenance, Units, runtime_field};
use crate::io::InputError;
use crate::io::serde_doc::{At, from_value, parse_object, top};
use crate::runtime::{CrossCoupledStep, FeedbackSpec, SsAntiWindup};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::fmt::Write;

/// The format tag.
pub const MULTIAXIS_FORMAT: &str = "fts.multiaxis-controller/1";

/// The contour-error estimate the coupling acts on, named in the file.
const ESTIMATE: &str = "yeh-hsu: eps = e - (e . t) t";

/// Three axis controllers and the optional cross-coupling controller.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiAxisControllerFile {
    /// Sample time, s.
    pub ts: f64,
    /// Signal units (the same for the three axes).
    pub units: Units,
    /// The feedback controllers of x, y and z (`u_i = K_i[r_i - y_i]`).
    pub axes: [Feedback; 3],
    /// The controller of each component of the contour-error estimate,
    /// one copy per axis; `None`: the axes run uncoupled.
    pub cross_coupling: Option<Feedback>,
    /// Provenance.
    pub provenance: Provenance,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct AxesDoc<B> {
    x: B,
    y: B,
    z: B,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MultiAxisDoc<B> {
    format: String,
    ts: f64,
    units: Units,
    contour_estimate: String,
    axes: AxesDoc<B>,
    cross_coupling: Option<B>,
    #[serde(default)]
    provenance: Provenance,
}

impl MultiAxisControllerFile {
    /// The runtime's coefficients: the three axes and the coupling.
    pub fn runtime_specs(&self) -> ([FeedbackSpec<'_>; 3], Option<FeedbackSpec<'_>>) {
        (
            [0, 1, 2].map(|i| self.axes[i].runtime_spec(self.ts)),
            self.cross_coupling
                .as_ref()
                .map(|c| c.runtime_spec(self.ts)),
        )
    }

    /// The loaded step, at rest.
    pub fn runtime_step(&self) -> Result<CrossCoupledStep, crate::runtime::RuntimeError> {
        let (axes, cross) = self.runtime_specs();
        CrossCoupledStep::new([&axes[0], &axes[1], &axes[2]], cross.as_ref())
    }

    /// The file text: pretty JSON, keys in alphabetical order, a trailing newline.
    pub fn to_json_string(&self) -> String {
        let block = |f: &Feedback| feedback_block(f, self.ts);
        let doc: MultiAxisDoc<Block<'static>> = MultiAxisDoc {
            format: MULTIAXIS_FORMAT.to_owned(),
            ts: self.ts,
            units: self.units.clone(),
            contour_estimate: ESTIMATE.to_owned(),
            axes: AxesDoc {
                x: block(&self.axes[0]),
                y: block(&self.axes[1]),
                z: block(&self.axes[2]),
            },
            cross_coupling: self.cross_coupling.as_ref().map(block),
            provenance: self.provenance.clone(),
        };
        let value = serde_json::to_value(doc).expect("serialisable");
        let mut s = serde_json::to_string_pretty(&value).expect("serialisable");
        s.push('\n');
        s
    }

    /// Checks that the file loads into the runtime step.
    pub fn validate(&self, source: &str) -> Result<(), InputError> {
        if !(self.ts.is_finite() && self.ts > 0.0) {
            let e = InputError::new(source, "expected a positive number of seconds");
            return Err(e.in_field("ts"));
        }
        for (i, f) in self.axes.iter().enumerate() {
            crate::runtime::RuntimeController::new(&crate::runtime::RuntimeSpec {
                zpetc: None,
                hysteresis: None,
                feedback: f.runtime_spec(self.ts),
                repetitive: None,
            })
            .map_err(|e| {
                let field = format!("axes.{}.{}", AXIS_NAMES[i], runtime_field(&e));
                InputError::new(source, e.to_string()).in_field(field)
            })?;
        }
        self.runtime_step().map(|_| ()).map_err(|e| {
            let field = match runtime_field(&e) {
                "cross_coupling" | "axes.feedback" => runtime_field(&e).to_owned(),
                f => format!("cross_coupling.{f}"),
            };
            InputError::new(source, e.to_string()).in_field(field)
        })
    }
}

const AXIS_NAMES: [&str; 3] = ["x", "y", "z"];

/// Parses and validates an `fts.multiaxis-controller/1` document.
pub fn parse_multiaxis(text: &str, source: &str) -> Result<MultiAxisControllerFile, InputError> {
    let value = parse_object(text, source, MULTIAXIS_FORMAT)?;
    let doc: MultiAxisDoc<Value> = from_value(value, top(source))?;
    if doc.contour_estimate != ESTIMATE {
        return Err(top(source).err(
            "contour_estimate",
            format!(
                "expected {ESTIMATE:?} (the only estimate the runtime computes), found {:?}",
                doc.contour_estimate
            ),
        ));
    }
    let read = |block: Value, path: &str| {
        let at = At { source, path };
        match read_feedback(block, at, doc.ts)? {
            Feedback::None => Err(at.err("type", "expected \"pid\" or \"state_space\"")),
            f => Ok(f),
        }
    };
    let AxesDoc { x, y, z } = doc.axes;
    let file = MultiAxisControllerFile {
        ts: doc.ts,
        units: doc.units,
        axes: [read(x, "axes.x")?, read(y, "axes.y")?, read(z, "axes.z")?],
        cross_coupling: doc
            .cross_coupling
            .map(|c| read(c, "cross_coupling"))
            .transpose()?,
        provenance: doc.provenance,
    };
    file.validate(source)?;
    Ok(file)
}

/// The runtime's `fts_feedback_kind` of a block.
fn kind(spec: &FeedbackSpec<'_>) -> (u8, &'static str) {
    match spec {
        FeedbackSpec::None => (0, "FTS_FEEDBACK_NONE"),
        FeedbackSpec::Pid(_) => (1, "FTS_FEEDBACK_PID"),
        FeedbackSpec::PidFiltered(_) => (2, "FTS_FEEDBACK_PID_FILTERED"),
        FeedbackSpec::StateSpace(_) => (3, "FTS_FEEDBACK_STATE_SPACE"),
        FeedbackSpec::Dob(_) => (4, "FTS_FEEDBACK_DOB"),
    }
}

/// One controller's numbers under `prefix` (`FTS_X`, .., `FTS_CC`): the
/// kind, the per-sample PID coefficients (0 for a state-space block) and
/// the state-space arrays (empty for a PID), so that the loader is the same
/// for every kind.
fn write_block(out: &mut String, prefix: &str, what: &str, spec: &FeedbackSpec<'_>) {
    let (number, name) = kind(spec);
    let _ = writeln!(
        out,
        "\n/* {what}: {name} */\n#define {prefix}_KIND {number}"
    );
    let zero_pid = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let (kp, ki, kd, pole, lo, hi) = match spec {
        FeedbackSpec::Pid(p) => (p.kp, p.ki, p.kd, 0.0, p.output_min, p.output_max),
        FeedbackSpec::PidFiltered(p) => (
            p.kp,
            p.ki,
            p.kd,
            p.derivative_pole,
            p.output_min,
            p.output_max,
        ),
        _ => zero_pid,
    };
    let names = [
        "KP",
        "KI",
        "KD",
        "DERIVATIVE_POLE",
        "OUTPUT_MIN",
        "OUTPUT_MAX",
    ];
    let values = [kp, ki, kd, pole, lo, hi];
    let defines: Vec<(String, f64)> = names
        .iter()
        .zip(values)
        .map(|(n, v)| (format!("{prefix}_PID_{n}"), v))
        .collect();
    let borrowed: Vec<(&str, f64)> = defines.iter().map(|(n, v)| (n.as_str(), *v)).collect();
    write_defines(out, &borrowed);
    let (a, b, c, d, conditional) = match spec {
        FeedbackSpec::StateSpace(k)
        | FeedbackSpec::Dob(crate::runtime::DobSpec { outer: k, .. }) => (
            k.a,
            k.b,
            k.c,
            k.d,
            k.anti_windup == SsAntiWindup::ConditionalUpdate,
        ),
        _ => (&[][..], &[][..], &[][..], 0.0, false),
    };
    let _ = writeln!(out, "#define {prefix}_SS_NX {}", b.len());
    c_array(out, &format!("{prefix}_SS_A"), a);
    c_array(out, &format!("{prefix}_SS_B"), b);
    c_array(out, &format!("{prefix}_SS_C"), c);
    let _ = writeln!(out, "#define {prefix}_SS_D {}", c_double(d));
    let _ = writeln!(
        out,
        "#define {prefix}_SS_CONDITIONAL_UPDATE {}",
        u8::from(conditional)
    );
    if let FeedbackSpec::Dob(d) = spec {
        super::c_header::write_dob_observer(out, prefix, d, "");
    }
}

/// A state-space limit as a C expression (`fts_infinity()` when absent).
fn c_limit(v: f64) -> String {
    if v == f64::INFINITY {
        "fts_infinity()".into()
    } else if v == f64::NEG_INFINITY {
        "-fts_infinity()".into()
    } else {
        c_double(v)
    }
}

/// The assignments filling an `fts_feedback_spec` named `var` from `prefix`.
fn loader_block(out: &mut String, var: &str, prefix: &str, spec: &FeedbackSpec<'_>) {
    let (lo, hi) = spec.limits();
    let (ss_lo, ss_hi) = match spec {
        FeedbackSpec::StateSpace(_) | FeedbackSpec::Dob(_) => (c_limit(lo), c_limit(hi)),
        _ => ("-fts_infinity()".into(), "fts_infinity()".into()),
    };
    let _ = write!(
        out,
        "    {var}.kind = {};\n    {var}.pid.kp = {prefix}_PID_KP;\n    {var}.pid.ki = {prefix}_PID_KI;\n    {var}.pid.kd = {prefix}_PID_KD;\n    {var}.pid.derivative_pole = {prefix}_PID_DERIVATIVE_POLE;\n    {var}.pid.output_min = {prefix}_PID_OUTPUT_MIN;\n    {var}.pid.output_max = {prefix}_PID_OUTPUT_MAX;\n    {var}.ss.n = {prefix}_SS_NX;\n    {var}.ss.a = {prefix}_SS_A;\n    {var}.ss.b = {prefix}_SS_B;\n    {var}.ss.c = {prefix}_SS_C;\n    {var}.ss.d = {prefix}_SS_D;\n    {var}.ss.output_min = {ss_lo};\n    {var}.ss.output_max = {ss_hi};\n    {var}.ss.conditional_update = {prefix}_SS_CONDITIONAL_UPDATE;\n",
        kind(spec).1
    );
    if let FeedbackSpec::Dob(_) = spec {
        super::c_header::dob_loader(out, var, prefix);
    }
}

/// The blocks' prefixes and descriptions.
const PREFIXES: [(&str, &str); 3] = [
    ("FTS_X", "axis x controller"),
    ("FTS_Y", "axis y controller"),
    ("FTS_Z", "axis z controller"),
];

/// The C header of `fts emit --multiaxis`: the numbers of every block and
/// `fts_multiaxis_controller_init`, which loads them into an `fts_multiaxis`
/// (`fts_runtime.h`, written beside it by `--format c`).
pub fn to_multiaxis_c_header(file: &MultiAxisControllerFile) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "/* {MULTIAXIS_FORMAT} coefficients, generated by fts {}; do not edit.\n * Per sample: e = r - y, eps = e - (e . t) t (t the unit tangent at r),\n *   u_i = K_i[r_i, y_i] + K_cc[0, -eps_i] (fts_multiaxis_step).\n * Units: reference {}, measurement {}, command {}.",
        file.provenance.fts_version,
        file.units.reference,
        file.units.measurement,
        file.units.command
    );
    for i in &file.provenance.inputs {
        let _ = writeln!(out, " * input {} ({}): sha256 {}", i.role, i.file, i.sha256);
    }
    out.push_str(
        " */\n#ifndef FTS_MULTIAXIS_H\n#define FTS_MULTIAXIS_H\n\n#include \"fts_runtime.h\"\n\n",
    );
    let _ = writeln!(out, "#define FTS_MULTIAXIS_FORMAT \"{MULTIAXIS_FORMAT}\"");
    let _ = writeln!(out, "#define FTS_TS {}", c_double(file.ts));
    let (axes, cross) = file.runtime_specs();
    let _ = writeln!(
        out,
        "#define FTS_HAS_CROSS_COUPLING {}",
        u8::from(cross.is_some())
    );
    for ((prefix, what), spec) in PREFIXES.iter().zip(&axes) {
        write_block(&mut out, prefix, what, spec);
    }
    let none = FeedbackSpec::None;
    let cc = cross.as_ref().unwrap_or(&none);
    write_block(&mut out, "FTS_CC", "cross-coupling controller", cc);
    out.push_str("\n/* Loads the numbers above into m, at rest; on an error *field (when not NULL) names the list. */\nstatic fts_status fts_multiaxis_controller_init(fts_multiaxis *m, const char **field)\n{\n    fts_feedback_spec axes[3];\n    fts_feedback_spec cross;\n");
    for (i, ((prefix, _), spec)) in PREFIXES.iter().zip(&axes).enumerate() {
        loader_block(&mut out, &format!("axes[{i}]"), prefix, spec);
    }
    loader_block(&mut out, "cross", "FTS_CC", cc);
    out.push_str("    return fts_multiaxis_init(m, axes, FTS_HAS_CROSS_COUPLING ? &cross : NULL, field);\n}\n\n#endif /* FTS_MULTIAXIS_H */\n");
    out
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::super::{ParallelPid, StateSpaceBlock};
    use super::*;
    use crate::runtime::PidSpec;
    use serde_json::json;

    pub(crate) fn sample() -> MultiAxisControllerFile {
        let ss = StateSpaceBlock {
            a: vec![0.5, 0.1, -0.2, 0.25],
            b: vec![1.0, -2.0 / 3.0],
            c: vec![0.1, 3e-7],
            d: 0.2,
            output_min: Some(-5.0),
            output_max: None,
            anti_windup: SsAntiWindup::ConditionalUpdate,
            discretisation: "tustin".into(),
        };
        MultiAxisControllerFile {
            ts: 1e-5,
            units: Units::default(),
            axes: [
                Feedback::ParallelPid(ParallelPid {
                    kp: 1.0,
                    ki: 0.01,
                    kd: 0.0005,
                    n: Some(100.0),
                    output_min: -10.0,
                    output_max: 10.0,
                }),
                Feedback::StateSpace(ss),
                Feedback::Pid(PidSpec {
                    kp: 0.1 + 0.2,
                    ki: 1e-3,
                    kd: 0.0,
                    output_min: -1.0,
                    output_max: 1.0,
                }),
            ],
            cross_coupling: Some(Feedback::ParallelPid(ParallelPid {
                kp: 0.4,
                ki: 0.005,
                kd: 0.0005,
                n: Some(100.0),
                output_min: -10.0,
                output_max: 10.0,
            })),
            provenance: Provenance {
                fts_version: "0.1.0".into(),
                inputs: vec![],
            },
        }
    }

    pub fn json_round_trip_is_exact_and_byte_stable() {
        let mut f = sample();
        for cross in [f.cross_coupling.clone(), None] {
            f.cross_coupling = cross;
            let text = f.to_json_string();
            let back = parse_multiaxis(&text, "k.json").unwrap_or_else(|e| panic!("{e}\n{text}"));
            assert_eq!(back, f);
            assert_eq!(back.to_json_string(), text);
        }
    }

    fn error_of(edit: impl Fn(&mut Value)) -> InputError {
        let mut doc: Value = serde_json::from_str(&sample().to_json_string()).unwrap();
        edit(&mut doc);
        parse_multiaxis(&doc.to_string(), "k.json").unwrap_err()
    }

    pub fn bad_files_name_the_field() {
        type Edit<'a> = &'a dyn Fn(&mut Value);
        let cases: [(Edit, &str); 7] = [
            (&|d| d["format"] = json!("fts.controller/1"), "format"),
            (
                &|d| d["axes"]["y"]["a"][1][0] = json!("x"),
                "axes.y.a[1][0]",
            ),
            (&|d| d["axes"]["w"] = json!({}), "axes.w"),
            (
                &|d| d["axes"]["z"]["type"] = json!("no_feedback"),
                "axes.z.type",
            ),
            (
                &|d| d["cross_coupling"]["kd"] = json!(1.0),
                "cross_coupling.kd",
            ),
            (&|d| d["axes"]["y"]["ts"] = json!(1e-4), "axes.y.ts"),
            (
                &|d| d["contour_estimate"] = json!("exact"),
                "contour_estimate",
            ),
        ];
        for (edit, field) in cases {
            let e = error_of(edit);
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
        }
        // The runtime's own checks, named below the block.
        let e = error_of(|d: &mut Value| d["axes"]["z"]["output_min"] = json!(2.0));
        assert_eq!(e.field.as_deref(), Some("axes.z.pid.output_min"), "{e}");
    }

    pub fn the_c_header_is_deterministic_and_carries_every_block() {
        let f = sample();
        let h = to_multiaxis_c_header(&f);
        assert_eq!(h, to_multiaxis_c_header(&f.clone()));
        for needle in [
            "#define FTS_X_KIND 2",
            "#define FTS_Y_KIND 3",
            "#define FTS_Z_KIND 1",
            "#define FTS_CC_KIND 2",
            "#define FTS_Z_PID_KP 3.0000000000000004e-1",
            "static const double FTS_Y_SS_B[2] = { 1e0, -6.666666666666666e-1 };",
            "    axes[1].ss.output_min = -5e0;\n    axes[1].ss.output_max = fts_infinity();",
            "#define FTS_HAS_CROSS_COUPLING 1",
        ] {
            assert!(h.contains(needle), "{needle}\n{h}");
        }
    }
}
