//! Registry: every block type by its netlist name, with its family,
//! parameter declarations, ports and a constructor. Each block file declares
//! its entry (`pub const TYPE: BlockType`); the list of all of them is the
//! [`crate::library!`] invocation in `lib.rs`. Adding a block type = one file
//! plus one line there.

use crate::block::{Block, OutputSpec, PortSpec};
use crate::params::{ParamSpec, Params, RawValue};
use crate::BlockError;

/// Families of the catalogue (`pneumo blocks`, docs/blocks.md), in catalogue order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Family {
    Sources,
    Capacities,
    Restrictions,
    DirectionalValves,
    PressureValves,
    LogicValves,
    ProportionalValves,
    Mechanics,
    Sensors,
    Control,
}

impl Family {
    /// Every family, in catalogue order.
    pub const ALL: &'static [Family] = &[
        Family::Sources,
        Family::Capacities,
        Family::Restrictions,
        Family::DirectionalValves,
        Family::PressureValves,
        Family::LogicValves,
        Family::ProportionalValves,
        Family::Mechanics,
        Family::Sensors,
        Family::Control,
    ];
    /// Heading of the family in the catalogue.
    pub fn title(self) -> &'static str {
        match self {
            Family::Sources => "Sources and exhaust",
            Family::Capacities => "Capacities and lines",
            Family::Restrictions => "Restrictions and flow controls",
            Family::DirectionalValves => "Directional control valves",
            Family::PressureValves => "Pressure control valves",
            Family::LogicValves => "Logic and exhaust valves",
            Family::ProportionalValves => "Proportional valves",
            Family::Mechanics => "Actuators, loads and mechanics",
            Family::Sensors => "Sensors and switches",
            Family::Control => "Control",
        }
    }
}

/// A block type known to the netlist.
pub struct BlockType {
    /// Name used in netlists (`"type": "chamber"`).
    pub name: &'static str,
    /// Family in the catalogue.
    pub family: Family,
    /// One line for listings and the schema.
    pub doc: &'static str,
    pub params: &'static [ParamSpec],
    /// Every port an instance may have (some appear only with certain
    /// parameters, e.g. a chamber's `piston` port only with an area; a
    /// sequencer's ports are named by its parameters and not listed).
    pub ports: &'static [PortSpec],
    /// Recorded outputs besides the signal outputs.
    pub outputs: &'static [OutputSpec],
    pub build: fn(&Params) -> Result<Box<dyn Block>, BlockError>,
}

/// A built block behind the trait object the registry hands out.
pub fn boxed<B: Block + 'static>(r: Result<B, BlockError>) -> Result<Box<dyn Block>, BlockError> {
    r.map(|b| Box::new(b) as Box<dyn Block>)
}

/// All block types.
pub use crate::TYPES;

/// Look up a block type by name.
pub fn block_type(name: &str) -> Result<&'static BlockType, BlockError> {
    TYPES.iter().find(|t| t.name == name).ok_or_else(|| BlockError::UnknownType {
        name: name.to_string(),
        hint: crate::suggest::did_you_mean(name, TYPES.iter().map(|t| t.name)),
        known: TYPES.iter().map(|t| t.name).collect::<Vec<_>>().join(", "),
    })
}

/// Build a block from its type name and raw parameters.
pub fn build<'a>(type_name: &str, raw: impl IntoIterator<Item = (&'a str, &'a RawValue)>) -> Result<Box<dyn Block>, BlockError> {
    let ty = block_type(type_name)?;
    let params = Params::from_raw(ty.params, raw)?;
    (ty.build)(&params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_builds_its_entry_name_and_declares_a_family_listed() {
        for t in TYPES {
            assert!(Family::ALL.contains(&t.family), "{}", t.name);
            assert!(!t.doc.is_empty() && t.doc.len() < 100, "{}: doc is one short line", t.name);
        }
    }

    #[test]
    fn names_are_unique_and_parameter_names_unique_per_type() {
        let mut names: Vec<_> = TYPES.iter().map(|t| t.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), TYPES.len());
        for t in TYPES {
            let mut p: Vec<_> = t.params.iter().map(|s| s.name).collect();
            p.sort();
            p.dedup();
            assert_eq!(p.len(), t.params.len(), "{}", t.name);
        }
    }

    #[test]
    fn unknown_type_and_parameter_are_named() {
        let e = build("chamberr", std::iter::empty()).unwrap_err().to_string();
        assert!(e.contains("chamberr") && e.contains("chamber"), "{e}");
        let v = RawValue::Number(1.0);
        let e = build("conductance", [("Cv", &v)]).unwrap_err().to_string();
        assert!(e.contains("Cv") && e.contains("accepted"), "{e}");
    }

    #[test]
    fn wrong_unit_and_range_errors_name_the_parameter() {
        let c = RawValue::Text("4 bar".into());
        let b = RawValue::Number(0.3);
        let e = build("conductance", [("C", &c), ("b", &b)]).unwrap_err().to_string();
        assert!(e.contains("\"C\""), "{e}");
        let c = RawValue::Text("13.2 L/min/bar".into());
        let b = RawValue::Number(1.2);
        let e = build("conductance", [("C", &c), ("b", &b)]).unwrap_err().to_string();
        assert!(e.contains("\"b\"") && e.contains("(0, 1)"), "{e}");
        let c = RawValue::Number(-1.0);
        let b = RawValue::Number(0.3);
        assert!(build("conductance", [("C", &c), ("b", &b)]).unwrap_err().to_string().contains("> 0"));
        let v = RawValue::Number(-1e-6);
        assert!(build("chamber", [("dead_volume", &v)]).is_err());
    }
}
