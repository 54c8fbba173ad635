//! Forward parameter sensitivities of a run: `S_k = ∂x/∂θ_k` along the
//! trajectory and `∂y/∂θ_k` of every recorded channel on the recording grid,
//! through the run's events.
//!
//! Method: the staggered direct method (M. Caracotsios & W. E. Stewart,
//! "Sensitivity analysis of initial value problems with mixed ODEs and
//! algebraic equations", Comput. Chem. Eng. 9 (1985) 359–365; the SUNDIALS
//! CVODES user guide, chapter "Mathematical considerations", section
//! "Forward sensitivity analysis"), in its Rosenbrock form: the state takes its
//! steps under its own error control, and each accepted step integrates
//! `S_k' = J S_k + ∂f/∂θ_k` with the same stages and the same factored
//! iteration matrix (`ode::Rosenbrock::set_sensitivities`). That matrix
//! leaves out the coupling block `∂(J S)/∂x` of the pair (x, S), which only
//! a W-method tolerates: a run with sensitivities therefore integrates with
//! ROS34PW2 (order 3 for the pair; RODAS4 measured 7e-4 relative error on a
//! closed form where ROS34PW2 gives 2e-9, `ode`'s `tests_sensitivity.rs`),
//! whatever [`SimOptions::method`] says.
//!
//! solve knows no netlist parameter names. The caller supplies, per
//! parameter θ_k, a copy of the model built at `θ_k + δ_k` ([`Parameter`]);
//! every derivative with respect to θ_k is a directional difference between
//! that copy and the run's model, the stage right-hand side of column k being
//! `F_k(t, x, S) = (f_{θ+δ_k}(t, x + δ_k S) − f_θ(t, x)) / δ_k`
//! `= J S + ∂f/∂θ_k + O(δ_k)`, so one evaluation of the copy per stage.
//! The same difference of the output map gives the channels' sensitivities,
//! and of the initial state (rest state included) `S_k(0)`. With `δ_k` a
//! relative 1e-7 of θ_k and the junction solve's 1e-13 pressure tolerance,
//! the truncation (O(δ)) and the round-off (≈ 1e-13/1e-7) errors are both
//! near 1e-6 relative; the tests (tests/sensitivity.rs) measure the
//! agreement with central differences of whole runs.
//!
//! Discrete state: each copy lives through the same events as the run's
//! model — the same roots and time events handled at the same instant — so
//! it is in the same mode (stick/slip, end stop, valve and controller states)
//! at every evaluation; a copy whose mechanical modes come out different from
//! the run's is an error ([`SolveError::Sensitivity`]): the parameter changes
//! a discrete decision, where no derivative exists.
//!
//! Events (jump conditions; P. I. Barton & co-workers: E. Galán, W. F.
//! Feehery & P. I. Barton, "Parametric sensitivity functions for hybrid
//! discrete/continuous systems", Appl. Numer. Math. 31 (1999) 17–47; I. A.
//! Hiskens & M. A. Pai, IEEE Trans. Circuits Syst. I 47 (2000) 204–220): at a
//! root g(x, θ) = 0 at time τ, `dτ/dθ = −(g_x S⁻ + g_θ)/(ġ)` with
//! `ġ = g_t + g_x f⁻`; the handling of the event is a map `x⁺ = h(x⁻, θ)`
//! (identity for a switch that leaves the state continuous, a velocity set to
//! zero at an end stop or on sticking), and
//! `S⁺ = h_x (S⁻ + f⁻ dτ/dθ) + h_θ − f⁺ dτ/dθ`. Both pieces are directional
//! differences again: `g_x S⁻ + g_θ` from the copy's root function at
//! `x⁻ + δ S⁻`, `ġ` from a central difference of the run's root along the
//! trajectory, and `h_x(·) + h_θ` by letting the copy handle the same event
//! from `x⁻ + δ (S⁻ + f⁻ dτ/dθ)`. Time events (a controller's switching
//! times) have `dτ/dθ = 0`. Several roots at one instant: the first one
//! reported sets dτ/dθ.
//!
//! The run's own trajectory is not changed by asking for sensitivities: the
//! copies are evaluated apart, and the run's model only through detached
//! evaluations ([`Model::eval_detached`]).

use crate::model::Model;
use crate::simulate::{resolve_events, SimOptions, SimResult, SolveError};
use ode::RhsError;

/// One parameter: its name (for the result) and the run's model rebuilt with
/// the parameter at `θ + delta` (same circuit, everything else equal).
#[derive(Debug, Clone)]
pub struct Parameter {
    pub name: String,
    pub model: Model,
    /// The perturbation δ, in the parameter's SI unit (≠ 0).
    pub delta: f64,
}

/// Sensitivities of the recorded channels, beside a [`SimResult`].
#[derive(Debug, Clone, Default)]
pub struct Sensitivities {
    /// Parameter names, in the order given.
    pub params: Vec<String>,
    /// Channel names (the result's columns).
    pub columns: Vec<String>,
    /// `values[k][row][column]`: ∂(column)/∂θ_k at the result's `times[row]`,
    /// in the column's SI unit per SI unit of the parameter; `None` where the
    /// channel is undefined.
    pub values: Vec<Vec<Vec<Option<f64>>>>,
    /// ∂x/∂θ_k of the state at the end of the run, per parameter.
    pub final_state: Vec<Vec<f64>>,
}

impl Sensitivities {
    /// ∂(channel)/∂(param) on the result's time grid.
    pub fn series(&self, channel: &str, param: &str) -> Option<Vec<Option<f64>>> {
        let c = self.columns.iter().position(|n| n == channel)?;
        let k = self.params.iter().position(|n| n == param)?;
        Some(self.values[k].iter().map(|row| row[c]).collect())
    }
}

/// Run `model` as [`crate::simulate`] does and integrate the sensitivities to
/// the parameters whose perturbed models `params` holds.
pub fn simulate_with_sensitivities(
    model: &mut Model,
    params: Vec<Parameter>,
    opts: &SimOptions,
) -> Result<(SimResult, Sensitivities), SolveError> {
    if let Some(p) = params.iter().find(|p| !(p.delta.is_finite() && p.delta != 0.0)) {
        return Err(SolveError::Settings(format!("the perturbation of parameter {} must be finite and non-zero", p.name)));
    }
    if let Some(p) = params.iter().find(|p| p.model.dim() != model.dim() || p.model.n_roots() != model.n_roots()) {
        return Err(SolveError::Settings(format!("the model of parameter {} has another structure than the run's", p.name)));
    }
    let mut tracker = Tracker::new(params, model.output_names());
    let opts = SimOptions { method: ode::Method::Ros34pw2, ..opts.clone() };
    let result = crate::simulate::run_tracked(model, &opts, &mut tracker)?;
    Ok((result, tracker.finish()))
}

/// The sensitivity side of a run (driven by `simulate::run`).
pub(crate) struct Tracker {
    params: Vec<Parameter>,
    out: Sensitivities,
    /// Buffers: a perturbed state, f of a copy, root values.
    x: Vec<f64>,
    f: Vec<f64>,
    g: Vec<f64>,
    /// f⁻ of the run's model before an event, and dτ/dθ_k.
    f_before: Vec<f64>,
    dtau: Vec<f64>,
    /// A result the copies' event handling writes its logs into (discarded).
    scratch: SimResult,
}

impl Tracker {
    fn new(params: Vec<Parameter>, columns: Vec<String>) -> Tracker {
        let p = params.len();
        Tracker {
            out: Sensitivities {
                params: params.iter().map(|p| p.name.clone()).collect(),
                columns,
                values: vec![Vec::new(); p],
                final_state: Vec::new(),
            },
            params,
            x: Vec::new(),
            f: Vec::new(),
            g: Vec::new(),
            f_before: Vec::new(),
            dtau: vec![0.0; p],
            scratch: SimResult::default(),
        }
    }

    fn finish(self) -> Sensitivities {
        self.out
    }

    pub(crate) fn n_params(&self) -> usize {
        self.params.len()
    }

    /// Bring every copy to the run's start (rest state, initial state, modes,
    /// events at t = 0) as the run did with `model`, whose start is `y`;
    /// returns `S_k(0) = (x_k(0) − x(0)) / δ_k`.
    pub(crate) fn start(&mut self, model: &Model, y: &[f64], opts: &SimOptions) -> Result<Vec<Vec<f64>>, SolveError> {
        let mut columns = Vec::with_capacity(self.params.len());
        for p in &mut self.params {
            let copy = &mut p.model;
            if copy.circuit.simulation.initial == graph::netlist::InitialMode::Rest {
                crate::rest::apply(copy)?;
            }
            let mut yk = copy.initial_state();
            copy.velocity_band = opts.atol;
            crate::simulate::initial_modes(copy, 0.0, &yk)?;
            resolve_events(copy, 0.0, &mut yk, &[], &[], &mut self.scratch)?;
            same_modes(model, copy, &p.name, 0.0)?;
            columns.push(yk.iter().zip(y).map(|(a, b)| (a - b) / p.delta).collect());
        }
        Ok(columns)
    }

    /// `F_k(t, x, s)` (see the module documentation).
    pub(crate) fn rhs(&mut self, k: usize, t: f64, x: &[f64], f: &[f64], s: &[f64], out: &mut [f64]) -> Result<(), RhsError> {
        let p = &mut self.params[k];
        self.x.clear();
        self.x.extend(x.iter().zip(s).map(|(a, b)| a + p.delta * b));
        p.model.eval(t, &self.x, Some(out), None).map_err(|e| RhsError(format!("sensitivity to {}: {e}", p.name)))?;
        for (o, fi) in out.iter_mut().zip(f) {
            *o = (*o - fi) / p.delta;
        }
        Ok(())
    }

    /// Record the channels' sensitivities at (t, x) given the run's row there
    /// and the sensitivity columns `s`.
    pub(crate) fn record(&mut self, t: f64, x: &[f64], row: &[Option<f64>], s: &[Vec<f64>]) -> Result<(), SolveError> {
        let mut perturbed = vec![None; row.len()];
        for (k, p) in self.params.iter_mut().enumerate() {
            self.x.clear();
            self.x.extend(x.iter().zip(&s[k]).map(|(a, b)| a + p.delta * b));
            p.model.record(t, &self.x, &mut perturbed)?;
            let d = row.iter().zip(&perturbed).map(|(a, b)| Some((b.as_ref()? - a.as_ref()?) / p.delta)).collect();
            self.out.values[k].push(d);
        }
        Ok(())
    }

    /// Before the run's model handles the event at t (state `x` just past
    /// it, sensitivities `s`): f⁻ and dτ/dθ_k from the first root in `crossings`.
    pub(crate) fn before_event(
        &mut self,
        model: &mut Model,
        t: f64,
        x: &[f64],
        crossings: &[usize],
        s: &[Vec<f64>],
    ) -> Result<(), SolveError> {
        let (n, m) = (model.dim(), model.n_roots());
        self.f_before.resize(n, 0.0);
        self.f.resize(n, 0.0);
        self.g.resize(m, 0.0);
        self.dtau.fill(0.0);
        model.eval_detached(t, x, Some(&mut self.f_before), Some(&mut self.g))?;
        let Some(&i) = crossings.first() else { return Ok(()) };
        let g0 = self.g[i];
        // ġ = g_t + g_x f⁻ by a central difference along the trajectory
        let eps = f64::EPSILON.sqrt() * t.abs().max(1e-3);
        let mut along = [0.0; 2];
        for (side, sign) in [1.0, -1.0].into_iter().enumerate() {
            self.x.clear();
            self.x.extend(x.iter().zip(&self.f_before).map(|(a, b)| a + sign * eps * b));
            model.eval_detached(t + sign * eps, &self.x, None, Some(&mut self.g))?;
            along[side] = self.g[i];
        }
        let g_dot = (along[0] - along[1]) / (2.0 * eps);
        for (k, p) in self.params.iter_mut().enumerate() {
            self.x.clear();
            self.x.extend(x.iter().zip(&s[k]).map(|(a, b)| a + p.delta * b));
            p.model.eval_detached(t, &self.x, None, Some(&mut self.g))?;
            let g_theta = (self.g[i] - g0) / p.delta;
            if !(g_dot.is_finite() && g_dot != 0.0) {
                return Err(SolveError::Sensitivity(format!(
                    "{} at t = {} s is reached tangentially (its rate is {}); the event time has no derivative",
                    model.root_name(i),
                    units::show::num(t),
                    units::show::num(g_dot)
                )));
            }
            self.dtau[k] = -g_theta / g_dot;
        }
        Ok(())
    }

    /// After the run's model handled the event at t (from `x_before` to
    /// `x_after`): each copy handles it too from its own state, and the
    /// columns jump (returned).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn after_event(
        &mut self,
        model: &mut Model,
        t: f64,
        x_before: &[f64],
        x_after: &[f64],
        crossings: &[usize],
        due: &[usize],
        s: &[Vec<f64>],
    ) -> Result<Vec<Vec<f64>>, SolveError> {
        self.f.resize(model.dim(), 0.0);
        model.eval_detached(t, x_after, Some(&mut self.f), None)?;
        let mut columns = Vec::with_capacity(self.params.len());
        for (k, p) in self.params.iter_mut().enumerate() {
            let dtau = self.dtau[k];
            let mut xk: Vec<f64> =
                x_before.iter().zip(&s[k]).zip(&self.f_before).map(|((a, sk), fb)| a + p.delta * (sk + fb * dtau)).collect();
            resolve_events(&mut p.model, t, &mut xk, crossings, due, &mut self.scratch)?;
            same_modes(model, &p.model, &p.name, t)?;
            columns.push(xk.iter().zip(x_after).zip(&self.f).map(|((a, b), fa)| (a - b) / p.delta - fa * dtau).collect());
        }
        self.scratch.events.clear();
        self.scratch.cycles.clear();
        Ok(columns)
    }

    pub(crate) fn set_final(&mut self, s: Vec<Vec<f64>>) {
        self.out.final_state = s;
    }
}

/// The copy of parameter `name` must be in the run's mechanical modes.
fn same_modes(model: &Model, copy: &Model, name: &str, t: f64) -> Result<(), SolveError> {
    match model.modes.iter().zip(&copy.modes).position(|(a, b)| a != b) {
        None => Ok(()),
        Some(node) => {
            let id = &model.circuit.instances[model.circuit.mechanical_nodes[node].inertia.block].id;
            Err(SolveError::Sensitivity(format!(
                "at t = {} s a change of {name} changes the mode of {id} ({} instead of {}): no derivative there",
                units::show::num(t),
                crate::simulate::mode_name(copy.modes[node]),
                crate::simulate::mode_name(model.modes[node])
            )))
        }
    }
}
