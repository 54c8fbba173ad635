//! The fallback of the exact Jacobian: the partial derivatives of one
//! phase of one block by central differences over the block's inputs, the
//! block evaluated alone (never the whole model). Used for a block that does
//! not give its partials ([`blocks::Block::partials`] returns false); the
//! summary of a run names such blocks. [`differentiate_record`] does the
//! same for the values a block records ([`Block::record`], which has no
//! partials of its own).
//!
//! Step: `1e-6·max(|u|, u_floor)` for an input u, with a floor per kind of
//! input (1e-3 of the state's typical size as the block states it, 1e-3 in
//! the unit of a signal, 1 kPa, 1 K, 1 mm, 1 mm/s, 1 mg/s, 0.1 W, 0.01 m/s²), so that the truncation error of the central
//! quotient is about 1e-12 relative for smooth equations. A changed
//! pressure or temperature at a port is passed as a whole gas state from
//! the gas model (density and enthalpy follow).

use blocks::block::{Balances, Block, Ctx, In, MechState, Motion, Partials, Phase, PortFlow, PortForce, Shape};
use gas::GasState;

/// Copies of one block's inputs, perturbed one at a time.
#[derive(Debug, Default)]
pub struct Inputs {
    states: Vec<f64>,
    gas: Vec<GasState>,
    mech: Vec<MechState>,
    sig: Vec<f64>,
    bal: Vec<PortFlow>,
    motion: Vec<Motion>,
    plus: Vec<f64>,
    minus: Vec<f64>,
    scales: Vec<f64>,
    derivs: Vec<f64>,
    mech_out: Vec<MechState>,
    gas_out: Vec<GasState>,
    flows_out: Vec<PortFlow>,
    forces_out: Vec<PortForce>,
    recorded: Vec<Option<f64>>,
}

/// Fill `out` (reset for this block and phase) with the central-difference
/// partials of `phase` of `block` at `ctx`/`balances`.
/// `derivs` are the block's state derivatives (read by the quadratures only).
pub fn differentiate(block: &dyn Block, phase: Phase, ctx: &Ctx, balances: &Balances, derivs: &[f64], out: &mut Partials, w: &mut Inputs) {
    let shape = out.shape();
    let rows = out.n_rows();
    columns(block, Some(phase), ctx, balances, derivs, shape, rows, w, &mut |r, col, d| {
        if d.is_finite() {
            out.row_mut(r)[col] = d;
        }
    });
}

/// The central-difference partials of `block`'s recorded values
/// ([`Block::record`]) at `ctx`/`balances`/`derivs` over the block's inputs
/// (columns of `shape`), row-major into `out` (a row per recorded value); NaN
/// where a recorded value is undefined at a perturbed input.
pub fn differentiate_record(
    block: &dyn Block,
    ctx: &Ctx,
    balances: &Balances,
    derivs: &[f64],
    shape: Shape,
    out: &mut Vec<f64>,
    w: &mut Inputs,
) {
    let rows = block.outputs().len();
    let cols = shape.n_inputs();
    out.clear();
    out.resize(rows * cols, 0.0);
    columns(block, None, ctx, balances, derivs, shape, rows, w, &mut |r, col, d| out[r * cols + col] = d);
}

/// Central differences of the outputs of `phase` (`None`: the recorded
/// values) over every input column of `shape`, each passed to `set(row, column, value)`.
#[allow(clippy::too_many_arguments)]
fn columns(
    block: &dyn Block,
    phase: Option<Phase>,
    ctx: &Ctx,
    balances: &Balances,
    derivs: &[f64],
    shape: Shape,
    rows: usize,
    w: &mut Inputs,
    set: &mut dyn FnMut(usize, usize, f64),
) {
    w.states.clear();
    w.states.extend_from_slice(ctx.states);
    w.gas.clear();
    w.gas.extend_from_slice(ctx.pneumatic);
    w.mech.clear();
    w.mech.extend_from_slice(ctx.mechanical);
    w.sig.clear();
    w.sig.extend_from_slice(ctx.signals);
    w.bal.clear();
    w.bal.extend_from_slice(balances.pneumatic);
    w.motion.clear();
    w.motion.extend_from_slice(balances.mechanical);
    w.derivs.clear();
    w.derivs.extend_from_slice(derivs);
    // the block's own typical sizes of its states
    w.scales.clear();
    w.scales.resize(w.states.len(), 1.0);
    block.state_scales(ctx.states, &mut w.scales);
    for col in 0..shape.n_inputs() {
        let input = shape.input_at(col);
        let base = read(w, input);
        let typical = match input {
            In::State(i) | In::Rate(i) => 1e-3 * w.scales[i].abs(),
            _ => floor(input),
        };
        let h = 1e-6 * base.abs().max(typical).max(f64::MIN_POSITIVE);
        if !phase.is_none_or(|phase| reads(phase, input)) {
            continue;
        }
        let mut plus = std::mem::take(&mut w.plus);
        let mut minus = std::mem::take(&mut w.minus);
        write(w, input, base + h, ctx);
        evaluate(block, phase, ctx.t, ctx.gas, w, rows, &mut plus);
        write(w, input, base - h, ctx);
        evaluate(block, phase, ctx.t, ctx.gas, w, rows, &mut minus);
        write(w, input, base, ctx);
        for r in 0..rows {
            set(r, col, (plus[r] - minus[r]) / (2.0 * h));
        }
        w.plus = plus;
        w.minus = minus;
    }
}

/// Whether a phase can read an input at all (balances only in the last two).
fn reads(phase: Phase, input: In) -> bool {
    match input {
        In::Mdot(_) | In::Edot(_) | In::Accel(_) => matches!(phase, Phase::Derivatives | Phase::Exchange | Phase::Quadratures),
        In::Rate(_) => phase == Phase::Quadratures,
        In::State(_) => true,
        _ => phase != Phase::Kinematics,
    }
}

fn floor(input: In) -> f64 {
    match input {
        In::State(_) | In::Signal(_) => 1e-3,
        In::P(_) => 1e3,
        In::T(_) => 1.0,
        In::X(_) | In::V(_) => 1e-3,
        In::Mdot(_) => 1e-6,
        In::Rate(_) => 1e-3,
        In::Edot(_) => 0.1,
        In::Accel(_) => 1e-2,
    }
}

fn read(w: &Inputs, input: In) -> f64 {
    match input {
        In::State(i) => w.states[i],
        In::P(k) => w.gas[k].p,
        In::T(k) => w.gas[k].t,
        In::X(k) => w.mech[k].x,
        In::V(k) => w.mech[k].v,
        In::Signal(k) => w.sig[k],
        In::Mdot(k) => w.bal[k].mdot,
        In::Edot(k) => w.bal[k].edot,
        In::Accel(k) => w.motion[k].accel,
        In::Rate(i) => w.derivs[i],
    }
}

fn write(w: &mut Inputs, input: In, v: f64, ctx: &Ctx) {
    match input {
        In::State(i) => w.states[i] = v,
        In::P(k) => w.gas[k] = if v == ctx.pneumatic[k].p { ctx.pneumatic[k] } else { ctx.gas.state_pt(v, w.gas[k].t) },
        In::T(k) => w.gas[k] = if v == ctx.pneumatic[k].t { ctx.pneumatic[k] } else { ctx.gas.state_pt(w.gas[k].p, v) },
        In::X(k) => w.mech[k].x = v,
        In::V(k) => w.mech[k].v = v,
        In::Signal(k) => w.sig[k] = v,
        In::Mdot(k) => w.bal[k].mdot = v,
        In::Edot(k) => w.bal[k].edot = v,
        In::Accel(k) => w.motion[k].accel = v,
        In::Rate(i) => w.derivs[i] = v,
    }
}

/// The outputs of `phase` (`None`: the recorded values, NaN where
/// undefined) at the inputs in `w`, in the rows of [`Partials`].
fn evaluate(block: &dyn Block, phase: Option<Phase>, t: f64, gas: &dyn gas::GasModel, w: &mut Inputs, rows: usize, out: &mut Vec<f64>) {
    out.clear();
    out.resize(rows, 0.0);
    let ctx = Ctx { t, gas, states: &w.states, pneumatic: &w.gas, mechanical: &w.mech, signals: &w.sig };
    let balances = Balances { pneumatic: &w.bal, mechanical: &w.motion };
    let Some(phase) = phase else {
        let mut recorded = std::mem::take(&mut w.recorded);
        recorded.clear();
        recorded.resize(rows, None);
        block.record(&ctx, &balances, &w.derivs, &mut recorded);
        for (o, v) in out.iter_mut().zip(&recorded) {
            *o = v.unwrap_or(f64::NAN);
        }
        w.recorded = recorded;
        return;
    };
    match phase {
        Phase::Kinematics => {
            w.mech_out.clear();
            w.mech_out.resize(w.mech.len(), MechState::default());
            block.kinematics(&w.states, &mut w.mech_out);
            for (k, m) in w.mech_out.iter().enumerate() {
                out[2 * k] = m.x;
                out[2 * k + 1] = m.v;
            }
        }
        Phase::Effort => {
            w.gas_out.clear();
            w.gas_out.extend_from_slice(&w.gas);
            block.effort(&ctx, &mut w.gas_out);
            for (k, s) in w.gas_out.iter().enumerate() {
                out[2 * k] = s.p;
                out[2 * k + 1] = s.t;
            }
        }
        Phase::Signals => block.signal_outputs(&ctx, out),
        Phase::Flows => {
            w.flows_out.clear();
            w.flows_out.resize(w.gas.len(), PortFlow::default());
            block.flows(&ctx, &mut w.flows_out);
            for (k, f) in w.flows_out.iter().enumerate() {
                out[2 * k] = f.mdot;
                out[2 * k + 1] = f.edot;
            }
        }
        Phase::Forces => {
            w.forces_out.clear();
            w.forces_out.resize(w.mech.len(), PortForce::default());
            block.forces(&ctx, &mut w.forces_out);
            for (k, f) in w.forces_out.iter().enumerate() {
                let dry = f.friction.unwrap_or_default();
                out[4 * k..4 * k + 4].copy_from_slice(&[f.applied, dry.sliding, dry.breakaway, dry.viscous]);
            }
        }
        Phase::Derivatives => block.derivatives(&ctx, &balances, out),
        Phase::Exchange => {
            let e = block.exchange(&ctx, &balances);
            out[0] = e.heat;
            out[1] = e.work;
        }
        Phase::Quadratures => block.quadrature_rates(&ctx, &balances, &w.derivs, out),
    }
}
