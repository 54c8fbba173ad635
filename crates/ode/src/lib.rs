//! Stiff ODE integration with root (event) location and dense output.
//!
//! Purpose: integrate the small (≈4–30 states), stiff, piecewise-smooth systems
//! `dy/dt = f(t, y)` that lumped-parameter circuit models produce. The crate knows
//! nothing about the physics: a model implements [`OdeSystem`], an integrator
//! implementing [`Integrator`] advances it towards a stop time, stopping early where
//! a root (event) function changes sign so that the caller can apply a
//! discontinuous change (switch a valve, hit an end stop) and restart.
//!
//! Provided integrator: [`Rosenbrock`], the L-stable, stiffly accurate 4th-order
//! Rosenbrock method RODAS4 with an embedded 3rd-order error estimate and a
//! 3rd-order dense output (E. Hairer & G. Wanner, *Solving Ordinary Differential
//! Equations II*, 2nd ed., Springer 1996, §IV.7; see `rodas4.rs` for the
//! coefficient table and its sources).
//!
//! Units: the crate is unit-agnostic; `t` and step sizes are in the unit of the
//! model's independent variable (seconds in `pneumo`), tolerances are in the units
//! of each state. All arithmetic is `f64`.
//!
//! Assumptions and valid ranges:
//! * `f` is smooth (at least C⁴ for full order) between the events the caller
//!   handles; discontinuities must be announced through root functions.
//! * The Jacobian is dense and formed by forward differences (cost per step ≈
//!   n + 7 evaluations of `f` plus one O(n³) LU factorisation), unless the
//!   system declares its structure ([`OdeSystem::jacobian_sparsity`]): then
//!   the Jacobian is stored sparse, filled by the system
//!   ([`OdeSystem::jacobian`]) or by grouped differences, and systems of at
//!   least [`SPARSE_LU_MIN_STATES`] states get a sparse LU (faer).
//! * Integration may go forwards or backwards in `t`.
//!
//! Typical use (a bouncing ball; the event is the height crossing zero):
//! ```
//! use ode::{Advance, Integrator, OdeSystem, Options, RhsError, Rosenbrock};
//! struct Ball;
//! impl OdeSystem for Ball {
//!     fn dim(&self) -> usize { 2 }
//!     fn rhs(&mut self, _t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
//!         d[0] = y[1];
//!         d[1] = -9.81;
//!         Ok(())
//!     }
//!     fn n_roots(&self) -> usize { 1 }
//!     fn roots(&mut self, _t: f64, y: &[f64], g: &mut [f64]) -> Result<(), RhsError> {
//!         g[0] = y[0];
//!         Ok(())
//!     }
//! }
//! let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 2), 2);
//! let (mut t, mut y) = (0.0, vec![10.0, 0.0]);
//! let mut bounces = 0;
//! while t < 5.0 {
//!     match int.advance(&mut Ball, &mut t, &mut y, 5.0, &mut |_dense| {})? {
//!         Advance::Reached => {}
//!         Advance::Root { .. } => {
//!             bounces += 1;
//!             y[0] = 0.0; // the zero at the restart point is not an event
//!             y[1] = -0.8 * y[1];
//!             int.reset();
//!         }
//!     }
//! }
//! assert_eq!(bounces, 2); // impacts at 1.428 s and 3.713 s (the third would be at 5.54 s)
//! # Ok::<(), ode::IntegratorError>(())
//! ```
//!
//! Modules: `lu` (in-place dense LU with partial pivoting on an `nalgebra::DMatrix`),
//! `sparsity` (declared Jacobian structure, column grouping), `sparse_lu`
//! (faer's sparse LU of the iteration matrix),
//! `rodas4` (coefficients), `dense` (dense output), `roots` (event location),
//! `rosenbrock` (the integrator and its step-size controller).

// Numerical kernels below index several parallel arrays with one loop variable;
// iterator chains would obscure the formulas.
#![allow(clippy::needless_range_loop)]

mod dense;
mod lu;
mod rodas4;
mod roots;
mod rosenbrock;
mod sparse_lu;
mod sparsity;
mod tableau;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_sensitivity;
#[cfg(test)]
mod tests_structure;

pub use rosenbrock::{Rosenbrock, SPARSE_LU_MIN_STATES};
pub use sparsity::{Sparsity, SparsityError};

/// The Rosenbrock methods [`Rosenbrock`] offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// RODAS4: order 4(3), a fresh Jacobian at every step.
    #[default]
    Rodas4,
    /// ROS34PW2: order 3(2) W-method, reuses its Jacobian over several steps.
    Ros34pw2,
}

/// Error returned by a model's right-hand side or root functions. At a trial
/// state (a stage of a step, or a step end not yet accepted) the integrator
/// treats it as a refusal of that state: the step is rejected and retried
/// smaller, and the error is returned only when the step cannot shrink
/// further. At an accepted state (the start, a Jacobian) it ends the run.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{0}")]
pub struct RhsError(pub String);

/// A system of ordinary differential equations `dy/dt = f(t, y)` with optional
/// root (event) functions `g(t, y)`.
pub trait OdeSystem {
    /// Number of states `n`.
    fn dim(&self) -> usize;
    /// dy/dt = f(t, y).
    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) -> Result<(), RhsError>;
    /// Number of trailing quadrature components: the last `k` entries of `y`
    /// are integrals that no derivative depends on (balances, costs). Their
    /// Jacobian columns are zero, so they are not perturbed (as CVODES treats
    /// quadratures). Default 0.
    fn n_quadrature(&self) -> usize {
        0
    }
    /// True if f does not depend on t explicitly (∂f/∂t = 0), which saves one
    /// evaluation per Jacobian. Default false.
    fn autonomous(&self) -> bool {
        false
    }
    /// Structure of `∂f/∂y`: the rows where each non-quadrature column may be
    /// non-zero (a superset is fine; an entry left out is taken as zero). A
    /// system that declares one gets a Jacobian in that structure — filled by
    /// [`OdeSystem::jacobian`] or by grouped finite differences — and, when
    /// large, a sparse LU. Asked once per dimension. Default: `None` (dense).
    fn jacobian_sparsity(&self) -> Option<Sparsity> {
        None
    }
    /// Fill the entries of `∂f/∂y` at (t, y) in the order of
    /// [`OdeSystem::jacobian_sparsity`] (column by column), given
    /// `f0 = f(t, y)` and the perturbation `deltas[j]` the integrator would
    /// use for column `j`. Returns `Ok(false)` to let the integrator use
    /// grouped finite differences instead (the default). Evaluations the
    /// system spends here are not counted in [`Stats::rhs_evals`].
    fn jacobian(&mut self, _t: f64, _y: &[f64], _f0: &[f64], _deltas: &[f64], _values: &mut [f64]) -> Result<bool, RhsError> {
        Ok(false)
    }
    /// Number of root (event) functions.
    fn n_roots(&self) -> usize {
        0
    }
    /// f(t, y) and the root functions g(t, y) at one point. Systems whose
    /// two share work (one evaluation of a model) override this; the default
    /// calls [`OdeSystem::rhs`] then [`OdeSystem::roots`].
    fn rhs_and_roots(&mut self, t: f64, y: &[f64], dydt: &mut [f64], g: &mut [f64]) -> Result<(), RhsError> {
        self.rhs(t, y, dydt)?;
        self.roots(t, y, g)
    }
    /// Root functions g(t, y); the integrator stops where one of them changes
    /// sign in its [`RootDirection`].
    fn roots(&mut self, _t: f64, _y: &[f64], _g: &mut [f64]) -> Result<(), RhsError> {
        Ok(())
    }
    /// Which sign changes of each root function are events (`out.len() ==
    /// n_roots()`). Asked whenever the integrator (re)starts — on its first
    /// call, after [`Integrator::reset`] and after returning at a root — since
    /// a caller's discrete state may change the functions. Default: every
    /// function [`RootDirection::Either`].
    fn root_directions(&self, out: &mut [RootDirection]) {
        out.fill(RootDirection::Either);
    }
    /// Right-hand side of forward sensitivity column `k` (`s_k = ∂y/∂θ_k`)
    /// at (t, y): `out = ∂f/∂y(t, y)·s + ∂f/∂θ_k(t, y)`, given
    /// `f = f(t, y)`. Called only while the integrator has sensitivity
    /// columns ([`Rosenbrock::set_sensitivities`]).
    fn sensitivity_rhs(&mut self, _k: usize, _t: f64, _y: &[f64], _f: &[f64], _s: &[f64], _out: &mut [f64]) -> Result<(), RhsError> {
        Err(RhsError("the system declares sensitivities but does not compute their right-hand side".into()))
    }
}

/// Which sign changes of a root function are events; the meaning of
/// SUNDIALS' `CVodeSetRootDirection` (+1, −1, 0).
///
/// A direction also says which side is the "no event" side, which settles
/// what a function that is exactly zero at a (re)start means: a
/// [`RootDirection::Rising`] function at zero is taken to be on its negative
/// side, so it fires as soon as it becomes positive, however soon that is.
/// An [`RootDirection::Either`] function at zero at a restart takes its side
/// from its value a little after the start (as SUNDIALS does), which cannot
/// tell "just crossed" from "about to cross"; give such functions a direction
/// when that matters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RootDirection {
    /// Either sign change.
    #[default]
    Either,
    /// From negative to positive only; negative is the "no event" side.
    Rising,
    /// From positive to negative only; positive is the "no event" side.
    Falling,
}

/// Integration options.
///
/// `atol` holds one absolute tolerance per state; if it is shorter than the
/// system dimension, the missing entries repeat its last value (or
/// [`Options::DEFAULT_ATOL`] when it is empty). The local error of a step is
/// measured in the weighted RMS norm with weights `atol_i + rtol·max(|y0_i|, |y1_i|)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Relative tolerance (dimensionless), > 0.
    pub rtol: f64,
    /// Absolute tolerance per state, in the unit of that state, > 0.
    pub atol: Vec<f64>,
    /// First step size; `None` lets the integrator choose one.
    pub h_init: Option<f64>,
    /// Largest step size (magnitude).
    pub h_max: f64,
    /// Smallest step size the controller may ask for before giving up with
    /// [`IntegratorError::StepSizeTooSmall`] (a last step clipped to `t_stop` may be shorter).
    pub h_min: f64,
    /// Largest number of accepted steps in one call of [`Integrator::advance`].
    pub max_steps: usize,
    /// Width of the final root bracket, in units of `t`.
    pub root_tol: f64,
    /// Root functions that change sign within this time after the first one
    /// (and within the same step) are reported with it, as one event, and the
    /// returned point moves past all of them; 0 (the default) means
    /// `root_tol`. Lets identical subsystems whose events differ only by
    /// round-off switch together instead of one restart each.
    pub event_window: f64,
    /// The same window as a fraction of the step in which the first root
    /// lies (the larger of the two applies; default 0). A fraction `r` moves
    /// an event by at most `r·h`, which changes each state by at most `r`
    /// times its change over the step: with `r = rtol`, within the step's
    /// error tolerance.
    pub event_window_per_step: f64,
}

impl Options {
    /// Absolute tolerance used when `atol` is empty.
    pub const DEFAULT_ATOL: f64 = 1e-8;

    /// Options with the given relative tolerance and the same absolute tolerance
    /// for all `dim` states; everything else as in [`Default`].
    pub fn with_tolerances(rtol: f64, atol: f64, dim: usize) -> Self {
        Self { rtol, atol: vec![atol; dim], ..Self::default() }
    }
}

impl Default for Options {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            atol: Vec::new(),
            h_init: None,
            h_max: f64::INFINITY,
            h_min: 0.0,
            max_steps: 100_000,
            root_tol: 1e-10,
            event_window: 0.0,
            event_window_per_step: 0.0,
        }
    }
}

/// Failures of an integration.
#[derive(Debug, thiserror::Error)]
pub enum IntegratorError {
    /// The step-size controller asked for a step below `h_min` or below the
    /// round-off limit of `t`.
    /// `index` is the component with the largest weighted error in the last
    /// rejected attempt (the one that keeps the step from growing).
    #[error("step size fell below {h:e} at t = {t:e} (largest error in component {index})")]
    StepSizeTooSmall { t: f64, h: f64, index: usize },
    /// `max_steps` accepted steps were taken in one `advance` call; `h` is
    /// the step proposed next and `index` the component with the largest
    /// weighted error in the last attempt (the one that keeps the step small).
    #[error("too many steps ({steps}) before reaching the stop time, at t = {t:e} (step {h:e}, largest error in component {index})")]
    TooManySteps { t: f64, steps: usize, h: f64, index: usize },
    /// The right-hand side (or a root function) returned an error at time `t`
    /// at an accepted state, or at trial states until the step could not
    /// shrink further (see [`RhsError`]).
    #[error("right-hand side failed at t = {t:e}: {source}")]
    Rhs {
        t: f64,
        #[source]
        source: RhsError,
    },
    /// A non-finite value (NaN or ±∞) appeared in state or derivative `index`
    /// and could not be avoided by reducing the step.
    #[error("non-finite value in component {index} at t = {t:e}")]
    NonFinite { t: f64, index: usize },
    /// The iteration matrix `I/(hγ) − J` was singular or not finite.
    #[error("singular iteration matrix at t = {t:e}")]
    SingularMatrix { t: f64 },
}

/// Dense output of one accepted step, valid on `[t_start, t_end]`
/// (`t_end` may be before the step's natural end when the step was truncated at a root).
pub trait Dense {
    /// Start of the interval covered.
    fn t_start(&self) -> f64;
    /// End of the interval covered.
    fn t_end(&self) -> f64;
    /// Interpolated state at `t` (should lie in `[t_start, t_end]`; outside it the
    /// polynomial is extrapolated). `out` must have the system dimension.
    fn eval(&self, t: f64, out: &mut [f64]);
    /// Interpolated sensitivity column `k` at `t` (see
    /// [`OdeSystem::sensitivity_rhs`]); false if the step has none.
    fn eval_sensitivity(&self, _k: usize, _t: f64, _out: &mut [f64]) -> bool {
        false
    }
}

/// Outcome of [`Integrator::advance`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Advance {
    /// `t == t_stop`.
    Reached,
    /// Stopped just past a sign change of the listed root functions (each of
    /// them strictly on its new side).
    Root { indices: Vec<usize> },
}

/// Work counters, cumulative over the life of an integrator.
#[derive(Debug, Clone, Copy, Default)]
pub struct Stats {
    /// Accepted steps.
    pub steps: usize,
    /// Rejected step attempts.
    pub rejected: usize,
    /// Evaluations of the right-hand side (including those for the Jacobian).
    pub rhs_evals: usize,
    /// Jacobian evaluations.
    pub jacobians: usize,
    /// LU factorisations.
    pub lu: usize,
}

/// A time-stepping method.
pub trait Integrator {
    /// Advance (t, y) towards t_stop. Returns Reached with t == t_stop, or Root with (t, y) just past the first sign change
    /// (the root bracket narrowed below root_tol; the returned point is strictly on the NEW side, never at an exact zero, so
    /// that the caller sees the changed sign), `indices` listing every root function that has changed sign in its
    /// [`RootDirection`] between the step start and the returned point. A function exactly zero at the step start is
    /// watched from the side its direction calls "no event" (see [`RootDirection`]).
    /// `observer` is called for every accepted step with its dense output, truncated at the returned point, so the caller can sample outputs.
    fn advance(
        &mut self,
        sys: &mut dyn OdeSystem,
        t: &mut f64,
        y: &mut [f64],
        t_stop: f64,
        observer: &mut dyn FnMut(&dyn Dense),
    ) -> Result<Advance, IntegratorError>;
    /// Forget cached derivative/Jacobian after the caller changed the system discontinuously (keep a step-size hint).
    fn reset(&mut self);
    /// Work counters so far.
    fn stats(&self) -> Stats;
}
