//! What several benches share.

/// A seeded uniform generator on [-0.5, 0.5) (64-bit LCG, top 53 bits), so
/// every bench run sees the same data without a dependency.
#[allow(dead_code)]
pub fn uniform() -> impl FnMut() -> f64 {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// Ten lightly damped modes in parallel: block `[[s, w], [-w, s]]` with
/// `w = 2 pi (50 + 100 i)` rad/s, `s = -0.05 w`; `B` all ones, `C`
/// alternating `1, 0.5` (as in the Python scripts beside the benches).
#[allow(dead_code)]
pub fn twenty_states() -> fts::lti::StateSpace {
    use faer::Mat;
    let n = 20;
    let mut a = Mat::<f64>::zeros(n, n);
    for i in 0..10 {
        let w = 2.0 * std::f64::consts::PI * (50.0 + 100.0 * i as f64);
        let s = -0.05 * w;
        let k = 2 * i;
        a[(k, k)] = s;
        a[(k + 1, k + 1)] = s;
        a[(k, k + 1)] = w;
        a[(k + 1, k)] = -w;
    }
    let b = Mat::from_fn(n, 1, |_, _| 1.0);
    let c = Mat::from_fn(1, n, |_, j| if j % 2 == 0 { 1.0 } else { 0.5 });
    fts::lti::StateSpace::new(a, b, c, Mat::zeros(1, 1), None).unwrap()
}
