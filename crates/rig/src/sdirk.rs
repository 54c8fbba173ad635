//! The integrator: a singly diagonally implicit Runge–Kutta method of order
//! 4 with an embedded order-3 error estimate (Hairer & Wanner, *Solving
//! Ordinary Differential Equations II*, 2nd ed., Springer 1996, Table 6.5,
//! "SDIRK4", γ = 1/4).
//!
//! # Why this method
//!
//! The rig is stiff in places: the dead volumes are small (20 cm³) and the
//! ISO 6358 ellipse has an unbounded ∂ṁ/∂p as the pressure ratio tends to 1,
//! so the fastest chamber time constants near equilibrium are far below the
//! time scale of the motion (fractions of a millisecond against seconds).
//! An explicit method would be limited by stability there. SDIRK4 is
//! L-stable and stiffly accurate (the last stage is the new solution, so
//! stiff components are damped completely), and, being a one-step method,
//! it restarts at full order after every discrete event — the rig has
//! several per cycle (valve switches, stick/slip, end stops, limit
//! switches), which would force a multistep (BDF) method back to order 1
//! each time. Its stages are solved one after the other, each an n×n
//! system (n = 6, or 8 with a supply line), by a simplified Newton
//! iteration with the matrix I − hγJ, where J is a forward-difference
//! Jacobian that is reused over steps while the iteration converges fast.
//!
//! # Details
//!
//! * Error estimate: e = h Σ (b_i − b̂_i) K_i, filtered through
//!   (I − hγJ)⁻¹ as Hairer & Wanner recommend for stiff problems (the raw
//!   difference overestimates the error of stiff components by a factor
//!   ~|hλ|). Norm: weighted RMS over the dynamic states with weights
//!   rtol·(|y_i| + floor_i).
//! * Step size: h_new = h·clamp(0.9·err^(−1/4), 0.2, 4), no growth right
//!   after a rejection; Newton failure: a fresh Jacobian first, then h/3.
//!   Two limits end a run that cannot go on, each with an error naming the
//!   time: h below 10⁻¹⁴·max(|t|, 1), and a budget of step attempts
//!   (accepted, rejected and abandoned; set by the caller, `RunSpec::max_steps`
//!   for the rig) for a step size that collapses without reaching that
//!   minimum — which, at 10⁻¹⁴ of t, would otherwise take hours.
//! * Newton: stopped when η‖ΔZ‖ ≤ 0.003 (weighted norm, η = θ/(1 − θ), θ
//!   the contraction rate; Hairer & Wanner IV.8; on the first iteration
//!   only if ‖ΔZ‖ ≤ 1 as well); failure after 12 iterations. When the
//!   iteration converges slowly without crossing a kink (θ ≥ 0.99, or
//!   predicted not to converge in time) the Jacobian is re-evaluated at the
//!   current iterate, once per stage, before giving up. The tolerance is ten times tighter than Hairer & Wanner's
//!   usual 0.03 because of the ellipse's cusp: with a looser Newton the
//!   stage values scatter across the cusp by a sizeable fraction of the
//!   error tolerance, the error estimate sees that scatter as error, and a
//!   chamber resting at supply pressure is then integrated with µs steps
//!   (measured: 75 000 steps for 0.5 s held at supply with 0.03, 11 000
//!   with 0.003).
//! * Damping at kinks: when a Newton correction points against the
//!   previous one (weighted inner product < 0), the iterates are jumping
//!   across a kink of f — the ISO 6358 ellipse has an unbounded slope at
//!   r → 1, where a chamber connected to a constant pressure comes to rest —
//!   and the corrections are halved from then on (down to 1/256). For an
//!   f ∝ sgn(u)√|u| this shrinks the band the iterates oscillate in by 4 per
//!   halving, where an undamped simplified Newton would oscillate forever.
//! * Quadrature states (mass and energy accounts) are Newton unknowns like
//!   the others (their Jacobian columns are known to be zero and are not
//!   differenced), so that linear invariants — total gas mass against the
//!   mass that crossed the boundary — hold to rounding error whatever the
//!   Newton residual; they take no part in error control.
//! * Dense output for sampling and as a first guess for events: Lagrange
//!   interpolation through the last (up to) four accepted points of the
//!   current continuous segment. Unlike Hermite interpolation it uses no
//!   derivatives, so a stiff component slightly off its slow manifold is not
//!   amplified into a spurious overshoot between steps.
//! * Event location is done by the caller with [`Sdirk::trial`], which
//!   repeats the last step with a shorter step size: an event state is
//!   therefore a true integration point, not an interpolated one.

// Index loops read like the textbook algorithms they implement.
#![allow(clippy::needless_range_loop)]

use crate::linalg::Lu;

const GAMMA: f64 = 0.25;
const STAGES: usize = 5;
const C: [f64; STAGES] = [0.25, 0.75, 11.0 / 20.0, 0.5, 1.0];
const A: [[f64; STAGES]; STAGES] = [
    [0.25, 0.0, 0.0, 0.0, 0.0],
    [0.5, 0.25, 0.0, 0.0, 0.0],
    [17.0 / 50.0, -1.0 / 25.0, 0.25, 0.0, 0.0],
    [371.0 / 1360.0, -137.0 / 2720.0, 15.0 / 544.0, 0.25, 0.0],
    [25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0, 0.25],
];
const B: [f64; STAGES] = A[4];
const BHAT: [f64; STAGES] = [59.0 / 48.0, -17.0 / 96.0, 225.0 / 32.0, -85.0 / 12.0, 0.0];

const NEWTON_TOL: f64 = 0.003;
/// Newton tolerance of the retries in `trial`.
const NEWTON_TOL_TRIAL: f64 = 0.03;
const NEWTON_MAX_ITER: usize = 12;
/// Recompute the Jacobian before the next step if any stage contracted
/// more slowly than this.
const THETA_REFRESH: f64 = 0.05;

/// A system of ODEs y' = f(t, y): `n_dyn` states that feed back, followed
/// by `n_quad` quadrature states whose derivatives depend on the first
/// `n_dyn` only.
pub(crate) trait OdeSystem {
    /// Writes all n_dyn + n_quad derivatives. Returns `false` if the state is
    /// outside the physical domain (then the step is retried smaller).
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> bool;
}

/// Counters for performance and diagnosis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolverStats {
    /// Accepted steps.
    pub steps: usize,
    /// Steps rejected by the error test.
    pub rejected: usize,
    /// Step attempts abandoned because the Newton iteration failed.
    pub newton_failures: usize,
    /// Right-hand-side evaluations (including Jacobians and event location).
    pub rhs_evals: usize,
    /// Jacobian evaluations.
    pub jacobians: usize,
    /// Trial steps taken to locate events.
    pub trial_steps: usize,
}

/// Why a step could not be taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum StepError {
    /// h fell below the minimum.
    TooSmall { t: f64, h: f64 },
    /// The step attempts (accepted, rejected and abandoned) of this stepper
    /// reached its limit ([`Sdirk::limit_attempts`]): the step size has
    /// collapsed without reaching the minimum.
    TooManySteps { t: f64, h: f64, attempts: usize },
    /// The state at the start of a step is outside the physical domain.
    NonPhysical { t: f64 },
}

struct Work {
    k: Vec<f64>,
    s: Vec<f64>,
    z: Vec<f64>,
    yy: Vec<f64>,
    f: Vec<f64>,
    g: Vec<f64>,
    e: Vec<f64>,
    lin: Vec<f64>,
    dz_prev: Vec<f64>,
    /// Start of the step being attempted and the derivative estimate there.
    y0: Vec<f64>,
    f0: Vec<f64>,
    ynew: Vec<f64>,
    eta: f64,
    theta_max: f64,
}

enum Attempt {
    /// Error norm of the finished step (≤ 1: acceptable).
    Done(f64),
    NewtonFailed,
}

/// The stepper. It owns the current point of a continuous segment and the
/// points needed for interpolation.
pub(crate) struct Sdirk {
    n: usize,
    nt: usize,
    rtol: f64,
    floor: Vec<f64>,
    h_max: f64,
    /// Most step attempts (accepted + rejected + Newton failures) allowed.
    max_attempts: usize,
    /// Current accepted point.
    pub t: f64,
    pub y: Vec<f64>,
    /// Previous accepted point (start of the last step).
    pub t_prev: f64,
    pub y_prev: Vec<f64>,
    fy: Vec<f64>,
    fy_prev: Vec<f64>,
    h: f64,
    jac: Vec<f64>,
    have_jac: bool,
    need_jac: bool,
    mat: Vec<f64>,
    lu: Lu,
    lu_ok: bool,
    rejected_last: bool,
    newton_tol: f64,
    history: Vec<(f64, Vec<f64>)>,
    w: Work,
    pub stats: SolverStats,
}

impl Sdirk {
    /// `floor[i]` sets the absolute part of the error weight of dynamic state
    /// i: weight = rtol·(|y_i| + floor_i).
    pub(crate) fn new(n_dyn: usize, n_quad: usize, rtol: f64, floor: Vec<f64>, h_max: f64) -> Self {
        let n = n_dyn;
        let nt = n_dyn + n_quad;
        Sdirk {
            n,
            nt,
            rtol,
            floor,
            h_max,
            max_attempts: usize::MAX,
            t: 0.0,
            y: vec![0.0; nt],
            t_prev: 0.0,
            y_prev: vec![0.0; nt],
            fy: vec![0.0; nt],
            fy_prev: vec![0.0; nt],
            h: 0.0,
            jac: vec![0.0; nt * nt],
            have_jac: false,
            need_jac: true,
            mat: vec![0.0; nt * nt],
            lu: Lu::new(nt),
            lu_ok: false,
            rejected_last: false,
            newton_tol: NEWTON_TOL,
            history: Vec::with_capacity(4),
            w: Work {
                k: vec![0.0; STAGES * nt],
                s: vec![0.0; nt],
                z: vec![0.0; nt],
                yy: vec![0.0; nt],
                f: vec![0.0; nt],
                g: vec![0.0; nt],
                e: vec![0.0; nt],
                lin: vec![0.0; nt],
                dz_prev: vec![0.0; nt],
                y0: vec![0.0; nt],
                f0: vec![0.0; nt],
                ynew: vec![0.0; nt],
                eta: 1.0,
                theta_max: 0.0,
            },
            stats: SolverStats::default(),
        }
    }

    /// Limits the step attempts over the stepper's life (accepted, rejected
    /// by the error test and abandoned by Newton), so that a step size that
    /// collapses — at a discontinuity of f the error test cannot get past,
    /// say — ends in an error instead of crawling on at femtosecond steps
    /// for hours.
    pub(crate) fn limit_attempts(&mut self, max_attempts: usize) {
        self.max_attempts = max_attempts;
    }

    /// Step attempts so far (accepted, rejected and abandoned).
    pub(crate) fn attempts(&self) -> usize {
        self.stats.steps + self.stats.rejected + self.stats.newton_failures
    }

    /// Starts a new continuous segment at (t, y): forgets the history and
    /// the Jacobian, and chooses an initial step from the derivative.
    pub(crate) fn restart<S: OdeSystem>(&mut self, sys: &mut S, t: f64, y: &[f64]) -> Result<(), StepError> {
        self.t = t;
        self.y.copy_from_slice(&y[..self.nt]);
        self.t_prev = t;
        self.y_prev.copy_from_slice(&self.y);
        self.stats.rhs_evals += 1;
        if !sys.rhs(t, &self.y, &mut self.fy) {
            return Err(StepError::NonPhysical { t });
        }
        self.fy_prev.copy_from_slice(&self.fy);
        // initial step: a fraction of the fastest relative rate, scaled with
        // the fourth root of the tolerance (local error ∝ h^4 of the estimate)
        let mut rate: f64 = 0.0;
        for i in 0..self.n {
            rate = rate.max(self.fy[i].abs() / (self.y[i].abs() + self.floor[i]));
        }
        let h0 = 0.1 * self.rtol.powf(0.25) / rate.max(1e-9);
        self.h = h0.min(self.h_max).max(1e-10);
        self.have_jac = false;
        self.need_jac = true;
        self.rejected_last = false;
        self.w.eta = 1.0;
        self.history.clear();
        self.history.push((t, self.y.clone()));
        Ok(())
    }

    fn weighted_dot(&self, a: &[f64], b: &[f64], y0: &[f64]) -> f64 {
        let mut s = 0.0;
        for i in 0..self.n {
            let wgt = self.rtol * (y0[i].abs() + self.floor[i]);
            s += a[i] * b[i] / (wgt * wgt);
        }
        s
    }

    fn weights_norm(&self, v: &[f64], y0: &[f64], y1: Option<&[f64]>) -> f64 {
        let mut s = 0.0;
        for i in 0..self.n {
            let mut mag = y0[i].abs();
            if let Some(y1) = y1 {
                mag = mag.max(y1[i].abs());
            }
            let wgt = self.rtol * (mag + self.floor[i]);
            let q = v[i] / wgt;
            s += q * q;
        }
        (s / self.n as f64).sqrt()
    }

    fn compute_jacobian<S: OdeSystem>(&mut self, sys: &mut S) -> Result<(), StepError> {
        let y = self.y.clone();
        self.jacobian_at(sys, self.t, &y)
    }

    /// Forward-difference Jacobian at (t, y): columns of the dynamic states
    /// only (the quadrature columns are zero), all rows.
    fn jacobian_at<S: OdeSystem>(&mut self, sys: &mut S, t: f64, y: &[f64]) -> Result<(), StepError> {
        let (n, nt) = (self.n, self.nt);
        let mut yp = y.to_vec();
        let mut fp = vec![0.0; nt];
        // a fresh f(y): a stored derivative is a stage value, accurate only
        // to the Newton tolerance, far too coarse for differencing
        let mut f0 = vec![0.0; nt];
        self.stats.rhs_evals += 1;
        if !sys.rhs(t, y, &mut f0) {
            return Err(StepError::NonPhysical { t });
        }
        for j in 0..n {
            let delta = f64::EPSILON.sqrt() * (y[j].abs() + self.floor[j]);
            yp[j] = y[j] + delta;
            self.stats.rhs_evals += 1;
            let ok = sys.rhs(t, &yp, &mut fp);
            let (dl, ok) = if ok {
                (delta, true)
            } else {
                // one-sided the other way (e.g. at a domain edge)
                yp[j] = y[j] - delta;
                self.stats.rhs_evals += 1;
                (-delta, sys.rhs(t, &yp, &mut fp))
            };
            if !ok {
                return Err(StepError::NonPhysical { t });
            }
            for i in 0..nt {
                self.jac[i * nt + j] = (fp[i] - f0[i]) / dl;
            }
            yp[j] = y[j];
        }
        self.stats.jacobians += 1;
        self.have_jac = true;
        self.need_jac = false;
        Ok(())
    }

    fn factor(&mut self, h: f64) -> bool {
        let nt = self.nt;
        for i in 0..nt {
            for j in 0..nt {
                self.mat[i * nt + j] = if i == j { 1.0 } else { 0.0 } - h * GAMMA * self.jac[i * nt + j];
            }
        }
        self.lu_ok = self.lu.factor(&self.mat);
        self.lu_ok
    }

    /// One step attempt from (t0, y0) of size h with the factorised matrix.
    fn attempt<S: OdeSystem>(&mut self, sys: &mut S, t0: f64, h: f64) -> Attempt {
        let nt = self.nt;
        let hg = h * GAMMA;
        self.w.theta_max = 0.0;
        for i in 0..STAGES {
            // s = h Σ_{l<i} a_il K_l
            for q in 0..nt {
                let mut acc = 0.0;
                for l in 0..i {
                    acc += A[i][l] * self.w.k[l * nt + q];
                }
                self.w.s[q] = h * acc;
            }
            // predictor: K_i ≈ K_{i−1} (K_0 from the derivative at y0)
            for q in 0..nt {
                let kp = if i == 0 { self.w.f0[q] } else { self.w.k[(i - 1) * nt + q] };
                self.w.z[q] = self.w.s[q] + hg * kp;
            }
            let mut eta = self.w.eta.max(f64::EPSILON).powf(0.8);
            let mut d_old = 0.0;
            let mut converged = false;
            let mut lambda: f64 = 1.0;
            let mut refreshed = false;
            let mut iter = 0;
            while iter < NEWTON_MAX_ITER {
                for q in 0..nt {
                    self.w.yy[q] = self.w.y0[q] + self.w.z[q];
                }
                self.stats.rhs_evals += 1;
                if !sys.rhs(t0 + C[i] * h, &self.w.yy, &mut self.w.f) {
                    return Attempt::NewtonFailed;
                }
                for q in 0..nt {
                    self.w.g[q] = -(self.w.z[q] - self.w.s[q] - hg * self.w.f[q]);
                }
                self.lu.solve(&mut self.w.g, &mut self.w.lin);
                // a correction pointing back against the previous one means
                // the iterates jump across a kink of f (the ISO 6358 ellipse
                // at r → 1 has an unbounded slope): damp
                if iter > 0 && self.weighted_dot(&self.w.g, &self.w.dz_prev, &self.w.y0) < 0.0 {
                    lambda = (0.5 * lambda).max(1.0 / 256.0);
                }
                for q in 0..nt {
                    self.w.dz_prev[q] = self.w.g[q];
                    self.w.z[q] += lambda * self.w.g[q];
                }
                let d = lambda * self.weights_norm(&self.w.g, &self.w.y0, None);
                if !d.is_finite() {
                    return Attempt::NewtonFailed;
                }
                if iter > 0 {
                    let theta = d / d_old;
                    self.w.theta_max = self.w.theta_max.max(theta);
                    eta = theta / (1.0 - theta).max(1e-3);
                    // slow, monotone convergence (no kink crossed): the
                    // Jacobian is far off; once per stage, evaluate it at the
                    // current iterate and go on
                    let slow = lambda == 1.0
                        && (theta >= 0.99 || (theta > 0.5 && eta * d * theta.powi((NEWTON_MAX_ITER - 1 - iter) as i32) > self.newton_tol));
                    if slow {
                        if refreshed {
                            return Attempt::NewtonFailed;
                        }
                        refreshed = true;
                        let yj: Vec<f64> = (0..nt).map(|q| self.w.y0[q] + self.w.z[q]).collect();
                        if self.jacobian_at(sys, t0 + C[i] * h, &yj).is_err() || !self.factor(h) {
                            return Attempt::NewtonFailed;
                        }
                        d_old = 0.0;
                        eta = 1.0;
                        iter = 0;
                        continue;
                    }
                }
                // on the first iteration the rate is only extrapolated from
                // earlier stages: accept only a correction that is itself
                // below the error tolerance
                if (eta * d <= self.newton_tol && (iter > 0 || d <= 1.0)) || d == 0.0 {
                    converged = true;
                    break;
                }
                d_old = d;
                iter += 1;
            }
            if !converged {
                return Attempt::NewtonFailed;
            }
            self.w.eta = eta;
            // stage derivative from Z (no stiff amplification of the Newton
            // error); the quadrature accounts are Newton unknowns too, so
            // linear invariants such as total mass = boundary mass are kept
            // to rounding whatever the Newton residual
            for q in 0..nt {
                self.w.k[i * nt + q] = (self.w.z[q] - self.w.s[q]) / hg;
            }
        }
        // stiffly accurate: the last stage is the solution
        for q in 0..nt {
            self.w.ynew[q] = self.w.y0[q] + self.w.z[q];
        }
        for q in 0..nt {
            let mut acc = 0.0;
            for i in 0..STAGES {
                acc += (B[i] - BHAT[i]) * self.w.k[i * nt + q];
            }
            self.w.e[q] = h * acc;
        }
        self.lu.solve(&mut self.w.e, &mut self.w.lin);
        let err = self.weights_norm(&self.w.e, &self.w.y0, Some(&self.w.ynew));
        if err.is_finite() {
            Attempt::Done(err)
        } else {
            Attempt::NewtonFailed
        }
    }

    /// Takes one accepted step, not beyond `t_limit`; lands exactly on
    /// `t_limit` if it is within reach.
    pub(crate) fn advance<S: OdeSystem>(&mut self, sys: &mut S, t_limit: f64) -> Result<(), StepError> {
        let h_min = 1e-14 * self.t.abs().max(1.0);
        // whether the Jacobian was evaluated at the current point in this call
        let mut fresh_here = false;
        loop {
            let remaining = t_limit - self.t;
            let mut h = self.h.min(self.h_max);
            let mut lands = false;
            if h >= remaining * (1.0 - 1e-12) || remaining - h < 0.1 * h {
                h = remaining;
                lands = true;
            } else if h > 0.5 * remaining {
                h = 0.5 * remaining;
            }
            if h < h_min {
                return Err(StepError::TooSmall { t: self.t, h });
            }
            if self.attempts() >= self.max_attempts {
                return Err(StepError::TooManySteps { t: self.t, h, attempts: self.attempts() });
            }
            if self.need_jac || !self.have_jac {
                self.compute_jacobian(sys)?;
                fresh_here = true;
            }
            if !self.factor(h) {
                self.h = h * 0.5;
                continue;
            }
            self.w.y0.copy_from_slice(&self.y);
            self.w.f0.copy_from_slice(&self.fy);
            match self.attempt(sys, self.t, h) {
                Attempt::Done(err) if err <= 1.0 => {
                    self.stats.steps += 1;
                    self.t_prev = self.t;
                    self.y_prev.copy_from_slice(&self.y);
                    self.fy_prev.copy_from_slice(&self.fy);
                    self.y.copy_from_slice(&self.w.ynew);
                    self.t = if lands { t_limit } else { self.t + h };
                    // derivative at the new point: the last stage derivative
                    let nt = self.nt;
                    self.fy.copy_from_slice(&self.w.k[(STAGES - 1) * nt..STAGES * nt]);
                    let mut fac = 0.9 * err.max(1e-10).powf(-0.25);
                    fac = fac.clamp(0.2, if self.rejected_last { 1.0 } else { 4.0 });
                    self.h = h * fac;
                    self.rejected_last = false;
                    if self.w.theta_max > THETA_REFRESH {
                        self.need_jac = true;
                    }
                    if self.history.len() == 4 {
                        self.history.remove(0);
                    }
                    self.history.push((self.t, self.y.clone()));
                    return Ok(());
                }
                Attempt::Done(err) => {
                    self.stats.rejected += 1;
                    self.rejected_last = true;
                    self.h = h * (0.9 * err.powf(-0.25)).clamp(0.2, 0.9);
                }
                Attempt::NewtonFailed => {
                    self.stats.newton_failures += 1;
                    if fresh_here {
                        self.h = h / 3.0;
                        self.rejected_last = true;
                    } else {
                        self.need_jac = true;
                        self.h = h;
                    }
                }
            }
        }
    }

    /// Repeats the last step from its start over `tau` ∈ (0, h] with the
    /// same Jacobian; returns the state reached, or `None` if that fails.
    /// If the Newton iteration fails, the Jacobian is refreshed at the start
    /// of the step, the Newton tolerance relaxed to 0.03 and the interval
    /// split into 2, 4, … 32 equal steps.
    /// Leaves the stepper's accepted points unchanged.
    pub(crate) fn trial<S: OdeSystem>(&mut self, sys: &mut S, tau: f64) -> Option<Vec<f64>> {
        self.stats.trial_steps += 1;
        if !self.have_jac {
            return None;
        }
        let saved_eta = self.w.eta;
        let mut out = None;
        for k in 0..6 {
            // after a failure: a fresh Jacobian and Hairer & Wanner's usual
            // Newton tolerance (a trial step only has to place an event)
            self.newton_tol = if k == 0 { NEWTON_TOL } else { NEWTON_TOL_TRIAL };
            let n_sub = 1usize << k;
            let hs = tau / n_sub as f64;
            if !self.factor(hs) {
                break;
            }
            self.w.y0.copy_from_slice(&self.y_prev);
            self.w.f0.copy_from_slice(&self.fy_prev);
            let mut ok = true;
            for j in 0..n_sub {
                match self.attempt(sys, self.t_prev + j as f64 * hs, hs) {
                    Attempt::Done(_) => {
                        let nt = self.nt;
                        self.w.y0.copy_from_slice(&self.w.ynew);
                        self.w.f0.copy_from_slice(&self.w.k[(STAGES - 1) * nt..STAGES * nt]);
                    }
                    Attempt::NewtonFailed => {
                        ok = false;
                        break;
                    }
                }
            }
            if ok {
                out = Some(self.w.y0.clone());
                break;
            }
            if k == 0 && self.jacobian_at_prev(sys).is_err() {
                break;
            }
        }
        self.w.eta = saved_eta;
        self.newton_tol = NEWTON_TOL;
        out
    }

    /// Recomputes the Jacobian at the start of the last step.
    fn jacobian_at_prev<S: OdeSystem>(&mut self, sys: &mut S) -> Result<(), StepError> {
        let y = self.y_prev.clone();
        self.jacobian_at(sys, self.t_prev, &y)
    }

    /// Cuts the last step short at (t, y) (an event found inside it): the
    /// new end point replaces the old one for interpolation.
    pub(crate) fn truncate(&mut self, t: f64, y: &[f64]) {
        self.t = t;
        self.y.copy_from_slice(&y[..self.nt]);
        // cut back to the start of the step: drop the step's end point
        if self.history.len() >= 2 && self.history[self.history.len() - 2].0 == t {
            self.history.pop();
        }
        if let Some(last) = self.history.last_mut() {
            last.0 = t;
            last.1.copy_from_slice(&y[..self.nt]);
        }
    }

    /// Overwrites component `i` of the current point (and of its copy kept
    /// for interpolation) — for a state the mode holds constant, to remove
    /// the rounding the linear algebra leaves on it.
    pub(crate) fn pin(&mut self, i: usize, value: f64) {
        self.y[i] = value;
        if let Some(last) = self.history.last_mut() {
            last.1[i] = value;
        }
    }

    /// Interpolates the current segment at `t` (meant for t within the last
    /// step) through the last up to four accepted points.
    pub(crate) fn interpolate(&self, t: f64, out: &mut [f64]) {
        let pts = &self.history;
        let m = pts.len();
        let last = &pts[m - 1].1;
        out[..self.nt].copy_from_slice(last);
        if m == 1 {
            return;
        }
        // written as last + Σ L_j (y_j − last), which is exact for a
        // component that is constant over the points (a held piston)
        for j in 0..m - 1 {
            let mut l = 1.0;
            for (k, pk) in pts.iter().enumerate() {
                if k != j {
                    l *= (t - pk.0) / (pts[j].0 - pk.0);
                }
            }
            for q in 0..self.nt {
                out[q] += l * (pts[j].1[q] - last[q]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Order conditions up to order 4 for (A, b, c) and up to order 3 for b̂.
    #[test]
    fn tableau_satisfies_the_order_conditions() {
        let s = STAGES;
        for i in 0..s {
            let row: f64 = A[i].iter().sum();
            assert!((row - C[i]).abs() < 1e-14, "row {i}");
            assert_eq!(A[i][i], GAMMA);
        }
        let dot = |w: &[f64; STAGES], v: &[f64]| -> f64 { (0..s).map(|i| w[i] * v[i]).sum() };
        let ac = |v: &[f64]| -> Vec<f64> { (0..s).map(|i| (0..s).map(|j| A[i][j] * v[j]).sum()).collect() };
        let c2: Vec<f64> = C.iter().map(|c| c * c).collect();
        let c3: Vec<f64> = C.iter().map(|c| c * c * c).collect();
        let one = vec![1.0; s];
        let a_c = ac(&C);
        let a_c2 = ac(&c2);
        let a_a_c = ac(&a_c);
        let c_a_c: Vec<f64> = (0..s).map(|i| C[i] * a_c[i]).collect();
        for (w, order) in [(&B, 4), (&BHAT, 3)] {
            assert!((dot(w, &one) - 1.0).abs() < 1e-13);
            assert!((dot(w, &C) - 0.5).abs() < 1e-13);
            assert!((dot(w, &c2) - 1.0 / 3.0).abs() < 1e-13);
            assert!((dot(w, &a_c) - 1.0 / 6.0).abs() < 1e-13);
            if order == 4 {
                assert!((dot(w, &c3) - 0.25).abs() < 1e-13);
                assert!((dot(w, &c_a_c) - 0.125).abs() < 1e-13);
                assert!((dot(w, &a_c2) - 1.0 / 12.0).abs() < 1e-13);
                assert!((dot(w, &a_a_c) - 1.0 / 24.0).abs() < 1e-13);
            }
        }
        // the embedded method is genuinely of order 3 only
        assert!((dot(&BHAT, &c3) - 0.25).abs() > 1e-3);
    }

    struct Linear {
        lam: f64,
    }
    impl OdeSystem for Linear {
        fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> bool {
            // stiff relaxation to cos t, plus a harmonic oscillator component
            dy[0] = self.lam * (y[0] - t.cos()) - t.sin();
            dy[1] = -y[0];
            dy[2] = y[0];
            true
        }
    }

    #[test]
    fn stiff_problem_is_solved_accurately_with_few_steps() {
        let mut sys = Linear { lam: -1e6 };
        let mut st = Sdirk::new(2, 1, 1e-8, vec![1e-3, 1e-3], 1.0);
        st.restart(&mut sys, 0.0, &[1.0, 0.0, 0.0]).unwrap();
        while st.t < 10.0 {
            st.advance(&mut sys, 10.0).unwrap();
        }
        // y0 = cos t, y1 = −sin t, y2 = sin t
        assert!((st.y[0] - 10f64.cos()).abs() < 1e-7, "{}", st.y[0]);
        assert!((st.y[1] + 10f64.sin()).abs() < 1e-6, "{}", st.y[1]);
        assert!((st.y[2] - 10f64.sin()).abs() < 1e-6, "{}", st.y[2]);
        assert!(st.stats.steps < 2000, "{:?}", st.stats);
    }

    #[test]
    fn global_error_shrinks_at_fourth_order() {
        // fixed h via t_limit stepping and a loose tolerance: error ratio ≈ 16
        let run = |n: usize| {
            let mut sys = Linear { lam: -2.0 };
            let mut st = Sdirk::new(2, 1, 1.0, vec![1.0, 1.0], 1.0);
            st.restart(&mut sys, 0.0, &[1.0, 0.0, 0.0]).unwrap();
            for k in 1..=n {
                st.h = 1.0;
                st.advance(&mut sys, k as f64 / n as f64).unwrap();
            }
            (st.y[1] + 1f64.sin()).abs()
        };
        let (e1, e2) = (run(8), run(16));
        let ratio = e1 / e2;
        assert!(ratio > 12.0 && ratio < 20.0, "{e1} {e2} {ratio}");
    }
}
