//! The seam between linearisation and differentiation: ∂f/∂x, ∂f/∂u,
//! ∂y/∂x and ∂y/∂u of the model at one state, with every discrete state
//! (mechanical modes, valve positions, controller steps) held.
//!
//! x are the block states (quadratures excluded), u the netlist's interface
//! inputs, set through [`Model::set_input`] (a live parameter: a supply
//! pressure, an external force, or the value of a signal source), y the
//! recorded values the caller names (result columns).
//!
//! Where the model has a structure ([`Structure::new`]) all four are exact:
//! the chain rule over the blocks' partial derivatives with implicit
//! differentiation through the junction solves ([`crate::exact`]). An input
//! is an extra column of that chain, seeded by the partials of the block
//! whose live parameter it sets ([`blocks::Block::live_partials`]: the
//! external input behind a port input, a supply's p and T, a piston's
//! external force, a mass-flow source's flow); an output that is a signal (a
//! piston's x and v, a chamber's p, a sensor's reading) reads that signal's
//! gradient. A block without partials for a phase is differentiated alone by
//! central differences of that phase, and [`Jacobians::finite_difference_blocks`]
//! names it.
//!
//! An output that is a value a block records ([`blocks::Block::record`]: a
//! valve's spool position, a chamber's density, a restriction's flow) has
//! no partials of its own: its block's record is differentiated alone by
//! central differences over the block's inputs
//! ([`crate::block_differences`], as for a phase without partials) and
//! chained exactly; [`Jacobians::record_difference_outputs`] names them.
//!
//! Fallback, named in [`Jacobians::difference_inputs`] and
//! [`Jacobians::difference_outputs`]: an input whose block gives no live
//! partials (none of the library's live parameters today), and a recorded output of a
//! block whose own live parameter is an input (its record may read the
//! parameter directly) or that is undefined near the point, take their
//! columns and rows of B, C, D from central differences of the whole model,
//! as does every matrix of a model without a structure: h_j = ε^{1/3}·max(|x_j|, s_j) with
//! s_j the state's typical size (for an input, max(|u|, one of its outer
//! unit), [`input_size`]), each evaluation detached from the run (the
//! junction solver's warm starts restored, so every difference starts the
//! algebraic solve from the same guess). Truncation and rounding are each
//! about 1e-10 relative; through a junction solve (solved to 1e-13
//! relative) the entries it touches carry up to ~1e-8. [`Method`] names
//! what produced a result; [`central_differences`] is the all-differences
//! path, kept as the fallback and as the check of the exact one.

use super::LinearizeError;
use crate::exact::{Exact, Quantity};
use crate::jacobian::Structure;
use crate::model::{Model, ModelError, WarmStart};
use linear::Matrix;

/// How the derivatives were formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Central differences of the whole model (see the module documentation).
    CentralDifferences,
    /// The chain rule over the blocks' partials, inputs seeded through their
    /// live parameters; the inputs and outputs named in
    /// [`Jacobians::difference_inputs`] / [`Jacobians::difference_outputs`]
    /// by central differences.
    Exact,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::CentralDifferences => "central differences",
            Method::Exact => "exact chain rule (block partials, inputs through their live parameters)",
        }
    }
}

/// ∂f/∂x (all block states × `columns`), ∂f/∂u (states × inputs),
/// ∂y/∂x (outputs × `columns`), ∂y/∂u (outputs × inputs).
#[derive(Debug, Clone)]
pub struct Jacobians {
    pub a: Matrix,
    pub b: Matrix,
    pub c: Matrix,
    pub d: Matrix,
    pub method: Method,
    /// Blocks the exact chain differentiated alone by central differences
    /// (no partials for some phase); empty with [`Method::CentralDifferences`].
    pub finite_difference_blocks: Vec<String>,
    /// Inputs (indices) whose columns of B and D are central differences
    /// (every input with [`Method::CentralDifferences`]).
    pub difference_inputs: Vec<usize>,
    /// Outputs (indices into the `outputs` asked for) whose rows of C and D
    /// are central differences of the whole model (every output with
    /// [`Method::CentralDifferences`]).
    pub difference_outputs: Vec<usize>,
    /// Outputs recorded by a block without partials for them: the block's
    /// record differentiated alone by central differences, chained exactly.
    pub record_difference_outputs: Vec<usize>,
}

/// Relative step of the central differences (ε^{1/3}).
const STEP: f64 = 6e-6;

/// The typical size of input k [SI]: one of the unit it is given in (1 g/s,
/// 1 bar, 1 mm), so that a mass flow of grams per second is not stepped by
/// kilograms per second.
pub fn input_size(model: &Model, k: usize) -> f64 {
    let factor = model.circuit.interface.inputs[k].unit.factor.abs();
    if factor.is_finite() && factor > 0.0 {
        factor
    } else {
        1.0
    }
}

/// The state derivatives ẋ = f(x, u) at (t, y) [block states only].
pub fn rates(model: &mut Model, t: f64, y: &[f64]) -> Result<Vec<f64>, ModelError> {
    let mut dy = vec![0.0; model.dim()];
    model.eval_detached(t, y, Some(&mut dy), None)?;
    dy.truncate(model.n_states);
    Ok(dy)
}

/// The recorded values in `columns` (indices into [`Model::output_names`]) at (t, y); NaN where undefined.
pub fn recorded(model: &mut Model, t: f64, y: &[f64], columns: &[usize]) -> Result<Vec<f64>, ModelError> {
    let mut row = vec![None; model.n_outputs];
    model.record(t, y, &mut row)?;
    Ok(columns.iter().map(|&c| row[c].unwrap_or(f64::NAN)).collect())
}

/// The block that records a recorded column, the column's index among its
/// recorded values, and the number of them that are its signal outputs (they
/// come first); None for a column no block records.
fn recorder(model: &Model, column: usize) -> Option<(usize, usize, usize)> {
    let b = model.slots.iter().position(|s| s.outputs.contains(&column))?;
    let slot = &model.slots[b];
    Some((b, column - slot.outputs.start, slot.sig_out.len()))
}

/// Derivatives at (t, y) and the model's current input values, for the
/// state `columns` and recorded `outputs`: exact where the model has a
/// structure, the rest by central differences (see the module
/// documentation). The inputs and the junction warm starts are restored.
pub fn jacobians(model: &mut Model, t: f64, y: &[f64], columns: &[usize], outputs: &[usize]) -> Result<Jacobians, LinearizeError> {
    let Some(structure) = Structure::new(model) else { return central_differences(model, t, y, columns, outputs) };
    let (n, m, p) = (model.n_states, model.n_inputs(), outputs.len());
    // input k → its parameter column (None: it acts on nothing here)
    let mut parameters = Vec::new();
    let parameter_of: Vec<Option<usize>> = model
        .circuit
        .interface
        .inputs
        .iter()
        .map(|i| {
            i.live.as_ref().map(|live| {
                parameters.push((live.block, live.param));
                parameters.len() - 1
            })
        })
        .collect();
    let mut exact = Exact::new(model, structure.pattern().clone());
    exact.set_parameters(model, &parameters);
    let mut warm = WarmStart::default();
    model.save_warm_start_into(&mut warm);
    // the last evaluation may be at other input values (set_input keeps it)
    model.forget_last_evaluation();
    let evaluated = exact.evaluate(model, t, y);
    model.restore_warm_start_from(&warm);
    model.forget_last_evaluation();
    evaluated?;
    // input k → its parameter column when the block gave its live partials
    let exact_column: Vec<Option<usize>> = parameter_of.iter().map(|c| c.filter(|&c| exact.parameter_given(c))).collect();
    let (mut a, mut b) = (Matrix::zeros(n, columns.len()), Matrix::zeros(n, m));
    let (mut c, mut d) = (Matrix::zeros(p, columns.len()), Matrix::zeros(p, m));
    let fill = |g: &[f64], i: usize, x: &mut Matrix, u: &mut Matrix| {
        for (col, &j) in columns.iter().enumerate() {
            x[(i, col)] = g[j];
        }
        for (k, column) in exact_column.iter().enumerate() {
            if let Some(col) = column {
                u[(i, k)] = g[n + col];
            }
        }
    };
    for i in 0..n {
        fill(&exact.gradient(model, Quantity::Rate(i)), i, &mut a, &mut b);
    }
    let (mut difference_outputs, mut record_difference_outputs) = (Vec::new(), Vec::new());
    for (i, &column) in outputs.iter().enumerate() {
        // a column no block records (none today) takes the whole-model fallback
        let Some((block, k, n_signals)) = recorder(model, column) else {
            difference_outputs.push(i);
            continue;
        };
        if k < n_signals {
            fill(&exact.gradient(model, Quantity::Signal(model.slots[block].sig_out.start + k)), i, &mut c, &mut d);
            continue;
        }
        // a value its block records: that block's record by differences, chained exactly —
        // unless the block's own live parameter is an input (record may read it directly)
        if !parameters.iter().any(|&(b, _)| b == block) {
            let g = exact.recorded_gradient(model, t, y, block, k - n_signals);
            if g.iter().all(|v| v.is_finite()) {
                fill(&g, i, &mut c, &mut d);
                record_difference_outputs.push(i);
                continue;
            }
        }
        difference_outputs.push(i);
    }
    let difference_inputs: Vec<usize> = (0..m).filter(|&k| parameter_of[k].is_some() && exact_column[k].is_none()).collect();
    if !difference_inputs.is_empty() || !difference_outputs.is_empty() {
        // the D rows of differenced outputs need every input; the D columns of differenced inputs every output
        let inputs: Vec<usize> = if difference_outputs.is_empty() { difference_inputs.clone() } else { (0..m).collect() };
        let state_columns = if difference_outputs.is_empty() { &[][..] } else { columns };
        let fd = differences(model, t, y, state_columns, outputs, false, &inputs)?;
        for &k in &difference_inputs {
            for i in 0..n {
                b[(i, k)] = fd.b[(i, k)];
            }
            for i in 0..p {
                d[(i, k)] = fd.d[(i, k)];
            }
        }
        for &i in &difference_outputs {
            for col in 0..columns.len() {
                c[(i, col)] = fd.c[(i, col)];
            }
            for k in 0..m {
                d[(i, k)] = fd.d[(i, k)];
            }
        }
    }
    Ok(Jacobians {
        a,
        b,
        c,
        d,
        method: Method::Exact,
        finite_difference_blocks: exact.fallback_blocks(model),
        difference_inputs,
        difference_outputs,
        record_difference_outputs,
    })
}

/// Every derivative by central differences (the fallback of [`jacobians`]).
pub fn central_differences(
    model: &mut Model,
    t: f64,
    y: &[f64],
    columns: &[usize],
    outputs: &[usize],
) -> Result<Jacobians, LinearizeError> {
    let all: Vec<usize> = (0..model.n_inputs()).collect();
    differences(model, t, y, columns, outputs, true, &all)
}

/// Central differences of C, of the columns `inputs` of B and D (the others
/// zero), and of A when `with_a` (else A is zero, and a state column costs
/// only the evaluations of the recorded outputs, none when there are no
/// outputs).
fn differences(
    model: &mut Model,
    t: f64,
    y: &[f64],
    columns: &[usize],
    outputs: &[usize],
    with_a: bool,
    inputs: &[usize],
) -> Result<Jacobians, LinearizeError> {
    let n = model.n_states;
    let m = model.n_inputs();
    let p = outputs.len();
    let scales = model.state_scales(y);
    let mut a = Matrix::zeros(n, columns.len());
    let mut c = Matrix::zeros(p, columns.len());
    let mut yp = y.to_vec();
    let state_columns = if with_a || p > 0 { columns } else { &[] };
    for (col, &j) in state_columns.iter().enumerate() {
        let h = STEP * y[j].abs().max(scales[j]);
        let mut at = |value: f64, model: &mut Model| -> Result<(Vec<f64>, Vec<f64>), LinearizeError> {
            yp[j] = value;
            let f = if with_a { rates(model, t, &yp)? } else { Vec::new() };
            let g = recorded(model, t, &yp, outputs)?;
            yp[j] = y[j];
            Ok((f, g))
        };
        let (f_plus, g_plus) = at(y[j] + h, model)?;
        let (f_minus, g_minus) = at(y[j] - h, model)?;
        for i in 0..f_plus.len() {
            a[(i, col)] = (f_plus[i] - f_minus[i]) / (2.0 * h);
        }
        for i in 0..p {
            c[(i, col)] = (g_plus[i] - g_minus[i]) / (2.0 * h);
        }
    }
    let mut b = Matrix::zeros(n, m);
    let mut d = Matrix::zeros(p, m);
    for &k in inputs {
        let u = model.input_value(k);
        let h = STEP * u.abs().max(input_size(model, k));
        let at = |value: f64, model: &mut Model| -> Result<(Vec<f64>, Vec<f64>), LinearizeError> {
            model.set_input(k, value)?;
            Ok((rates(model, t, y)?, recorded(model, t, y, outputs)?))
        };
        let both = at(u + h, model).and_then(|plus| Ok((plus, at(u - h, model)?)));
        model.set_input(k, u)?;
        let ((f_plus, g_plus), (f_minus, g_minus)) = both?;
        for i in 0..n {
            b[(i, k)] = (f_plus[i] - f_minus[i]) / (2.0 * h);
        }
        for i in 0..p {
            d[(i, k)] = (g_plus[i] - g_minus[i]) / (2.0 * h);
        }
    }
    Ok(Jacobians {
        a,
        b,
        c,
        d,
        method: Method::CentralDifferences,
        finite_difference_blocks: Vec::new(),
        difference_inputs: (0..m).collect(),
        difference_outputs: (0..p).collect(),
        record_difference_outputs: Vec::new(),
    })
}
