//! The seam between linearisation and differentiation: ∂f/∂x, ∂f/∂u,
//! ∂y/∂x and ∂y/∂u of the model at one state, with every discrete state
//! (mechanical modes, valve positions, controller steps) held.
//!
//! x are the block states (quadratures excluded), u the netlist's interface
//! inputs, set through [`Model::set_input`] (a live parameter: a supply
//! pressure, an external force, or the value of a signal source), y the
//! recorded values the caller names (result columns).
//!
//! ∂f/∂x is exact where the model has a structure ([`Structure::new`]): the
//! chain rule over the blocks' partial derivatives with implicit
//! differentiation through the junction solves ([`crate::exact`]); a block
//! without partials for a phase is differentiated alone by central
//! differences of that phase, and [`Jacobians::finite_difference_blocks`]
//! names it. ∂f/∂u, ∂y/∂x and ∂y/∂u (and ∂f/∂x of a model without a
//! structure) are central differences, h_j = ε^{1/3}·max(|x_j|, s_j) with
//! s_j the state's typical size, each evaluation detached from the run (the
//! junction solver's warm starts restored, so every difference starts the
//! algebraic solve from the same guess); with the exact ∂f/∂x, ∂f/∂x's own
//! differences are not taken. Truncation and rounding are each
//! about 1e-10 relative; through a junction solve (solved to 1e-13
//! relative) the entries it touches carry up to ~1e-8. [`Method`] names
//! what produced a result; [`central_differences`] is the all-differences
//! path, kept as the fallback and as the check of the exact one.

use super::LinearizeError;
use crate::exact::Exact;
use crate::jacobian::Structure;
use crate::model::{Model, ModelError, WarmStart};
use linear::Matrix;

/// How the derivatives were formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Central differences of the whole model (see the module documentation).
    CentralDifferences,
    /// ∂f/∂x exact (chain rule over the blocks' partials), ∂f/∂u, ∂y/∂x and
    /// ∂y/∂u by central differences.
    ExactStates,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::CentralDifferences => "central differences",
            Method::ExactStates => "exact state Jacobian (block partials); central differences for inputs and outputs",
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
    /// Blocks the exact ∂f/∂x differentiated alone by central differences
    /// (no partials for some phase); empty with [`Method::CentralDifferences`].
    pub finite_difference_blocks: Vec<String>,
}

/// Relative step of the central differences (ε^{1/3}).
const STEP: f64 = 6e-6;

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

/// Derivatives at (t, y) and the model's current input values, for the
/// state `columns` and recorded `outputs`: ∂f/∂x exact where the model has
/// a structure, the rest by central differences (see the module
/// documentation). The inputs and the junction warm starts are restored.
pub fn jacobians(model: &mut Model, t: f64, y: &[f64], columns: &[usize], outputs: &[usize]) -> Result<Jacobians, LinearizeError> {
    let Some(structure) = Structure::new(model) else { return central_differences(model, t, y, columns, outputs) };
    // B, C, D by differences; A's differences are not taken, the exact A replaces them
    let mut j = differences(model, t, y, columns, outputs, false)?;
    let mut exact = Exact::new(model, structure.pattern().clone());
    let mut values = vec![0.0; exact.pattern().nnz()];
    let mut warm = WarmStart::default();
    model.save_warm_start_into(&mut warm);
    // the last evaluation may be at other input values (set_input keeps it)
    model.forget_last_evaluation();
    let filled = exact.fill(model, t, y, &mut values);
    model.restore_warm_start_from(&warm);
    model.forget_last_evaluation();
    filled?;
    let pattern = exact.pattern();
    for (col, &c) in columns.iter().enumerate() {
        for i in 0..model.n_states {
            j.a[(i, col)] = 0.0;
        }
        for (p, &i) in pattern.column(c).iter().enumerate() {
            if i < model.n_states {
                j.a[(i, col)] = values[pattern.column_range(c).start + p];
            }
        }
    }
    j.method = Method::ExactStates;
    j.finite_difference_blocks = exact.fallback_blocks(model);
    Ok(j)
}

/// Every derivative by central differences (the fallback of [`jacobians`]).
pub fn central_differences(
    model: &mut Model,
    t: f64,
    y: &[f64],
    columns: &[usize],
    outputs: &[usize],
) -> Result<Jacobians, LinearizeError> {
    differences(model, t, y, columns, outputs, true)
}

/// Central differences of B, C, D, and of A when `with_a` (else A is zero,
/// and a state column costs only the evaluations of the recorded outputs,
/// none when there are no outputs).
fn differences(
    model: &mut Model,
    t: f64,
    y: &[f64],
    columns: &[usize],
    outputs: &[usize],
    with_a: bool,
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
    for k in 0..m {
        let u = model.input_value(k);
        let h = STEP * u.abs().max(1.0);
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
    Ok(Jacobians { a, b, c, d, method: Method::CentralDifferences, finite_difference_blocks: Vec::new() })
}
