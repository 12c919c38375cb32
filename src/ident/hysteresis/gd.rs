//! Gradient-based identification (\[Li21\] used gradient descent): L-BFGS,
//! run by argmin, on the least-squares cost of docs/math.md §1.5,
//! `J(w) = 1/(2N) ||Phi w - y||^2`. The cost is quadratic, so each step is
//! the exact minimiser along the L-BFGS direction (no line search).
//!
//! The cost is evaluated from the triangular factor of `[Phi | y]`, which the
//! identification forms anyway (for the condition number) in one pass over
//! the record. With `[Phi | y] = Q [R z; 0 rho]`,
//!
//! `J(w) = (||R w - z||^2 + rho^2) / (2N)`, `grad J(w) = R^T (R w - z) / N`,
//!
//! exactly, for any orthogonal `Q`. Each evaluation then costs `O(p^2)`
//! instead of `O(N p)` (about `N / p` times less work: 3,000x on a 33,715-sample
//! record with 12 columns), and it is more accurate than the residual it
//! replaces: the solver minimises the variable part `||R w - z||^2 / (2N)`
//! alone, so the line search's cost comparisons are not absorbed into the
//! constant `rho^2` (the residual floor), and `R^T R` (the Gram matrix, whose
//! condition is the square of `Phi`'s) is never formed.
//!
//! The unknowns are scaled by the column norms of `Phi` (`w = D x`,
//! `D = diag(1/||phi_j||)`; `||phi_j||` is the norm of `R`'s column `j`): a
//! diagonal preconditioner that leaves the optimum unchanged and makes the
//! Hessian's diagonal one, which the play-operator regressors (columns of very
//! different size, e.g. an offset column of ones next to volts) badly need.

use crate::ident::ls::dot;
use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{
    Error as ArgminError, Executor, IterState, KV, Problem, Solver, State, TerminationReason,
    TerminationStatus,
};

/// The solver state an [`Observe`] implementation sees (for progress display).
/// Its cost is the part of `J` above the floor `rho^2 / (2N)`, which falls
/// to round-off at the optimum.
pub type GdState = IterState<Vec<f64>, Vec<f64>, (), (), (), f64>;

/// Settings of the gradient solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GdParams {
    /// Iteration cap per solve. Default 2000.
    pub max_iters: u64,
    /// L-BFGS memory (pairs kept). Default 20: at least the unknowns of the
    /// usual models (12 for MPI-cbrt with ten operators), so the solver keeps
    /// the whole curvature of the quadratic.
    pub memory: usize,
    /// Stop when the gradient norm falls below this fraction of its initial
    /// value. Default 1e-12.
    pub rel_tol_grad: f64,
}

impl Default for GdParams {
    fn default() -> Self {
        Self {
            max_iters: 2000,
            memory: 20,
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

/// The least-squares problem carried by the triangular factor of `[Phi | y]`,
/// in the scaled unknowns `x = D^-1 w`.
#[derive(Debug, Clone)]
pub struct TriangularLeastSquares {
    p: usize,
    /// `R D`, column-major `p x p`, upper triangular.
    rd: Vec<f64>,
    /// `D`: the reciprocal column norms of `Phi` (1 for a zero column).
    scale: Vec<f64>,
    z: Vec<f64>,
    /// `rho^2 / (2N)`: the cost no `w` can remove.
    floor: f64,
    /// `1 / N`.
    inv_rows: f64,
}

impl TriangularLeastSquares {
    /// From the `(p+1) x (p+1)` column-major factor of `[Phi | y]` (what
    /// `StreamingQr::r` returns) and the number of rows `N` it came from.
    pub fn from_factor(r_aug: &[f64], rows: usize) -> Self {
        let cols = (r_aug.len() as f64).sqrt().round() as usize;
        assert_eq!(cols * cols, r_aug.len(), "factor must be square");
        assert!(cols >= 2 && rows > 0);
        let p = cols - 1;
        let at = |i: usize, j: usize| r_aug[j * cols + i];
        let scale: Vec<f64> = (0..p)
            .map(|j| {
                let norm = (0..=j).map(|i| at(i, j).powi(2)).sum::<f64>().sqrt();
                if norm > 0.0 { 1.0 / norm } else { 1.0 }
            })
            .collect();
        let mut rd = vec![0.0; p * p];
        for j in 0..p {
            for i in 0..=j {
                rd[j * p + i] = at(i, j) * scale[j];
            }
        }
        let inv_rows = 1.0 / rows as f64;
        Self {
            p,
            rd,
            scale,
            z: (0..p).map(|i| at(i, p)).collect(),
            floor: at(p, p).powi(2) * 0.5 * inv_rows,
            inv_rows,
        }
    }

    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.p
    }

    /// Column `j` of `R D` down to the diagonal.
    #[inline]
    fn column(&self, j: usize) -> &[f64] {
        &self.rd[j * self.p..j * self.p + j + 1]
    }

    /// `out = R D v`.
    fn apply(&self, v: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        for (j, &vj) in v.iter().enumerate() {
            for (o, a) in out.iter_mut().zip(self.column(j)) {
                *o += a * vj;
            }
        }
    }

    /// `out = factor (R D)^T v`.
    fn apply_transpose(&self, v: &[f64], factor: f64, out: &mut [f64]) {
        for (j, o) in out.iter_mut().enumerate() {
            *o = factor
                * self
                    .column(j)
                    .iter()
                    .zip(v)
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
        }
    }

    /// `e = R D x - z` (the part of the residual `x` can change, rotated by
    /// `Q^T`) and the gradient `g = (R D)^T e / N`; returns the variable part
    /// of the cost, `||e||^2 / (2N)`.
    fn evaluate(&self, x: &[f64], e: &mut [f64], g: &mut [f64]) -> f64 {
        self.apply(x, e);
        for (ei, zi) in e.iter_mut().zip(&self.z) {
            *ei -= zi;
        }
        self.apply_transpose(e, self.inv_rows, g);
        0.5 * e.iter().map(|v| v * v).sum::<f64>() * self.inv_rows
    }

    /// The whole cost `J = 1/(2N) ||Phi D x - y||^2` and its gradient in `x`.
    pub fn cost_and_gradient(&self, x: &[f64]) -> (f64, Vec<f64>) {
        let (mut e, mut g) = (vec![0.0; self.p], vec![0.0; self.p]);
        let variable = self.evaluate(x, &mut e, &mut g);
        (variable + self.floor, g)
    }
}

/// L-BFGS for the quadratic cost of [`TriangularLeastSquares`], as an argmin
/// solver that allocates nothing after `init`.
///
/// * Direction: the two-loop recursion over the last `memory` pairs
///   `(s, y)` (\[NW06\] ch. 7, the two-loop recursion), scaled by `s'y / y'y` of
///   the newest pair (its usual initial matrix).
/// * Step: the exact minimiser along the direction, `alpha = -g'd / d'Hd`
///   with `d'Hd = ||R D d||^2 / N`: the cost is quadratic, so no line search
///   is needed, and `y = H s = alpha (R D)^T (R D d) / N` is formed directly
///   rather than as a difference of gradients that cancels near the optimum.
///   With exact steps on a quadratic, BFGS reaches the optimum in at most
///   `p` steps in exact arithmetic (\[NW06\] ch. 6); with a memory of at
///   least `p` pairs this solver takes `p` steps on the piezo record (11 and
///   12, benches/hysteresis.rs), and the checks hold it to that.
/// * A direction that is not a descent direction (round-off near the
///   optimum) restarts from the steepest descent with the memory cleared.
///
/// The iterate, its best value and the memory live in the solver's buffers;
/// the argmin state carries the cost and the iteration count (its `param`
/// stays empty, so argmin's bookkeeping copies no vector per iteration).
struct ExactStepLbfgs {
    memory: usize,
    tol_grad: f64,
    tol_cost: f64,
    x: Vec<f64>,
    best: Vec<f64>,
    best_cost: f64,
    g: Vec<f64>,
    e: Vec<f64>,
    d: Vec<f64>,
    rd_d: Vec<f64>,
    /// Pairs `s_i`, `y_i` in a ring of `memory` rows of `p`.
    s: Vec<f64>,
    y: Vec<f64>,
    rho: Vec<f64>,
    alpha: Vec<f64>,
    /// Pairs held, and the ring slot of the newest.
    held: usize,
    newest: usize,
    cost: f64,
    cost_change: f64,
    grad_norm: f64,
}

impl ExactStepLbfgs {
    fn new(x0: Vec<f64>, memory: usize, tol_grad: f64, tol_cost: f64) -> Self {
        let p = x0.len();
        let m = memory.max(1);
        Self {
            memory: m,
            tol_grad,
            tol_cost,
            best: x0.clone(),
            x: x0,
            best_cost: f64::INFINITY,
            g: vec![0.0; p],
            e: vec![0.0; p],
            d: vec![0.0; p],
            rd_d: vec![0.0; p],
            s: vec![0.0; m * p],
            y: vec![0.0; m * p],
            rho: vec![0.0; m],
            alpha: vec![0.0; m],
            held: 0,
            newest: 0,
            cost: f64::INFINITY,
            cost_change: f64::INFINITY,
            grad_norm: f64::INFINITY,
        }
    }

    /// `d = -H_k g` by the two-loop recursion (\[NW06\] ch. 7).
    fn direction(&mut self) {
        let (m, p) = (self.memory, self.x.len());
        let row = |slot: usize| slot * p..(slot + 1) * p;
        let d = &mut self.d;
        d.copy_from_slice(&self.g);
        for k in 0..self.held {
            let slot = (self.newest + m - k) % m;
            let a = self.rho[slot] * dot::<false>(&self.s[row(slot)], d);
            axpy(-a, &self.y[row(slot)], d);
            self.alpha[slot] = a;
        }
        if self.held > 0 {
            let (s, y) = (&self.s[row(self.newest)], &self.y[row(self.newest)]);
            let gamma = dot::<false>(s, y) / dot::<false>(y, y);
            d.iter_mut().for_each(|v| *v *= gamma);
        }
        for k in (0..self.held).rev() {
            let slot = (self.newest + m - k) % m;
            let b = self.rho[slot] * dot::<false>(&self.y[row(slot)], d);
            axpy(self.alpha[slot] - b, &self.s[row(slot)], d);
        }
        d.iter_mut().for_each(|v| *v = -*v);
    }

    /// Keeps `(s, y) = (alpha d, alpha H d)` as the newest pair.
    fn remember(&mut self, problem: &TriangularLeastSquares, alpha: f64) {
        let p = self.x.len();
        let slot = if self.held == 0 {
            0
        } else {
            (self.newest + 1) % self.memory
        };
        let (s, y) = (
            &mut self.s[slot * p..(slot + 1) * p],
            &mut self.y[slot * p..(slot + 1) * p],
        );
        for (si, di) in s.iter_mut().zip(&self.d) {
            *si = alpha * di;
        }
        problem.apply_transpose(&self.rd_d, alpha * problem.inv_rows, y);
        let sy = dot::<false>(s, y);
        if sy > 0.0 && sy.is_finite() {
            self.rho[slot] = 1.0 / sy;
            self.newest = slot;
            self.held = (self.held + 1).min(self.memory);
        } else if self.held == self.memory {
            // The slot held the oldest pair, now overwritten: drop it.
            self.held -= 1;
        }
    }

    /// One step: the L-BFGS direction, or the steepest descent (memory
    /// cleared) where round-off has left it no descent direction; then the
    /// exact step length along it.
    fn step(&mut self, problem: &TriangularLeastSquares) {
        self.direction();
        let mut slope = dot::<false>(&self.g, &self.d);
        let descends = slope < 0.0;
        if !descends {
            self.held = 0;
            self.d.iter_mut().zip(&self.g).for_each(|(d, g)| *d = -g);
            slope = -dot::<false>(&self.g, &self.g);
        }
        problem.apply(&self.d, &mut self.rd_d);
        let curvature = dot::<false>(&self.rd_d, &self.rd_d) * problem.inv_rows;
        if curvature > 0.0 && curvature.is_finite() && slope < 0.0 {
            let alpha = -slope / curvature;
            axpy(alpha, &self.d, &mut self.x);
            self.remember(problem, alpha);
        }
        self.evaluate(problem);
    }

    fn evaluate(&mut self, problem: &TriangularLeastSquares) {
        let cost = problem.evaluate(&self.x, &mut self.e, &mut self.g);
        self.cost_change = (self.cost - cost).abs();
        self.cost = cost;
        self.grad_norm = dot::<false>(&self.g, &self.g).sqrt();
        if cost < self.best_cost {
            self.best_cost = cost;
            self.best.copy_from_slice(&self.x);
        }
    }
}

impl ExactStepLbfgs {
    /// Runs `work` on the problem (counted as one gradient evaluation by
    /// argmin) and hands argmin the new cost.
    fn work_on(
        &mut self,
        problem: &mut Problem<&TriangularLeastSquares>,
        state: GdState,
        work: fn(&mut Self, &TriangularLeastSquares),
    ) -> Result<(GdState, Option<KV>), ArgminError> {
        problem.problem("gradient_count", |p| {
            work(self, p);
            Ok(())
        })?;
        Ok((state.cost(self.cost), None))
    }
}

fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

impl Solver<&TriangularLeastSquares, GdState> for ExactStepLbfgs {
    fn name(&self) -> &str {
        "L-BFGS, exact steps"
    }

    fn init(
        &mut self,
        problem: &mut Problem<&TriangularLeastSquares>,
        state: GdState,
    ) -> Result<(GdState, Option<KV>), ArgminError> {
        self.work_on(problem, state, Self::evaluate)
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<&TriangularLeastSquares>,
        state: GdState,
    ) -> Result<(GdState, Option<KV>), ArgminError> {
        self.work_on(problem, state, Self::step)
    }

    fn terminate(&mut self, _state: &GdState) -> TerminationStatus {
        if self.grad_norm <= self.tol_grad || self.cost_change < self.tol_cost {
            TerminationStatus::Terminated(TerminationReason::SolverConverged)
        } else {
            TerminationStatus::NotTerminated
        }
    }
}

/// Minimises `1/(2N) ||Phi w - y||^2` by L-BFGS with exact steps from `start`
/// (or `w = 0`), given the triangular factor of `[Phi | y]` (see
/// [`TriangularLeastSquares`]).
///
/// Stops when the gradient norm falls below `rel_tol_grad` times its value at
/// `w = 0` (the problem's own scale, whatever the start), when an iteration
/// changes the cost by less than `eps^2` of the cost at `w = 0` (the
/// round-off level of the variable part, which vanishes at the optimum; a
/// step that cannot lower the cost changes it by nothing), or after
/// `max_iters`.
pub fn gd_lstsq<O>(
    problem: &TriangularLeastSquares,
    params: &GdParams,
    start: Option<&[f64]>,
    observer: O,
) -> Result<(Vec<f64>, GdInfo), ArgminError>
where
    O: Observe<GdState> + 'static,
{
    let p = problem.unknowns();
    let zeros = vec![0.0; p];
    let (cost0, g0) = problem.cost_and_gradient(&zeros);
    let g0_norm = dot::<false>(&g0, &g0).sqrt();
    // x = w / D in the scaled unknowns.
    let x0 = match start {
        Some(w) if w.len() == p => w.iter().zip(&problem.scale).map(|(w, d)| w / d).collect(),
        _ => zeros,
    };
    let solver = ExactStepLbfgs::new(
        x0,
        params.memory,
        params.rel_tol_grad * g0_norm,
        f64::EPSILON * f64::EPSILON * cost0,
    );
    let result = Executor::new(problem, solver)
        .configure(|state| state.max_iters(params.max_iters))
        .timer(false)
        .add_observer(observer, ObserverMode::Always)
        .run()?;
    let solver = &result.solver;
    let w: Vec<f64> = solver
        .best
        .iter()
        .zip(&problem.scale)
        .map(|(a, b)| a * b)
        .collect();
    Ok((
        w,
        GdInfo {
            iterations: result.state.get_iter(),
            cost: solver.best_cost + problem.floor,
            termination: result.state.get_termination_status().to_string(),
        },
    ))
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use crate::ident::hysteresis::lsq::{ColMajor, qr_of, solve_from_r};

    /// A tall problem with columns of very different size (as play-operator
    /// regressors have) and a residual no weight can remove.
    fn problem(rows: usize, p: usize) -> (ColMajor, Vec<f64>) {
        let mut seed = 3u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut a = ColMajor::zeros(rows, p);
        for j in 0..p {
            let size = 10f64.powi(j as i32 % 4 - 1);
            for v in a.col_mut(j) {
                *v = size * next();
            }
        }
        let y = (0..rows)
            .map(|i| (0..p).map(|j| a.col(j)[i] * (j as f64 - 2.5)).sum::<f64>() + 0.3 * next())
            .collect();
        (a, y)
    }

    /// `J` and its gradient straight from the residual `Phi D x - y`.
    fn from_residual(a: &ColMajor, y: &[f64], scale: &[f64], x: &[f64]) -> (f64, Vec<f64>) {
        let n = y.len() as f64;
        let r: Vec<f64> = (0..y.len())
            .map(|i| {
                (0..a.cols())
                    .map(|j| a.col(j)[i] * scale[j] * x[j])
                    .sum::<f64>()
                    - y[i]
            })
            .collect();
        let cost = r.iter().map(|v| v * v).sum::<f64>() / (2.0 * n);
        let grad = (0..a.cols())
            .map(|j| scale[j] * a.col(j).iter().zip(&r).map(|(p, e)| p * e).sum::<f64>() / n)
            .collect();
        (cost, grad)
    }

    /// The factor's cost and gradient are the residual's, to round-off, at
    /// points near and far from the optimum; the scale is `1 / ||phi_j||`.
    pub fn factor_cost_and_gradient_are_the_residuals() {
        let (a, y) = problem(3000, 6);
        let factor = qr_of(&a, &y);
        let problem = TriangularLeastSquares::from_factor(factor.r(), y.len());
        for j in 0..6 {
            let norm = a.col(j).iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((problem.scale[j] * norm - 1.0).abs() < 1e-14);
        }
        for x in [
            [0.0; 6],
            [1.0, -2.0, 0.5, 3.0, 0.0, 1.0],
            [40.0, -7.0, 2.0, 0.1, 9.0, -3.0],
        ] {
            let (cost, grad) = from_residual(&a, &y, &problem.scale, &x);
            let (got, g) = problem.cost_and_gradient(&x);
            assert!((got - cost).abs() <= 1e-13 * cost, "cost {got} vs {cost}");
            let scale = grad.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            for (a, b) in g.iter().zip(&grad) {
                assert!((a - b).abs() <= 1e-12 * scale, "gradient {g:?} vs {grad:?}");
            }
        }
    }

    /// L-BFGS reaches the least-squares solution of the same factor: the
    /// same cost to round-off and the same weights to 1e-9, from zero and
    /// from a start; a two-step cap stops short and says so in its count.
    pub fn lbfgs_reaches_the_least_squares_solution() {
        let (a, y) = problem(3000, 6);
        let factor = qr_of(&a, &y);
        let ls = solve_from_r(factor.r(), 7, 6, None).unwrap();
        let problem = TriangularLeastSquares::from_factor(factor.r(), y.len());
        let ls_cost = 0.5 * ls.residual_norm.powi(2) / y.len() as f64;
        let start = [1.0; 6];
        for start in [None, Some(&start[..])] {
            let (w, info) = gd_lstsq(&problem, &GdParams::default(), start, Silent).unwrap();
            assert!(
                (info.cost - ls_cost).abs() <= 1e-13 * ls_cost,
                "{info:?} vs {ls_cost}"
            );
            let big = ls.x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in w.iter().zip(&ls.x) {
                assert!((a - b).abs() <= 1e-9 * big, "{w:?} vs {:?}", ls.x);
            }
            // Exact steps on a quadratic: the optimum in p steps, plus
            // one that finds nothing left to change.
            assert!(info.iterations <= 7, "{info:?}");
        }
        let capped = GdParams {
            max_iters: 2,
            ..Default::default()
        };
        let (_, info) = gd_lstsq(&problem, &capped, None, Silent).unwrap();
        assert_eq!(info.iterations, 2);
        assert!(info.cost > ls_cost * (1.0 + 1e-6), "{info:?}");
    }
}
