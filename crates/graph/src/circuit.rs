//! Building a wired circuit from a flat netlist, and assigning causality.
//!
//! Ports joined by power connections form nodes (a pneumatic node is a
//! 0-junction: common p and T, flows sum to zero; a mechanical node is a rigid
//! 1-junction: common x and v). Causality in the bond-graph sense:
//! - a pneumatic node with one effort port (chamber or pressure source) takes
//!   its p, T from it; a node with none lies between restrictions only and is
//!   an algebraic junction whose pressure `solve` finds by a bracketed root
//!   solve; a node with two effort ports would need derivative causality and
//!   is refused;
//! - a mechanical node has exactly one inertia (integral causality); forces
//!   from chambers, friction and springs act on it;
//! - signal inputs read exactly one signal output; blocks with direct
//!   feedthrough are ordered topologically, and a loop among them is refused.
//!
//! The result, [`Circuit`], holds the blocks and index tables only; it knows
//! nothing of the equations inside the blocks.

use crate::expand::FlatNetlist;
use crate::interface::Drive;
use crate::netlist::{split_ref, GasModelName, Species};
use crate::GraphError;
use blocks::block::{Domain, PortKind};
use blocks::Block;
use gas::GasModel;
use petgraph::graph::{DiGraph, NodeIndex};
use std::collections::BTreeMap;
use std::sync::Arc;

/// A port of a block instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PortRef {
    pub block: usize,
    /// Index into the block's `ports()`.
    pub port: usize,
}

/// How a pneumatic node gets its pressure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeCausality {
    /// Imposed by this effort port (chamber or source).
    Effort(PortRef),
    /// Algebraic junction between restrictions: p solved each evaluation.
    Junction,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PneumaticNode {
    pub ports: Vec<PortRef>,
    pub causality: NodeCausality,
}

#[derive(Debug, Clone, PartialEq)]
pub struct MechanicalNode {
    pub inertia: PortRef,
    pub ports: Vec<PortRef>,
}

/// A block instance with its id.
#[derive(Debug, Clone)]
pub struct Instance {
    pub id: String,
    pub block: Box<dyn Block>,
    /// Node index of each port (pneumatic or mechanical node, by domain); `None` for signals.
    pub port_nodes: Vec<Option<usize>>,
    /// For each signal input (in port order), the signal output it reads.
    pub signal_sources: Vec<PortRef>,
}

/// A wired circuit with causality assigned.
#[derive(Debug, Clone)]
pub struct Circuit {
    pub name: String,
    pub gas: Arc<dyn GasModel>,
    pub instances: Vec<Instance>,
    pub pneumatic_nodes: Vec<PneumaticNode>,
    pub mechanical_nodes: Vec<MechanicalNode>,
    /// Junction nodes grouped into clusters coupled through restrictions.
    pub junction_clusters: Vec<Vec<usize>>,
    /// Order in which blocks compute signal outputs.
    pub signal_order: Vec<usize>,
    pub simulation: crate::netlist::Simulation,
    /// Component graph (edges = connections), for reports and Graphviz.
    pub graph: DiGraph<String, String>,
    /// Every parameter value, resolved (for `pneumo check` and tools).
    pub resolved: crate::params::Resolved,
    /// Questionable input found while building, one line each.
    pub warnings: Vec<crate::Warning>,
    /// The netlist's inputs and outputs, bound to the blocks.
    pub interface: crate::interface::ModelInterface,
}

impl Circuit {
    pub fn port_name(&self, r: PortRef) -> String {
        format!("{}.{}", self.instances[r.block].id, self.instances[r.block].block.ports()[r.port].name)
    }
    pub fn port_kind(&self, r: PortRef) -> PortKind {
        self.instances[r.block].block.ports()[r.port].kind
    }
    pub fn find(&self, id: &str) -> Option<usize> {
        self.instances.iter().position(|i| i.id == id)
    }
}

/// Make the gas model a netlist asks for.
pub fn gas_model(choice: &crate::netlist::GasChoice) -> Arc<dyn GasModel> {
    match (choice.model, choice.species) {
        (GasModelName::Ideal, Species::Air) => Arc::new(gas::IdealGas::air()),
        (GasModelName::Ideal, Species::Nitrogen) => Arc::new(gas::IdealGas::nitrogen()),
        (GasModelName::SemiPerfect, Species::Air) => Arc::new(gas::SemiPerfectGas::air()),
        (GasModelName::SemiPerfect, Species::Nitrogen) => Arc::new(gas::SemiPerfectGas::nitrogen()),
        (GasModelName::Real, Species::Air) => Arc::new(gas::VirialGas::air()),
        (GasModelName::Real, Species::Nitrogen) => Arc::new(gas::VirialGas::nitrogen()),
    }
}

/// Ids after expansion: user ids joined by '.' (`cyl.head`).
fn valid_id(id: &str) -> bool {
    id.split('.').all(|part| !part.is_empty() && part.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'))
}

struct UnionFind(Vec<usize>);
impl UnionFind {
    fn find(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        self.0[ra] = rb;
    }
}

/// Resolve parameters and expressions, then build blocks, wire them, and
/// assign causality; the netlist runs by itself ([`Drive::Standalone`]).
pub fn build(flat: &FlatNetlist) -> Result<Circuit, GraphError> {
    build_with(flat, Drive::Standalone)
}

/// [`build`], with the interface's inputs acting as `drive` says
/// ([`Drive::External`]: the model is driven from outside, e.g. as an FMU).
pub fn build_with(flat: &FlatNetlist, drive: Drive) -> Result<Circuit, GraphError> {
    let (concrete, resolved) = crate::params::concrete(flat)?;
    let mut circuit = build_concrete(&concrete, drive, &resolved).map_err(|e| e.in_file(&flat.origin))?;
    // the file a component was written in; for the inside of a built-in, the top-level file
    let origin = |id: &str| match concrete.component(id) {
        Some(c) if !c.origin.starts_with(crate::library::FILE_PREFIX) => c.origin.clone(),
        _ => concrete.origin.clone(),
    };
    crate::consistency::errors(&circuit, &origin)?;
    circuit.warnings = resolved.warnings.clone();
    circuit.warnings.extend(crate::consistency::check(&circuit, &origin));
    circuit.resolved = resolved;
    Ok(circuit)
}

/// Build from a netlist whose values are all literals.
fn build_concrete(flat: &FlatNetlist, drive: Drive, resolved: &crate::params::Resolved) -> Result<Circuit, GraphError> {
    // 1. ids and blocks
    let mut seen = BTreeMap::new();
    let mut instances = Vec::new();
    for c in &flat.components {
        if !valid_id(&c.id) {
            return Err(GraphError::BadId { file: c.origin.clone(), id: c.id.clone() });
        }
        if seen.insert(c.id.clone(), ()).is_some() {
            return Err(GraphError::DuplicateId { file: c.origin.clone(), id: c.id.clone() });
        }
        if c.kind == "subsystem" {
            return Err(GraphError::Subsystem { id: c.id.clone(), message: "subsystem was not expanded".into() });
        }
        let raw: Vec<(String, blocks::RawValue)> = c.params.iter().chain(c.init.iter()).map(|(k, v)| (k.clone(), v.to_raw())).collect();
        let block = blocks::registry::build(&c.kind, raw.iter().map(|(k, v)| (k.as_str(), v))).map_err(|source| GraphError::Block {
            file: c.origin.clone(),
            id: c.id.clone(),
            source: Box::new(source),
        })?;
        let n = block.ports().len();
        instances.push(Instance { id: c.id.clone(), block, port_nodes: vec![None; n], signal_sources: Vec::new() });
    }
    let by_id: BTreeMap<&str, usize> = instances.iter().enumerate().map(|(i, b)| (b.id.as_str(), i)).collect();

    // 2. resolve connection ends
    let resolve = |r: &str| -> Result<PortRef, GraphError> {
        let (id, port) = split_ref(r).ok_or_else(|| GraphError::BadRef { reference: crate::escape(r) })?;
        let &block = by_id.get(id).ok_or_else(|| GraphError::UnknownComponent { reference: crate::escape(r), id: crate::escape(id) })?;
        let ports = instances[block].block.ports();
        let port = ports.iter().position(|p| p.name == port).ok_or_else(|| GraphError::UnknownPort {
            reference: crate::escape(r),
            ports: ports.iter().map(|p| p.name).collect::<Vec<_>>().join(", "),
        })?;
        Ok(PortRef { block, port })
    };
    let ends = flat.connections.iter().map(|(a, b)| Ok((resolve(a)?, resolve(b)?))).collect::<Result<Vec<_>, GraphError>>()?;
    drop(by_id);
    // the model interface: a source block for each input bound to ports, the outputs it reports
    let bound = crate::interface::bind_inputs(flat, &mut instances, &ends, drive, resolved)?;
    let outputs = crate::interface::bind_outputs(flat, &instances)?;
    let mut offsets = Vec::with_capacity(instances.len());
    let mut total = 0;
    for inst in &instances {
        offsets.push(total);
        total += inst.block.ports().len();
    }
    let flat_index = |r: PortRef| offsets[r.block] + r.port;
    let mut uf = UnionFind((0..total).collect());
    let mut connected = vec![false; total];
    let mut signal_src: BTreeMap<PortRef, PortRef> = BTreeMap::new();
    let mut graph = DiGraph::<String, String>::new();
    let gnodes: Vec<NodeIndex> = instances.iter().map(|i| graph.add_node(format!("{} ({})", i.id, i.block.type_name()))).collect();
    for ((a, b), &(ra, rb)) in flat.connections.iter().zip(&ends) {
        if ra == rb {
            return Err(GraphError::SelfConnection { reference: a.clone() });
        }
        let (ka, kb) = (instances[ra.block].block.ports()[ra.port].kind, instances[rb.block].block.ports()[rb.port].kind);
        if ka.domain() != kb.domain() {
            return Err(GraphError::DomainMismatch { a: a.clone(), da: ka.domain(), b: b.clone(), db: kb.domain() });
        }
        let signal = if ka.domain() == Domain::Signal {
            let (src, dst) = match (ka, kb) {
                (PortKind::SignalOut, PortKind::SignalIn) => (ra, rb),
                (PortKind::SignalIn, PortKind::SignalOut) => (rb, ra),
                _ => return Err(GraphError::SignalDirection { a: a.clone(), b: b.clone() }),
            };
            if bound.replaced.contains(&dst) {
                continue; // an interface input drives this port instead
            }
            Some((src, dst))
        } else {
            None
        };
        connected[flat_index(ra)] = true;
        connected[flat_index(rb)] = true;
        graph.add_edge(gnodes[ra.block], gnodes[rb.block], format!("{} -> {}", a, b));
        match signal {
            Some((src, dst)) => {
                if signal_src.insert(dst, src).is_some() {
                    let name = if dst == ra { a } else { b };
                    return Err(GraphError::SignalDriven { reference: name.clone() });
                }
            }
            None => uf.union(flat_index(ra), flat_index(rb)),
        }
    }
    for &(src, dst) in &bound.connections {
        connected[flat_index(dst)] = true;
        let label = format!("{} -> {}", port_name_of(&instances, src), port_name_of(&instances, dst));
        graph.add_edge(gnodes[src.block], gnodes[dst.block], label);
        signal_src.insert(dst, src);
    }

    // 3. unconnected ports
    for (bi, inst) in instances.iter().enumerate() {
        for (pi, p) in inst.block.ports().iter().enumerate() {
            if p.kind != PortKind::SignalOut && !connected[offsets[bi] + pi] {
                return Err(GraphError::Unconnected { reference: format!("{}.{}", inst.id, p.name), doc: p.doc.to_string() });
            }
        }
    }

    // 4. nodes
    let mut pneumatic_nodes: Vec<PneumaticNode> = Vec::new();
    let mut mech_groups: Vec<Vec<PortRef>> = Vec::new();
    let mut root_to_node: BTreeMap<usize, usize> = BTreeMap::new();
    for (bi, inst) in instances.iter_mut().enumerate() {
        let ports = inst.block.ports().to_vec();
        for (pi, p) in ports.iter().enumerate() {
            let domain = p.kind.domain();
            if domain == Domain::Signal {
                continue;
            }
            let root = uf.find(offsets[bi] + pi);
            let r = PortRef { block: bi, port: pi };
            let node = *root_to_node.entry(root).or_insert_with(|| {
                if domain == Domain::Pneumatic {
                    pneumatic_nodes.push(PneumaticNode { ports: Vec::new(), causality: NodeCausality::Junction });
                    pneumatic_nodes.len() - 1
                } else {
                    mech_groups.push(Vec::new());
                    mech_groups.len() - 1
                }
            });
            if domain == Domain::Pneumatic {
                pneumatic_nodes[node].ports.push(r);
            } else {
                mech_groups[node].push(r);
            }
            inst.port_nodes[pi] = Some(node);
        }
        inst.signal_sources = ports
            .iter()
            .enumerate()
            .filter(|(_, p)| p.kind == PortKind::SignalIn)
            .map(|(pi, _)| signal_src[&PortRef { block: bi, port: pi }])
            .collect();
    }
    let name_of = |r: PortRef| format!("{}.{}", instances[r.block].id, instances[r.block].block.ports()[r.port].name);

    // 5. pneumatic causality
    for node in pneumatic_nodes.iter_mut() {
        let efforts: Vec<PortRef> =
            node.ports.iter().copied().filter(|r| instances[r.block].block.ports()[r.port].kind == PortKind::PneumaticEffort).collect();
        match efforts.len() {
            0 => node.causality = NodeCausality::Junction,
            1 => node.causality = NodeCausality::Effort(efforts[0]),
            _ => return Err(GraphError::DerivativeCausality { ports: efforts.iter().map(|&r| name_of(r)).collect::<Vec<_>>().join(", ") }),
        }
    }
    let junction_clusters = junction_clusters(&instances, &pneumatic_nodes, &name_of)?;

    // 6. mechanical causality
    let mut mechanical_nodes = Vec::new();
    for ports in mech_groups {
        let inertias: Vec<PortRef> =
            ports.iter().copied().filter(|r| instances[r.block].block.ports()[r.port].kind == PortKind::MechanicalInertia).collect();
        match inertias.len() {
            1 => mechanical_nodes.push(MechanicalNode { inertia: inertias[0], ports }),
            0 => return Err(GraphError::NoInertia { ports: ports.iter().map(|&r| name_of(r)).collect::<Vec<_>>().join(", ") }),
            _ => return Err(GraphError::TiedInertias { ports: inertias.iter().map(|&r| name_of(r)).collect::<Vec<_>>().join(", ") }),
        }
    }

    // 7. signal evaluation order: feedthrough blocks after their sources
    let mut sig = DiGraph::<usize, ()>::new();
    let sn: Vec<NodeIndex> = (0..instances.len()).map(|i| sig.add_node(i)).collect();
    for (bi, inst) in instances.iter().enumerate() {
        if inst.block.feedthrough() {
            for src in &inst.signal_sources {
                sig.add_edge(sn[src.block], sn[bi], ());
            }
        }
    }
    let signal_order = petgraph::algo::toposort(&sig, None)
        .map_err(|cycle| GraphError::SignalLoop { id: instances[sig[cycle.node_id()]].id.clone() })?
        .into_iter()
        .map(|n| sig[n])
        .collect();

    Ok(Circuit {
        name: flat.name.clone(),
        gas: gas_model(&flat.gas),
        instances,
        pneumatic_nodes,
        mechanical_nodes,
        junction_clusters,
        signal_order,
        simulation: flat.simulation.clone(),
        graph,
        resolved: Default::default(),
        warnings: Vec::new(),
        interface: crate::interface::ModelInterface { inputs: bound.inputs, outputs },
    })
}

fn port_name_of(instances: &[Instance], r: PortRef) -> String {
    format!("{}.{}", instances[r.block].id, instances[r.block].block.ports()[r.port].name)
}

/// Group junction nodes coupled through blocks, and check each group borders
/// at least one node whose pressure is known (else its pressure is undefined).
fn junction_clusters(
    instances: &[Instance],
    nodes: &[PneumaticNode],
    name_of: &dyn Fn(PortRef) -> String,
) -> Result<Vec<Vec<usize>>, GraphError> {
    let n = nodes.len();
    let mut uf = UnionFind((0..n).collect());
    let mut borders_effort = vec![false; n];
    for inst in instances {
        let pn: Vec<usize> = inst
            .block
            .ports()
            .iter()
            .zip(&inst.port_nodes)
            .filter(|(p, _)| p.kind.domain() == Domain::Pneumatic)
            .filter_map(|(_, node)| *node)
            .collect();
        for &a in &pn {
            for &b in &pn {
                let (ja, jb) = (nodes[a].causality == NodeCausality::Junction, nodes[b].causality == NodeCausality::Junction);
                if ja && jb {
                    uf.union(a, b);
                }
                if ja && !jb {
                    borders_effort[a] = true;
                }
            }
        }
    }
    let mut clusters: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (i, node) in nodes.iter().enumerate() {
        if node.causality == NodeCausality::Junction {
            clusters.entry(uf.find(i)).or_default().push(i);
        }
    }
    for members in clusters.values() {
        if !members.iter().any(|&m| borders_effort[m]) {
            let ports: Vec<String> = members.iter().flat_map(|&m| nodes[m].ports.iter().map(|&r| name_of(r))).collect();
            return Err(GraphError::FloatingNode { ports: ports.join(", ") });
        }
    }
    Ok(clusters.into_values().collect())
}
