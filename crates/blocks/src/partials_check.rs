//! Test support: a block's exact partials ([`Block::partials`]) against
//! central differences of the phase they differentiate, for blocks whose
//! outputs are flows, state derivatives, signals or the wall exchange (restrictions, valves
//! with states, signal blocks). Used by the blocks' unit tests on branches
//! the shipped circuits do not visit (choked and subsonic flow, closed,
//! opening and open valves).

use crate::block::*;
use gas::{GasModel, GasState};

/// The point a block is differentiated at.
pub struct Point<'a> {
    pub gas: &'a gas::IdealGas,
    pub states: Vec<f64>,
    /// (p, T) at each pneumatic port.
    pub ports: Vec<(f64, f64)>,
    pub signals: Vec<f64>,
    /// Typical size of each state (steps are 1e-4 of it); 1 where not given.
    pub state_sizes: Vec<f64>,
    /// Steps relative to each input's size (1e-4 unless set).
    pub relative_step: f64,
}

impl Point<'_> {
    /// The same point with typical sizes of the states (a tube segment's
    /// mass is a few milligrams: a step of 1e-4 kg would empty it).
    pub fn with_state_sizes(mut self, sizes: &[f64]) -> Self {
        self.state_sizes = sizes.to_vec();
        self
    }
    /// The same point with steps of `relative` times each input's size (for
    /// pressure differences of a few pascals, where 1e-4 of 3 bar would
    /// reverse the flow).
    pub fn with_relative_step(mut self, relative: f64) -> Self {
        self.relative_step = relative;
        self
    }
    fn outputs(&self, block: &dyn Block, phase: Phase, states: &[f64], ports: &[(f64, f64)], signals: &[f64]) -> Vec<f64> {
        let gas_states: Vec<GasState> = ports.iter().map(|&(p, t)| self.gas.state_pt(p, t)).collect();
        let ctx = Ctx { t: 0.0, gas: self.gas, states, pneumatic: &gas_states, mechanical: &[], signals };
        let bal = Balances { pneumatic: &[], mechanical: &[] };
        match phase {
            Phase::Flows => {
                let mut f = vec![PortFlow::default(); ports.len()];
                block.flows(&ctx, &mut f);
                f.iter().flat_map(|x| [x.mdot, x.edot]).collect()
            }
            Phase::Derivatives => {
                let mut d = vec![0.0; states.len()];
                block.derivatives(&ctx, &bal, &mut d);
                d
            }
            Phase::Signals => {
                let n = block.ports().iter().filter(|p| p.kind == PortKind::SignalOut).count();
                let mut s = vec![0.0; n];
                block.signal_outputs(&ctx, &mut s);
                s
            }
            Phase::Exchange => {
                let e = block.exchange(&ctx, &bal);
                vec![e.heat, e.work]
            }
            _ => panic!("{phase:?} is not checked here"),
        }
    }

    /// Asserts that the block gives its partials of `phase` at this point and
    /// that every entry equals the central difference (steps δ and δ/4
    /// agreeing, i.e. no kink within δ) to 1e-6 of its column's size.
    pub fn check(&self, block: &dyn Block, phase: Phase) {
        let shape = Shape::of(block);
        let gas_states: Vec<GasState> = self.ports.iter().map(|&(p, t)| self.gas.state_pt(p, t)).collect();
        let ctx = Ctx { t: 0.0, gas: self.gas, states: &self.states, pneumatic: &gas_states, mechanical: &[], signals: &self.signals };
        let bal = Balances { pneumatic: &[], mechanical: &[] };
        let mut d = Partials::default();
        d.reset(shape, phase);
        assert!(block.partials(phase, &ctx, &bal, &mut d), "{}: no partials of {phase:?}", block.type_name());
        let mut inputs: Vec<(In, f64)> = (0..self.states.len())
            .map(|i| (In::State(i), self.states[i].abs().max(self.state_sizes.get(i).copied().unwrap_or(1.0))))
            .collect();
        for (k, &(p, t)) in self.ports.iter().enumerate() {
            inputs.push((In::P(k), p));
            inputs.push((In::T(k), t));
        }
        inputs.extend((0..self.signals.len()).map(|k| (In::Signal(k), self.signals[k].abs().max(1.0))));
        for (input, size) in inputs {
            let col = shape.input(input).expect("an input of the block");
            let diff = |h: f64| {
                let at = |s: f64| {
                    let (mut x, mut ports, mut sig) = (self.states.clone(), self.ports.clone(), self.signals.clone());
                    match input {
                        In::State(i) => x[i] += s,
                        In::P(k) => ports[k].0 += s,
                        In::T(k) => ports[k].1 += s,
                        In::Signal(k) => sig[k] += s,
                        _ => unreachable!(),
                    }
                    self.outputs(block, phase, &x, &ports, &sig)
                };
                let (p, m) = (at(h), at(-h));
                p.iter().zip(&m).map(|(a, b)| (a - b) / (2.0 * h)).collect::<Vec<f64>>()
            };
            let h = self.relative_step * size;
            let (a, b) = (diff(h), diff(h / 4.0));
            let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            assert!(
                a.iter().zip(&b).all(|(x, z)| (x - z).abs() <= 1e-6 * scale),
                "{}: a kink within the step of {input:?} ({phase:?}): choose another point ({a:?} vs {b:?})",
                block.type_name()
            );
            for (r, &want) in b.iter().enumerate() {
                let got = d.row(r)[col];
                assert!(
                    (got - want).abs() <= 1e-6 * scale + 1e-300,
                    "{} {phase:?}: ∂out{r}/∂{input:?}: exact {got:e}, central {want:e} (column size {scale:e})",
                    block.type_name()
                );
            }
        }
    }
}

/// A block of registry type `ty` from parameter texts ("4 bar", "yes").
pub fn build(ty: &crate::registry::BlockType, raw: &[(&str, &str)]) -> Box<dyn Block> {
    use crate::params::{Params, RawValue};
    let raw: Vec<(&str, RawValue)> = raw.iter().map(|(k, v)| (*k, RawValue::Text(v.to_string()))).collect();
    let params = Params::from_raw(ty.params, raw.iter().map(|(k, v)| (*k, v))).unwrap_or_else(|e| panic!("{}: {e}", ty.name));
    (ty.build)(&params).unwrap_or_else(|e| panic!("{}: {e}", ty.name))
}

/// A point with the given states, port (p, T) and signals in air.
pub fn point(states: &[f64], ports: &[(f64, f64)], signals: &[f64]) -> Point<'static> {
    static AIR: std::sync::OnceLock<gas::IdealGas> = std::sync::OnceLock::new();
    Point {
        gas: AIR.get_or_init(gas::IdealGas::air),
        states: states.to_vec(),
        ports: ports.to_vec(),
        signals: signals.to_vec(),
        state_sizes: Vec::new(),
        relative_step: 1e-4,
    }
}
