//! What several benches share.

/// A seeded uniform generator on [-0.5, 0.5) (64-bit LCG, top 53 bits), so
/// every bench run sees the same data without a dependency.
pub fn uniform() -> impl FnMut() -> f64 {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}
