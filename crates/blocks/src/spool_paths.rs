//! The pattern every spool valve shares: a set of flow paths between its
//! ports, each an ISO 6358 restriction (paper Eq. 33–35) scaled by the
//! opening the spool gives it, optionally with a leak across the land while
//! the path is closed, (1 − o)·ṁ(C_leak).
//!
//! A valve file says only how its spool moves and which opening each path
//! has at a spool position ([`Opening`]); the flows into the ports, a port's
//! flow with its pressure slope (for the junction solves) and the exact
//! partials are summed here once. Energy flows carry the upstream enthalpy
//! ([`crate::conductance::restriction_flow`]).

use crate::block::*;
use crate::conductance::{add_path, restriction_flow, restriction_flow_slopes, restriction_partials};
use crate::iso6358::FlowCharacteristic;

/// One path at the current spool position.
#[derive(Debug, Clone, Copy)]
pub struct Opening<'a> {
    /// Pneumatic port the positive flow leaves from, and the one it enters.
    pub from: usize,
    pub to: usize,
    /// The restriction when fully open.
    pub flow: &'a FlowCharacteristic,
    /// Leakage across the land while the path is (partly) closed, if any.
    pub leak: Option<&'a FlowCharacteristic>,
    /// Opening o ∈ [0, 1].
    pub opening: f64,
    /// ∂o/∂(the block's state 0) — the spool position — or 0 where the
    /// opening does not move with a state (a switched spool, a clamp).
    pub slope: f64,
}

impl Opening<'_> {
    fn flow_between(&self, a: &gas::GasState, b: &gas::GasState) -> PortFlow {
        let mut f = restriction_flow(self.flow, self.opening, a, b, 0.0);
        if let Some(leak) = self.leak {
            f += restriction_flow(leak, 1.0 - self.opening, a, b, 0.0);
        }
        f
    }
}

/// The flows into every pneumatic port (`out` is cleared first).
pub fn flows<'a>(paths: impl IntoIterator<Item = Opening<'a>>, ctx: &Ctx, out: &mut [PortFlow]) {
    out.fill(PortFlow::default());
    for path in paths {
        let f = path.flow_between(&ctx.pneumatic[path.from], &ctx.pneumatic[path.to]);
        out[path.from] += f;
        out[path.to] += -f;
    }
}

/// The flow into `port` and its derivative by that port's pressure, every
/// other input held.
pub fn port_flow<'a>(paths: impl IntoIterator<Item = Opening<'a>>, ctx: &Ctx, port: usize) -> (PortFlow, f64) {
    let (mut sum, mut slope) = (PortFlow::default(), 0.0);
    for path in paths.into_iter().filter(|p| p.from == port || p.to == port) {
        let (a, b) = (&ctx.pneumatic[path.from], &ctx.pneumatic[path.to]);
        let (mut f, mut da, mut db) = restriction_flow_slopes(path.flow, path.opening, a, b, 0.0);
        if let Some(leak) = path.leak {
            let (fl, dla, dlb) = restriction_flow_slopes(leak, 1.0 - path.opening, a, b, 0.0);
            f += fl;
            da += dla;
            db += dlb;
        }
        if path.from == port {
            sum += f;
            slope += da;
        } else {
            sum += -f;
            slope -= db;
        }
    }
    (sum, slope)
}

/// Exact partials of the flows (phase `Flows`): by the port pressures and
/// temperatures, and by state 0 through each opening's slope.
pub fn flow_partials<'a>(paths: impl IntoIterator<Item = Opening<'a>>, ctx: &Ctx, d: &mut Partials) {
    for path in paths {
        if path.opening <= 0.0 && path.slope == 0.0 && path.leak.is_none() {
            continue; // shut, and staying shut: nothing moves
        }
        let (a, b) = (&ctx.pneumatic[path.from], &ctx.pneumatic[path.to]);
        let r = restriction_partials(path.flow, path.opening, a, b, 0.0, ctx.gas);
        let moves: &[(In, f64)] = if path.slope != 0.0 { &[(In::State(0), path.slope)] } else { &[] };
        add_path(d, path.from, path.to, &r, moves);
        if let Some(leak) = path.leak {
            let r = restriction_partials(leak, 1.0 - path.opening, a, b, 0.0, ctx.gas);
            let moves: &[(In, f64)] = if path.slope != 0.0 { &[(In::State(0), -path.slope)] } else { &[] };
            add_path(d, path.from, path.to, &r, moves);
        }
    }
}
