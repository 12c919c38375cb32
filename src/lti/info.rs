//! What `fts ss-info` reports of a system, computed in one place: poles,
//! stability, invariant zeros with the normal rank, and the H2 and
//! H-infinity norms (the analysis MATLAB spreads over `pole`, `isstable`,
//! `tzero`, `norm(sys, 2)` and `hinfnorm`; SLICOT over dgeev, AB08ND,
//! AB13BD and AB13DD).

use super::c64;
use super::norms::{HinfNorm, h2_norm_of_stable, hinf_norm_confirmed_with_poles};
use super::ss::{SsError, StateSpace};
use super::zeros::{Zeros, invariant_zeros};

/// Relative tolerance of the H-infinity norm's bisection in [`system_info`].
pub const HINF_RTOL: f64 = 1e-9;

/// The analysis of one system.
#[derive(Debug, Clone)]
pub struct SystemInfo {
    /// Eigenvalues of `A`.
    pub poles: Vec<c64>,
    /// All poles in the open left half plane (continuous) or the open unit disc.
    pub stable: bool,
    /// Finite invariant zeros and the normal rank.
    pub zeros: Zeros,
    /// The H2 norm; `None` when it is infinite (unstable, or continuous with
    /// `D != 0`) or the Gramian is too inaccurate to give it.
    pub h2_norm: Option<f64>,
    /// The H-infinity norm with its frequency and certified bound; `None`
    /// for an unstable system or when no level could be bracketed.
    pub hinf_norm: Option<HinfNorm>,
}

/// Poles, stability, zeros and both norms of `sys`.
pub fn system_info(sys: &StateSpace) -> Result<SystemInfo, SsError> {
    let poles = sys.poles()?;
    let stable = sys.poles_are_stable(&poles);
    let (h2_norm, hinf_norm) = if stable {
        (
            h2_norm_of_stable(sys).ok().filter(|x| x.is_finite()),
            hinf_norm_confirmed_with_poles(sys, HINF_RTOL, &poles).ok(),
        )
    } else {
        (None, None)
    };
    let zeros = invariant_zeros(sys, None)?;
    Ok(SystemInfo {
        poles,
        stable,
        zeros,
        h2_norm,
        hinf_norm,
    })
}
