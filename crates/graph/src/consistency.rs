//! Warnings about input that builds but is probably not what the user
//! meant, found by comparing the [`blocks::block::Fact`]s blocks state:
//! - geometry of one actuator disagreeing between blocks (the piston's stroke
//!   against the rod chamber's gas column and a cushion's stroke, bores and
//!   rod diameters of the chambers and the piston, a limit switch placed
//!   beyond the stroke);
//! - the chambers on one piston: a rod-side (retracting) chamber with no gas
//!   column, and chambers that all push the piston the same way (a rod-side
//!   chamber left at `orientation: extend`); these are [`errors`] when the
//!   circuit could not run (the chamber's volume reaches zero within the
//!   stroke; the chamber at fault is plain);
//! - a supply below the ambient pressure;
//! - a command source whose levels lie strictly between the released and
//!   actuated levels of the on/off valve it drives.
//!
//! Facts about a moving mass are grouped by mechanical node; a fact on a
//! signal input belongs to the node of the block that drives the input.

use crate::circuit::{Circuit, PortRef};
use crate::{GraphError, Warning};
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

/// A length in mm for a message, rounded to 1 nm unless that hides it.
fn mm(x: f64) -> String {
    let v = x * 1e3;
    let rounded = (v * 1e6).round() / 1e6;
    format!("{} mm", units::show::num(if rounded != 0.0 && rounded.is_finite() { rounded } else { v }))
}

fn cm3(v: f64) -> String {
    format!("{} cm3", (v * 1e6 * 1e4).round() / 1e4)
}

/// A value and the `id.param` of the block that states it.
type Stated = (f64, String);

/// A chamber's face on a piston (see [`Fact::PistonFace`]).
struct Face {
    id: String,
    sigma: f64,
    area: f64,
    dead_volume: f64,
    length_at_zero: f64,
    rod: bool,
}

/// All warnings for a built circuit; `origin` gives the file a component
/// was written in (for the warning's file).
pub fn check(c: &Circuit, origin: &dyn Fn(&str) -> String) -> Vec<Warning> {
    let mut warnings = Vec::new();
    let warn = |warnings: &mut Vec<Warning>, id: &str, message: String| warnings.push(Warning { file: origin(id), message });
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
                // compared per piston by `piston_findings`
                Fact::PistonFace { .. } => None,
                Fact::SwitchPosition { x, param } => {
                    if let Some(n) = mechanical_node(c, r) {
                        switches.push((n, x, who(param)));
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
                Fact::SetPressure(_) => None, // an error, see `errors`
            };
            if let Some((key, (x, name))) = entry {
                match geometry.get(&key) {
                    Some((y, first)) if (x - y).abs() > SAME * x.abs().max(y.abs()) => warn(
                        &mut warnings,
                        &inst.id,
                        format!("{first} = {} but {name} = {}: the geometry of one actuator disagrees", mm(*y), mm(x)),
                    ),
                    Some(_) => {}
                    None => {
                        geometry.insert(key, (x, name));
                    }
                }
            }
        }
    }
    for finding in piston_findings(c).into_iter().filter(|f| !f.fatal) {
        warn(&mut warnings, &finding.id, finding.message);
    }
    for (node, x, name) in switches {
        if let Some((stroke, by)) = geometry.get(&(node, Geometry::Stroke)) {
            if x > *stroke * (1.0 + SAME) {
                let id = name.rsplit_once('.').map(|(id, _)| id).unwrap_or(&name).to_string();
                warn(&mut warnings, &id, format!("{name} trips at {} but {by} = {}: the switch is never reached", mm(x), mm(*stroke)));
            }
        }
    }
    let (p_amb, amb_name) = ambient.unwrap_or((units::STANDARD_ATMOSPHERE, "the standard atmosphere".into()));
    for (p, name) in supplies {
        if p < p_amb {
            let id = name.rsplit_once('.').map(|(id, _)| id).unwrap_or(&name).to_string();
            warn(
                &mut warnings,
                &id,
                format!(
                    "{name} = {} bar is below {amb_name} ({} bar): pressures are absolute",
                    units::show::fixed(p / 1e5, 4),
                    units::show::fixed(p_amb / 1e5, 4)
                ),
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
                &inst.id,
                format!(
                    "{} takes the value {}, between the released ({}) and actuated ({}) levels of {}",
                    c.port_name(*src),
                    units::show::num(*v),
                    units::show::num(released),
                    units::show::num(actuated),
                    c.port_name(r)
                ),
            );
        }
    }
    warnings
}

/// Something wrong with the chambers acting on one piston: `fatal` when the
/// circuit cannot run (the integrator would fail or the piston could never
/// move back), else a warning. `param` is the chamber's parameter to fix.
struct FaceFinding {
    id: String,
    param: &'static str,
    message: String,
    fatal: bool,
}

/// The chambers' faces on each moving mass, with the stroke stated there
/// (value and `id.stroke` of the first block stating it).
fn piston_faces(c: &Circuit) -> Vec<(Vec<Face>, Option<Stated>)> {
    let mut faces: BTreeMap<usize, Vec<Face>> = BTreeMap::new();
    let mut strokes: BTreeMap<usize, Stated> = BTreeMap::new();
    for (bi, inst) in c.instances.iter().enumerate() {
        for (port, fact) in inst.block.facts() {
            let Some(n) = mechanical_node(c, PortRef { block: bi, port }) else { continue };
            match fact {
                Fact::PistonFace { sigma, area, dead_volume, length_at_zero, rod } => {
                    faces.entry(n).or_default().push(Face { id: inst.id.clone(), sigma, area, dead_volume, length_at_zero, rod })
                }
                Fact::Stroke(x) => {
                    strokes.entry(n).or_insert((x, format!("{}.stroke", inst.id)));
                }
                _ => {}
            }
        }
    }
    faces.into_iter().map(|(n, f)| (f, strokes.get(&n).cloned())).collect()
}

/// Everything wrong with the chambers on every piston.
fn piston_findings(c: &Circuit) -> Vec<FaceFinding> {
    piston_faces(c).iter().flat_map(|(faces, stroke)| face_findings(faces, stroke.as_ref())).collect()
}

/// What is wrong with the chambers acting on one piston: a retracting
/// (rod-side) chamber without a gas column or with one that is not the
/// stroke (fatal when its volume reaches zero within the stroke: the
/// integrator fails there), and chambers that all push the same way (fatal
/// when one of them is recognisably the other side's: nothing pushes the
/// piston back, it stalls at a stop).
fn face_findings(faces: &[Face], stroke: Option<&Stated>) -> Vec<FaceFinding> {
    let mut out = Vec::new();
    let finding = |f: &Face, param, message, fatal| FaceFinding { id: f.id.clone(), param, message, fatal };
    for f in faces.iter().filter(|f| f.sigma < 0.0) {
        let Some((s, by)) = stroke else {
            if f.length_at_zero <= 0.0 {
                let message = format!(
                    "{0}.length_at_zero = 0 mm: the rod-side chamber (orientation retract) has no gas column, only {1} of dead volume; set it to the stroke",
                    f.id,
                    cm3(f.dead_volume)
                );
                out.push(finding(f, "length_at_zero", message, false));
            }
            continue;
        };
        let empty_at = f.length_at_zero + f.dead_volume / f.area; // x at which V = 0 (V = V0 + A (L0 - x))
        if empty_at < *s * (1.0 - SAME) {
            let column =
                if f.length_at_zero <= 0.0 { "no gas column".to_string() } else { format!("a gas column of {}", mm(f.length_at_zero)) };
            let message = format!(
                "is {} but {by} = {}: this rod-side chamber (orientation retract) has {column}, so its volume ({} dead) is used up at x = {:.1} mm and the simulation would fail there; set \"length_at_zero\" to the stroke (\"= stroke\" in a sub-circuit), or use the built-in \"type\": \"cylinder\"",
                mm(f.length_at_zero),
                mm(*s),
                cm3(f.dead_volume),
                empty_at * 1e3
            );
            out.push(finding(f, "length_at_zero", message, true));
        } else if (f.length_at_zero - s).abs() > SAME * s.abs() {
            let message = format!(
                "{0}.length_at_zero = {1} but {by} = {2}: the rod-side gas column at x = 0 is the stroke",
                f.id,
                mm(f.length_at_zero),
                mm(*s)
            );
            out.push(finding(f, "length_at_zero", message, false));
        }
    }
    if faces.len() >= 2 {
        for (sigma, way, fix) in [(1.0, "extend", "retract"), (-1.0, "retract", "extend")] {
            if faces.iter().all(|f| f.sigma == sigma) {
                // the chamber that looks like the other side: a rod through it, or a gas column
                let looks = |f: &&Face| if sigma > 0.0 { f.rod || f.length_at_zero > 0.0 } else { !f.rod };
                let suspects: Vec<&Face> = faces.iter().filter(looks).collect();
                let culprit = if suspects.len() == 1 { suspects[0] } else { &faces[faces.len() - 1] };
                let ids: Vec<&str> = faces.iter().map(|f| f.id.as_str()).collect();
                let all = if ids.len() == 2 { "both" } else { "all" };
                let side = if sigma > 0.0 { "rod-side" } else { "head-side" };
                let message = if suspects.len() == 1 {
                    format!(
                        "is \"{way}\", but {} {all} push the piston toward {way}, so nothing pushes it back and it stalls at the end stop; this {side} chamber needs \"orientation\": \"{fix}\" (or use the built-in \"type\": \"cylinder\")",
                        ids.join(" and ")
                    )
                } else {
                    format!(
                        "{} {all} push the piston toward {way}: the {side} chamber needs {}.orientation = {fix}",
                        ids.join(" and "),
                        culprit.id
                    )
                };
                out.push(finding(culprit, "orientation", message, suspects.len() == 1));
            }
        }
    }
    // a chamber turned the wrong way is the cause of its missing gas column: named first
    out.sort_by_key(|f| f.param != "orientation");
    out
}

/// Input that cannot work: a rod-side chamber whose volume reaches zero
/// within the stroke, chambers that all push one piston the same way when
/// one of them is plainly the other side's (see [`face_findings`]), and a regulator whose set pressure is not below the
/// supply that reaches its supply port (through any pneumatic path, not
/// through other regulators, which count as sources at their set pressure).
pub fn errors(c: &Circuit, origin: &dyn Fn(&str) -> String) -> Result<(), GraphError> {
    if let Some(f) = piston_findings(c).into_iter().find(|f| f.fatal) {
        return Err(GraphError::Inconsistent { file: origin(&f.id), id: f.id, param: f.param.into(), message: f.message });
    }
    for (bi, inst) in c.instances.iter().enumerate() {
        for (port, fact) in inst.block.facts() {
            let Fact::SetPressure(p_set) = fact else { continue };
            let Some(node) = inst.port_nodes.get(port).copied().flatten() else { continue };
            let Some((p_supply, source)) = available_supply(c, node, bi) else { continue };
            if p_set >= p_supply {
                return Err(GraphError::Inconsistent {
                    file: origin(&inst.id),
                    id: inst.id.clone(),
                    param: "p_set".into(),
                    message: format!(
                        "set to {} bar, not below the supply that reaches it ({source} = {} bar); pressures are absolute",
                        units::show::fixed(p_set / 1e5, 4),
                        units::show::fixed(p_supply / 1e5, 4)
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Highest supply pressure reaching pneumatic node `start` without passing
/// through block `skip`, with the name of the value that sets it.
fn available_supply(c: &Circuit, start: usize, skip: usize) -> Option<(f64, String)> {
    let mut seen = vec![false; c.pneumatic_nodes.len()];
    let mut queue = std::collections::VecDeque::from([start]);
    seen[start] = true;
    let mut best: Option<(f64, String)> = None;
    let mut offer = |p: f64, name: String| {
        if best.as_ref().is_none_or(|(q, _)| p > *q) {
            best = Some((p, name));
        }
    };
    while let Some(n) = queue.pop_front() {
        for r in &c.pneumatic_nodes[n].ports {
            if r.block == skip {
                continue;
            }
            let inst = &c.instances[r.block];
            let facts = inst.block.facts();
            let supply_here = facts.iter().find_map(|(k, f)| match f {
                Fact::SupplyPressure(p) if *k == r.port => Some(*p),
                _ => None,
            });
            if let Some(p) = supply_here {
                offer(p, format!("{}.p", inst.id));
                continue;
            }
            if let Some((k, p)) = facts.iter().find_map(|(k, f)| if let Fact::SetPressure(p) = f { Some((*k, *p)) } else { None }) {
                // another regulator: a source at its set pressure if reached from its outlet side
                if k != r.port {
                    offer(p, format!("{}.p_set", inst.id));
                }
                continue;
            }
            for (pi, (spec, node)) in inst.block.ports().iter().zip(&inst.port_nodes).enumerate() {
                if pi == r.port || spec.kind.domain() != Domain::Pneumatic {
                    continue;
                }
                if let Some(m) = *node {
                    if !seen[m] {
                        seen[m] = true;
                        queue.push_back(m);
                    }
                }
            }
        }
    }
    best
}
