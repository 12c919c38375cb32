//! Test signals for the identification tests: the library sweep and a
//! deterministic pseudo-random noise.

/// Linear sine sweep 0 -> f1 Hz over n samples, unit amplitude, from
/// [`crate::ident::excite::sweep`] (the `fts excite sweep` signal).
pub fn chirp(n: usize, ts: f64, f1: f64) -> Vec<f64> {
    let p = crate::ident::excite::SweepParams {
        f0: 0.0,
        f1,
        duration: n as f64 * ts,
        amplitude: 1.0,
        offset: 0.0,
        ts,
        spacing: crate::ident::excite::SweepSpacing::Linear,
    };
    let mut u = crate::ident::excite::sweep(&p).expect("valid sweep");
    u.resize(n, 0.0);
    u
}

/// Deterministic Gaussian-ish noise (sum of 12 uniforms), unit variance.
pub fn noise(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    let mut uni = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| (0..12).map(|_| uni()).sum::<f64>() - 6.0)
        .collect()
}
