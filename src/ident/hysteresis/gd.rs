//! Gradient-based identification (\[Li21\] used gradient descent): L-BFGS with a
//! More–Thuente line search (argmin) on the least-squares cost of docs/math.md §1.5,
//! `J(w) = 1/(2N) ||Phi w - y||^2`.
//!
//! The unknowns are scaled by the column norms of `Phi` (`w = D x`,
//! `D = diag(1/||phi_j||)`): a diagonal preconditioner that leaves the optimum
//! unchanged and makes the Hessian's diagonal one, which the play-operator
//! regressors (columns of very different size, e.g. an offset column of ones
//! next to volts) badly need.

use super::lsq::ColMajor;
use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{CostFunction, Error as ArgminError, Executor, Gradient, IterState, State};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;

/// The solver state an [`Observe`] implementation sees (for progress display).
pub type GdState = IterState<Vec<f64>, Vec<f64>, (), (), (), f64>;

/// Settings of the gradient solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GdParams {
    /// Iteration cap per solve. Default 2000.
    pub max_iters: u64,
    /// L-BFGS memory (pairs kept). Default 10.
    pub memory: usize,
    /// Stop when the gradient norm falls below this fraction of its initial
    /// value. Default 1e-12.
    pub rel_tol_grad: f64,
}

impl Default for GdParams {
    fn default() -> Self {
        Self {
            max_iters: 2000,
            memory: 10,
            rel_tol_grad: 1e-12,
        }
    }
}

/// What the gradient solver did.
#[derive(Debug, Clone, PartialEq)]
pub struct GdInfo {
    /// Iterations used.
    pub iterations: u64,
    /// Final cost `J = 1/(2N) ||Phi w - y||^2`.
    pub cost: f64,
    /// argmin's termination reason.
    pub termination: String,
}

/// An observer that does nothing (for callers without progress display).
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl<I> Observe<I> for Silent {}

struct ScaledLeastSquares<'a> {
    phi: &'a ColMajor,
    y: &'a [f64],
    scale: Vec<f64>,
}

impl ScaledLeastSquares<'_> {
    fn residual(&self, x: &[f64]) -> Vec<f64> {
        let n = self.phi.rows();
        let mut r: Vec<f64> = self.y.iter().map(|v| -v).collect();
        for (j, (xj, dj)) in x.iter().zip(&self.scale).enumerate() {
            let c = xj * dj;
            for (ri, pij) in r.iter_mut().zip(self.phi.col(j)) {
                *ri += c * pij;
            }
        }
        debug_assert_eq!(r.len(), n);
        r
    }
}

impl CostFunction for ScaledLeastSquares<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, ArgminError> {
        let r = self.residual(x);
        Ok(r.iter().map(|v| v * v).sum::<f64>() / (2.0 * r.len() as f64))
    }
}

impl Gradient for ScaledLeastSquares<'_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, x: &Vec<f64>) -> Result<Vec<f64>, ArgminError> {
        // dJ/dx = (1/N) D Phi^T (Phi D x - y)
        let r = self.residual(x);
        let n = r.len() as f64;
        Ok((0..x.len())
            .map(|j| {
                let col = self.phi.col(j);
                self.scale[j] * col.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>() / n
            })
            .collect())
    }
}

/// Minimises `1/(2N) ||Phi w - y||^2` by L-BFGS from `start` (or `w = 0`).
///
/// Stops when the gradient norm falls below `rel_tol_grad` times its value at
/// `w = 0` (the problem's own scale, whatever the start), when an iteration
/// changes the cost by less than 1e-16 of the cost at `w = 0` (round-off
/// level), or after `max_iters`.
pub fn gd_lstsq<O>(
    phi: &ColMajor,
    y: &[f64],
    params: &GdParams,
    start: Option<&[f64]>,
    observer: O,
) -> Result<(Vec<f64>, GdInfo), ArgminError>
where
    O: Observe<GdState> + 'static,
{
    let p = phi.cols();
    let norms: Vec<f64> = (0..p)
        .map(|j| phi.col(j).iter().map(|v| v * v).sum::<f64>().sqrt())
        .collect();
    let scale: Vec<f64> = norms
        .iter()
        .map(|&n| if n > 0.0 { 1.0 / n } else { 1.0 })
        .collect();
    let problem = ScaledLeastSquares { phi, y, scale };
    let zeros = vec![0.0; p];
    let g0 = problem.gradient(&zeros)?;
    let g0_norm = g0.iter().map(|v| v * v).sum::<f64>().sqrt();
    let cost0 = problem.cost(&zeros)?;
    // x = w / D in the scaled unknowns.
    let x0 = match start {
        Some(w) if w.len() == p => w.iter().zip(&problem.scale).map(|(w, d)| w / d).collect(),
        _ => zeros,
    };
    let solver = LBFGS::new(MoreThuenteLineSearch::new(), params.memory)
        .with_tolerance_grad(params.rel_tol_grad * g0_norm)?
        .with_tolerance_cost(1e-16 * cost0)?;
    let scale = problem.scale.clone();
    let result = Executor::new(problem, solver)
        .configure(|state| state.param(x0).max_iters(params.max_iters))
        .add_observer(observer, ObserverMode::Always)
        .run()?;
    let state = result.state();
    let x = state
        .get_best_param()
        .cloned()
        .unwrap_or_else(|| vec![0.0; p]);
    let w: Vec<f64> = x.iter().zip(&scale).map(|(a, b)| a * b).collect();
    Ok((
        w,
        GdInfo {
            iterations: state.get_iter(),
            cost: state.get_best_cost(),
            termination: state.get_termination_status().to_string(),
        },
    ))
}
