//! Deterministic test signals for the identification tests (the library's
//! excitation generators live in `excite`; these keep unit tests self-contained).

/// Linear chirp 0 -> f1 Hz over n samples (test input only).
pub fn chirp(n: usize, ts: f64, f1: f64) -> Vec<f64> {
    let t_end = n as f64 * ts;
    (0..n)
        .map(|k| {
            let t = k as f64 * ts;
            (std::f64::consts::PI * f1 / t_end * t * t).sin()
        })
        .collect()
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
