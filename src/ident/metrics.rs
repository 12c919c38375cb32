//! Fit metrics shared by every identification method.

/// MATLAB `compare` / `goodnessOfFit(..., 'NRMSE')` fit in percent (docs/math.md §2):
/// `100 * (1 - ||y - y_hat|| / ||y - mean(y)||)`. 100 is a perfect fit, 0 is
/// no better than the mean, and it is negative when worse than the mean.
/// Returns `NaN` when `y` is constant or the lengths differ or are zero.
pub fn nrmse_fit_percent(y: &[f64], y_hat: &[f64]) -> f64 {
    if y.is_empty() || y.len() != y_hat.len() {
        return f64::NAN;
    }
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let err: f64 = y
        .iter()
        .zip(y_hat)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let dev: f64 = y.iter().map(|a| (a - mean).powi(2)).sum::<f64>().sqrt();
    if dev == 0.0 {
        return f64::NAN;
    }
    100.0 * (1.0 - err / dev)
}

/// Root mean square of a signal.
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;

    pub fn nrmse_hand_computed() {
        // y = [1, 2, 3, 4], mean 2.5, ||y - mean|| = sqrt(5);
        // y_hat = [1, 2, 3, 5], ||e|| = 1 -> fit = 100 (1 - 1/sqrt(5)) = 55.2786...
        let fit = nrmse_fit_percent(&[1.0, 2.0, 3.0, 4.0], &[1.0, 2.0, 3.0, 5.0]);
        assert!((fit - 55.278_640_450_004_2).abs() < 1e-12, "{fit}");
        assert_eq!(nrmse_fit_percent(&[1.0, 2.0], &[1.0, 2.0]), 100.0);
        assert!(nrmse_fit_percent(&[1.0, 1.0], &[1.0, 2.0]).is_nan());
        assert_eq!(rms(&[3.0, -3.0]), 3.0);
    }
}
