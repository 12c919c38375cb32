//! Lagged correlations of long records: the sums of the residual tests.
//!
//! `r_ab(t) = (1/N) sum_k (a(k) - mean a) (b(k - t) - mean b)`, `t = 0..=lags`
//! (terms with `k - t < 0` are absent), for the four pairs the tests need,
//! in one pass over the record. The record is read in blocks of
//! [`BLOCK`] samples; each block is demeaned into a scratch buffer that also
//! holds the `lags` samples before it (zeros before the record), so the
//! input is neither copied whole nor read once per lag. Four lags share each
//! load of `a` (eight independent partial sums per lag), with fused
//! multiply-adds where the CPU has them. The two halves of a long record
//! are summed on two threads and added after; the record is cut at its
//! middle whatever the machine, so the sums do not depend on its cores.

use super::fork;
use super::ls::{Kernel, dot, madd};
use super::metrics::sum_pairs;

/// Samples per block (the scratch of a block fits in the L1 cache).
const BLOCK: usize = 1024;

/// The lagged sums of a residual `e` and an input `u`, each `lags + 1` long
/// and divided by the record's length.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ResidualCorrelations {
    /// `r_ee(t)`.
    pub ee: Vec<f64>,
    /// `r_uu(t)`.
    pub uu: Vec<f64>,
    /// `r_eu(t)`: the residual at `k` against the input at `k - t`.
    pub eu: Vec<f64>,
    /// `r_ue(t)`: the input at `k` against the residual at `k - t`.
    pub ue: Vec<f64>,
}

/// The four lagged correlations of `e` and `u` (the shorter length of the
/// two), demeaned, for `t = 0..=lags`.
pub(crate) fn residual_correlations(e: &[f64], u: &[f64], lags: usize) -> ResidualCorrelations {
    let n = e.len().min(u.len());
    let (e, u) = (&e[..n], &u[..n]);
    let mean = |x: &[f64]| sum_pairs(x, x, |v, _| v) / n.max(1) as f64;
    let means = (mean(e), mean(u));
    let mid = n / 2;
    let (first, second) = fork::join(
        n,
        || ResidualCorrelations::summed(e, u, means, lags, 0..mid),
        || ResidualCorrelations::summed(e, u, means, lags, mid..n),
    );
    let scale = 1.0 / n.max(1) as f64;
    let total = |a: Vec<f64>, b: &[f64]| -> Vec<f64> {
        a.iter().zip(b).map(|(x, y)| (x + y) * scale).collect()
    };
    ResidualCorrelations {
        ee: total(first.ee, &second.ee),
        uu: total(first.uu, &second.uu),
        eu: total(first.eu, &second.eu),
        ue: total(first.ue, &second.ue),
    }
}

impl ResidualCorrelations {
    /// The unscaled sums over the samples `k` in `range` (their lagged
    /// partners may lie before it).
    fn summed(
        e: &[f64],
        u: &[f64],
        (me, mu): (f64, f64),
        lags: usize,
        range: std::ops::Range<usize>,
    ) -> Self {
        let kernel = Kernel::detect();
        let mut sums = Self {
            ee: vec![0.0; lags + 1],
            uu: vec![0.0; lags + 1],
            eu: vec![0.0; lags + 1],
            ue: vec![0.0; lags + 1],
        };
        let mut ed = vec![0.0; BLOCK + lags];
        let mut ud = vec![0.0; BLOCK + lags];
        for start in range.clone().step_by(BLOCK) {
            let end = (start + BLOCK).min(range.end);
            let len = lags + end - start;
            demeaned(e, me, start, lags, &mut ed[..len]);
            demeaned(u, mu, start, lags, &mut ud[..len]);
            let (ed, ud) = (&ed[..len], &ud[..len]);
            kernel.lagged_sums(ed, ed, lags, &mut sums.ee);
            kernel.lagged_sums(ud, ud, lags, &mut sums.uu);
            kernel.lagged_sums(ed, ud, lags, &mut sums.eu);
            kernel.lagged_sums(ud, ed, lags, &mut sums.ue);
        }
        sums
    }
}

/// `out[j] = x(start - lags + j) - mean`, zero before the record.
fn demeaned(x: &[f64], mean: f64, start: usize, lags: usize, out: &mut [f64]) {
    let before = lags.saturating_sub(start);
    out[..before].fill(0.0);
    let from = start + before - lags;
    for (o, v) in out[before..].iter_mut().zip(&x[from..]) {
        *o = v - mean;
    }
}

impl Kernel {
    /// `sums[t] += sum_j a[lags + j] b[lags + j - t]` over the block
    /// `j = 0..a.len() - lags`, `t = 0..=lags` (`a` and `b` hold the
    /// `lags` samples before the block first).
    fn lagged_sums(self, a: &[f64], b: &[f64], lags: usize, sums: &mut [f64]) {
        assert!(a.len() == b.len() && a.len() >= lags && sums.len() == lags + 1);
        match self {
            Kernel::Portable => lagged_sums_kernel::<false>(a, b, lags, sums),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Kernel::Avx2Fma` is only constructed by `detect` after
            // `is_x86_feature_detected!` confirmed AVX2 and FMA on this CPU;
            // `lagged_sums_avx2` has no other precondition (all accesses are
            // bounds-checked slices).
            Kernel::Avx2Fma => unsafe { lagged_sums_avx2(a, b, lags, sums) },
        }
    }
}

/// [`lagged_sums_kernel`] in AVX2 registers: four lags at a time, two
/// 4-lane accumulators each (the compiler, left to itself, vectorises the
/// portable kernel across lags in 2-lane registers and spills).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn lagged_sums_avx2(a: &[f64], b: &[f64], lags: usize, sums: &mut [f64]) {
    use std::arch::x86_64::{
        __m256d, _mm256_add_pd, _mm256_fmadd_pd, _mm256_loadu_pd, _mm256_setzero_pd,
        _mm256_storeu_pd,
    };
    let len = a.len() - lags;
    let cur = &a[lags..];
    let window = |t: usize| &b[lags - t..lags - t + len];
    let load = |x: &[f64], i: usize| -> __m256d {
        let four = &x[i..i + 4];
        // SAFETY: `four` is four in-bounds f64s; the load is unaligned.
        unsafe { _mm256_loadu_pd(four.as_ptr()) }
    };
    let chunks = len / 8;
    let mut t = 0;
    while t + 4 <= lags + 1 {
        let w = [window(t), window(t + 1), window(t + 2), window(t + 3)];
        let mut acc = [_mm256_setzero_pd(); 8];
        for q in 0..chunks {
            let i = 8 * q;
            let (x0, x1) = (load(cur, i), load(cur, i + 4));
            for (l, w) in w.iter().enumerate() {
                acc[2 * l] = _mm256_fmadd_pd(x0, load(w, i), acc[2 * l]);
                acc[2 * l + 1] = _mm256_fmadd_pd(x1, load(w, i + 4), acc[2 * l + 1]);
            }
        }
        for (l, w) in w.iter().enumerate() {
            let mut lanes = [0.0f64; 4];
            // SAFETY: `lanes` holds four f64s; the store is unaligned.
            unsafe {
                _mm256_storeu_pd(
                    lanes.as_mut_ptr(),
                    _mm256_add_pd(acc[2 * l], acc[2 * l + 1]),
                )
            };
            let tail: f64 = (8 * chunks..len).map(|i| cur[i] * w[i]).sum();
            sums[t + l] += ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + tail;
        }
        t += 4;
    }
    for (lag, s) in sums.iter_mut().enumerate().skip(t) {
        *s += dot::<true>(cur, window(lag));
    }
}

/// [`Kernel::lagged_sums`]: four lags at a time, each with eight partial
/// sums, so that one load of `a` serves four products.
#[inline(always)]
fn lagged_sums_kernel<const FMA: bool>(a: &[f64], b: &[f64], lags: usize, sums: &mut [f64]) {
    let len = a.len() - lags;
    let cur = &a[lags..];
    let window = |t: usize| &b[lags - t..lags - t + len];
    let mut t = 0;
    while t + 4 <= lags + 1 {
        let w = [window(t), window(t + 1), window(t + 2), window(t + 3)];
        let mut acc = [[0.0f64; 8]; 4];
        let chunks = len / 8;
        for q in 0..chunks {
            let x = &cur[8 * q..8 * q + 8];
            for (acc, w) in acc.iter_mut().zip(&w) {
                let y = &w[8 * q..8 * q + 8];
                for l in 0..8 {
                    acc[l] = madd::<FMA>(x[l], y[l], acc[l]);
                }
            }
        }
        for (s, (acc, w)) in sums[t..t + 4].iter_mut().zip(acc.iter().zip(&w)) {
            let tail: f64 = (8 * chunks..len).map(|i| cur[i] * w[i]).sum();
            *s += ((acc[0] + acc[1]) + (acc[2] + acc[3]))
                + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
                + tail;
        }
        t += 4;
    }
    for (lag, s) in sums.iter_mut().enumerate().skip(t) {
        *s += dot::<FMA>(cur, window(lag));
    }
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::internal_checks::unit_uniform;

    /// The blocked sums are the direct demeaned sums
    /// `sum_k (a(k) - ma) (b(k - t) - mb) / N`, over lengths below, at and
    /// across the block size and the parallel threshold, and lags beyond
    /// the record; the portable kernel agrees with the one the CPU runs.
    pub fn lagged_sums_are_the_direct_sums() {
        let mut rnd = unit_uniform(7);
        for n in [
            1usize,
            5,
            31,
            BLOCK,
            BLOCK + 1,
            9001,
            fork::PARALLEL_SAMPLES + 77,
        ] {
            let e: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let u: Vec<f64> = (0..n).map(|_| 3.0 * rnd() + 0.3).collect();
            let lags = 40;
            let got = residual_correlations(&e, &u, lags);
            let mean = |x: &[f64]| sum_pairs(x, x, |v, _| v) / n as f64;
            let (me, mu) = (mean(&e), mean(&u));
            let direct = |a: &[f64], ma: f64, b: &[f64], mb: f64, t: usize| {
                let terms = (t..n).map(|k| (a[k] - ma) * (b[k - t] - mb));
                let size: f64 = terms.clone().map(f64::abs).sum::<f64>() / n as f64;
                (terms.sum::<f64>() / n as f64, size)
            };
            for t in 0..=lags {
                for (g, (a, ma, b, mb)) in [
                    (got.ee[t], (&e, me, &e, me)),
                    (got.uu[t], (&u, mu, &u, mu)),
                    (got.eu[t], (&e, me, &u, mu)),
                    (got.ue[t], (&u, mu, &e, me)),
                ] {
                    let (want, size) = direct(a, ma, b, mb, t);
                    assert!(
                        (g - want).abs() <= 1e-13 * size.max(1e-300),
                        "n {n} t {t}: {g} vs {want}"
                    );
                }
            }
        }
        let a: Vec<f64> = (0..BLOCK + 30).map(|_| rnd()).collect();
        let b: Vec<f64> = (0..BLOCK + 30).map(|_| rnd()).collect();
        let (mut portable, mut native) = (vec![0.0; 31], vec![0.0; 31]);
        Kernel::Portable.lagged_sums(&a, &b, 30, &mut portable);
        Kernel::detect().lagged_sums(&a, &b, 30, &mut native);
        for (p, q) in portable.iter().zip(&native) {
            assert!((p - q).abs() <= 1e-12 * p.abs().max(1.0), "{p} vs {q}");
        }
    }
}
