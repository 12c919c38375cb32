//! The composite controller of [Li21] Fig. 5 and its stage grammar:
//! `pid`, `pid+hc`, `pid+zpec`, `pid+hc+zpec` (feedback PID, hysteresis
//! compensation feedforward, ZPETC reference pre-filter).

/// Which stages a composite controller has. The PID is always there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stages {
    /// Inverse-hysteresis feedforward (HC).
    pub hysteresis_compensation: bool,
    /// ZPETC reference pre-filter (ZPEC).
    pub zpetc: bool,
}

/// The forms `--controller` accepts, in order.
pub const VALID_STAGE_STRINGS: [&str; 4] = ["pid", "pid+hc", "pid+zpec", "pid+hc+zpec"];

/// Why a stage string is not understood.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}; valid controllers: {}", VALID_STAGE_STRINGS.join(", "))]
pub struct StageError {
    /// What is wrong.
    pub message: String,
}

impl Stages {
    /// Parses `pid[+hc][+zpec]` (case-insensitive; `zpetc` is accepted for `zpec`).
    pub fn parse(text: &str) -> Result<Stages, StageError> {
        let lower = text.trim().to_ascii_lowercase();
        let parts: Vec<&str> = lower.split('+').map(str::trim).collect();
        let known = ["pid", "hc", "zpec"];
        let mut ranks = Vec::new();
        for p in &parts {
            let p = if *p == "zpetc" { "zpec" } else { p };
            match known.iter().position(|k| *k == p) {
                Some(r) => ranks.push(r),
                None => {
                    return Err(StageError {
                        message: format!("unknown stage {p:?} in {text:?}"),
                    });
                }
            }
        }
        if ranks.first() != Some(&0) {
            return Err(StageError {
                message: format!("{text:?} must start with the feedback stage \"pid\""),
            });
        }
        if ranks.windows(2).any(|w| w[0] >= w[1]) {
            return Err(StageError {
                message: format!(
                    "stages in {text:?} are repeated or out of order (pid, then hc, then zpec)"
                ),
            });
        }
        Ok(Stages {
            hysteresis_compensation: ranks.contains(&1),
            zpetc: ranks.contains(&2),
        })
    }

    /// The canonical spelling.
    pub fn name(&self) -> &'static str {
        match (self.hysteresis_compensation, self.zpetc) {
            (false, false) => "pid",
            (true, false) => "pid+hc",
            (false, true) => "pid+zpec",
            (true, true) => "pid+hc+zpec",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grammar() {
        for s in VALID_STAGE_STRINGS {
            assert_eq!(Stages::parse(s).unwrap().name(), s);
        }
        assert_eq!(Stages::parse("PID+HC+ZPETC").unwrap().name(), "pid+hc+zpec");
        let e = Stages::parse("hc+pid").unwrap_err();
        assert!(e.to_string().contains("must start"), "{e}");
        assert!(e.to_string().contains("pid+hc+zpec"), "{e}");
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
    }
}
