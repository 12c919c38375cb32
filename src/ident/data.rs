//! Data preparation for identification: detrending and estimation/validation
//! splits (MATLAB `detrend`, `data(1:n)`).

/// Trend removed before identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Detrend {
    /// Keep the data as they are (default).
    #[default]
    None,
    /// Subtract each signal's mean (MATLAB `detrend(data)` on `iddata`): an
    /// offset in the operating point otherwise enters the model as a bias.
    Mean,
    /// Subtract each signal's least-squares straight line (drift).
    Linear,
}

/// The trend that was removed from one signal: `x(k) - (offset + slope k)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Trend {
    /// Value of the trend at `k = 0`.
    pub offset: f64,
    /// Slope per sample.
    pub slope: f64,
}

/// Removes the trend in place and returns it.
pub fn detrend(x: &mut [f64], how: Detrend) -> Trend {
    let n = x.len();
    if n == 0 || how == Detrend::None {
        return Trend {
            offset: 0.0,
            slope: 0.0,
        };
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let slope = if how == Detrend::Linear && n > 1 {
        // Least-squares line on the centred time axis: the two unknowns
        // decouple, so this closed form is the orthogonal projection itself
        // (no normal-equation conditioning issue).
        let tc = (n - 1) as f64 / 2.0;
        let (mut num, mut den) = (0.0, 0.0);
        for (k, v) in x.iter().enumerate() {
            let t = k as f64 - tc;
            num += t * (v - mean);
            den += t * t;
        }
        num / den
    } else {
        0.0
    };
    let offset = mean - slope * (n - 1) as f64 / 2.0;
    for (k, v) in x.iter_mut().enumerate() {
        *v -= offset + slope * k as f64;
    }
    Trend { offset, slope }
}

/// Number of estimation samples when the first `fraction` of `n` samples
/// is used for estimation and the rest for validation (rounded to nearest).
pub fn split_point(n: usize, fraction: f64) -> usize {
    ((n as f64 * fraction).round() as usize).min(n)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn detrend_mean_and_linear() {
        let mut x = vec![1.0, 2.0, 3.0, 6.0];
        let t = detrend(&mut x, Detrend::Mean);
        assert_eq!(t.offset, 3.0);
        assert_eq!(x, vec![-2.0, -1.0, 0.0, 3.0]);
        let mut x: Vec<f64> = (0..10).map(|k| 2.0 + 0.5 * k as f64).collect();
        let t = detrend(&mut x, Detrend::Linear);
        assert!((t.offset - 2.0).abs() < 1e-14 && (t.slope - 0.5).abs() < 1e-14);
        assert!(x.iter().all(|v| v.abs() < 1e-13));
        assert_eq!(split_point(1000, 0.5), 500);
    }
}
