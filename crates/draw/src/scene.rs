//! From a wired circuit to what is drawn: *items* (one symbol each — a
//! block, or a whole cylinder made of a piston and the blocks on its
//! mechanical node), *nets* (the lines between their pins) and *groups*
//! (subsystem instances, drawn as frames).
//!
//! Decisions taken here, before any geometry:
//! - a piston with chambers on its node is a cylinder; the friction,
//!   springs, loads, rod sensors, limit switches and cushions on that node
//!   (a cushion through its chamber line) are drawn on it;
//! - a pneumatic node holding an `atmosphere` is not a line: every other
//!   port on it gets its own exhaust mark;
//! - two-port symbols are turned so that their port nearer the supply (by
//!   hops through the circuit, not through exhausts) is at the bottom.

use crate::shape::{PinKind, Shape};
use crate::symbols::{self, Ctx, Member};
use crate::DrawError;
use blocks::block::{Domain, PortKind};
use blocks::params::Params;
use graph::circuit::Circuit;
use graph::FlatNetlist;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// How an item takes part in the layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A cylinder: top row.
    Actuator,
    /// A symbol on the working lines: placed in rows by the flow of energy.
    Pneumatic,
    /// A signal block (or a block standing alone): the control column.
    Control,
}

/// One drawn symbol.
pub struct Item {
    pub shape: Shape,
    /// Instance indices of the circuit's blocks it draws.
    pub members: Vec<usize>,
    pub role: Role,
    /// Subsystem instance it belongs to ("" at the top level).
    pub group: String,
    /// Id shown in the label (relative to its group's frame).
    pub display: String,
    /// What it is, for the tooltip ("valve_5_2", "cylinder").
    pub kind: String,
    /// Full ids of the blocks it draws.
    pub ids: Vec<String>,
}

/// What a net's line is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum NetKind {
    /// Pneumatic (working lines, with dashed branches to pilot ports).
    Pneumatic,
    Mechanical,
    Signal,
}

/// A pin of an item.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct PinRef {
    pub item: usize,
    pub pin: usize,
}

/// Ports joined by one line (or, for an exhaust, one mark per pin).
pub struct Net {
    pub kind: NetKind,
    pub pins: Vec<PinRef>,
    /// The atmosphere block the pins vent to: drawn as exhaust marks.
    pub exhaust: Option<usize>,
}

/// A subsystem instance: its path and the file it came from.
pub struct Group {
    pub path: String,
    pub file: String,
}

/// Everything to draw, before placement.
pub struct Scene {
    pub items: Vec<Item>,
    pub nets: Vec<Net>,
    pub groups: Vec<Group>,
    /// Atmosphere blocks: id shown, and the label of its marks.
    pub exhausts: BTreeMap<usize, String>,
    pub name: String,
}

/// Parse each instance's parameters again (from the netlist with its
/// expressions evaluated): the symbol builders read them as the blocks did.
fn parameters(flat: &FlatNetlist, circuit: &Circuit) -> Result<Vec<Params>, DrawError> {
    let (concrete, _) = graph::params::concrete(flat)?;
    let by_id: BTreeMap<&str, &graph::netlist::Component> = concrete.components.iter().map(|c| (c.id.as_str(), c)).collect();
    circuit
        .instances
        .iter()
        .map(|inst| {
            let c = by_id.get(inst.id.as_str()).ok_or_else(|| DrawError::Internal(format!("no component {}", inst.id)))?;
            let ty = blocks::registry::block_type(&c.kind).map_err(|e| DrawError::Internal(e.to_string()))?;
            let raw: Vec<(String, blocks::RawValue)> = c.params.iter().chain(c.init.iter()).map(|(k, v)| (k.clone(), v.to_raw())).collect();
            Params::from_raw(ty.params, raw.iter().map(|(k, v)| (k.as_str(), v))).map_err(|e| DrawError::Internal(e.to_string()))
        })
        .collect()
}

fn group_of(id: &str) -> &str {
    id.rsplit_once('.').map(|(g, _)| g).unwrap_or("")
}

/// Build the scene of a circuit.
pub fn build(flat: &FlatNetlist, circuit: &Circuit) -> Result<Scene, DrawError> {
    let params = parameters(flat, circuit)?;
    let n = circuit.instances.len();
    let type_of = |i: usize| circuit.instances[i].block.type_name();
    let ty = |i: usize| blocks::registry::block_type(type_of(i)).map_err(|e| DrawError::Internal(e.to_string()));

    // ---- which blocks are drawn together ----
    let mut item_of: Vec<Option<usize>> = vec![None; n];
    let mut groups_of_items: Vec<(Vec<usize>, bool)> = Vec::new(); // members, is cylinder
    for node in &circuit.mechanical_nodes {
        let members: Vec<usize> = node.ports.iter().map(|r| r.block).collect::<BTreeSet<_>>().into_iter().collect();
        let has_chamber = members.iter().any(|&b| type_of(b) == "chamber");
        if type_of(node.inertia.block) != "piston" || !has_chamber {
            continue;
        }
        let mut members = members;
        // cushions in the line of one of its chambers
        for (b, inst) in circuit.instances.iter().enumerate() {
            if type_of(b) != "cushion" || members.contains(&b) {
                continue;
            }
            let chamber_port = inst.block.ports().iter().position(|p| p.name == "chamber");
            let node_of = |block: usize, port: usize| circuit.instances[block].port_nodes[port];
            let joined = chamber_port.and_then(|p| node_of(b, p)).is_some_and(|cn| {
                members.iter().any(|&m| {
                    type_of(m) == "chamber"
                        && circuit.instances[m].block.ports().iter().position(|p| p.name == "port").and_then(|p| node_of(m, p)) == Some(cn)
                })
            });
            if joined {
                members.push(b);
            }
        }
        let index = groups_of_items.len();
        for &m in &members {
            if item_of[m].is_none() {
                item_of[m] = Some(index);
            }
        }
        let members: Vec<usize> = members.into_iter().filter(|&m| item_of[m] == Some(index)).collect();
        groups_of_items.push((members, true));
    }
    let is_atmosphere = |i: usize| type_of(i) == "atmosphere";
    for (i, item) in item_of.iter_mut().enumerate() {
        if item.is_none() && !is_atmosphere(i) {
            *item = Some(groups_of_items.len());
            groups_of_items.push((vec![i], false));
        }
    }
    // order items by their first block, as the netlist lists them
    let mut order: Vec<usize> = (0..groups_of_items.len()).collect();
    order.sort_by_key(|&g| groups_of_items[g].0.iter().min().copied().unwrap_or(usize::MAX));
    let mut renumber = vec![0; order.len()];
    for (new, &old) in order.iter().enumerate() {
        renumber[old] = new;
    }
    let item_of: Vec<Option<usize>> = item_of.into_iter().map(|g| g.map(|g| renumber[g])).collect();
    let mut groups_of_items: Vec<(Vec<usize>, bool)> = order.into_iter().map(|g| std::mem::take(&mut groups_of_items[g])).collect();
    for g in &mut groups_of_items {
        g.0.sort_unstable();
    }

    // ---- ports that connect outside their item ----
    let mut used: Vec<BTreeSet<(usize, String)>> = vec![BTreeSet::new(); groups_of_items.len()];
    let mut mark = |block: usize, port: &str| {
        if let Some(it) = item_of[block] {
            let member = groups_of_items[it].0.iter().position(|&b| b == block).unwrap_or(0);
            used[it].insert((member, port.to_string()));
        }
    };
    let port_name = |r: graph::PortRef| circuit.instances[r.block].block.ports()[r.port].name;
    for node in &circuit.pneumatic_nodes {
        let items: BTreeSet<Option<usize>> = node.ports.iter().map(|r| item_of[r.block]).collect();
        if items.len() > 1 {
            node.ports.iter().for_each(|&r| mark(r.block, port_name(r)));
        }
    }
    for node in &circuit.mechanical_nodes {
        let items: BTreeSet<Option<usize>> = node.ports.iter().map(|r| item_of[r.block]).collect();
        if items.len() > 1 {
            node.ports.iter().for_each(|&r| mark(r.block, port_name(r)));
        }
    }
    for (b, inst) in circuit.instances.iter().enumerate() {
        let inputs = inst.block.ports().iter().filter(|p| p.kind == PortKind::SignalIn);
        for (p, src) in inputs.zip(&inst.signal_sources) {
            if item_of[b] != item_of[src.block] {
                mark(b, p.name);
                mark(src.block, port_name(*src));
            }
        }
    }

    // ---- orientation: hops from the supply ----
    let node_count = circuit.pneumatic_nodes.len();
    let exhaust_node: Vec<bool> = circuit.pneumatic_nodes.iter().map(|nd| nd.ports.iter().any(|r| is_atmosphere(r.block))).collect();
    let mut hops = vec![usize::MAX; node_count];
    let mut queue = VecDeque::new();
    for (k, nd) in circuit.pneumatic_nodes.iter().enumerate() {
        if nd.ports.iter().any(|r| matches!(type_of(r.block), "pressure_source" | "mass_flow_source")) {
            hops[k] = 0;
            queue.push_back(k);
        }
    }
    let nodes_of = |b: usize| -> Vec<usize> {
        let inst = &circuit.instances[b];
        inst.block
            .ports()
            .iter()
            .zip(&inst.port_nodes)
            .filter(|(p, _)| p.kind.domain() == Domain::Pneumatic)
            .filter_map(|(_, nd)| *nd)
            .collect()
    };
    let mut blocks_at: Vec<Vec<usize>> = vec![Vec::new(); node_count];
    for b in 0..n {
        for k in nodes_of(b) {
            blocks_at[k].push(b);
        }
    }
    while let Some(k) = queue.pop_front() {
        if exhaust_node[k] {
            continue;
        }
        for &b in &blocks_at[k] {
            for next in nodes_of(b) {
                if hops[next] == usize::MAX {
                    hops[next] = hops[k] + 1;
                    queue.push_back(next);
                }
            }
        }
    }
    let flip_of = |b: usize| -> bool {
        let Some((bottom, top)) = symbols::flippable(type_of(b)) else { return false };
        let inst = &circuit.instances[b];
        let node = |name: &str| inst.block.ports().iter().position(|p| p.name == name).and_then(|p| inst.port_nodes[p]);
        match (node(bottom), node(top)) {
            (Some(a), Some(t)) => hops[t] < hops[a] || (hops[t] == hops[a] && exhaust_node[t] && !exhaust_node[a]),
            _ => false,
        }
    };

    // ---- symbols ----
    let mut items = Vec::with_capacity(groups_of_items.len());
    for (it, (members, cylinder)) in groups_of_items.iter().enumerate() {
        let tys: Vec<&'static blocks::registry::BlockType> = members.iter().map(|&m| ty(m)).collect::<Result<_, _>>()?;
        let ms: Vec<Member> = members
            .iter()
            .zip(&tys)
            .map(|(&m, t)| Member { id: &circuit.instances[m].id, ty: t, params: &params[m], ports: circuit.instances[m].block.ports() })
            .collect();
        let ctx = Ctx { members: &ms, used: &used[it], flip: !cylinder && flip_of(members[0]) };
        let (shape, kind, lead) = if *cylinder {
            let piston = members.iter().position(|&m| type_of(m) == "piston").unwrap_or(0);
            (symbols::actuators::cylinder(&ctx), "cylinder".to_string(), members[piston])
        } else {
            let shape = symbols::block_symbol(&ctx).unwrap_or_else(|| symbols::generic(&ctx));
            (shape, type_of(members[0]).to_string(), members[0])
        };
        let role = if *cylinder {
            Role::Actuator
        } else if shape.pins.iter().any(|p| matches!(p.kind, PinKind::Working)) {
            Role::Pneumatic
        } else {
            Role::Control
        };
        let id = &circuit.instances[lead].id;
        let group = group_of(id).to_string();
        let ids = members.iter().map(|&m| circuit.instances[m].id.clone()).collect();
        items.push(Item { shape, members: members.clone(), role, group, display: symbols::actuators::local(id).to_string(), kind, ids });
    }

    // ---- nets ----
    let mut pin_at: BTreeMap<(usize, &str), PinRef> = BTreeMap::new();
    for (it, item) in items.iter().enumerate() {
        for (k, pin) in item.shape.pins.iter().enumerate() {
            if let Some(&block) = item.members.get(pin.member) {
                pin_at.entry((block, pin.port.as_str())).or_insert(PinRef { item: it, pin: k });
            }
        }
    }
    let find = |r: graph::PortRef| pin_at.get(&(r.block, port_name(r))).copied();
    let mut nets = Vec::new();
    let mut exhausts = BTreeMap::new();
    for nd in &circuit.pneumatic_nodes {
        let pins: Vec<PinRef> = nd.ports.iter().filter_map(|&r| find(r)).collect();
        let exhaust = nd.ports.iter().find(|r| is_atmosphere(r.block)).map(|r| r.block);
        if let Some(a) = exhaust {
            let p = circuit.instances[a].block.ports().first().map(|_| params[a].get("p")).unwrap_or(0.0);
            exhausts.insert(a, format!("{} {}", symbols::actuators::local(&circuit.instances[a].id), crate::format::pressure(p)));
            if !pins.is_empty() {
                nets.push(Net { kind: NetKind::Pneumatic, pins, exhaust });
            }
        } else if pins.len() >= 2 {
            nets.push(Net { kind: NetKind::Pneumatic, pins, exhaust: None });
        }
    }
    for nd in &circuit.mechanical_nodes {
        let pins: Vec<PinRef> = nd.ports.iter().filter_map(|&r| find(r)).collect();
        if pins.len() >= 2 {
            nets.push(Net { kind: NetKind::Mechanical, pins, exhaust: None });
        }
    }
    let mut by_source: BTreeMap<graph::PortRef, Vec<PinRef>> = BTreeMap::new();
    for (b, inst) in circuit.instances.iter().enumerate() {
        let inputs = inst.block.ports().iter().enumerate().filter(|(_, p)| p.kind == PortKind::SignalIn);
        for ((pi, _), src) in inputs.zip(&inst.signal_sources) {
            if let Some(pin) = find(graph::PortRef { block: b, port: pi }) {
                by_source.entry(*src).or_default().push(pin);
            }
        }
    }
    for (src, inputs) in by_source {
        let Some(source) = find(src) else { continue };
        let mut pins = vec![source];
        pins.extend(inputs.into_iter().filter(|p| p.item != source.item));
        if pins.len() >= 2 {
            nets.push(Net { kind: NetKind::Signal, pins, exhaust: None });
        }
    }

    // ---- subsystem frames: around two or more symbols; a subsystem drawn
    // as one symbol (a cylinder) gives it its name and file instead ----
    let top_dir = std::path::Path::new(&flat.origin).parent().map(|p| p.to_path_buf()).unwrap_or_default();
    let file_of = |path: &str| -> String {
        let prefix = format!("{path}.");
        flat.components
            .iter()
            .find(|c| c.id.starts_with(&prefix) && group_of(&c.id) == path)
            .map(|c| {
                let p = std::path::Path::new(&c.origin);
                p.strip_prefix(&top_dir).unwrap_or(p).display().to_string()
            })
            .unwrap_or_default()
    };
    let inside = |items: &[Item], path: &str| -> usize {
        let prefix = format!("{path}.");
        items.iter().filter(|it| it.group == path || it.group.starts_with(&prefix)).count()
    };
    for k in 0..items.len() {
        while !items[k].group.is_empty() && inside(&items, &items[k].group) == 1 {
            let path = items[k].group.clone();
            let file = file_of(&path);
            let item = &mut items[k];
            item.display = symbols::actuators::local(&path).to_string();
            if !file.is_empty() {
                item.shape.label.push(format!("subsystem {file}"));
            }
            item.group = group_of(&path).to_string();
        }
    }
    let mut paths: BTreeSet<String> = BTreeSet::new();
    for item in &items {
        let mut g = item.group.as_str();
        while !g.is_empty() {
            paths.insert(g.to_string());
            g = group_of(g);
        }
    }
    let groups = paths.into_iter().map(|path| Group { file: file_of(&path), path }).collect();

    Ok(Scene { items, nets, groups, exhausts, name: flat.name.clone() })
}
