//! Warnings about input that builds but is probably not what the user
//! meant, found by comparing the [`blocks::block::Fact`]s blocks state:
//! - geometry of one actuator disagreeing between blocks (the piston's stroke
//!   against the rod chamber's gas column, bores and rod diameters of the
//!   chambers and the piston, a limit switch placed beyond the stroke);
//! - a supply below the ambient pressure;
//! - a command source whose levels lie strictly between the released and
//!   actuated levels of the on/off valve it drives.
//!
//! Facts about a moving mass are grouped by mechanical node; a fact on a
//! signal input belongs to the node of the block that drives the input.

use crate::circuit::{Circuit, PortRef};
use crate::Warning;
use blocks::block::{Domain, Fact};
use std::collections::BTreeMap;

/// Relative difference below which two lengths agree.
const SAME: f64 = 1e-9;

/// Comparable geometric facts, by kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Geometry {
    Stroke,
    Bore,
    Rod,
}

/// Mechanical node a port belongs to, following a signal input to its driver.
fn mechanical_node(c: &Circuit, r: PortRef) -> Option<usize> {
    let inst = &c.instances[r.block];
    let kind = inst.block.ports()[r.port].kind;
    match kind.domain() {
        Domain::Mechanical => inst.port_nodes[r.port],
        Domain::Signal => {
            let k = inst.block.ports()[..r.port].iter().filter(|p| p.kind == blocks::block::PortKind::SignalIn).count();
            let src = if kind == blocks::block::PortKind::SignalIn { *inst.signal_sources.get(k)? } else { r };
            let driver = &c.instances[src.block];
            let mech: Vec<usize> = driver
                .block
                .ports()
                .iter()
                .zip(&driver.port_nodes)
                .filter(|(p, _)| p.kind.domain() == Domain::Mechanical)
                .filter_map(|(_, n)| *n)
                .collect();
            (mech.len() == 1).then(|| mech[0])
        }
        Domain::Pneumatic => None,
    }
}

fn mm(x: f64) -> String {
    format!("{} mm", (x * 1e3 * 1e6).round() / 1e6)
}

/// All warnings for a built circuit.
pub fn check(c: &Circuit) -> Vec<Warning> {
    let mut warnings = Vec::new();
    let warn = |warnings: &mut Vec<Warning>, message: String| warnings.push(Warning { file: String::new(), message });
    // (node, kind) → (value, "id.param") of the first block stating it
    let mut geometry: BTreeMap<(usize, Geometry), (f64, String)> = BTreeMap::new();
    let mut switches: Vec<(usize, f64, String)> = Vec::new();
    let mut supplies: Vec<(f64, String)> = Vec::new();
    let mut ambient: Option<(f64, String)> = None;
    let mut levels: BTreeMap<PortRef, Vec<f64>> = BTreeMap::new();
    let mut thresholds: Vec<(PortRef, f64, f64)> = Vec::new();
    for (bi, inst) in c.instances.iter().enumerate() {
        for (port, fact) in inst.block.facts() {
            let r = PortRef { block: bi, port };
            let who = |what: &str| format!("{}.{what}", inst.id);
            let geo = |kind: Geometry, x: f64, what: &str| mechanical_node(c, r).map(|n| ((n, kind), (x, who(what))));
            let entry = match fact {
                Fact::Stroke(x) => geo(Geometry::Stroke, x, "stroke"),
                Fact::Bore(x) => geo(Geometry::Bore, x, "bore"),
                Fact::RodDiameter(x) => geo(Geometry::Rod, x, "rod_diameter"),
                Fact::SwitchPosition(x) => {
                    if let Some(n) = mechanical_node(c, r) {
                        switches.push((n, x, who("stroke")));
                    }
                    None
                }
                Fact::SupplyPressure(p) => {
                    supplies.push((p, who("p")));
                    None
                }
                Fact::AmbientPressure(p) => {
                    if ambient.as_ref().is_none_or(|(q, _)| p > *q) {
                        ambient = Some((p, who("p")));
                    }
                    None
                }
                Fact::CommandLevels(v) => {
                    levels.insert(r, v);
                    None
                }
                Fact::CommandThresholds { released, actuated } => {
                    thresholds.push((r, released, actuated));
                    None
                }
            };
            if let Some((key, (x, name))) = entry {
                match geometry.get(&key) {
                    Some((y, first)) if (x - y).abs() > SAME * x.abs().max(y.abs()) => {
                        warn(&mut warnings, format!("{first} = {} but {name} = {}: the geometry of one actuator disagrees", mm(*y), mm(x)))
                    }
                    Some(_) => {}
                    None => {
                        geometry.insert(key, (x, name));
                    }
                }
            }
        }
    }
    for (node, x, name) in switches {
        if let Some((stroke, by)) = geometry.get(&(node, Geometry::Stroke)) {
            if x > *stroke * (1.0 + SAME) {
                warn(&mut warnings, format!("{name} trips at {} but {by} = {}: the switch is never reached", mm(x), mm(*stroke)));
            }
        }
    }
    let (p_amb, amb_name) = ambient.unwrap_or((units::STANDARD_ATMOSPHERE, "the standard atmosphere".into()));
    for (p, name) in supplies {
        if p < p_amb {
            warn(
                &mut warnings,
                format!("{name} = {:.4} bar is below {amb_name} ({:.4} bar): pressures are absolute", p / 1e5, p_amb / 1e5),
            );
        }
    }
    for (r, released, actuated) in thresholds {
        let inst = &c.instances[r.block];
        let k = inst.block.ports()[..r.port].iter().filter(|p| p.kind == blocks::block::PortKind::SignalIn).count();
        let Some(src) = inst.signal_sources.get(k) else { continue };
        let Some(values) = levels.get(src) else { continue };
        let (lo, hi) = (released.min(actuated), released.max(actuated));
        if let Some(v) = values.iter().find(|v| **v > lo && **v < hi) {
            warn(
                &mut warnings,
                format!(
                    "{} takes the value {v}, between the released ({released}) and actuated ({actuated}) levels of {}",
                    c.port_name(*src),
                    c.port_name(r)
                ),
            );
        }
    }
    warnings
}
