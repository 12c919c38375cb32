//! The composite controller of \[Li21\] Fig. 5 and its stage grammar:
//! a feedback stage (`pid`, `ss` for a discrete state-space controller
//! such as an H2 / H-infinity / mixsyn design, or `dob` for either inside
//! \[Karagoz18\]'s disturbance observer), optionally followed by
//! hysteresis compensation feedforward (`hc`) and the ZPETC reference
//! pre-filter (`zpec`): `pid`, `pid+hc`, `pid+zpec`, `pid+hc+zpec`, `ss`,
//! `ss+hc`, `ss+zpec`, `ss+hc+zpec`, `dob`, `dob+hc`, `dob+zpec`,
//! `dob+hc+zpec`; or feedforward only, without a
//! feedback stage: `hc`, `zpec`, `hc+zpec`.

/// The feedback controller of a composite controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedbackKind {
    /// The \[Li21\] Eq. 5 PID.
    Pid,
    /// A discrete state-space controller (`state_space` block).
    StateSpace,
    /// The PID or a state-space controller inside a disturbance observer
    /// with friction feedforward (`dob` block, `synth::dob`).
    Dob,
    /// None: a feedforward-only controller (`no_feedback` block).
    None,
}

/// Which stages a composite controller has: at most one feedback
/// controller, and at least one stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stages {
    /// The feedback controller.
    pub feedback: FeedbackKind,
    /// Inverse-hysteresis feedforward (HC).
    pub hysteresis_compensation: bool,
    /// ZPETC reference pre-filter (ZPEC).
    pub zpetc: bool,
}

/// The forms `--controller` accepts, in order.
pub const VALID_STAGE_STRINGS: [&str; 15] = [
    "pid",
    "pid+hc",
    "pid+zpec",
    "pid+hc+zpec",
    "ss",
    "ss+hc",
    "ss+zpec",
    "ss+hc+zpec",
    "dob",
    "dob+hc",
    "dob+zpec",
    "dob+hc+zpec",
    "hc",
    "zpec",
    "hc+zpec",
];

/// Why a stage string is not understood.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}; valid controllers: {}", VALID_STAGE_STRINGS.join(", "))]
pub struct StageError {
    /// What is wrong.
    pub message: String,
}

impl Stages {
    /// The PID with the given feedforward stages.
    pub fn pid(hysteresis_compensation: bool, zpetc: bool) -> Self {
        Self {
            feedback: FeedbackKind::Pid,
            hysteresis_compensation,
            zpetc,
        }
    }

    /// Parses `pid|ss|dob[+hc][+zpec]` (case-insensitive; `zpetc` is accepted
    /// for `zpec`, `state_space` for `ss`).
    pub fn parse(text: &str) -> Result<Stages, StageError> {
        let lower = text.trim().to_ascii_lowercase();
        let parts: Vec<&str> = lower.split('+').map(str::trim).collect();
        // pid, ss and dob share rank 0: the feedback stage.
        let known = [("pid", 0), ("ss", 0), ("dob", 0), ("hc", 1), ("zpec", 2)];
        let mut ranks = Vec::new();
        let mut feedback = FeedbackKind::Pid;
        for p in &parts {
            let p = match *p {
                "zpetc" => "zpec",
                "state_space" | "state-space" => "ss",
                other => other,
            };
            match known.iter().find(|(k, _)| *k == p) {
                Some((k, r)) => {
                    match *k {
                        "ss" => feedback = FeedbackKind::StateSpace,
                        "dob" => feedback = FeedbackKind::Dob,
                        _ => {}
                    }
                    ranks.push(*r);
                }
                None => {
                    return Err(StageError {
                        message: format!("unknown stage {p:?} in {text:?}"),
                    });
                }
            }
        }
        if ranks.first() != Some(&0) {
            feedback = FeedbackKind::None;
        }
        if ranks.windows(2).any(|w| w[0] >= w[1]) {
            return Err(StageError {
                message: format!(
                    "stages in {text:?} are repeated or out of order (pid, ss or dob if any, then hc, then zpec)"
                ),
            });
        }
        Ok(Stages {
            feedback,
            hysteresis_compensation: ranks.contains(&1),
            zpetc: ranks.contains(&2),
        })
    }

    /// The canonical spelling.
    pub fn name(&self) -> &'static str {
        let i = usize::from(self.hysteresis_compensation) + 2 * usize::from(self.zpetc);
        if self.feedback == FeedbackKind::None {
            // Feedforward only ("" cannot be parsed: there is no empty controller).
            return ["", "hc", "zpec", "hc+zpec"][i];
        }
        let i = i + 4 * match self.feedback {
            FeedbackKind::StateSpace => 1,
            FeedbackKind::Dob => 2,
            _ => 0,
        };
        [
            "pid",
            "pid+hc",
            "pid+zpec",
            "pid+hc+zpec",
            "ss",
            "ss+hc",
            "ss+zpec",
            "ss+hc+zpec",
            "dob",
            "dob+hc",
            "dob+zpec",
            "dob+hc+zpec",
        ][i]
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn grammar() {
        for s in VALID_STAGE_STRINGS {
            assert_eq!(Stages::parse(s).unwrap().name(), s);
        }
        assert_eq!(Stages::parse("PID+HC+ZPETC").unwrap().name(), "pid+hc+zpec");
        assert_eq!(
            Stages::parse("state_space+zpetc").unwrap().feedback,
            FeedbackKind::StateSpace
        );
        let e = Stages::parse("hc+pid").unwrap_err();
        assert!(e.to_string().contains("out of order"), "{e}");
        assert_eq!(
            Stages::parse("hc+zpetc").unwrap().feedback,
            FeedbackKind::None
        );
        assert!(e.to_string().contains("pid+hc+zpec"), "{e}");
        assert!(e.to_string().contains("ss+hc+zpec"), "{e}");
        assert!(
            Stages::parse("pid+zpec+hc")
                .unwrap_err()
                .to_string()
                .contains("out of order")
        );
        assert!(
            Stages::parse("pid+ilc")
                .unwrap_err()
                .to_string()
                .contains("unknown stage")
        );
        assert!(Stages::parse("pid+hc+hc").is_err());
        assert!(Stages::parse("pid+ss").is_err());
        assert!(Stages::parse("ss+pid").is_err());
        assert!(Stages::parse("dob+ss").is_err());
        assert_eq!(
            Stages::parse("DOB+zpetc").unwrap().feedback,
            FeedbackKind::Dob
        );
    }
}
