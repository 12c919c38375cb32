//! Stability verdicts on clustered discrete poles against 200-digit roots
//! of the stored coefficients (issue #19, item 2). The reference verdicts
//! were made once by `tests/data/stability/gen_clusters.py` (numpy's float
//! expansion of `(z - r)^k`, roots by mpmath at 200 digits); no Python is
//! needed here.

use crate::common::cmd::fts;
use fts::lti::stability::{
    StabilityTest, hurwitz_roots_left, hurwitz_verdict, schur_roots_inside, schur_stable,
    schur_verdict,
};
use fts::lti::{DiscreteTf, Poly};
use serde::Deserialize;

#[derive(Deserialize)]
struct Case {
    root: f64,
    multiplicity: usize,
    den: Vec<f64>,
    max_modulus: f64,
    stable: bool,
}

#[derive(Deserialize)]
struct Cases {
    cases: Vec<Case>,
}

fn cases() -> Vec<Case> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/stability/clusters.json"
    );
    serde_json::from_str::<Cases>(&std::fs::read_to_string(path).unwrap())
        .unwrap()
        .cases
}

#[derive(Deserialize)]
struct HighDegreeCase {
    seed: u64,
    degree: usize,
    poles: String,
    den: Vec<f64>,
    roots_inside: usize,
    closest_to_circle: f64,
}

#[derive(Deserialize)]
struct ContinuousCase {
    seed: u64,
    degree: usize,
    poles: String,
    den: Vec<f64>,
    roots_left: usize,
    closest_to_axis: f64,
}

#[derive(Deserialize)]
struct HighDegreeCases {
    cases: Vec<HighDegreeCase>,
    continuous_cases: Vec<ContinuousCase>,
}

fn high_degree_cases() -> HighDegreeCases {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/stability/high_degree.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Degree 60 to 160 expansions of lightly damped pole sets, with the
/// number of roots inside the circle of the stored coefficients from
/// python-flint's rigorous root isolation (`gen_high_degree.py`): every
/// verdict is decided, exact or certified, and agrees; the argument
/// principle's count is the isolation's wherever it decides.
#[test]
fn high_degrees_get_the_verdict_of_their_stored_coefficients() {
    let cases = high_degree_cases().cases;
    assert!(cases.len() >= 36);
    let (mut counted, mut unstable_as_drawn) = (0, 0);
    for c in &cases {
        let name = format!("seed {} degree {} {}", c.seed, c.degree, c.poles);
        let stable = c.roots_inside == c.degree;
        let verdict = schur_verdict(&c.den).unwrap_or_else(|| {
            panic!(
                "{name}: undecided (closest root {:.1e} from the circle)",
                c.closest_to_circle
            )
        });
        assert_eq!(verdict.stable, stable, "{name}");
        assert_ne!(verdict.test, StabilityTest::ComputedRoots);
        if let Some(inside) = schur_roots_inside(&c.den) {
            assert_eq!(inside, c.roots_inside, "{name}");
            counted += 1;
        }
        unstable_as_drawn += usize::from(c.poles == "drawn" && !stable);
    }
    println!(
        "{} cases decided, {counted} counted by the argument principle; {unstable_as_drawn} \
         drawn inside the circle are unstable as stored",
        cases.len()
    );
    assert!(counted >= 30 && unstable_as_drawn >= 2);
}

/// Degree 20 to 120 continuous expansions of lightly damped pairs over two
/// decades, one pair moved right in half of them, with python-flint's count
/// of roots in the left half plane: every Hurwitz verdict is decided and
/// agrees, and the axis walk's count is the isolation's wherever it decides.
#[test]
fn continuous_high_degrees_get_the_verdict_of_their_stored_coefficients() {
    let cases = high_degree_cases().continuous_cases;
    assert!(cases.len() >= 36);
    let mut counted = 0;
    for c in &cases {
        let name = format!("seed {} degree {} {}", c.seed, c.degree, c.poles);
        let stable = c.roots_left == c.degree;
        let verdict = hurwitz_verdict(&c.den).unwrap_or_else(|| {
            panic!(
                "{name}: undecided (closest root {:.1e} from the axis)",
                c.closest_to_axis
            )
        });
        assert_eq!(verdict.stable, stable, "{name}");
        if let Some(left) = hurwitz_roots_left(&c.den) {
            assert_eq!(left, c.roots_left, "{name}");
            counted += 1;
        }
    }
    println!(
        "{} continuous cases decided, {counted} counted on the axis",
        cases.len()
    );
    assert_eq!(counted, cases.len());
}

#[test]
fn clustered_poles_get_the_verdict_of_their_stored_coefficients() {
    let cases = cases();
    assert!(cases.len() >= 20);
    let (mut unstable, mut roots_wrong) = (0, 0);
    for c in &cases {
        let name = format!("(z - {})^{}", c.root, c.multiplicity);
        assert_eq!(
            schur_stable(&c.den),
            Some(c.stable),
            "{name}: |z|max {}",
            c.max_modulus
        );
        let g = DiscreteTf::new(vec![1.0], c.den.clone(), 0, 1e-3).unwrap();
        assert_eq!(g.is_stable().unwrap(), c.stable, "{name}");
        // How often the computed roots alone would have answered wrongly.
        let by_roots = Poly::new(c.den.clone())
            .z_roots()
            .unwrap()
            .iter()
            .all(|z| z.norm() < 1.0);
        roots_wrong += usize::from(by_roots != c.stable);
        unstable += usize::from(!c.stable);
    }
    println!(
        "{} cases, {unstable} unstable as stored; computed root moduli wrong on {roots_wrong}",
        cases.len()
    );
    assert!(unstable >= 4);
}

#[test]
fn tf_info_says_unstable_and_why() {
    let den = &cases()
        .into_iter()
        .find(|c| c.root == 0.99 && c.multiplicity == 8)
        .unwrap()
        .den;
    let text = tf_info_text(den);
    assert!(text.contains("poles (UNSTABLE, exact test)"), "{text}");
    assert!(
        text.contains("the exact test on the stored denominator says unstable"),
        "{text}"
    );
}

/// Descending coefficients of `prod (z^2 - 2 r cos(th) z + r^2)` over
/// `pairs`, times `(z - extra)` for each real root in `extra`.
fn expand(pairs: &[(f64, f64)], extra: &[f64]) -> Vec<f64> {
    let mut c = vec![1.0];
    let mut times = |q: &[f64]| {
        let mut next = vec![0.0; c.len() + q.len() - 1];
        for (i, &ci) in c.iter().enumerate() {
            for (j, &qj) in q.iter().enumerate() {
                next[i + j] += ci * qj;
            }
        }
        c = next;
    };
    for &(r, th) in pairs {
        times(&[1.0, -2.0 * r * th.cos(), r * r]);
    }
    for &x in extra {
        times(&[1.0, -x]);
    }
    c
}

fn tf_info_text(den: &[f64]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("high.json");
    let doc = serde_json::json!({
        "format": "fts.tf/1", "var": "z^-1", "ts": 1e-3, "delay": 0, "num": [1.0], "den": den
    });
    std::fs::write(&path, doc.to_string()).unwrap();
    let out = fts().args(["tf", "info"]).arg(&path).output().unwrap();
    assert!(out.status.success());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn tf_info_certifies_high_degrees_and_says_when_it_cannot() {
    // Degree 60, poles of modulus 0.7-0.99 with full-mantissa
    // coefficients: beyond the exact test's budget, settled by the
    // certified inclusion discs.
    let mut rnd = crate::common::unit_uniform(3);
    let pairs: Vec<(f64, f64)> = (0..30)
        .map(|_| (0.7 + 0.29 * rnd(), std::f64::consts::PI * rnd()))
        .collect();
    assert_eq!(fts::lti::stability::schur_exact(&expand(&pairs, &[])), None);
    let text = tf_info_text(&expand(&pairs, &[]));
    assert!(text.contains("poles (stable, certified test)"), "{text}");
    let text = tf_info_text(&expand(&pairs, &[1.02]));
    assert!(text.contains("poles (UNSTABLE, certified test)"), "{text}");
    // An isolated pole at 1 - 1.1e-15 is still certified inside: the disc
    // around it is far smaller than its distance to the circle.
    let text = tf_info_text(&expand(&pairs, &[1.0 - 1e-15]));
    assert!(text.contains("poles (stable, certified test)"), "{text}");
    // A pole at z = 1 (as stored, within about 1e-16 of it): neither test
    // can decide, and the report says so instead of guessing silently.
    let text = tf_info_text(&expand(&pairs, &[1.0]));
    assert!(text.contains("computed-roots test"), "{text}");
    assert!(text.contains("too close to call"), "{text}");
}
