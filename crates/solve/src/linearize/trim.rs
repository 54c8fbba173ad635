//! Trim: an equilibrium f(x*, u*) = 0 that meets the constraints a user
//! states ("the piston at 225 mm, the head at 4 bar, no load").
//!
//! Unknowns are the states of the linear model's kind (block states less
//! those of held mechanical nodes and those that reach no output, see
//! [`super`]) and every interface input — as in Simulink's operating-point
//! specifications, where states and inputs are free unless known. Each
//! constraint fixes a state, an input or a recorded value (a pressure). The
//! equations are ẋᵢ = 0 for every unknown state and one per constraint.
//!
//! Before solving, the count is checked where it can be wrong: the
//! equilibria of the model form a family of dimension d = (unknowns) −
//! rank ∂f/∂(x, u) (a closed chamber keeps whatever gas it holds, an
//! adiabatic one its entropy too, so d grows with every conserved
//! quantity), and exactly d independent constraints pick one member. Fewer
//! is under-determined, more is over-determined; both are refused, naming
//! the unknowns left free or the count to drop. The rank is numerical:
//! singular values of the scaled Jacobian above 1e-8 of the largest. It is
//! taken at a generic point: a guess on a kink (a zero-lapped spool at
//! centre, the netlist's start) is first moved by ~1e-6 of each unknown's
//! scale if that raises the rank.
//!
//! Then Gauss–Newton on the scaled unknowns (states over their typical
//! size, inputs over max(|u|, 1)), with the minimum-norm step of the SVD
//! and step halving while the residual does not fall or the model leaves
//! its domain; converged when every scaled residual is below 1e-10
//! (rates relative to the state's size per second, constraint errors
//! relative to the value).

use super::jacobians::{jacobians, rates, recorded};
use super::{output_columns, reaching_outputs, set_modes, Friction, LinearizeError, OperatingPoint, PointKind};
use crate::model::Model;
use linear::lstsq::svd;
use linear::Matrix;

/// What a constraint fixes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// A block state (index in the state vector).
    State(usize),
    /// An interface input.
    Input(usize),
    /// A recorded value (index among [`Model::output_names`]).
    Recorded(usize),
}

/// One stated condition: `name` = `value` [SI].
#[derive(Debug, Clone, PartialEq)]
pub struct Constraint {
    /// As the user wrote it ("cyl.piston.x", "u").
    pub name: String,
    pub target: Target,
    pub value: f64,
}

/// A value a trim held or solved, in SI.
#[derive(Debug, Clone, PartialEq)]
pub struct TrimValue {
    pub name: String,
    pub value: f64,
    pub unit: String,
}

/// What a trim held, what it solved, and what it left as it was.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrimReport {
    /// The constraints.
    pub held: Vec<TrimValue>,
    /// The unknowns, at the solution.
    pub solved: Vec<TrimValue>,
    /// States neither held nor solved (a held mechanical node, a state that reaches no output), with the reason.
    pub untouched: Vec<(String, String)>,
    pub iterations: usize,
    /// Largest scaled residual at the solution.
    pub residual: f64,
}

/// What `name` names in `model`, with its SI unit: an interface input, an
/// interface output (a recorded value), a state ("cyl.piston.x") or a
/// result column ("cyl.head.p"), in that order.
pub fn target(model: &Model, name: &str) -> Option<(Target, String)> {
    let inputs = super::input_names(model);
    if let Some(k) = inputs.iter().position(|i| i.name == name) {
        return Some((Target::Input(k), inputs[k].unit.clone()));
    }
    let (outputs, _) = output_columns(model);
    if let Some((named, col)) = outputs.iter().find(|o| o.0.name == name) {
        return Some((Target::Recorded(*col), named.unit.clone()));
    }
    if let Some(i) = (0..model.n_states).find(|&i| model.state_name(i) == name) {
        return Some((Target::State(i), super::state_unit(model, i)));
    }
    let names = model.output_names();
    let col = names.iter().position(|c| c == name)?;
    Some((Target::Recorded(col), model.output_units()[col].clone()))
}

/// Largest number of Gauss–Newton iterations.
const MAX_ITER: usize = 60;
/// Converged when every scaled residual is below this.
const TOL: f64 = 1e-10;
/// Relative size of a singular value that counts (rank decisions).
const RCOND: f64 = 1e-8;

/// Solve the trim from the state `guess` (the whole state vector), at t = 0.
pub fn trim(model: &mut Model, guess: &[f64], constraints: &[Constraint], friction: Friction) -> Result<OperatingPoint, LinearizeError> {
    let t = 0.0;
    let n = model.n_states;
    let m = model.n_inputs();
    let mut y = guess.to_vec();
    for c in constraints {
        match c.target {
            Target::State(i) => y[i] = c.value,
            Target::Input(k) => model.set_input(k, c.value)?,
            Target::Recorded(_) => {}
        }
    }
    // a stated value the model cannot be evaluated at (a position beyond
    // the stroke, a negative pressure) is named, not left to the model's error
    let mechanics = set_modes(model, t, &y, PointKind::Trim, friction)
        .map_err(|e| LinearizeError::Trim(format!("the model cannot be evaluated at the stated {}: {e}", stated(model, constraints))))?;
    let held: Vec<usize> = mechanics.iter().flat_map(|nm| nm.held_states.iter().copied()).collect();
    // a constraint on a held node's state is met by holding it: not an equation
    let equations: Vec<Constraint> =
        constraints.iter().filter(|c| !matches!(c.target, Target::State(i) if held.contains(&i))).cloned().collect();
    // unknown states: those that reach an output or a constraint
    let free: Vec<usize> = (0..n).filter(|i| !held.contains(i)).collect();
    let (outputs, _) = output_columns(model);
    let mut watch: Vec<usize> = outputs.iter().map(|o| o.1).collect();
    watch.extend(equations.iter().filter_map(|c| if let Target::Recorded(col) = c.target { Some(col) } else { None }));
    let all: Vec<usize> = (0..n).collect();
    let j0 = jacobians(model, t, &y, &all, &watch)?;
    let states: Vec<usize> = if model.circuit.interface.outputs.is_empty() {
        free.clone()
    } else {
        // a state named in a constraint counts as watched
        let mut rows = j0.c.to_rows();
        for c in &equations {
            if let Target::State(i) = c.target {
                let mut r = vec![0.0; n];
                r[i] = 1.0;
                rows.push(r);
            }
        }
        let c = if rows.is_empty() { Matrix::zeros(0, n) } else { Matrix::from_rows(&rows)? };
        reaching_outputs(model, &j0.a, &c, &free)
    };
    let unknown_names: Vec<String> =
        states.iter().map(|&i| model.state_name(i)).chain(model.circuit.interface.inputs.iter().map(|i| i.name.clone())).collect();
    let point = Point { y, u: (0..m).map(|k| model.input_value(k)).collect() };
    let problem = Problem { scales: scales(model, &point, &states), states: states.clone(), constraints: equations, t };
    let n_unknowns = states.len() + m;

    // the count: the family of equilibria and the constraints that pick one
    let (mut point, jf) = off_kink_start(model, &problem, point)?;
    let rows_f: Vec<usize> = (0..states.len()).collect();
    let cols: Vec<usize> = (0..n_unknowns).collect();
    let family = n_unknowns - svd(&jf.select(&rows_f, &cols))?.rank(RCOND);
    let k = problem.constraints.len();
    let given = problem.constraints.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ");
    if k > family {
        return Err(LinearizeError::Trim(format!(
            "over-determined: {k} constraint{} ({given}) for equilibria that form a family of dimension {family}: drop {} (a value that follows from the others, such as a pressure the force balance sets)",
            plural(k),
            k - family
        )));
    }
    let full = svd(&jf)?;
    if k < family || full.rank(RCOND) < n_unknowns {
        let free_names = null_directions(&full, &unknown_names);
        let fixed = if k == 0 { "no constraint fixes".to_string() } else { format!("{given} fix{}", if k == 1 { "es" } else { "" }) };
        let how = if k < family { format!("only {k} of them") } else { "fewer of them (the constraints are not independent)".to_string() };
        let add = if family > k { format!("{} of them", family - k) } else { "one of them instead".to_string() };
        return Err(LinearizeError::Trim(format!(
            "under-determined: the equilibria form a family of dimension {family} and {fixed} {how}; left free: {} (add NAME=VALUE for {add})",
            free_names.join(", ")
        )));
    }

    // Gauss–Newton
    let mut residual = problem.residual(model, &point)?;
    let mut iterations = 0;
    while norm_inf(&residual) > TOL {
        if iterations == MAX_ITER {
            return Err(LinearizeError::Trim(format!(
                "no equilibrium found in {MAX_ITER} iterations: the largest residual is {:.1e} (in {}); check that {} can hold together",
                norm_inf(&residual),
                problem.equation_name(model, &residual),
                stated(model, constraints)
            )));
        }
        iterations += 1;
        let j = problem.jacobian(model, &point)?;
        let step = svd(&j)?.solve(&residual, 1e-12);
        let mut lambda = 1.0;
        loop {
            let trial = problem.moved(&point, &step, -lambda);
            match problem.residual(model, &trial) {
                Ok(r) if norm2(&r) < norm2(&residual) => {
                    point = trial;
                    residual = r;
                    break;
                }
                _ if lambda < 1e-6 => {
                    return Err(LinearizeError::Trim(format!(
                        "no equilibrium found: the residual stops falling at {:.1e} (in {}); check that {} can hold together",
                        norm_inf(&residual),
                        problem.equation_name(model, &residual),
                        stated(model, constraints)
                    )));
                }
                _ => lambda *= 0.5,
            }
        }
    }
    // a state solved to within round-off of zero (a velocity at rest,
    // ~1e-29 m/s) is set to zero where that keeps the residual converged:
    // the linearisation chooses the friction mode from the sign of v, and
    // the trim was solved in the mode of v = 0
    for (k, &i) in problem.states.iter().enumerate() {
        if point.y[i] != 0.0 && point.y[i].abs() < 1e-12 * problem.scales[k] {
            let mut q = point.clone();
            q.y[i] = 0.0;
            if let Ok(r) = problem.residual(model, &q) {
                if norm_inf(&r) <= TOL {
                    (point, residual) = (q, r);
                }
            }
        }
    }
    problem.set_inputs(model, &point)?;
    let units: Vec<String> =
        states.iter().map(|&i| super::state_unit(model, i)).chain(super::input_names(model).into_iter().map(|i| i.unit)).collect();
    let values: Vec<f64> = states.iter().map(|&i| point.y[i]).chain(point.u.iter().copied()).collect();
    let report = TrimReport {
        held: constraints
            .iter()
            .map(|c| TrimValue { name: c.name.clone(), value: c.value, unit: target(model, &c.name).map(|(_, u)| u).unwrap_or_default() })
            .collect(),
        solved: unknown_names
            .iter()
            .zip(values)
            .zip(units)
            .map(|((name, value), unit)| TrimValue { name: name.clone(), value, unit })
            .filter(|v| !constraints.iter().any(|c| c.name == v.name))
            .collect(),
        untouched: (0..n)
            .filter(|i| !states.contains(i))
            .map(|i| {
                let why = match mechanics.iter().find(|nm| nm.held_states.contains(&i)) {
                    Some(nm) => format!("{} is held", nm.id),
                    None => "reaches no output: not in equilibrium".to_string(),
                };
                (model.state_name(i), why)
            })
            .collect(),
        iterations,
        residual: norm_inf(&residual),
    };
    Ok(OperatingPoint { t, y: point.y, kind: PointKind::Trim, trim: Some(report) })
}

/// The start of the Gauss–Newton iteration and the Jacobian there. A guess
/// on a kink (a zero-lapped spool exactly at centre, where every opening's
/// slope is zero on one side) has a rank-deficient Jacobian that would count
/// a spurious direction into the family of equilibria and stall the
/// iteration; the rank at a generic point nearby is the one that counts. So
/// when ∂f/∂(x, u) at the guess lacks full row rank, the unknowns are moved
/// by about 1e-6 of their scales (distinct fractions, all positive) and that
/// point is the start if its rank is higher.
fn off_kink_start(model: &mut Model, problem: &Problem, guess: Point) -> Result<(Point, Matrix), LinearizeError> {
    let ns = problem.n_states();
    // (rank of ∂f/∂(x, u), rank with the constraints' rows)
    let ranks = |j: &Matrix| -> Result<(usize, usize), LinearizeError> {
        let rows: Vec<usize> = (0..ns).collect();
        let cols: Vec<usize> = (0..j.cols()).collect();
        Ok((svd(&j.select(&rows, &cols))?.rank(RCOND), svd(j)?.rank(RCOND)))
    };
    let j = problem.jacobian(model, &guess)?;
    let at_guess = ranks(&j)?;
    if at_guess == (ns, j.rows().min(j.cols())) {
        return Ok((guess, j));
    }
    let nudge: Vec<f64> = (0..j.cols()).map(|k| 1e-6 * (1.0 + 0.5 * ((k + 1) as f64).sin())).collect();
    let nudged = problem.moved(&guess, &nudge, 1.0);
    if let Ok(jn) = problem.jacobian(model, &nudged) {
        if ranks(&jn)? > at_guess {
            return Ok((nudged, jn));
        }
    }
    let j = problem.jacobian(model, &guess)?;
    Ok((guess, j))
}

/// A trial point: the whole state vector and the inputs.
#[derive(Debug, Clone)]
struct Point {
    y: Vec<f64>,
    u: Vec<f64>,
}

/// The unknowns and equations of one trim.
struct Problem {
    /// Unknown states (indices); the inputs follow them.
    states: Vec<usize>,
    constraints: Vec<Constraint>,
    /// Scale of each unknown state, then of each input.
    scales: Vec<f64>,
    t: f64,
}

/// Typical sizes of the unknown states and of the inputs.
fn scales(model: &Model, p: &Point, states: &[usize]) -> Vec<f64> {
    let s = model.state_scales(&p.y);
    states.iter().map(|&i| s[i].max(p.y[i].abs())).chain(p.u.iter().map(|u| u.abs().max(1.0))).collect()
}

impl Problem {
    fn n_states(&self) -> usize {
        self.states.len()
    }

    fn set_inputs(&self, model: &mut Model, p: &Point) -> Result<(), LinearizeError> {
        for (k, &u) in p.u.iter().enumerate() {
            if model.input_value(k) != u {
                model.set_input(k, u)?;
            }
        }
        Ok(())
    }

    /// The scaled residual at p.
    fn residual(&self, model: &mut Model, p: &Point) -> Result<Vec<f64>, LinearizeError> {
        self.set_inputs(model, p)?;
        let f = rates(model, self.t, &p.y)?;
        let mut r: Vec<f64> = self.states.iter().enumerate().map(|(k, &i)| f[i] / self.scales[k]).collect();
        for c in &self.constraints {
            let (value, scale) = self.constraint_value(model, p, c)?;
            r.push((value - c.value) / scale);
        }
        if r.iter().any(|v| !v.is_finite()) {
            return Err(LinearizeError::Point("the model is undefined at a trial point".into()));
        }
        Ok(r)
    }

    /// The current value of a constraint's target and its scale.
    fn constraint_value(&self, model: &mut Model, p: &Point, c: &Constraint) -> Result<(f64, f64), LinearizeError> {
        Ok(match c.target {
            Target::State(i) => (p.y[i], self.scale_of_state(model, &p.y, i)),
            Target::Input(k) => (p.u[k], c.value.abs().max(1.0)),
            Target::Recorded(col) => (recorded(model, self.t, &p.y, &[col])?[0], c.value.abs().max(1e-9)),
        })
    }

    fn scale_of_state(&self, model: &Model, y: &[f64], i: usize) -> f64 {
        match self.states.iter().position(|&s| s == i) {
            Some(k) => self.scales[k],
            None => model.state_scales(y)[i].max(y[i].abs()),
        }
    }

    /// ∂residual/∂(scaled unknowns) at p.
    fn jacobian(&self, model: &mut Model, p: &Point) -> Result<Matrix, LinearizeError> {
        self.set_inputs(model, p)?;
        let ns = self.n_states();
        let m = p.u.len();
        let recorded_cols: Vec<usize> =
            self.constraints.iter().filter_map(|c| if let Target::Recorded(col) = c.target { Some(col) } else { None }).collect();
        let j = jacobians(model, self.t, &p.y, &self.states, &recorded_cols)?;
        let mut out = Matrix::zeros(ns + self.constraints.len(), ns + m);
        for (r, &i) in self.states.iter().enumerate() {
            for c in 0..ns {
                out[(r, c)] = j.a[(i, c)] * self.scales[c] / self.scales[r];
            }
            for k in 0..m {
                out[(r, ns + k)] = j.b[(i, k)] * self.scales[ns + k] / self.scales[r];
            }
        }
        let mut next_recorded = 0;
        for (q, c) in self.constraints.iter().enumerate() {
            let r = ns + q;
            let (_, scale) = self.constraint_value(model, p, c)?;
            match c.target {
                Target::State(i) => {
                    if let Some(col) = self.states.iter().position(|&s| s == i) {
                        out[(r, col)] = self.scales[col] / scale;
                    }
                }
                Target::Input(k) => out[(r, ns + k)] = self.scales[ns + k] / scale,
                Target::Recorded(_) => {
                    for col in 0..ns {
                        out[(r, col)] = j.c[(next_recorded, col)] * self.scales[col] / scale;
                    }
                    for k in 0..m {
                        out[(r, ns + k)] = j.d[(next_recorded, k)] * self.scales[ns + k] / scale;
                    }
                    next_recorded += 1;
                }
            }
        }
        Ok(out)
    }

    /// p with the unknowns moved by `factor`·step (step in scaled units).
    fn moved(&self, p: &Point, step: &[f64], factor: f64) -> Point {
        let ns = self.n_states();
        let mut q = p.clone();
        for (k, &i) in self.states.iter().enumerate() {
            q.y[i] = p.y[i] + factor * step[k] * self.scales[k];
        }
        for (k, u) in q.u.iter_mut().enumerate() {
            *u = p.u[k] + factor * step[ns + k] * self.scales[ns + k];
        }
        q
    }

    /// "the rate of cyl.head.m" or "constraint cyl.piston.x" for the largest residual.
    fn equation_name(&self, model: &Model, r: &[f64]) -> String {
        let k = (0..r.len()).max_by(|&a, &b| r[a].abs().total_cmp(&r[b].abs())).unwrap_or(0);
        match self.states.get(k) {
            Some(&i) => format!("the rate of {}", model.state_name(i)),
            None => format!("constraint {}", self.constraints.get(k - self.states.len()).map_or("?", |c| c.name.as_str())),
        }
    }
}

/// Names of the unknowns that make up the null space of `j` (components above 0.1 of the largest).
fn null_directions(j: &linear::lstsq::Svd, names: &[String]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for v in j.null_space(RCOND) {
        let top = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (i, x) in v.iter().enumerate() {
            if x.abs() >= 0.1 * top && !out.contains(&names[i]) {
                out.push(names[i].clone());
            }
        }
    }
    out
}

/// "piston.x = 0.6 m, F = 0 N": the constraints as stated, in SI.
fn stated(model: &Model, constraints: &[Constraint]) -> String {
    constraints
        .iter()
        .map(|c| {
            let unit = target(model, &c.name).map(|(_, u)| u).unwrap_or_default();
            format!("{} = {} {unit}", c.name, units::show::num(c.value)).trim_end().to_string()
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn plural(k: usize) -> &'static str {
    if k == 1 {
        ""
    } else {
        "s"
    }
}

fn norm_inf(r: &[f64]) -> f64 {
    r.iter().fold(0.0, |m, v| m.max(v.abs()))
}

fn norm2(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum::<f64>().sqrt()
}
