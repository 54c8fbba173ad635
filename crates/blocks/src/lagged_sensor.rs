//! The pattern every lagged sensor shares: one port that is read and passes
//! nothing (no gas through a pneumatic port, no force on a mechanical one),
//! one signal output, and a first-order instrument lag between them.
//!
//! A sensor file says only what it reads ([`Reading`]): its ports, its
//! parameters beyond `time_constant`, the quantity and the block input it
//! moves with. The lag, the states, the start at the initial value and the
//! exact partials live here once.
//!
//! # Equations
//! τ·ẏ = u − y with u the quantity read (first-order instrument, Doebelin,
//! *Measurement Systems*, §3.3); y = u when τ = 0. The reading starts at the
//! initial value of u (no start-up transient).

use crate::block::*;
use crate::params::Params;
use crate::support::Lag;

/// What one kind of lagged sensor reads.
pub trait Reading: std::fmt::Debug + Clone + PartialEq + Send + Sync + 'static {
    /// The netlist type name ("pressure_sensor", ...).
    const TYPE_NAME: &'static str;
    /// The ports: the port read first, then the signal output.
    const PORTS: &'static [PortSpec];
    /// Typical size of the reading in SI (the solver's error scale).
    const SCALE: f64;
    /// The block input the quantity moves with, with slope 1 (`In::P(0)`, ...).
    const INPUT: In;
    /// Everything but `time_constant` from the block's parameters.
    fn from_params(p: &Params) -> Result<Self, crate::BlockError>;
    /// The quantity read, before the lag [SI].
    fn value(&self, ctx: &Ctx) -> f64;
}

/// A sensor: a [`Reading`] behind a first-order [`Lag`].
#[derive(Debug, Clone, PartialEq)]
pub struct LaggedSensor<R: Reading> {
    pub lag: Lag,
    pub reading: R,
}

impl<R: Reading> LaggedSensor<R> {
    /// Built from the netlist parameters (`time_constant` and the reading's own).
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(LaggedSensor { lag: Lag { tau: p.get("time_constant") }, reading: R::from_params(p)? })
    }
}

impl<R: Reading> Block for LaggedSensor<R> {
    fn type_name(&self) -> &'static str {
        R::TYPE_NAME
    }
    fn ports(&self) -> &[PortSpec] {
        R::PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn states(&self) -> &[StateSpec] {
        self.lag.states()
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out.fill(R::SCALE);
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        self.lag.start_at(self.reading.value(ctx), states);
    }
    fn flows(&self, _ctx: &Ctx, out: &mut [PortFlow]) {
        out.fill(PortFlow::default());
    }
    fn forces(&self, _ctx: &Ctx, out: &mut [PortForce]) {
        out.fill(PortForce::default());
    }
    fn partials(&self, phase: Phase, _ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        self.lag.partials(phase, 0, &[(R::INPUT, 1.0)], d);
        true
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.lag.output(self.reading.value(ctx), ctx.states);
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        self.lag.derivative(self.reading.value(ctx), ctx.states, out);
    }
}
