//! Invariant zeros against SLICOT `AB08ND` (through slycot): the routine's
//! documentation example and random square, rank-deficient, tall and wide
//! systems from `tests/data/zeros/generate.py` (fixed seeds). Every zero is
//! The references use `TOL = (n+p)(n+m) eps`, the default here; with
//! AB08ND's own default, `sqrt((n+p)(n+m)) eps`, slycot misses the
//! unobservable mode -11.4 of `wide_7` (a zero by construction, which the
//! Rosenbrock test below confirms). Every zero is
//! also checked on its own: the Rosenbrock matrix `[A - zI, B; C, D]` must
//! drop below its normal rank there.

use faer::Mat;
use fts::lti::ss::mat_from_rows;
use fts::lti::{StateSpace, c64, invariant_zeros};
use serde_json::Value;

struct Case {
    name: String,
    sys: StateSpace,
    zeros: Vec<c64>,
    normal_rank: usize,
    infinite_orders: Vec<usize>,
    right_kronecker: Vec<usize>,
    left_kronecker: Vec<usize>,
}

fn mat(v: &Value, rows: usize, cols: usize) -> Mat<f64> {
    let r: Vec<Vec<f64>> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|row| {
            row.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect();
    if rows == 0 || cols == 0 {
        return Mat::zeros(rows, cols);
    }
    mat_from_rows(&r, cols)
}

fn ints(v: &Value) -> Vec<usize> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as usize)
        .collect()
}

fn cases() -> Vec<Case> {
    let text = std::fs::read_to_string("tests/data/zeros/cases.json").unwrap();
    let json: Value = serde_json::from_str(&text).unwrap();
    json["cases"]
        .as_array()
        .unwrap()
        .iter()
        .map(parse_case)
        .collect()
}

fn parse_case(c: &Value) -> Case {
    let dim = |k: &str| c[k].as_u64().unwrap() as usize;
    let (n, m, p) = (dim("n"), dim("m"), dim("p"));
    let sys = StateSpace::new(
        mat(&c["a"], n, n),
        mat(&c["b"], n, m),
        mat(&c["c"], p, n),
        mat(&c["d"], p, m),
        None,
    )
    .unwrap();
    let (re, im) = (
        c["zeros_re"].as_array().unwrap(),
        c["zeros_im"].as_array().unwrap(),
    );
    let zeros = re
        .iter()
        .zip(im)
        .map(|(r, i)| c64::new(r.as_f64().unwrap(), i.as_f64().unwrap()))
        .collect();
    Case {
        name: c["name"].as_str().unwrap().to_string(),
        sys,
        zeros,
        normal_rank: dim("normal_rank"),
        infinite_orders: ints(&c["infinite_orders"]),
        right_kronecker: ints(&c["right_kronecker"]),
        left_kronecker: ints(&c["left_kronecker"]),
    }
}

/// Worst relative distance `|z - z_ref| / max(1, |z_ref|)` over a greedy
/// nearest pairing of two multisets of equal size (`None` if the sizes
/// differ).
fn multiset_error(got: &[c64], want: &[c64]) -> Option<f64> {
    if got.len() != want.len() {
        return None;
    }
    let mut left: Vec<c64> = got.to_vec();
    let mut worst: f64 = 0.0;
    let mut order: Vec<&c64> = want.iter().collect();
    order.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    for w in order {
        let (k, d) = left
            .iter()
            .enumerate()
            .map(|(k, z)| (k, (z - w).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        worst = worst.max(d / w.norm().max(1.0));
        left.swap_remove(k);
    }
    Some(worst)
}

/// Singular values (descending) of the Rosenbrock matrix at `s`.
fn rosenbrock_sv(sys: &StateSpace, s: c64) -> Vec<f64> {
    let (n, m, p) = (sys.nx(), sys.nu(), sys.ny());
    let r = |x: f64| c64::new(x, 0.0);
    let big = Mat::from_fn(n + p, n + m, |i, j| match (i < n, j < n) {
        (true, true) => r(sys.a[(i, j)]) - if i == j { s } else { r(0.0) },
        (true, false) => r(sys.b[(i, j - n)]),
        (false, true) => r(sys.c[(i - n, j)]),
        (false, false) => r(sys.d[(i - n, j - n)]),
    });
    let mut sv = big.singular_values().unwrap();
    sv.sort_by(|a, b| b.total_cmp(a));
    sv
}

#[test]
fn ab08nd_documentation_example() {
    let case = cases()
        .into_iter()
        .find(|c| c.name == "ab08nd_example")
        .unwrap();
    assert_eq!((case.sys.nx(), case.sys.nu(), case.sys.ny()), (6, 2, 3));
    let z = invariant_zeros(&case.sys, None).unwrap();
    // AB08ND.res: finite zeros 2 and -1, two infinite zeros of order 1,
    // no right Kronecker index, one left index 2, normal rank 2.
    let want = [c64::new(2.0, 0.0), c64::new(-1.0, 0.0)];
    assert!(
        multiset_error(&z.finite, &want).unwrap() < 1e-12,
        "{:?}",
        z.finite
    );
    assert_eq!(z.normal_rank, 2);
    assert_eq!(z.infinite_orders, vec![2]);
    assert_eq!(z.n_infinite, 2);
    assert!(z.right_kronecker.is_empty());
    assert_eq!(z.left_kronecker, vec![2]);
    assert_eq!(case.sys.zeros().unwrap().len(), 2);
}

#[test]
fn random_systems_match_slycot_ab08nd() {
    let cases = cases();
    assert!(cases.len() >= 61);
    let mut worst: (f64, String) = (0.0, String::new());
    for case in &cases {
        let z = invariant_zeros(&case.sys, None).unwrap();
        let err = multiset_error(&z.finite, &case.zeros)
            .unwrap_or_else(|| panic!("{}: {:?} vs {:?}", case.name, z.finite, case.zeros));
        assert!(err < 1e-7, "{}: error {err:e}", case.name);
        if err > worst.0 {
            worst = (err, case.name.clone());
        }
        assert_eq!(z.normal_rank, case.normal_rank, "{}", case.name);
        assert_eq!(z.infinite_orders, case.infinite_orders, "{}", case.name);
        assert_eq!(z.right_kronecker, case.right_kronecker, "{}", case.name);
        assert_eq!(z.left_kronecker, case.left_kronecker, "{}", case.name);
        assert_eq!(case.sys.zeros().unwrap(), z.finite, "{}", case.name);
        for zero in &z.finite {
            assert!(
                z.finite.contains(&zero.conj()),
                "{}: {zero} unpaired",
                case.name
            );
        }
    }
    eprintln!(
        "{} cases, worst zero error {:e} ({})",
        cases.len(),
        worst.0,
        worst.1
    );
}

/// Independent of slycot: at each reported zero the Rosenbrock matrix
/// loses rank (its `n + r`-th singular value, `r` the normal rank, is tiny
/// relative to its norm), while at a generic point it has rank `n + r`
/// exactly.
#[test]
fn every_zero_drops_the_rosenbrock_rank() {
    let mut worst: f64 = 0.0;
    for case in cases() {
        let z = invariant_zeros(&case.sys, None).unwrap();
        let k = case.sys.nx() + z.normal_rank;
        let generic = rosenbrock_sv(&case.sys, c64::new(0.37, 1.13));
        assert!(
            generic[k - 1] > 1e-6 * generic[0],
            "{}: rank below n + r",
            case.name
        );
        if let Some(&next) = generic.get(k) {
            assert!(next < 1e-10 * generic[0], "{}: rank above n + r", case.name);
        }
        for zero in &z.finite {
            let sv = rosenbrock_sv(&case.sys, *zero);
            let rel = sv[k - 1] / sv[0];
            assert!(
                rel < 1e-8,
                "{}: zero {zero} leaves sigma {rel:e}",
                case.name
            );
            worst = worst.max(rel);
        }
    }
    eprintln!("worst relative sigma_(n+r) at a zero: {worst:e}");
}
