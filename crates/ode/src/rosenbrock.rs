//! The RODAS4 Rosenbrock integrator with adaptive step size, dense output and
//! root location.
//!
//! Method: 6-stage, order-4, stiffly accurate, L-stable Rosenbrock method RODAS4
//! with embedded order-3 solution (Hairer & Wanner, *Solving ODEs II*, §IV.7;
//! coefficients and formulas in `rodas4.rs`). Each step solves
//! `(I/(hγ) − J) u_i = f(t0 + c_i h, Y_i) + Σ c_ij u_j / h + h d_i ∂f/∂t` with one LU
//! factorisation of the iteration matrix.
//!
//! * Jacobian `J = ∂f/∂y` (dense): forward differences at the step start, column `j`
//!   perturbed by `δ_j = √ε·max(|y_j|, atol_j/rtol)` (ε = machine epsilon); `∂f/∂t`
//!   by a forward difference with `δ_t = √ε·max(|t|, |h|)`. Recomputed at every
//!   accepted step (Rosenbrock methods need the exact Jacobian for their order),
//!   reused after a rejection.
//! * Error: weighted RMS norm of the embedded difference `u_6`,
//!   `err = sqrt(1/n Σ (u6_i / (atol_i + rtol·max(|y0_i|, |y1_i|)))²)`; a step is
//!   accepted when `err ≤ 1`.
//! * Step size: `h_new = h·min(6, max(0.2, 0.9·err^(−1/4)))`, combined on acceptance
//!   with the predictive controller of Gustafsson (K. Gustafsson, ACM TOMS 20
//!   (1994) 496–517; Hairer & Wanner II, §IV.8) as in RODAS; no increase right after a rejection; `|h| ≤ h_max`;
//!   the last step is clipped to hit `t_stop` exactly.
//! * Initial step (when neither `h_init` nor a hint is known): the estimate of
//!   Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.4 (one explicit Euler probe).
//! * Failures: a non-finite stage value, a trial state the system refuses (an
//!   error of its right-hand side at a stage or at the end of a step not yet
//!   accepted) or an (almost) singular iteration matrix rejects the step and
//!   quarters/halves `h`; the integrator gives up with `NonFinite`, `Rhs` (the
//!   system's own message), `SingularMatrix` or `StepSizeTooSmall` when `h`
//!   falls below `max(h_min, 16ε|t|)` or after 100 consecutive failed
//!   attempts, so it never hangs. An error of the right-hand side at an
//!   accepted state (the start, a Jacobian) ends the run at once.
//! * Dense output: the RODAS 3rd-order continuous extension (see `dense.rs`).
//! * Roots: after each accepted step the root functions are evaluated at its end;
//!   a sign change in a function's [`RootDirection`](crate::RootDirection),
//!   relative to the side it is watched from during the step (`roots::watch`), is
//!   located on the dense output by the Illinois bracketing iteration of
//!   `roots.rs` to within `root_tol`, and the state is returned strictly on the new
//!   side. The side of a function that is exactly zero at the step start: the
//!   "no event" side of its direction; for an `Either` function, the side it was
//!   on at the previous step end (a step may end on an exact zero, which is not a
//!   change), or after a restart its side a little after the start (SUNDIALS'
//!   rule; the only value ever taken past the start, and only for `Either`).
//!
//! All work buffers are allocated in [`Rosenbrock::new`] (or when the dimension or
//! the number of root functions changes); the step loop does not allocate.

use nalgebra::DMatrix;

use crate::dense::{SensColumn, StepDense};
use crate::lu::LuFactors;
use crate::roots::{changed, watch, RootFinder};
use crate::sparse_lu::SparseLu;
use crate::sparsity::Sparsity;
use crate::tableau::{DenseKind, Tableau};
use crate::Method;
use crate::{Advance, Integrator, IntegratorError, OdeSystem, Options, RhsError, RootDirection, Stats};

const SAFETY: f64 = 0.9;
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 6.0;
/// Smallest step-size factor after a rejected step: a step that missed by far
/// (the first step after an event, with the size that suited the dynamics
/// before it) shrinks as much as its error says, in one go.
const FAC_MIN_REJECT: f64 = 0.01;
/// Consecutive failed attempts (rejections, non-finite values, singular matrices) tolerated at one point.
const MAX_FAILURES: usize = 100;
/// Consecutive singular iteration matrices tolerated before giving up.
const MAX_SINGULAR: usize = 5;
/// Accepted steps a W-method may take with one Jacobian.
const MAX_JACOBIAN_AGE: usize = 20;
/// Smallest number of (non-quadrature) states for which a system that
/// declares its Jacobian structure gets a sparse LU; below it a dense LU of
/// the small matrix is cheaper.
pub const SPARSE_LU_MIN_STATES: usize = 40;

/// The Jacobian in the structure the system declared
/// ([`OdeSystem::jacobian_sparsity`]).
#[derive(Debug)]
struct SparseJacobian {
    pattern: Sparsity,
    values: Vec<f64>,
    /// Column groups for finite differences, found at the first Jacobian the
    /// system does not fill itself (a system that always fills it never pays
    /// for the colouring, whose cost grows with the columns times the longest
    /// row: quadratically with a row that every column touches).
    groups: Option<Vec<Vec<usize>>>,
    /// (row, column, entry) of the entries in quadrature rows.
    quadrature: Vec<(usize, usize, usize)>,
    /// Perturbation of each state column.
    deltas: Vec<f64>,
    /// Sparse factorisation, for systems of at least [`SPARSE_LU_MIN_STATES`] states.
    lu: Option<SparseLu>,
}

impl SparseJacobian {
    fn new(pattern: Sparsity, ns: usize) -> SparseJacobian {
        let mut quadrature = Vec::new();
        for j in 0..pattern.n_columns() {
            for (k, &r) in pattern.column_range(j).zip(pattern.column(j)) {
                if r >= ns {
                    quadrature.push((r, j, k));
                }
            }
        }
        let lu = if ns >= SPARSE_LU_MIN_STATES { SparseLu::new(&pattern, ns) } else { None };
        SparseJacobian { values: vec![0.0; pattern.nnz()], groups: None, quadrature, deltas: vec![0.0; ns], lu, pattern }
    }
}

impl Clone for SparseJacobian {
    fn clone(&self) -> Self {
        let mut copy = SparseJacobian::new(self.pattern.clone(), self.deltas.len());
        copy.values.copy_from_slice(&self.values);
        copy
    }
}

/// Outcome of one step attempt.
enum Attempt {
    /// Computed; weighted error norm.
    Done(f64),
    /// A stage produced a non-finite value in `index` at time `t`.
    NonFinite { t: f64, index: usize },
    /// The system refused a stage's trial state at time `t` (an error of its
    /// right-hand side): rejected like a non-finite stage, the message kept
    /// for when the step cannot shrink further.
    Refused { t: f64, source: RhsError },
    /// The iteration matrix could not be factored.
    Singular,
}

/// RODAS4 Rosenbrock integrator (see the module documentation).
#[derive(Debug, Clone)]
pub struct Rosenbrock {
    opts: Options,
    n: usize,
    /// Component with the largest weighted error in the last attempt.
    largest_error: usize,
    // Cached values at the current point (t_cache, y_cache).
    cache_valid: bool,
    jac_valid: bool,
    roots_valid: bool,
    t_cache: f64,
    y_cache: Vec<f64>,
    f0: Vec<f64>,
    g0: Vec<f64>,
    // Work buffers.
    f1: Vec<f64>,
    ft: Vec<f64>,
    fs: Vec<f64>,
    ytmp: Vec<f64>,
    y1: Vec<f64>,
    u: Vec<Vec<f64>>,
    tableau: Tableau,
    /// Accepted steps since the Jacobian was formed (W-methods reuse it).
    jac_age: usize,
    /// Number of trailing quadrature components (their columns of J are zero
    /// and no derivative reads them, so W is block lower-triangular and only
    /// its leading block is factored).
    nq: usize,
    q1: Vec<f64>,
    q2: Vec<f64>,
    y_root: Vec<f64>,
    g1: Vec<f64>,
    g_probe: Vec<f64>,
    g_ret: Vec<f64>,
    /// Direction of each root function (asked from the system at each restart).
    directions: Vec<RootDirection>,
    /// Side each root function is watched from during the current step (see `roots::watch`).
    watch: Vec<f64>,
    /// Last non-zero side of each root function since the last restart (0 = not known).
    last_side: Vec<f64>,
    /// Dense Jacobian (systems without a declared structure).
    jac: DMatrix<f64>,
    /// Jacobian in a declared structure (then `jac` is empty).
    sparse: Option<SparseJacobian>,
    /// The system's structure has been asked since the last resize.
    structure_known: bool,
    /// Dense LU of the iteration matrix (unless the sparse one is used).
    lu: LuFactors,
    root_finder: RootFinder,
    // Step-size control.
    h_next: Option<f64>,
    h_acc: f64,
    err_acc: f64,
    have_acc: bool,
    fixed_h: Option<f64>,
    stats: Stats,
    /// Forward sensitivity columns (see [`Rosenbrock::set_sensitivities`]).
    sens: Vec<SensColumn>,
    /// Stage arguments and right-hand sides of the last attempt, kept for
    /// the sensitivity stages (only while there are sensitivity columns).
    stage_y: Vec<Vec<f64>>,
    stage_f: Vec<Vec<f64>>,
    /// Work buffers of the sensitivity stages.
    sens_u: Vec<Vec<f64>>,
    sens_arg: Vec<f64>,
    sens_f0: Vec<f64>,
}

impl Rosenbrock {
    /// New integrator for systems of dimension `dim`. Options are sanitised:
    /// `atol` is extended to `dim` entries (see [`Options`]), non-positive or
    /// non-finite tolerances are replaced by small positive ones.
    pub fn new(options: Options, dim: usize) -> Self {
        let mut opts = options;
        if !opts.rtol.is_finite() || opts.rtol <= 0.0 {
            opts.rtol = 1e-6;
        }
        opts.rtol = opts.rtol.max(10.0 * f64::EPSILON);
        if opts.h_max.is_nan() || opts.h_max <= 0.0 {
            opts.h_max = f64::INFINITY;
        }
        if !opts.h_min.is_finite() || opts.h_min < 0.0 {
            opts.h_min = 0.0;
        }
        if !opts.root_tol.is_finite() || opts.root_tol <= 0.0 {
            opts.root_tol = 1e-10;
        }
        let mut me = Self {
            opts,
            n: 0,
            cache_valid: false,
            jac_valid: false,
            largest_error: 0,
            roots_valid: false,
            t_cache: 0.0,
            y_cache: Vec::new(),
            f0: Vec::new(),
            g0: Vec::new(),
            f1: Vec::new(),
            ft: Vec::new(),
            fs: Vec::new(),
            ytmp: Vec::new(),
            y1: Vec::new(),
            u: Vec::new(),
            tableau: Tableau::rodas4(),
            jac_age: 0,
            nq: 0,
            q1: Vec::new(),
            q2: Vec::new(),
            y_root: Vec::new(),
            g1: Vec::new(),
            g_probe: Vec::new(),
            g_ret: Vec::new(),
            directions: Vec::new(),
            watch: Vec::new(),
            last_side: Vec::new(),
            jac: DMatrix::zeros(0, 0),
            sparse: None,
            structure_known: false,
            lu: LuFactors::new(0),
            root_finder: RootFinder::new(0),
            h_next: None,
            h_acc: 0.0,
            err_acc: 1.0,
            have_acc: false,
            fixed_h: None,
            stats: Stats::default(),
            sens: Vec::new(),
            stage_y: Vec::new(),
            stage_f: Vec::new(),
            sens_u: Vec::new(),
            sens_arg: Vec::new(),
            sens_f0: Vec::new(),
        };
        me.resize(dim);
        me
    }

    /// New integrator using `method`.
    pub fn with_method(options: Options, dim: usize, method: Method) -> Self {
        let mut me = Self::new(options, dim);
        me.tableau = match method {
            Method::Rodas4 => Tableau::rodas4(),
            Method::Ros34pw2 => Tableau::ros34pw2(),
        };
        me.resize(dim);
        me
    }

    /// Human-readable name of the method.
    pub fn method_name(&self) -> &str {
        self.tableau.name
    }

    /// Step size to try first on the next `advance` (magnitude; ignored if not positive and finite).
    pub fn set_step_hint(&mut self, h: f64) {
        if h.is_finite() && h > 0.0 {
            self.h_next = Some(h);
        }
    }

    /// The step size the controller proposes for the next step, if known.
    pub fn step_hint(&self) -> Option<f64> {
        self.h_next
    }

    /// Fixed-step mode (no error control, every step accepted unless it produces
    /// non-finite values): `Some(h)` steps with `|h|` (the last step of each
    /// `advance` clipped to `t_stop`); `None` restores adaptive stepping.
    /// Meant for convergence studies.
    pub fn set_fixed_step(&mut self, h: Option<f64>) {
        self.fixed_h = h.filter(|h| h.is_finite() && *h > 0.0);
    }

    /// Integrate forward sensitivities `s_k = ∂y/∂θ_k` beside the state,
    /// starting from `columns` at the point of the next `advance` (one
    /// column of the system dimension per parameter; empty to stop). The
    /// system computes each column's right-hand side
    /// ([`OdeSystem::sensitivity_rhs`]). The columns take the state's steps
    /// (its error control alone chooses them) and the state's stages: each
    /// accepted step solves, for every column, the stage equations
    /// `W v_i = F_k(t_i, Y_i, s0 + Σ a_ij v_j) + Σ (γc_ij/h) v_j` with the
    /// step's factored `W = I/(hγ) − J` and stage arguments `Y_i`, where
    /// `F_k(t, y, s) = J(t, y) s + ∂f/∂θ_k(t, y)`; the `h d_i ∂F/∂t` term is
    /// left out (zero for a system with no explicit time dependence). For
    /// the W-method ROS34PW2 this is the method itself applied to the pair
    /// (x, s) with a matrix that leaves out the pair's coupling block
    /// `∂(J s)/∂y` — a W-method keeps its order 3 with any matrix. RODAS4
    /// needs the exact Jacobian of the pair for its order: without the
    /// coupling block its sensitivities are of low order (measured: 7e-4
    /// relative error at rtol 1e-8 on `tests_sensitivity.rs`'s problem,
    /// against 2e-9 for ROS34PW2), so use ROS34PW2 for sensitivities.
    pub fn set_sensitivities(&mut self, columns: &[Vec<f64>]) {
        self.sens =
            columns.iter().map(|c| SensColumn { s0: c.clone(), s1: c.clone(), q1: vec![0.0; c.len()], q2: vec![0.0; c.len()] }).collect();
    }

    /// Sensitivity column `k` at the current point (after an `advance`, at
    /// the point it returned); panics if `k` is not below the number of columns.
    pub fn sensitivity(&self, k: usize) -> &[f64] {
        &self.sens[k].s0
    }

    /// The component with the largest weighted error in the last attempted
    /// step (the one that keeps the step from growing).
    pub fn largest_error(&self) -> usize {
        self.largest_error
    }

    /// Number of sensitivity columns.
    pub fn n_sensitivities(&self) -> usize {
        self.sens.len()
    }

    /// One accepted step (t0 → t0 + h) of every sensitivity column, with the
    /// stages kept by the last attempt and its factored matrix; `f1` is
    /// f at the step end (for the Hermite dense output).
    fn sensitivity_step(&mut self, sys: &mut dyn OdeSystem, t0: f64, h: f64) -> Result<(), IntegratorError> {
        let n = self.n;
        let ns = n - self.nq;
        let stages = self.tableau.stages;
        if self.sens_u.len() != stages || self.sens_arg.len() != n {
            self.sens_u = (0..stages).map(|_| vec![0.0; n]).collect();
            self.sens_arg = vec![0.0; n];
            self.sens_f0 = vec![0.0; n];
        }
        let inv_h = 1.0 / h;
        let hg = h * self.tableau.gamma;
        for k in 0..self.sens.len() {
            if self.sens[k].s0.len() != n {
                let message = format!("sensitivity column {k} has {} entries, the system {n}", self.sens[k].s0.len());
                return Err(IntegratorError::Rhs { t: t0, source: RhsError(message) });
            }
            for st in 0..stages {
                let (done, rest) = self.sens_u.split_at_mut(st);
                let vi = &mut rest[0];
                let arow = &self.tableau.a[st];
                for i in 0..n {
                    let mut v = self.sens[k].s0[i];
                    for (j, vj) in done.iter().enumerate() {
                        v += arow[j] * vj[i];
                    }
                    self.sens_arg[i] = v;
                }
                let ts = t0 + self.tableau.c[st] * h;
                sys.sensitivity_rhs(k, ts, &self.stage_y[st], &self.stage_f[st], &self.sens_arg, vi)
                    .map_err(|source| IntegratorError::Rhs { t: ts, source })?;
                if st == 0 {
                    self.sens_f0.copy_from_slice(vi);
                }
                let grow = &self.tableau.gc[st];
                for i in 0..n {
                    let mut v = vi[i];
                    for (j, vj) in done.iter().enumerate() {
                        v += grow[j] * inv_h * vj[i];
                    }
                    vi[i] = v;
                }
                solve_w(self.sparse.as_mut(), &self.lu, &self.jac, ns, hg, vi);
            }
            let c = &mut self.sens[k];
            for i in 0..n {
                let mut v = c.s0[i];
                for (j, vj) in self.sens_u.iter().enumerate() {
                    v += self.tableau.m[j] * vj[i];
                }
                c.s1[i] = v;
                if !v.is_finite() {
                    return Err(IntegratorError::NonFinite { t: t0 + h, index: i });
                }
            }
            match &self.tableau.dense {
                DenseKind::Rodas { e1, e2 } => {
                    for i in 0..n {
                        c.q1[i] = (0..e1.len()).map(|j| e1[j] * self.sens_u[j][i]).sum();
                        c.q2[i] = (0..e2.len()).map(|j| e2[j] * self.sens_u[j][i]).sum();
                    }
                }
                DenseKind::Hermite => {
                    let mut f_end = std::mem::take(&mut self.sens_arg);
                    sys.sensitivity_rhs(k, t0 + h, &self.y1, &self.f1, &c.s1, &mut f_end)
                        .map_err(|source| IntegratorError::Rhs { t: t0 + h, source })?;
                    for i in 0..n {
                        let delta = c.s1[i] - c.s0[i];
                        c.q1[i] = h * self.sens_f0[i] - delta;
                        c.q2[i] = 2.0 * delta - h * (self.sens_f0[i] + f_end[i]);
                    }
                    self.sens_arg = f_end;
                }
            }
        }
        Ok(())
    }

    /// The options in use (after sanitising).
    pub fn options(&self) -> &Options {
        &self.opts
    }

    fn resize(&mut self, dim: usize) {
        let last = self.opts.atol.last().copied().unwrap_or(Options::DEFAULT_ATOL);
        self.opts.atol.resize(dim.max(self.opts.atol.len()), last);
        self.opts.atol.truncate(dim);
        for a in self.opts.atol.iter_mut() {
            if !a.is_finite() || *a <= 0.0 {
                *a = if a.is_finite() && *a < 0.0 { -*a } else { f64::MIN_POSITIVE };
            }
        }
        self.n = dim;
        let z = || vec![0.0; dim];
        self.y_cache = z();
        self.f0 = z();
        self.f1 = z();
        self.ft = z();
        self.fs = z();
        self.ytmp = z();
        self.y1 = z();
        self.u = (0..self.tableau.stages).map(|_| z()).collect();
        self.q1 = z();
        self.q2 = z();
        self.y_root = z();
        self.jac = DMatrix::zeros(0, 0);
        self.sparse = None;
        self.structure_known = false;
        self.lu = LuFactors::new(0);
        self.cache_valid = false;
        self.jac_valid = false;
        self.roots_valid = false;
    }

    /// Ask the system for its Jacobian structure (once per dimension) and
    /// size the Jacobian and the LU accordingly.
    fn setup_structure(&mut self, sys: &dyn OdeSystem) -> Result<(), IntegratorError> {
        if self.structure_known {
            return Ok(());
        }
        let (n, ns) = (self.n, self.n - self.nq.min(self.n));
        self.sparse = match sys.jacobian_sparsity() {
            None => None,
            Some(p) if p.n_rows() == n && p.n_columns() == ns => Some(SparseJacobian::new(p, ns)),
            Some(p) => {
                let message = format!(
                    "the declared Jacobian structure is {}×{} but the system has {n} equations and {ns} non-quadrature states",
                    p.n_rows(),
                    p.n_columns()
                );
                return Err(IntegratorError::Rhs { t: self.t_cache, source: RhsError(message) });
            }
        };
        self.jac = if self.sparse.is_some() { DMatrix::zeros(0, 0) } else { DMatrix::zeros(n, n) };
        let sparse_lu = self.sparse.as_ref().is_some_and(|s| s.lu.is_some());
        self.lu = LuFactors::new(if sparse_lu { 0 } else { ns });
        self.structure_known = true;
        Ok(())
    }

    /// The linear algebra in use: "dense" (finite-difference Jacobian, dense
    /// LU), "structured" (declared structure, dense LU) or "sparse"
    /// (declared structure, sparse LU). Known after the first `advance`.
    pub fn linear_algebra(&self) -> &'static str {
        match &self.sparse {
            None => "dense",
            Some(s) if s.lu.is_some() => "sparse",
            Some(_) => "structured",
        }
    }

    fn resize_roots(&mut self, m: usize) {
        if self.g0.len() != m {
            self.g0 = vec![0.0; m];
            self.g1 = vec![0.0; m];
            self.g_probe = vec![0.0; m];
            self.g_ret = vec![0.0; m];
            self.directions = vec![RootDirection::Either; m];
            self.watch = vec![0.0; m];
            self.last_side = vec![0.0; m];
            self.roots_valid = false;
        }
        self.root_finder.ensure_len(m);
    }

    /// Weighted RMS norm of `v` with weights `atol_i + rtol·|y_i|`.
    fn wrms(&self, v: &[f64], y: &[f64]) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let mut s = 0.0;
        for i in 0..self.n {
            let w = self.opts.atol[i] + self.opts.rtol * y[i].abs();
            let r = v[i] / w;
            s += r * r;
        }
        (s / self.n as f64).sqrt()
    }

    /// Initial step magnitude (Hairer–Nørsett–Wanner I, §II.4), using `self.f0` at (t, y).
    fn initial_step(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], dir: f64, h_limit: f64) -> Result<f64, IntegratorError> {
        let d0 = self.wrms(y, y);
        let d1 = self.wrms(&self.f0, y);
        let mut h0 = if d0 < 1e-5 || d1 < 1e-5 { 1e-6 } else { 0.01 * d0 / d1 };
        h0 = h0.min(h_limit);
        for i in 0..self.n {
            self.ytmp[i] = y[i] + dir * h0 * self.f0[i];
        }
        let tp = t + dir * h0;
        let bad = eval_rhs(sys, tp, &self.ytmp, &mut self.fs, &mut self.stats)?;
        if bad.is_some() {
            return Ok(h0 * 1e-3);
        }
        for i in 0..self.n {
            self.ytmp[i] = (self.fs[i] - self.f0[i]) / h0;
        }
        let d2 = self.wrms(&self.ytmp, y);
        let dm = d1.max(d2);
        let h1 = if dm <= 1e-15 { (h0 * 1e-3).max(1e-6) } else { (0.01 / dm).powf(0.2) };
        let h = (100.0 * h0).min(h1).min(h_limit);
        Ok(if h.is_finite() && h > 0.0 { h } else { h0 })
    }

    /// Perturbation of state column `j` for finite differences.
    fn column_delta(&self, y: &[f64], j: usize) -> f64 {
        let typ = self.opts.atol[j] / self.opts.rtol;
        let d = f64::EPSILON.sqrt() * y[j].abs().max(typ);
        if d == 0.0 || !d.is_finite() {
            f64::EPSILON.sqrt()
        } else {
            d
        }
    }

    /// Jacobian in the declared structure at (t, y), using `self.f0`: filled by
    /// the system if it can, else by grouped forward differences
    /// (Curtis–Powell–Reid; see `sparsity.rs`), a group falling back to a
    /// backward difference where f is not finite.
    fn structured_jacobian(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64]) -> Result<(), IntegratorError> {
        let Some(mut sp) = self.sparse.take() else { return Ok(()) };
        for j in 0..sp.deltas.len() {
            sp.deltas[j] = self.column_delta(y, j);
        }
        let filled = sys.jacobian(t, y, &self.f0, &sp.deltas, &mut sp.values);
        let result = match filled {
            Err(source) => Err(IntegratorError::Rhs { t, source }),
            Ok(true) => match sp.values.iter().position(|v| !v.is_finite()) {
                Some(k) => Err(IntegratorError::NonFinite { t, index: row_of_entry(&sp.pattern, k) }),
                None => Ok(()),
            },
            Ok(false) => self.grouped_differences(sys, t, y, &mut sp),
        };
        self.sparse = Some(sp);
        result
    }

    fn grouped_differences(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], sp: &mut SparseJacobian) -> Result<(), IntegratorError> {
        self.ytmp.copy_from_slice(y);
        let groups = sp.groups.get_or_insert_with(|| sp.pattern.column_groups());
        for group in groups.iter() {
            let mut bad = 0;
            let mut ok = false;
            for sign in [1.0, -1.0] {
                for &j in group {
                    self.ytmp[j] = y[j] + sign * sp.deltas[j];
                }
                match eval_rhs(sys, t, &self.ytmp, &mut self.fs, &mut self.stats)? {
                    None => {
                        for &j in group {
                            let dj = self.ytmp[j] - y[j];
                            for k in sp.pattern.column_range(j) {
                                let r = sp.pattern.rows()[k];
                                sp.values[k] = (self.fs[r] - self.f0[r]) / dj;
                            }
                        }
                        ok = true;
                    }
                    Some(index) => bad = index,
                }
                for &j in group {
                    self.ytmp[j] = y[j];
                }
                if ok {
                    break;
                }
            }
            if !ok {
                return Err(IntegratorError::NonFinite { t, index: bad });
            }
        }
        Ok(())
    }

    /// Jacobian (finite differences, or the declared structure) and time derivative at (t, y), using `self.f0`.
    fn jacobian(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) -> Result<(), IntegratorError> {
        self.jac_age = 0;
        if self.sparse.is_some() {
            self.structured_jacobian(sys, t, y)?;
            return self.time_derivative(sys, t, y, h);
        }
        self.ytmp.copy_from_slice(y);
        let n_state = self.n - sys.n_quadrature().min(self.n);
        for j in n_state..self.n {
            for i in 0..self.n {
                self.jac[(i, j)] = 0.0;
            }
        }
        for j in 0..n_state {
            let d = self.column_delta(y, j);
            let yj = y[j];
            // Forward difference; if f is not finite there (e.g. at the edge of its
            // domain), fall back to a backward difference.
            let mut ok = false;
            let mut bad = 0;
            for sign in [1.0, -1.0] {
                self.ytmp[j] = yj + sign * d;
                let dj = self.ytmp[j] - yj;
                match eval_rhs(sys, t, &self.ytmp, &mut self.fs, &mut self.stats)? {
                    None => {
                        for i in 0..self.n {
                            self.jac[(i, j)] = (self.fs[i] - self.f0[i]) / dj;
                        }
                        ok = true;
                        break;
                    }
                    Some(index) => bad = index,
                }
            }
            self.ytmp[j] = yj;
            if !ok {
                return Err(IntegratorError::NonFinite { t, index: bad });
            }
        }
        self.time_derivative(sys, t, y, h)
    }

    /// ∂f/∂t by a forward difference (zero for autonomous systems).
    fn time_derivative(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) -> Result<(), IntegratorError> {
        let sqrt_eps = f64::EPSILON.sqrt();
        if sys.autonomous() {
            self.ft.fill(0.0);
            self.stats.jacobians += 1;
            return Ok(());
        }
        let dir = if h < 0.0 { -1.0 } else { 1.0 };
        let dt_mag = sqrt_eps * t.abs().max(h.abs()).max(f64::MIN_POSITIVE);
        let mut ok = false;
        let mut bad = None;
        for sign in [dir, -dir] {
            let tp = t + sign * dt_mag;
            let dt = tp - t;
            if dt == 0.0 {
                continue;
            }
            match eval_rhs(sys, tp, y, &mut self.fs, &mut self.stats)? {
                None => {
                    for i in 0..self.n {
                        self.ft[i] = (self.fs[i] - self.f0[i]) / dt;
                    }
                    ok = true;
                    break;
                }
                Some(index) => bad = Some(index),
            }
        }
        if !ok {
            match bad {
                Some(index) => return Err(IntegratorError::NonFinite { t, index }),
                None => self.ft.fill(0.0), // t cannot be perturbed (not reached in practice)
            }
        }
        self.stats.jacobians += 1;
        Ok(())
    }

    /// One step from (t0, y) to t1 with the tableau's stages; fills `self.y1`,
    /// `self.u` and the error vector (in `self.ft`'s sibling `self.q1` is not
    /// touched here).
    fn attempt(&mut self, sys: &mut dyn OdeSystem, t0: f64, t1: f64, y: &[f64]) -> Result<Attempt, IntegratorError> {
        let n = self.n;
        let h = t1 - t0;
        let inv_hg = 1.0 / (h * self.tableau.gamma);
        let ns = n - self.nq;
        self.stats.lu += 1;
        let factored = match self.sparse.as_mut() {
            Some(SparseJacobian { lu: Some(slu), values, .. }) => slu.factor(values, inv_hg),
            Some(sp) => {
                let a = self.lu.matrix_mut();
                a.fill(0.0);
                for j in 0..ns {
                    for (k, &r) in sp.pattern.column_range(j).zip(sp.pattern.column(j)) {
                        if r < ns {
                            a[(r, j)] = -sp.values[k];
                        }
                    }
                    a[(j, j)] += inv_hg;
                }
                self.lu.factor()
            }
            None => {
                let a = self.lu.matrix_mut();
                for j in 0..ns {
                    for i in 0..ns {
                        a[(i, j)] = -self.jac[(i, j)];
                    }
                    a[(j, j)] += inv_hg;
                }
                self.lu.factor()
            }
        };
        if factored.is_err() {
            return Ok(Attempt::Singular);
        }
        let keep_stages = !self.sens.is_empty();
        if keep_stages && (self.stage_y.len() != self.tableau.stages || self.stage_y[0].len() != n) {
            self.stage_y = (0..self.tableau.stages).map(|_| vec![0.0; n]).collect();
            self.stage_f = (0..self.tableau.stages).map(|_| vec![0.0; n]).collect();
        }
        let tab = &self.tableau;
        let u = &mut self.u;
        let ytmp = &mut self.ytmp;
        let fs = &mut self.fs;
        let ft = &self.ft;
        let lu = &self.lu;
        let jac = &self.jac;
        let mut sparse = self.sparse.as_mut();
        let stats = &mut self.stats;
        let inv_h = 1.0 / h;
        for st in 0..tab.stages {
            let (done, rest) = u.split_at_mut(st);
            let ui = &mut rest[0];
            let f: &[f64] = if st == 0 {
                &self.f0
            } else {
                let arow = &tab.a[st];
                for i in 0..n {
                    let mut v = y[i];
                    for (j, uj) in done.iter().enumerate() {
                        v += arow[j] * uj[i];
                    }
                    ytmp[i] = v;
                }
                let ts = t0 + tab.c[st] * h;
                match eval_rhs(sys, ts, ytmp, fs, stats) {
                    Ok(Some(index)) => return Ok(Attempt::NonFinite { t: ts, index }),
                    Ok(None) => {}
                    Err(IntegratorError::Rhs { t, source }) => return Ok(Attempt::Refused { t, source }),
                    Err(e) => return Err(e),
                }
                fs
            };
            let grow = &tab.gc[st];
            let hd = h * tab.d[st];
            for i in 0..n {
                let mut v = f[i] + hd * ft[i];
                for (j, uj) in done.iter().enumerate() {
                    v += grow[j] * inv_h * uj[i];
                }
                ui[i] = v;
            }
            if keep_stages {
                self.stage_y[st].copy_from_slice(if st == 0 { y } else { &ytmp[..] });
                self.stage_f[st].copy_from_slice(f);
            }
            solve_w(sparse.as_deref_mut(), lu, jac, ns, h * tab.gamma, ui);
        }
        for i in 0..n {
            let mut v = y[i];
            let mut e = 0.0;
            for (j, uj) in u.iter().enumerate() {
                v += tab.m[j] * uj[i];
                e += tab.e[j] * uj[i];
            }
            self.y1[i] = v;
            self.q2[i] = e; // the error vector, overwritten by the dense output once accepted
            if !v.is_finite() {
                return Ok(Attempt::NonFinite { t: t1, index: i });
            }
        }
        // Error norm with weights atol + rtol·max(|y0|, |y1|).
        let mut s = 0.0;
        let mut largest = 0.0;
        for i in 0..n {
            let w = self.opts.atol[i] + self.opts.rtol * y[i].abs().max(self.y1[i].abs());
            let r = self.q2[i] / w;
            s += r * r;
            if r.abs() > largest {
                largest = r.abs();
                self.largest_error = i;
            }
        }
        let err = if n > 0 { (s / n as f64).sqrt() } else { 0.0 };
        Ok(Attempt::Done(err))
    }

    /// Coefficients of the dense output of the accepted step from t0 to t0 + h
    /// (needs `self.f1` = f(t1, y1) for the Hermite form).
    fn prepare_dense(&mut self, y0: &[f64], h: f64) {
        match &self.tableau.dense {
            DenseKind::Rodas { e1, e2 } => {
                for i in 0..self.n {
                    let mut a = 0.0;
                    let mut b = 0.0;
                    for j in 0..e1.len() {
                        a += e1[j] * self.u[j][i];
                        b += e2[j] * self.u[j][i];
                    }
                    self.q1[i] = a;
                    self.q2[i] = b;
                }
            }
            DenseKind::Hermite => {
                // y(θ) = y0 + θ[Δ + (1 − θ)(q1 + θ q2)] with q1 = h f0 − Δ, q2 = 2Δ − h(f0 + f1)
                for i in 0..self.n {
                    let delta = self.y1[i] - y0[i];
                    self.q1[i] = h * self.f0[i] - delta;
                    self.q2[i] = 2.0 * delta - h * (self.f0[i] + self.f1[i]);
                }
            }
        }
    }

    /// Ensure f0 (and g0) correspond to (t, y); after a restart also ask the
    /// root directions again and forget the sides seen before.
    fn refresh_cache(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64]) -> Result<(), IntegratorError> {
        let same_point = self.cache_valid && t == self.t_cache && y == self.y_cache.as_slice();
        if !same_point {
            if let Some(index) = y.iter().position(|v| !v.is_finite()) {
                return Err(IntegratorError::NonFinite { t, index });
            }
            // f and the root functions at the (re)start point in one evaluation
            if let Some(index) = eval_rhs_and_roots(sys, t, y, &mut self.f0, &mut self.g0, &mut self.stats)? {
                return Err(IntegratorError::NonFinite { t, index });
            }
            self.t_cache = t;
            self.y_cache.copy_from_slice(y);
            self.cache_valid = true;
            self.jac_valid = false;
            self.roots_valid = false;
        }
        if !self.roots_valid {
            if same_point {
                eval_roots(sys, t, y, &mut self.g0)?;
            }
            sys.root_directions(&mut self.directions);
            self.last_side.fill(0.0);
            self.roots_valid = true;
        }
        Ok(())
    }

    /// Step-size factor after an accepted step with error `err` and size `h` (magnitude).
    fn accepted_factor(&mut self, err: f64, h: f64) -> f64 {
        let e = err.max(1e-10);
        let x = self.tableau.err_exponent;
        let mut fac = (SAFETY * e.powf(-x)).clamp(FAC_MIN, FAC_MAX);
        if self.have_acc && self.h_acc > 0.0 {
            // Gustafsson's predictive controller.
            let gus = SAFETY * (h / self.h_acc) * (self.err_acc / (e * e)).powf(x);
            fac = fac.min(gus.clamp(FAC_MIN, FAC_MAX));
        }
        self.have_acc = true;
        self.h_acc = h;
        self.err_acc = err.max(1e-2);
        fac
    }
}

/// Solve `W x = b` in place (`ui` holds b) for the iteration matrix
/// `W = [W_ss 0; −J_qs I/(hγ)]`: the states with the factored `W_ss`, then
/// the quadratures.
fn solve_w(sparse: Option<&mut SparseJacobian>, lu: &LuFactors, jac: &DMatrix<f64>, ns: usize, hg: f64, ui: &mut [f64]) {
    let n = ui.len();
    match sparse {
        Some(sp) => {
            match sp.lu.as_mut() {
                Some(slu) => slu.solve(&mut ui[..ns]),
                None => lu.solve(&mut ui[..ns]),
            }
            for &(q, j, k) in &sp.quadrature {
                ui[q] += sp.values[k] * ui[j];
            }
            for q in ns..n {
                ui[q] *= hg;
            }
        }
        None => {
            lu.solve(&mut ui[..ns]);
            for q in ns..n {
                let mut v = ui[q];
                for j in 0..ns {
                    v += jac[(q, j)] * ui[j];
                }
                ui[q] = hg * v;
            }
        }
    }
}

/// Evaluate f; `Ok(Some(i))` if component `i` is not finite.
fn eval_rhs(sys: &mut dyn OdeSystem, t: f64, y: &[f64], out: &mut [f64], stats: &mut Stats) -> Result<Option<usize>, IntegratorError> {
    stats.rhs_evals += 1;
    sys.rhs(t, y, out).map_err(|source| IntegratorError::Rhs { t, source })?;
    Ok(out.iter().position(|v| !v.is_finite()))
}

/// Evaluate f and the root functions at one point (one system evaluation
/// where the system supports it); `Ok(Some(i))` if component `i` of f is not finite.
fn eval_rhs_and_roots(
    sys: &mut dyn OdeSystem,
    t: f64,
    y: &[f64],
    out: &mut [f64],
    g: &mut [f64],
    stats: &mut Stats,
) -> Result<Option<usize>, IntegratorError> {
    if g.is_empty() {
        return eval_rhs(sys, t, y, out, stats);
    }
    stats.rhs_evals += 1;
    sys.rhs_and_roots(t, y, out, g).map_err(|source| IntegratorError::Rhs { t, source })?;
    if let Some(i) = out.iter().position(|v| !v.is_finite()) {
        return Ok(Some(i));
    }
    if let Some(i) = g.iter().position(|v| !v.is_finite()) {
        return Err(IntegratorError::Rhs { t, source: RhsError(format!("root function {i} is not finite")) });
    }
    Ok(None)
}

/// Evaluate the root functions; a non-finite value is reported as an Rhs error.
fn eval_roots(sys: &mut dyn OdeSystem, t: f64, y: &[f64], g: &mut [f64]) -> Result<(), IntegratorError> {
    if g.is_empty() {
        return Ok(());
    }
    sys.roots(t, y, g).map_err(|source| IntegratorError::Rhs { t, source })?;
    if let Some(i) = g.iter().position(|v| !v.is_finite()) {
        return Err(IntegratorError::Rhs { t, source: RhsError(format!("root function {i} is not finite")) });
    }
    Ok(())
}

impl Integrator for Rosenbrock {
    fn advance(
        &mut self,
        sys: &mut dyn OdeSystem,
        t: &mut f64,
        y: &mut [f64],
        t_stop: f64,
        observer: &mut dyn FnMut(&dyn crate::Dense),
    ) -> Result<Advance, IntegratorError> {
        if sys.dim() != y.len() {
            return Err(IntegratorError::Rhs {
                t: *t,
                source: RhsError(format!("dimension mismatch: system has {} states, y has {}", sys.dim(), y.len())),
            });
        }
        let nq = sys.n_quadrature().min(y.len());
        if y.len() != self.n || nq != self.nq {
            self.nq = nq;
            self.resize(y.len());
        }
        self.resize_roots(sys.n_roots());
        self.setup_structure(sys)?;
        if !t.is_finite() || !t_stop.is_finite() {
            return Err(IntegratorError::NonFinite { t: *t, index: 0 });
        }
        if *t == t_stop {
            return Ok(Advance::Reached);
        }
        let dir = if t_stop > *t { 1.0 } else { -1.0 };
        self.refresh_cache(sys, *t, y)?;

        let n = self.n;
        let h_max = self.opts.h_max;
        let mut h = match (self.fixed_h, self.h_next, self.opts.h_init) {
            (Some(hf), _, _) => hf,
            (None, Some(hn), _) => hn,
            (None, None, Some(hi)) if hi.is_finite() && hi > 0.0 => hi,
            _ => {
                let lim = h_max.min((t_stop - *t).abs());
                self.initial_step(sys, *t, y, dir, lim)?
            }
        };
        h = h.min(h_max);
        let mut steps = 0usize;
        let mut failures = 0usize;
        let mut singular = 0usize;
        let mut after_reject = false;

        loop {
            if !self.jac_valid {
                self.jacobian(sys, *t, y, dir * h)?;
                self.jac_valid = true;
            }
            // Never below the resolution of t; clip to t_stop (the last step may be
            // up to 1e-4·h longer than proposed, to avoid leaving a sliver).
            h = h.max(8.0 * f64::EPSILON * t.abs());
            let remaining = (t_stop - *t).abs();
            let h_unclipped = h;
            let last = h * 1.0001 >= remaining;
            if last {
                h = remaining;
            }
            let t1 = if last { t_stop } else { *t + dir * h };
            let floor = self.opts.h_min.max(16.0 * f64::EPSILON * t.abs());

            let attempt = self.attempt(sys, *t, t1, y)?;
            // a failure at a trial state (a stage, or a step end not yet
            // accepted): a non-finite value, or a state the system refuses
            let mut trial_failure = None;
            let err = match attempt {
                Attempt::Done(err) if err <= 1.0 || self.fixed_h.is_some() => {
                    // Derivative at the new point (needed for the next step), and the
                    // root functions there, in one evaluation of the system.
                    match eval_rhs_and_roots(sys, t1, &self.y1, &mut self.f1, &mut self.g1, &mut self.stats) {
                        Ok(None) => Some(err),
                        Ok(Some(index)) => {
                            trial_failure = Some(IntegratorError::NonFinite { t: t1, index });
                            None
                        }
                        Err(IntegratorError::Rhs { t: tf, source }) => {
                            trial_failure = Some(IntegratorError::Rhs { t: tf, source });
                            None
                        }
                        Err(e) => return Err(e),
                    }
                }
                Attempt::Done(err) => {
                    self.stats.rejected += 1;
                    failures += 1;
                    // a rejected step of a W-method with an old Jacobian first gets a fresh one
                    if self.tableau.w_method && self.jac_age > 0 {
                        self.jac_valid = false;
                    }
                    let fac = (SAFETY * err.powf(-self.tableau.err_exponent)).clamp(FAC_MIN_REJECT, 0.9);
                    h *= if err.is_finite() { fac } else { FAC_MIN };
                    after_reject = true;
                    if h < floor || failures > MAX_FAILURES {
                        return Err(IntegratorError::StepSizeTooSmall { t: *t, h, index: self.largest_error });
                    }
                    None
                }
                Attempt::NonFinite { t: tf, index } => {
                    trial_failure = Some(IntegratorError::NonFinite { t: tf, index });
                    None
                }
                Attempt::Refused { t: tf, source } => {
                    trial_failure = Some(IntegratorError::Rhs { t: tf, source });
                    None
                }
                Attempt::Singular => {
                    self.stats.rejected += 1;
                    failures += 1;
                    singular += 1;
                    h *= 0.5;
                    after_reject = true;
                    if self.fixed_h.is_some() || singular > MAX_SINGULAR || h < floor {
                        return Err(IntegratorError::SingularMatrix { t: *t });
                    }
                    None
                }
            };
            // A trial failure rejects the step and quarters it. A state the
            // system refuses (a real-gas equation of state far below its
            // range in an overshooting stage, which the junction solve
            // reports as an error) is treated as a non-finite value is; the
            // system's message is returned only when the step cannot shrink
            // further. An error at an accepted state still ends the run.
            if let Some(give_up) = trial_failure {
                self.stats.rejected += 1;
                failures += 1;
                h *= 0.25;
                after_reject = true;
                if self.fixed_h.is_some() || h < floor || failures > MAX_FAILURES {
                    return Err(give_up);
                }
            }
            let Some(err) = err else {
                continue;
            };

            // ---- Accepted step (t -> t1). ----
            self.stats.steps += 1;
            steps += 1;
            failures = 0;
            singular = 0;
            let t0 = *t;
            self.prepare_dense(y, t1 - t0);
            if !self.sens.is_empty() {
                self.sensitivity_step(sys, t0, t1 - t0)?;
            }

            // Next step size.
            let mut h_new = if let Some(hf) = self.fixed_h {
                hf
            } else {
                let mut hn = h * self.accepted_factor(err, h);
                if after_reject {
                    hn = hn.min(h);
                }
                if last && h_unclipped > h {
                    // The step was shortened only to hit t_stop: keep the longer proposal.
                    hn = hn.max(h_unclipped);
                }
                hn
            };
            h_new = h_new.min(h_max);
            after_reject = false;
            self.h_next = Some(h_new);

            // Root functions at the step end.
            let m = self.g0.len();
            let mut root_at = None;
            if m > 0 {
                let dense = StepDense { t0, t1, t_end: t1, y0: y, y1: &self.y1, q1: &self.q1, q2: &self.q2, sens: &self.sens };
                // Side each function is watched from. Only an `Either` function that
                // is zero at the start with no side seen since the restart needs a
                // value after the start (see `roots::watch`).
                let probe_needed =
                    (0..m).any(|i| self.g0[i] == 0.0 && self.directions[i] == RootDirection::Either && self.last_side[i] == 0.0);
                if probe_needed {
                    let len = (t1 - t0).abs();
                    let delta = len.min((100.0 * f64::EPSILON * (t0.abs() + len)).max(0.5 * self.opts.root_tol));
                    let tp = t0 + dir * delta;
                    dense.interpolate(tp, &mut self.y_root);
                    eval_roots(sys, tp, &self.y_root, &mut self.g_probe)?;
                    for i in 0..m {
                        if self.g0[i] == 0.0 && self.directions[i] == RootDirection::Either && self.last_side[i] == 0.0 {
                            self.last_side[i] = if self.g_probe[i] != 0.0 { self.g_probe[i].signum() } else { 0.0 };
                        }
                    }
                }
                for i in 0..m {
                    self.watch[i] = watch(self.directions[i], self.g0[i], self.last_side[i]);
                }
                if (0..m).any(|i| changed(self.watch[i], self.g1[i])) {
                    let tol = self.opts.root_tol.max(4.0 * f64::EPSILON * t0.abs().max(t1.abs()));
                    let y_root = &mut self.y_root;
                    let mut tr = self.root_finder.locate(t0, t1, &self.watch, &self.g0, &self.g1, tol, &mut |tm: f64, g: &mut [f64]| {
                        dense.interpolate(tm, y_root);
                        eval_roots(sys, tm, y_root, g)
                    })?;
                    self.g_ret.copy_from_slice(&self.root_finder.g_hi);
                    // Functions that cross within `tol` (or the event window) after the
                    // first one are reported too; the returned point then moves onto
                    // their new side as well.
                    let pending = (0..m).any(|i| !changed(self.watch[i], self.g_ret[i]) && changed(self.watch[i], self.g1[i]));
                    if pending {
                        let window = tol.max(self.opts.event_window).max(self.opts.event_window_per_step * (t1 - t0).abs());
                        let tp = if (t1 - tr).abs() <= window { t1 } else { tr + dir * window };
                        if tp == t1 {
                            self.g_probe.copy_from_slice(&self.g1);
                        } else {
                            dense.interpolate(tp, &mut self.y_root);
                            eval_roots(sys, tp, &self.y_root, &mut self.g_probe)?;
                        }
                        let keeps_first = (0..m).all(|i| !changed(self.watch[i], self.g_ret[i]) || changed(self.watch[i], self.g_probe[i]));
                        if keeps_first {
                            tr = tp;
                            std::mem::swap(&mut self.g_ret, &mut self.g_probe);
                        }
                    }
                    root_at = Some(tr);
                }
            }

            if let Some(tr) = root_at {
                let dense = StepDense { t0, t1, t_end: tr, y0: y, y1: &self.y1, q1: &self.q1, q2: &self.q2, sens: &self.sens };
                dense.interpolate(tr, &mut self.y_root);
                observer(&dense);
                let indices: Vec<usize> = (0..m).filter(|&i| changed(self.watch[i], self.g_ret[i])).collect();
                for c in self.sens.iter_mut() {
                    let view = StepDense { t0, t1, t_end: tr, y0: &c.s0, y1: &c.s1, q1: &c.q1, q2: &c.q2, sens: &[] };
                    view.interpolate(tr, &mut self.y1); // y1 is free now: y_root holds the state at tr
                    c.s0.copy_from_slice(&self.y1);
                }
                y.copy_from_slice(&self.y_root);
                *t = tr;
                // The caller is expected to change the system here; nothing is cached.
                self.cache_valid = false;
                self.jac_valid = false;
                self.roots_valid = false;
                return Ok(Advance::Root { indices });
            }

            {
                let dense = StepDense { t0, t1, t_end: t1, y0: y, y1: &self.y1, q1: &self.q1, q2: &self.q2, sens: &self.sens };
                observer(&dense);
            }
            // Sides seen at the step end carry over to the next step (a step may end
            // on an exact zero, which is not a change).
            for i in 0..m {
                if self.g1[i] != 0.0 {
                    self.last_side[i] = self.g1[i].signum();
                } else if self.watch[i] != 0.0 {
                    self.last_side[i] = self.watch[i];
                }
            }
            y.copy_from_slice(&self.y1);
            *t = t1;
            for c in self.sens.iter_mut() {
                std::mem::swap(&mut c.s0, &mut c.s1);
            }
            std::mem::swap(&mut self.f0, &mut self.f1);
            std::mem::swap(&mut self.g0, &mut self.g1);
            self.t_cache = t1;
            self.y_cache.copy_from_slice(y);
            self.cache_valid = true;
            self.roots_valid = true;
            // a W-method keeps its order with an older Jacobian: reuse it for a while
            self.jac_age += 1;
            if !self.tableau.w_method || self.jac_age >= MAX_JACOBIAN_AGE {
                self.jac_valid = false;
            }
            debug_assert_eq!(n, y.len());

            if last {
                return Ok(Advance::Reached);
            }
            if steps >= self.opts.max_steps {
                return Err(IntegratorError::TooManySteps { t: *t, steps, h: h_new, index: self.largest_error });
            }
            h = h_new;
        }
    }

    fn reset(&mut self) {
        self.cache_valid = false;
        self.jac_valid = false;
        self.roots_valid = false;
        self.have_acc = false;
    }

    fn stats(&self) -> Stats {
        self.stats
    }
}

/// Row of entry `k` of a structure (for error messages).
fn row_of_entry(p: &Sparsity, k: usize) -> usize {
    p.rows().get(k).copied().unwrap_or(0)
}
