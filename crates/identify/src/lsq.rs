//! Bounded nonlinear least squares: minimise `cost(x) = ½·Σ rᵢ(x)²` subject to
//! `lo ≤ x ≤ hi`.
//!
//! # Method
//! Projected Levenberg–Marquardt:
//! * The step `h` solves the damped normal equations
//!   `(JᵀJ + μ·D²)·h = −Jᵀr` restricted to the *free* variables, where `D` is the
//!   diagonal scaling of Moré (1978, "The Levenberg–Marquardt algorithm:
//!   implementation and theory", Lecture Notes in Math. 630): `D_jj` is the
//!   largest column norm `‖J_j‖` seen so far, which makes the method invariant to
//!   the units of the parameters.
//! * The damping `μ` follows Nielsen's update (H. B. Nielsen, "Damping parameter in
//!   Marquardt's method", IMM-REP-1999-05, DTU; also Madsen, Nielsen & Tingleff,
//!   "Methods for non-linear least squares problems", 2004, §3.2): with the gain
//!   ratio `ρ = (cost(x) − cost(x+h)) / (L(0) − L(h))`, where `L` is the
//!   Gauss–Newton model `L(h) = ½‖r + J·h‖²`, an accepted step (`ρ > 0`) sets
//!   `μ ← μ·max(1/3, 1 − (2ρ − 1)³)`, `ν ← 2`; a rejected one sets `μ ← μ·ν`,
//!   `ν ← 2ν`. The initial value is `μ₀ = 10⁻³` (relative to `D²`).
//! * Bounds by projection (the "projected LM" of Kanzow, Yamashita & Fukushima,
//!   J. Comput. Appl. Math. 172, 2004): each trial point is clipped onto the box,
//!   `x⁺ = P(x + h)`, and the predicted reduction is evaluated for the clipped
//!   step actually taken. A variable sitting on a bound whose gradient component
//!   `gⱼ = (Jᵀr)ⱼ` pushes it outward (at `lo` with `gⱼ > 0`, at `hi` with `gⱼ < 0`)
//!   is held fixed for that iteration (active set).
//! * A residual evaluation that fails (returns `Err`, non-finite values, or a
//!   different length) at a trial point counts as a rejected step (damping is
//!   increased); at the starting point it is an error.
//!
//! # Jacobian
//! Forward differences, `J_j ≈ (r(x + hⱼeⱼ) − r(x))/hⱼ` with
//! `hⱼ = fd_rel_step·max(|xⱼ|, 1)`; the step is taken backward when the forward
//! point would leave the box. Columns are evaluated in parallel with rayon when
//! `LsqOptions::parallel` is set (the residual function is `Sync`).
//!
//! With [`JacobianUpdate::FiniteDifference`] (the default) a fresh
//! forward-difference Jacobian (`n` residual evaluations) is taken at every
//! accepted iterate. With [`JacobianUpdate::Broyden`] the Jacobian is carried from
//! one accepted iterate to the next by Broyden's rank-one secant update
//! (Madsen, Nielsen & Tingleff, "Methods for non-linear least squares
//! problems", 2nd ed. 2004, §3.4 "The L-M method with a secant Jacobian",
//! eq. 3.33 and Algorithm 3.34; Broyden, Math. Comp. 19, 1965):
//! `J ← J + (r(x+h) − r(x) − J·h)·hᵀ / (hᵀh)`, which costs no evaluation
//! beyond the trial point. A fresh forward-difference Jacobian replaces the
//! updated one when it is stale:
//! * after `max_updates` consecutive updates;
//! * when a step computed from an updated Jacobian is rejected (the refresh
//!   rule of Powell's hybrid method, MINPACK `hybrd`: Moré, Garbow &
//!   Hillstrom, "User guide for MINPACK-1", ANL-80-74, 1980) — the damping is
//!   then left as it was, the failure being the Jacobian's;
//! * before any stopping test may end the run (gradient, cost, step and the
//!   caller's give-up test are passed only with the finite-difference
//!   Jacobian at the iterate; a cost test met by a secant step makes one more
//!   step from the fresh Jacobian), and at the last point when
//!   `final_jacobian` is set, so the returned `jacobian` and the covariance
//!   are the finite-difference ones at `x`. Without `final_jacobian`, a run
//!   ended by the cost test returns the finite-difference Jacobian of the
//!   previous iterate, from which its last step was computed.
//!
//! A step shorter than the finite-difference step in every coordinate
//! does not update the Jacobian (its secant would be noisier than a
//! difference column); the Jacobian of the previous iterate is kept. The
//! Moré scaling `D` is taken from finite-difference Jacobians only.
//!
//! # Stopping tests (MINPACK-like, Moré 1978)
//! * `gtol`: the largest cosine between `r` and a free column of `J`,
//!   `maxⱼ |J_jᵀr| / (‖J_j‖·‖r‖) ≤ gtol` (scale free), or `cost = 0`;
//! * `ftol`: an accepted step whose actual and predicted relative reductions of
//!   the cost are both `≤ ftol`;
//! * `xtol`: a step with `‖D·h‖ ≤ xtol·(xtol + ‖D·x‖)`;
//! * `max_iter` step attempts (accepted or rejected) without the above:
//!   `converged = false`. With Broyden updates only the attempts from a
//!   finite-difference Jacobian count (the limit bounds the finite-difference
//!   Jacobians as before); at most `max_updates` secant attempts follow each.
//!
//! # Covariance
//! `cov = s²·(JᵀJ)⁻¹` with `s² = 2·cost/(m − n)` at the solution, using the full
//! Jacobian (all `n` parameters, also those at a bound: such a covariance is only
//! indicative). `None` when `m ≤ n` or `JᵀJ` is numerically singular
//! (reciprocal condition number below `m·n·ε`). `std_errors` are the square roots
//! of its diagonal. These are the usual asymptotic (linearised) estimates and
//! assume independent residuals of equal variance.
//!
//! Units: whatever the caller's parameters and residuals carry; the method is
//! unit invariant thanks to the `D` scaling (the finite-difference step is
//! relative, with an absolute floor of `fd_rel_step` for parameters smaller
//! than 1 in magnitude — rescale such parameters, or give a larger step, if they
//! are much smaller than 1).

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// How the Jacobian is obtained after the first (finite-difference) one;
/// see the module documentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JacobianUpdate {
    /// A forward-difference Jacobian at every accepted iterate.
    FiniteDifference,
    /// Broyden rank-one updates between forward-difference Jacobians, at
    /// most `max_updates` in a row.
    Broyden { max_updates: usize },
}

impl Default for JacobianUpdate {
    /// Finite differences at every iterate: on the discrepancy fits the
    /// Broyden variant ends at other points (docs/discrepancy.md, "Speed").
    fn default() -> Self {
        JacobianUpdate::FiniteDifference
    }
}

impl JacobianUpdate {
    /// Broyden updates with a fresh finite-difference Jacobian at least
    /// every 8 steps.
    pub const BROYDEN: JacobianUpdate = JacobianUpdate::Broyden { max_updates: 8 };
}

/// Residual evaluations of all least-squares runs of this process, by use
/// (run-time accounting of docs/discrepancy.md, "Speed").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Runs of [`least_squares_until`].
    pub runs: usize,
    /// Evaluations at starting and trial points.
    pub trials: usize,
    /// Evaluations for finite-difference Jacobian columns.
    pub columns: usize,
    /// Finite-difference Jacobians computed.
    pub jacobians: usize,
    /// Broyden updates made.
    pub updates: usize,
}

static RUNS: AtomicUsize = AtomicUsize::new(0);
static TRIALS: AtomicUsize = AtomicUsize::new(0);
static COLUMNS: AtomicUsize = AtomicUsize::new(0);
static JACOBIANS: AtomicUsize = AtomicUsize::new(0);
static UPDATES: AtomicUsize = AtomicUsize::new(0);

/// [`Counts`] since the process started.
pub fn counts() -> Counts {
    let l = |a: &AtomicUsize| a.load(Ordering::Relaxed);
    Counts { runs: l(&RUNS), trials: l(&TRIALS), columns: l(&COLUMNS), jacobians: l(&JACOBIANS), updates: l(&UPDATES) }
}

/// Box constraints `lo[i] ≤ x[i] ≤ hi[i]`; use `±f64::INFINITY` for "no bound".
#[derive(Debug, Clone)]
pub struct Bounds {
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

impl Bounds {
    /// No bounds on `n` parameters.
    pub fn unbounded(n: usize) -> Self {
        Bounds { lo: vec![f64::NEG_INFINITY; n], hi: vec![f64::INFINITY; n] }
    }
    /// Bounds from two vectors (checked by [`least_squares`]).
    pub fn new(lo: Vec<f64>, hi: Vec<f64>) -> Self {
        Bounds { lo, hi }
    }
}

/// Solver options; see the module documentation for the meaning of the
/// tolerances.
#[derive(Debug, Clone)]
pub struct LsqOptions {
    /// Maximum number of step attempts (accepted or rejected) from a
    /// finite-difference Jacobian (with [`JacobianUpdate::FiniteDifference`]:
    /// all of them).
    pub max_iter: usize,
    /// Relative reduction of the cost below which the iteration stops.
    pub ftol: f64,
    /// Relative (scaled) step length below which the iteration stops.
    pub xtol: f64,
    /// Largest cosine between the residual vector and a Jacobian column.
    pub gtol: f64,
    /// Relative finite-difference step for the Jacobian.
    pub fd_rel_step: f64,
    /// Evaluate Jacobian columns in parallel (rayon).
    pub parallel: bool,
    /// Compute the Jacobian at the last point when the iteration limit ends
    /// the run right after an accepted step (for the covariance; with
    /// Broyden updates, also when the cost test does). Without it the
    /// result's `jacobian` and `covariance` are those of the previous
    /// iterate (`x`, `cost` and `residuals` are the same either way).
    /// With [`JacobianUpdate::Broyden`] it also makes the returned Jacobian
    /// the finite-difference one at `x` when the limit ends the run.
    pub final_jacobian: bool,
    /// Finite differences at every iterate, or Broyden updates between them.
    pub jacobian: JacobianUpdate,
}

impl Default for LsqOptions {
    fn default() -> Self {
        LsqOptions {
            max_iter: 200,
            ftol: 1e-10,
            xtol: 1e-10,
            gtol: 1e-10,
            fd_rel_step: f64::EPSILON.sqrt(),
            parallel: true,
            final_jacobian: true,
            jacobian: JacobianUpdate::default(),
        }
    }
}

/// Outcome of [`least_squares`].
#[derive(Debug, Clone)]
pub struct LsqResult {
    /// Parameters at the solution.
    pub x: Vec<f64>,
    /// `½·Σ rᵢ²` at `x`.
    pub cost: f64,
    /// Residuals at `x`.
    pub residuals: Vec<f64>,
    /// Forward-difference Jacobian at `x` (m × n).
    pub jacobian: DMatrix<f64>,
    /// `s²·(JᵀJ)⁻¹`, `s² = 2·cost/(m − n)`; `None` if `m ≤ n` or singular.
    pub covariance: Option<DMatrix<f64>>,
    /// Square roots of the covariance diagonal.
    pub std_errors: Option<Vec<f64>>,
    /// Step attempts made.
    pub iterations: usize,
    /// Residual evaluations made (including those for the Jacobian).
    pub evaluations: usize,
    /// Of these, evaluations for finite-difference Jacobian columns.
    pub column_evaluations: usize,
    /// Finite-difference Jacobians computed.
    pub jacobians: usize,
    /// Broyden updates made.
    pub updates: usize,
    /// Whether a stopping test (not the iteration limit) ended the run.
    pub converged: bool,
    /// Which test stopped the iteration.
    pub message: String,
    /// `at_bound[i]`: `x[i]` lies on `lo[i]` or `hi[i]`.
    pub at_bound: Vec<bool>,
}

/// Errors of [`least_squares`].
#[derive(Debug, thiserror::Error)]
pub enum LsqError {
    /// The residual function failed where it must not (starting point, or a
    /// Jacobian evaluation that failed both forward and backward).
    #[error("residual evaluation failed at x = {x:?}: {message}")]
    Residual { x: Vec<f64>, message: String },
    /// Inconsistent sizes, NaN, empty problem, inverted bounds...
    #[error("bad input to least_squares: {0}")]
    BadInput(String),
}

/// Counts calls and checks the residual vector (finite, fixed length).
struct Evaluator<'a, F> {
    f: &'a F,
    m: AtomicUsize,
    count: AtomicUsize,
    /// Of `count`, those for Jacobian columns.
    columns: AtomicUsize,
    /// Finite-difference Jacobians computed.
    jacobians: AtomicUsize,
}

impl<F> Evaluator<'_, F>
where
    F: Fn(&[f64]) -> Result<Vec<f64>, String> + Sync,
{
    fn eval(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        self.count.fetch_add(1, Ordering::Relaxed);
        let r = (self.f)(x)?;
        let m = self.m.load(Ordering::Relaxed);
        if m != 0 && r.len() != m {
            return Err(format!("residual length changed from {m} to {}", r.len()));
        }
        if let Some(i) = r.iter().position(|v| !v.is_finite()) {
            return Err(format!("residual {i} is not finite ({})", r[i]));
        }
        Ok(r)
    }
}

fn half_sum_sq(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

fn on_bound(x: f64, b: f64) -> bool {
    b.is_finite() && (x - b).abs() <= 1e-12 * b.abs().max(1.0)
}

/// Forward-difference Jacobian at `x` (residuals `r0` at `x`).
fn jacobian<F>(ev: &Evaluator<'_, F>, x: &[f64], r0: &[f64], bounds: &Bounds, opts: &LsqOptions) -> Result<DMatrix<f64>, LsqError>
where
    F: Fn(&[f64]) -> Result<Vec<f64>, String> + Sync,
{
    let n = x.len();
    let m = r0.len();
    ev.jacobians.fetch_add(1, Ordering::Relaxed);
    let column = |j: usize| -> Result<Vec<f64>, LsqError> {
        let step = opts.fd_rel_step * x[j].abs().max(1.0);
        // Forward if it stays in the box, else backward; if one side fails to
        // evaluate, try the other one.
        let fwd_ok = x[j] + step <= bounds.hi[j];
        let bwd_ok = x[j] - step >= bounds.lo[j];
        let mut order: Vec<f64> = Vec::with_capacity(2);
        if fwd_ok {
            order.push(step);
        }
        if bwd_ok {
            order.push(-step);
        }
        if order.is_empty() {
            // Box narrower than the step: use the larger room available.
            let room_up = bounds.hi[j] - x[j];
            let room_dn = x[j] - bounds.lo[j];
            let h = if room_up >= room_dn { room_up } else { -room_dn };
            if h == 0.0 {
                return Ok(vec![0.0; m]);
            }
            order.push(h);
        }
        let mut last_err = String::new();
        for h in order {
            let mut xp = x.to_vec();
            xp[j] += h;
            let hj = xp[j] - x[j]; // the step actually representable
            if hj == 0.0 {
                continue;
            }
            ev.columns.fetch_add(1, Ordering::Relaxed);
            match ev.eval(&xp) {
                Ok(rp) => return Ok(rp.iter().zip(r0).map(|(a, b)| (a - b) / hj).collect()),
                Err(e) => last_err = e,
            }
        }
        let mut xp = x.to_vec();
        xp[j] += step;
        Err(LsqError::Residual { x: xp, message: format!("Jacobian column {j}: {last_err}") })
    };
    let cols: Vec<Vec<f64>> = if opts.parallel {
        (0..n).into_par_iter().map(column).collect::<Result<_, _>>()?
    } else {
        (0..n).map(column).collect::<Result<_, _>>()?
    };
    Ok(DMatrix::from_fn(m, n, |i, j| cols[j][i]))
}

/// Broyden's rank-one secant update (Madsen, Nielsen & Tingleff 2004,
/// eq. 3.33): `J ← J + (r_new − r − J·h)·hᵀ / (hᵀh)`, so that afterwards
/// `J·h = r_new − r` and `J·v` is unchanged for every `v ⟂ h`.
fn broyden_update(jac: &mut DMatrix<f64>, h: &[f64], r: &[f64], r_new: &[f64]) {
    let hv = DVector::from_column_slice(h);
    let hh = hv.norm_squared();
    if hh == 0.0 {
        return;
    }
    let jh = &*jac * &hv;
    let u = DVector::from_fn(r.len(), |i, _| (r_new[i] - r[i] - jh[i]) / hh);
    jac.ger(1.0, &u, &hv, 1.0);
}

/// Solve `(A + μ·diag(d2))·h = b` (A symmetric positive semi-definite) by
/// Cholesky, falling back to an SVD pseudo-inverse when Cholesky fails.
fn damped_solve(a: &DMatrix<f64>, d2: &[f64], mu: f64, b: &DVector<f64>) -> Option<DVector<f64>> {
    let mut k = a.clone();
    for (i, d) in d2.iter().enumerate() {
        k[(i, i)] += mu * d;
    }
    if let Some(ch) = k.clone().cholesky() {
        let h = ch.solve(b);
        if h.iter().all(|v| v.is_finite()) {
            return Some(h);
        }
    }
    let svd = k.svd(true, true);
    let h = svd.solve(b, f64::EPSILON * 1e3).ok()?;
    h.iter().all(|v| v.is_finite()).then_some(h)
}

/// Covariance `s²(JᵀJ)⁻¹`, or `None` when not identifiable.
fn covariance(j: &DMatrix<f64>, cost: f64) -> Option<DMatrix<f64>> {
    let (m, n) = j.shape();
    if m <= n || n == 0 {
        return None;
    }
    let svd = j.clone().svd(false, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smax <= 0.0 || smin <= smax * (m * n) as f64 * f64::EPSILON {
        return None;
    }
    let v_t = svd.v_t.as_ref()?;
    // (JᵀJ)⁻¹ = V·Σ⁻²·Vᵀ
    let s2 = 2.0 * cost / (m - n) as f64;
    let mut cov = DMatrix::zeros(n, n);
    for k in 0..n {
        let w = s2 / (svd.singular_values[k] * svd.singular_values[k]);
        for a in 0..n {
            for b in 0..n {
                cov[(a, b)] += w * v_t[(k, a)] * v_t[(k, b)];
            }
        }
    }
    Some(cov)
}

/// Minimise `½‖f(x)‖²` over the box `bounds`, starting at `x0` (projected into
/// the box if it lies outside). See the module documentation for the method.
pub fn least_squares<F>(f: F, x0: &[f64], bounds: &Bounds, opts: &LsqOptions) -> Result<LsqResult, LsqError>
where
    F: Fn(&[f64]) -> Result<Vec<f64>, String> + Sync,
{
    least_squares_until(f, x0, bounds, opts, None)
}

/// A test on the Gauss–Newton prospect of a fit: given the residuals `r`
/// at the iterate and `r + J·h` at the minimiser h of the linear model
/// `‖r + J·h‖²` over the free variables (bounds ignored, so at least as low
/// as any step the iteration could take from here to first order), whether
/// to stop.
pub type GiveUp<'a> = &'a (dyn Fn(&[f64], &[f64]) -> bool + Sync);

/// [`least_squares`] that also stops (not converged, message "given up")
/// at an iterate where `give_up` says that even the Gauss–Newton model's
/// minimum is not worth reaching (the screen of [`crate::candidates`]).
/// Without it the iteration is that of [`least_squares`], step for step.
pub fn least_squares_until<F>(f: F, x0: &[f64], bounds: &Bounds, opts: &LsqOptions, give_up: Option<GiveUp>) -> Result<LsqResult, LsqError>
where
    F: Fn(&[f64]) -> Result<Vec<f64>, String> + Sync,
{
    let n = x0.len();
    if n == 0 {
        return Err(LsqError::BadInput("no parameters".into()));
    }
    if bounds.lo.len() != n || bounds.hi.len() != n {
        return Err(LsqError::BadInput(format!("{} parameters but bounds of length {} and {}", n, bounds.lo.len(), bounds.hi.len())));
    }
    for (i, (&lo, &hi)) in bounds.lo.iter().zip(&bounds.hi).enumerate() {
        if lo.is_nan() || hi.is_nan() || lo > hi || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
            return Err(LsqError::BadInput(format!("bad bounds [{lo}, {hi}] for parameter {i}")));
        }
        if !x0[i].is_finite() {
            return Err(LsqError::BadInput(format!("x0[{i}] = {} is not finite", x0[i])));
        }
    }
    if !(opts.fd_rel_step > 0.0 && opts.fd_rel_step.is_finite()) {
        return Err(LsqError::BadInput(format!("fd_rel_step = {}", opts.fd_rel_step)));
    }
    if opts.ftol < 0.0 || opts.xtol < 0.0 || opts.gtol < 0.0 {
        return Err(LsqError::BadInput("negative tolerance".into()));
    }
    let project = |x: &mut [f64]| {
        for ((xi, lo), hi) in x.iter_mut().zip(&bounds.lo).zip(&bounds.hi) {
            *xi = xi.clamp(*lo, *hi);
        }
    };

    let ev = Evaluator {
        f: &f,
        m: AtomicUsize::new(0),
        count: AtomicUsize::new(0),
        columns: AtomicUsize::new(0),
        jacobians: AtomicUsize::new(0),
    };
    let mut x = x0.to_vec();
    project(&mut x);
    let mut r = ev.eval(&x).map_err(|message| LsqError::Residual { x: x.clone(), message })?;
    if r.is_empty() {
        return Err(LsqError::BadInput("residual vector is empty".into()));
    }
    let m = r.len();
    ev.m.store(m, Ordering::Relaxed);
    let mut cost = half_sum_sq(&r);
    let fd = |x: &[f64], r: &[f64]| jacobian(&ev, x, r, bounds, opts);
    let mut jac = fd(&x, &r)?;
    // `exact`: `jac` is the finite-difference Jacobian at `x`; `since`:
    // Broyden updates since the last finite-difference Jacobian.
    let mut exact = true;
    let mut since = 0;
    let mut updates = 0;
    let max_updates = match opts.jacobian {
        JacobianUpdate::FiniteDifference => 0,
        JacobianUpdate::Broyden { max_updates } => max_updates,
    };

    let mut d2 = vec![0.0_f64; n]; // Moré scaling, squared
    let mut mu = 1e-3;
    let mut nu = 2.0;
    let mut iterations = 0;
    // step attempts from finite-difference Jacobians: those the limit counts
    let mut counted = 0;
    let mut converged = false;
    let mut message = String::from("iteration limit reached");

    'outer: loop {
        // Gradient, normal matrix and scaling at the current point.
        let rv = DVector::from_column_slice(&r);
        let g = jac.transpose() * &rv;
        let jtj = jac.transpose() * &jac;
        let col_norms: Vec<f64> = (0..n).map(|j| jac.column(j).norm()).collect();
        for j in 0..n {
            if exact {
                d2[j] = d2[j].max(col_norms[j] * col_norms[j]);
            }
            if d2[j] == 0.0 {
                d2[j] = 1.0;
            }
        }
        // Active set: on a bound with the gradient pushing outward.
        let free: Vec<usize> = (0..n)
            .filter(|&j| {
                let at_lo = on_bound(x[j], bounds.lo[j]) && g[j] > 0.0;
                let at_hi = on_bound(x[j], bounds.hi[j]) && g[j] < 0.0;
                !(at_lo || at_hi || bounds.lo[j] == bounds.hi[j])
            })
            .collect();
        // Gradient test on the free variables.
        let rnorm = norm(&r);
        if cost == 0.0 {
            converged = true;
            message = "zero residual".into();
            break;
        }
        let gcos = free.iter().filter(|&&j| col_norms[j] > 0.0).map(|&j| g[j].abs() / (col_norms[j] * rnorm)).fold(0.0_f64, f64::max);
        if free.is_empty() || gcos <= opts.gtol {
            // A stopping test met with an updated Jacobian is checked
            // again with the finite-difference one at the same point.
            if !exact {
                (jac, exact, since) = (fd(&x, &r)?, true, 0);
                continue 'outer;
            }
            converged = true;
            message = format!("gradient test: max cosine {gcos:.3e} <= gtol");
            break;
        }
        let nf = free.len();
        let a = DMatrix::from_fn(nf, nf, |p, q| jtj[(free[p], free[q])]);
        let b = DVector::from_fn(nf, |p, _| -g[free[p]]);
        let d2f: Vec<f64> = free.iter().map(|&j| d2[j]).collect();
        let dx_norm = x.iter().zip(&d2).map(|(v, d)| v * v * d).sum::<f64>().sqrt();
        if let Some(stop) = give_up {
            if let Some(hf) = damped_solve(&a, &d2f, 0.0, &b) {
                let mut lin = r.clone();
                for (p, &j) in free.iter().enumerate() {
                    for (l, jv) in lin.iter_mut().zip(jac.column(j).iter()) {
                        *l += jv * hf[p];
                    }
                }
                if stop(&r, &lin) {
                    if !exact {
                        (jac, exact, since) = (fd(&x, &r)?, true, 0);
                        continue 'outer;
                    }
                    message = "given up: the Gauss–Newton model's minimum does not pass the test".into();
                    break 'outer;
                }
            }
        }

        // Inner loop: try steps until one is accepted.
        loop {
            if counted >= opts.max_iter && exact {
                break 'outer;
            }
            iterations += 1;
            counted += exact as usize;
            let Some(hf) = damped_solve(&a, &d2f, mu, &b) else {
                mu *= nu;
                nu *= 2.0;
                continue;
            };
            let mut xt = x.clone();
            for (p, &j) in free.iter().enumerate() {
                xt[j] += hf[p];
            }
            project(&mut xt);
            let h: Vec<f64> = (0..n).map(|j| xt[j] - x[j]).collect();
            let dh_norm = h.iter().zip(&d2).map(|(v, d)| v * v * d).sum::<f64>().sqrt();
            if dh_norm <= opts.xtol * (opts.xtol + dx_norm) {
                if !exact {
                    (jac, exact, since) = (fd(&x, &r)?, true, 0);
                    continue 'outer;
                }
                converged = true;
                message = format!("step test: scaled step {dh_norm:.3e} below xtol");
                break 'outer;
            }
            // Predicted reduction of the Gauss–Newton model for the clipped step.
            let hv = DVector::from_column_slice(&h);
            let jh = &jac * &hv;
            let pred = -(g.dot(&hv) + 0.5 * jh.norm_squared());
            let trial = ev.eval(&xt);
            let (accepted, new_r, new_cost, rho) = match trial {
                Ok(rt) => {
                    let ct = half_sum_sq(&rt);
                    let actual = cost - ct;
                    let rho = if pred > 0.0 { actual / pred } else { -1.0 };
                    (rho > 0.0 && actual > 0.0, Some(rt), ct, rho)
                }
                Err(_) => (false, None, f64::INFINITY, -1.0),
            };
            if accepted {
                let Some(rt) = new_r else { continue };
                let actual_rel = (cost - new_cost) / cost;
                let pred_rel = pred / cost;
                let r_old = std::mem::replace(&mut r, rt);
                x = xt;
                cost = new_cost;
                mu *= (1.0_f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                nu = 2.0;
                let cost_test = actual_rel <= opts.ftol && pred_rel <= opts.ftol;
                let last = !cost_test && counted >= opts.max_iter && since >= max_updates;
                if !opts.final_jacobian && last {
                    exact = false;
                    break 'outer;
                }
                // An updated Jacobian from here on, unless this step meets
                // the cost test (converged only if its step was predicted by
                // a finite-difference Jacobian), the limit ends the run, or
                // the update is due for a refresh.
                let secant_step = !exact;
                if !cost_test && !last && since < max_updates {
                    let long = h.iter().zip(&x).any(|(hj, xj)| hj.abs() >= opts.fd_rel_step * xj.abs().max(1.0));
                    if long {
                        broyden_update(&mut jac, &h, &r_old, &r);
                        updates += 1;
                    }
                    (exact, since) = (false, since + 1);
                    continue 'outer;
                }
                if cost_test && !secant_step && max_updates > 0 && !opts.final_jacobian {
                    // converged on a step from a finite-difference Jacobian;
                    // the Jacobian at the new point is wanted by nobody
                    converged = true;
                    exact = false;
                    message = format!("cost test: relative reduction {actual_rel:.3e} <= ftol");
                    break 'outer;
                }
                (jac, exact, since) = (fd(&x, &r)?, true, 0);
                if cost_test && !secant_step {
                    converged = true;
                    message = format!("cost test: relative reduction {actual_rel:.3e} <= ftol");
                    break 'outer;
                }
                continue 'outer;
            }
            if !exact {
                // A step of an updated Jacobian failed: refresh it, keep μ.
                if counted >= opts.max_iter {
                    break 'outer;
                }
                (jac, exact, since) = (fd(&x, &r)?, true, 0);
                continue 'outer;
            }
            mu *= nu;
            nu *= 2.0;
            if !mu.is_finite() || mu > 1e300 {
                message = "damping overflow: no descent step found".into();
                break 'outer;
            }
        }
    }
    if opts.final_jacobian && !exact {
        jac = fd(&x, &r)?;
    }

    let covariance = covariance(&jac, cost);
    let std_errors = covariance.as_ref().map(|c| (0..n).map(|i| c[(i, i)].max(0.0).sqrt()).collect());
    let at_bound = (0..n).map(|i| on_bound(x[i], bounds.lo[i]) || on_bound(x[i], bounds.hi[i])).collect();
    let evaluations = ev.count.load(Ordering::Relaxed);
    let column_evaluations = ev.columns.load(Ordering::Relaxed);
    let jacobians = ev.jacobians.load(Ordering::Relaxed);
    RUNS.fetch_add(1, Ordering::Relaxed);
    TRIALS.fetch_add(evaluations - column_evaluations, Ordering::Relaxed);
    COLUMNS.fetch_add(column_evaluations, Ordering::Relaxed);
    JACOBIANS.fetch_add(jacobians, Ordering::Relaxed);
    UPDATES.fetch_add(updates, Ordering::Relaxed);
    Ok(LsqResult {
        x,
        cost,
        residuals: r,
        jacobian: jac,
        covariance,
        std_errors,
        iterations,
        evaluations,
        column_evaluations,
        jacobians,
        updates,
        converged,
        message,
        at_bound,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::synth::Rng as Normal;

    fn opts(parallel: bool) -> LsqOptions {
        LsqOptions { parallel, ..LsqOptions::default() }
    }

    fn broyden_opts(parallel: bool) -> LsqOptions {
        LsqOptions { jacobian: JacobianUpdate::BROYDEN, ..opts(parallel) }
    }

    type Residuals<'a> = Box<dyn Fn(&[f64]) -> Result<Vec<f64>, String> + Sync + 'a>;

    /// The test problems of this module: name, residuals, start, bounds.
    fn problems() -> Vec<(&'static str, Residuals<'static>, Vec<f64>, Bounds)> {
        let mut rng = Normal::new(42);
        let t: Vec<f64> = (0..120).map(|i| i as f64 * 0.03).collect();
        let y: Vec<f64> = t.iter().map(|&ti| 2.0 * (-ti / 0.7).exp() + 0.3 + 0.02 * rng.normal()).collect();
        let decay: Residuals =
            Box::new(move |p: &[f64]| Ok(t.iter().zip(&y).map(|(&ti, &yi)| p[0] * (-ti / p[1]).exp() + p[2] - yi).collect()));
        let t: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let line: Residuals = Box::new(move |p: &[f64]| Ok(t.iter().map(|ti| p[0] * ti + p[1] - (2.0 * ti + 1.0)).collect()));
        vec![
            ("rosenbrock", Box::new(|x: &[f64]| Ok(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]])), vec![-1.2, 1.0], Bounds::unbounded(2)),
            ("decay", decay, vec![1.0, 2.0, 0.0], Bounds::new(vec![0.0, 1e-3, -10.0], vec![10.0, 10.0, 10.0])),
            ("line on a bound", line, vec![0.5, 0.0], Bounds::new(vec![0.0, -100.0], vec![1.5, 100.0])),
            ("cubic", Box::new(|x: &[f64]| Ok(vec![x[0].powi(3) - 1.9f64.powi(3)])), vec![0.1], Bounds::unbounded(1)),
        ]
    }

    #[test]
    fn broyden_updates_reach_the_finite_difference_optimum_with_fewer_evaluations() {
        for (name, f, x0, b) in problems() {
            let fd = least_squares(&f, &x0, &b, &opts(false)).expect("solve");
            let secant = least_squares(&f, &x0, &b, &broyden_opts(false)).expect("solve");
            assert!(fd.converged && secant.converged, "{name}: {} / {}", fd.message, secant.message);
            for (a, c) in fd.x.iter().zip(&secant.x) {
                assert!((a - c).abs() <= 1e-6 * a.abs().max(1.0), "{name}: {:?} vs {:?}", fd.x, secant.x);
            }
            assert!(secant.cost <= fd.cost * (1.0 + 1e-9) + 1e-16, "{name}: cost {} vs {}", secant.cost, fd.cost);
            assert!(secant.updates > 0 && fd.updates == 0, "{name}: {} updates", secant.updates);
            assert!(
                secant.evaluations < fd.evaluations && secant.jacobians < fd.jacobians,
                "{name}: {} evaluations ({} Jacobians) against {} ({})",
                secant.evaluations,
                secant.jacobians,
                fd.evaluations,
                fd.jacobians
            );
            assert_eq!(fd.evaluations - fd.column_evaluations, fd.iterations + 1 - fd.message.starts_with("step test") as usize, "{name}");
        }
    }

    #[test]
    fn broyden_returns_the_finite_difference_jacobian_at_its_last_point() {
        let (_, f, x0, b) = problems().swap_remove(1);
        let fd_at = |x: &[f64], r: &[f64], o: &LsqOptions| {
            let ev = Evaluator {
                f: &f,
                m: AtomicUsize::new(r.len()),
                count: AtomicUsize::new(0),
                columns: AtomicUsize::new(0),
                jacobians: AtomicUsize::new(0),
            };
            jacobian(&ev, x, r, &b, o).expect("jacobian")
        };
        // converged: the Jacobian and covariance are those of differences at the solution
        let o = broyden_opts(true);
        let res = least_squares(&f, &x0, &b, &o).expect("fit");
        assert!(res.converged && res.updates > 0, "{} ({} updates)", res.message, res.updates);
        let j = fd_at(&res.x, &res.residuals, &o);
        assert_eq!(res.jacobian, j);
        assert_eq!(res.covariance, covariance(&j, res.cost));
        // cut by the iteration limit right after secant steps: recomputed too ...
        let cut = LsqOptions { max_iter: 5, ..o.clone() };
        let res = least_squares(&f, &x0, &b, &cut).expect("fit");
        assert!(!res.converged && res.updates > 0, "{} ({} updates)", res.message, res.updates);
        let j = fd_at(&res.x, &res.residuals, &o);
        assert_eq!(res.jacobian, j);
        // ... which the updated Jacobian is not: without `final_jacobian` it is returned as it is
        let kept = least_squares(&f, &x0, &b, &LsqOptions { final_jacobian: false, ..cut }).expect("fit");
        assert_eq!(kept.x, res.x);
        let worst = (0..j.ncols()).map(|c| (kept.jacobian.column(c) - j.column(c)).norm() / j.column(c).norm()).fold(0.0, f64::max);
        assert!(worst > 1e-3, "the updated Jacobian is the difference one ({worst:e}): the test above proves nothing");
        assert_eq!(kept.evaluations + 3, res.evaluations);
    }

    #[test]
    fn rosenbrock_unbounded() {
        for parallel in [false, true] {
            let f = |x: &[f64]| Ok(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
            let res = least_squares(f, &[-1.2, 1.0], &Bounds::unbounded(2), &opts(parallel)).expect("solve");
            assert!(res.converged, "{}", res.message);
            assert!((res.x[0] - 1.0).abs() < 1e-6, "{:?}", res.x);
            assert!((res.x[1] - 1.0).abs() < 1e-6, "{:?}", res.x);
            assert!(res.cost < 1e-12);
            assert!(res.evaluations > res.iterations);
            // m == n: no covariance.
            assert!(res.covariance.is_none());
        }
    }

    /// y = A·exp(−t/τ) + c with Gaussian noise of σ = 0.02.
    fn decay_fit(seed: u64) -> (Vec<f64>, Vec<f64>) {
        let truth = [2.0, 0.7, 0.3];
        let sigma = 0.02;
        let mut rng = Normal::new(seed);
        let t: Vec<f64> = (0..120).map(|i| i as f64 * 0.03).collect();
        let y: Vec<f64> = t.iter().map(|&ti| truth[0] * (-ti / truth[1]).exp() + truth[2] + sigma * rng.normal()).collect();
        let f = |p: &[f64]| Ok(t.iter().zip(&y).map(|(&ti, &yi)| p[0] * (-ti / p[1]).exp() + p[2] - yi).collect());
        let b = Bounds::new(vec![0.0, 1e-3, -10.0], vec![10.0, 10.0, 10.0]);
        let res = least_squares(f, &[1.0, 2.0, 0.0], &b, &opts(true)).expect("fit");
        assert!(res.converged, "{}", res.message);
        assert!(res.at_bound.iter().all(|a| !a));
        // Residual scatter estimates σ.
        let s = (2.0 * res.cost / (120.0 - 3.0)).sqrt();
        assert!((s / sigma - 1.0).abs() < 0.2, "s = {s}");
        (res.x.clone(), res.std_errors.expect("std errors"))
    }

    #[test]
    fn exponential_decay_recovers_parameters_within_std_errors() {
        let truth = [2.0, 0.7, 0.3];
        let (x, se) = decay_fit(42);
        for i in 0..3 {
            assert!((x[i] - truth[i]).abs() < 3.0 * se[i], "p{i}: {} ± {}", x[i], se[i]);
            assert!(se[i] > 0.0 && se[i] < 0.1 * truth[i]);
        }
        // Over many noise realisations, the spread of the estimates matches
        // the predicted standard errors (within sampling error of ~12 % for 40
        // draws), and about 68 % fall within one standard error.
        let draws: Vec<(Vec<f64>, Vec<f64>)> = (1..=40).map(decay_fit).collect();
        let mut inside = 0;
        for (i, &true_i) in truth.iter().enumerate() {
            let mean = draws.iter().map(|d| d.0[i]).sum::<f64>() / 40.0;
            let sd = (draws.iter().map(|d| (d.0[i] - mean).powi(2)).sum::<f64>() / 39.0).sqrt();
            let se_mean = draws.iter().map(|d| d.1[i]).sum::<f64>() / 40.0;
            assert!((sd / se_mean - 1.0).abs() < 0.35, "p{i}: sd {sd} vs se {se_mean}");
            assert!((mean - true_i).abs() < 3.0 * se_mean / 40f64.sqrt() + 1e-12);
            inside += draws.iter().filter(|d| (d.0[i] - true_i).abs() < d.1[i]).count();
        }
        let frac = inside as f64 / 120.0;
        assert!((0.55..0.82).contains(&frac), "coverage {frac}");
    }

    #[test]
    fn optimum_outside_box_lands_on_bound() {
        // Data y = 2t + 1; fit y = a·t + c with a ≤ 1.5. The constrained optimum
        // is a = 1.5 and c = ȳ − 1.5·t̄ (least squares in c with a fixed).
        let t: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let y: Vec<f64> = t.iter().map(|v| 2.0 * v + 1.0).collect();
        let f = |p: &[f64]| Ok(t.iter().zip(&y).map(|(ti, yi)| p[0] * ti + p[1] - yi).collect());
        let b = Bounds::new(vec![0.0, -100.0], vec![1.5, 100.0]);
        let res = least_squares(f, &[0.5, 0.0], &b, &opts(false)).expect("fit");
        assert!(res.converged, "{}", res.message);
        assert_eq!(res.x[0], 1.5);
        assert_eq!(res.at_bound, vec![true, false]);
        let tbar = 4.5;
        let ybar = 2.0 * tbar + 1.0;
        assert!((res.x[1] - (ybar - 1.5 * tbar)).abs() < 1e-7, "{:?}", res.x);
        // Lower bound active from the other side: y = -t fitted with a ≥ 0 → a = 0.
        let y2: Vec<f64> = t.iter().map(|v| -v).collect();
        let f2 = |p: &[f64]| Ok(t.iter().zip(&y2).map(|(ti, yi)| p[0] * ti - yi).collect());
        let b2 = Bounds::new(vec![0.0], vec![f64::INFINITY]);
        let res2 = least_squares(f2, &[3.0], &b2, &opts(false)).expect("fit");
        assert_eq!(res2.x, vec![0.0]);
        assert_eq!(res2.at_bound, vec![true]);
        assert!(res2.converged);
    }

    #[test]
    fn covariance_matches_linear_regression_formulas() {
        // y = a + b·t with noise; OLS closed forms for estimates and covariance.
        let mut rng = Normal::new(7);
        let t: Vec<f64> = (0..25).map(|i| 0.4 * i as f64).collect();
        let y: Vec<f64> = t.iter().map(|v| 1.0 - 0.5 * v + 0.1 * rng.normal()).collect();
        let n = t.len() as f64;
        let tbar = t.iter().sum::<f64>() / n;
        let ybar = y.iter().sum::<f64>() / n;
        let sxx: f64 = t.iter().map(|v| (v - tbar).powi(2)).sum();
        let sxy: f64 = t.iter().zip(&y).map(|(a, b)| (a - tbar) * (b - ybar)).sum();
        let b_hat = sxy / sxx;
        let a_hat = ybar - b_hat * tbar;
        let rss: f64 = t.iter().zip(&y).map(|(a, b)| (b - a_hat - b_hat * a).powi(2)).sum();
        let s2 = rss / (n - 2.0);
        let sum_t2: f64 = t.iter().map(|v| v * v).sum();
        let var_b = s2 / sxx;
        let var_a = s2 * sum_t2 / (n * sxx);
        let cov_ab = -s2 * tbar / sxx;

        let f = |p: &[f64]| Ok(t.iter().zip(&y).map(|(ti, yi)| p[0] + p[1] * ti - yi).collect());
        let res = least_squares(f, &[0.0, 0.0], &Bounds::unbounded(2), &opts(true)).expect("fit");
        assert!(res.converged, "{}", res.message);
        assert!((res.x[0] - a_hat).abs() < 1e-8);
        assert!((res.x[1] - b_hat).abs() < 1e-8);
        assert!((2.0 * res.cost - rss).abs() < 1e-10 * rss.max(1.0));
        let c = res.covariance.expect("covariance");
        assert!((c[(0, 0)] / var_a - 1.0).abs() < 1e-6);
        assert!((c[(1, 1)] / var_b - 1.0).abs() < 1e-6);
        assert!((c[(0, 1)] / cov_ab - 1.0).abs() < 1e-6);
        assert!((c[(1, 0)] / cov_ab - 1.0).abs() < 1e-6);
        let se = res.std_errors.expect("se");
        assert!((se[1] - var_b.sqrt()).abs() < 1e-6 * var_b.sqrt());
    }

    #[test]
    fn without_the_final_jacobian_a_run_cut_by_the_limit_ends_at_the_same_point_with_fewer_evaluations() {
        // Rosenbrock from the classic start needs more than 5 step attempts
        let f = |x: &[f64]| Ok(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
        let with = LsqOptions { max_iter: 5, ..opts(false) };
        let a = least_squares(f, &[-1.2, 1.0], &Bounds::unbounded(2), &with).expect("solve");
        let b = least_squares(f, &[-1.2, 1.0], &Bounds::unbounded(2), &LsqOptions { final_jacobian: false, ..with }).expect("solve");
        assert!(!a.converged && !b.converged);
        assert_eq!((a.x.clone(), a.cost, a.residuals.clone()), (b.x.clone(), b.cost, b.residuals.clone()));
        // the fifth attempt was accepted: its Jacobian (2 evaluations) is skipped
        assert_eq!(a.evaluations, b.evaluations + 2, "{} {}", a.evaluations, b.evaluations);
    }

    #[test]
    fn a_give_up_test_sees_the_gauss_newton_minimum_and_stops_the_run() {
        // a linear problem: the Gauss–Newton minimum is the solution itself
        let t: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let f = |p: &[f64]| Ok(t.iter().map(|ti| p[0] + p[1] * ti - (2.0 + 0.5 * ti)).collect());
        let seen = std::sync::Mutex::new(Vec::new());
        let stop = |r: &[f64], lin: &[f64]| {
            assert_eq!(r.len(), lin.len());
            seen.lock().unwrap().push(lin.iter().map(|v| v * v).sum::<f64>());
            true
        };
        let res = least_squares_until(f, &[0.0, 0.0], &Bounds::unbounded(2), &opts(false), Some(&stop)).expect("fit");
        assert!(!res.converged && res.message.starts_with("given up"), "{}", res.message);
        assert_eq!(res.x, vec![0.0, 0.0]);
        assert_eq!(res.evaluations, 3, "the start and its Jacobian only");
        let seen = seen.into_inner().unwrap();
        assert_eq!(seen.len(), 1);
        assert!(seen[0] < 1e-12, "{seen:?}");
        // a test that never fires leaves the run as it was
        let never = |_: &[f64], _: &[f64]| false;
        let a = least_squares(f, &[0.0, 0.0], &Bounds::unbounded(2), &opts(false)).expect("fit");
        let b = least_squares_until(f, &[0.0, 0.0], &Bounds::unbounded(2), &opts(false), Some(&never)).expect("fit");
        assert_eq!((a.x, a.evaluations, a.message), (b.x, b.evaluations, b.message));
    }

    #[test]
    fn failing_trial_points_are_rejected_not_fatal() {
        // r = x³ − 1.9³, undefined for x > 2. From x = 0.1 the Gauss–Newton
        // step (≈ +228) lands far outside the domain: rejected, damping grows.
        let calls_outside = AtomicUsize::new(0);
        let f = |x: &[f64]| {
            if x[0] > 2.0 {
                calls_outside.fetch_add(1, Ordering::Relaxed);
                Err("outside domain".to_string())
            } else {
                Ok(vec![x[0].powi(3) - 1.9f64.powi(3)])
            }
        };
        let res = least_squares(f, &[0.1], &Bounds::unbounded(1), &opts(false)).expect("fit");
        assert!(calls_outside.load(Ordering::Relaxed) > 0);
        assert!(res.converged, "{}", res.message);
        assert!((res.x[0] - 1.9).abs() < 1e-6);
        // But a failure at x0 is an error carrying x0.
        let err = least_squares(f, &[3.0], &Bounds::unbounded(1), &opts(false)).unwrap_err();
        match err {
            LsqError::Residual { x, .. } => assert_eq!(x, vec![3.0]),
            e => panic!("unexpected {e}"),
        }
    }

    #[test]
    fn bad_input_is_reported() {
        let f = |x: &[f64]| Ok(vec![x[0]]);
        let b = Bounds::new(vec![1.0], vec![0.0]);
        assert!(matches!(least_squares(f, &[0.5], &b, &opts(false)), Err(LsqError::BadInput(_))));
        let b = Bounds::new(vec![0.0, 0.0], vec![1.0, 1.0]);
        assert!(matches!(least_squares(f, &[0.5], &b, &opts(false)), Err(LsqError::BadInput(_))));
        let empty = |_: &[f64]| Ok(Vec::new());
        assert!(matches!(least_squares(empty, &[0.5], &Bounds::unbounded(1), &opts(false)), Err(LsqError::BadInput(_))));
    }
}
