//! Registry: every block type by its netlist name, with its parameter
//! declarations and a constructor. Adding a block type = one file plus one
//! entry here.

use crate::block::{Block, OutputSpec, PortSpec};
use crate::params::{ParamSpec, Params, RawValue};
use crate::BlockError;

/// A block type known to the netlist.
pub struct BlockType {
    /// Name used in netlists (`"type": "chamber"`).
    pub name: &'static str,
    /// One line for listings and the schema.
    pub doc: &'static str,
    pub params: &'static [ParamSpec],
    /// Every port an instance may have (some appear only with certain
    /// parameters, e.g. a chamber's `piston` port only with an area).
    pub ports: &'static [PortSpec],
    /// Recorded outputs besides the signal outputs.
    pub outputs: &'static [OutputSpec],
    pub build: fn(&Params) -> Result<Box<dyn Block>, BlockError>,
}

fn boxed<B: Block + 'static>(r: Result<B, BlockError>) -> Result<Box<dyn Block>, BlockError> {
    r.map(|b| Box::new(b) as Box<dyn Block>)
}

use crate::*;

/// All block types.
pub static TYPES: &[BlockType] = &[
    BlockType {
        name: "chamber",
        doc: "variable-volume pneumatic capacity (Eq. 5-17)",
        params: chamber::PARAMS,
        ports: chamber::PORTS_CYLINDER,
        outputs: chamber::OUTPUTS,
        build: |p| boxed(chamber::Chamber::from_params(p)),
    },
    BlockType {
        name: "conductance",
        doc: "ISO 6358 restriction (Eq. 33-35)",
        params: conductance::PARAMS,
        ports: conductance::PORTS,
        outputs: conductance::OUTPUTS,
        build: |p| boxed(conductance::Conductance::from_params(p)),
    },
    BlockType {
        name: "check_valve",
        doc: "one-way restriction with cracking pressure",
        params: check_valve::PARAMS,
        ports: check_valve::PORTS,
        outputs: check_valve::OUTPUTS,
        build: |p| boxed(check_valve::CheckValve::from_params(p)),
    },
    BlockType {
        name: "speed_control_valve",
        doc: "throttle in parallel with a check valve",
        params: speed_control_valve::PARAMS,
        ports: speed_control_valve::PORTS,
        outputs: speed_control_valve::OUTPUTS,
        build: |p| boxed(speed_control_valve::SpeedControlValve::from_params(p)),
    },
    BlockType {
        name: "valve_5_2",
        doc: "5/2 directional valve",
        params: directional_valve::PARAMS_5_2,
        ports: directional_valve::PORTS_5_2,
        outputs: directional_valve::OUTPUTS,
        build: |p| boxed(directional_valve::DirectionalValve::five_two(p)),
    },
    BlockType {
        name: "valve_3_2",
        doc: "3/2 directional valve",
        params: directional_valve::PARAMS_3_2,
        ports: directional_valve::PORTS_3_2,
        outputs: directional_valve::OUTPUTS,
        build: |p| boxed(directional_valve::DirectionalValve::three_two(p)),
    },
    BlockType {
        name: "valve_2_2",
        doc: "2/2 directional valve",
        params: directional_valve::PARAMS_2_2,
        ports: directional_valve::PORTS_2_2,
        outputs: directional_valve::OUTPUTS,
        build: |p| boxed(directional_valve::DirectionalValve::two_two(p)),
    },
    BlockType {
        name: "pressure_source",
        doc: "reservoir at fixed p and T (supply)",
        params: pressure_source::PARAMS,
        ports: pressure_source::PORTS,
        outputs: &[],
        build: |p| boxed(pressure_source::PressureSource::from_params(p, "pressure_source")),
    },
    BlockType {
        name: "atmosphere",
        doc: "ambient reservoir (exhaust)",
        params: pressure_source::ATMOSPHERE_PARAMS,
        ports: pressure_source::PORTS,
        outputs: &[],
        build: |p| boxed(pressure_source::PressureSource::from_params(p, "atmosphere")),
    },
    BlockType {
        name: "mass_flow_source",
        doc: "prescribed mass flow into a node",
        params: mass_flow_source::PARAMS,
        ports: mass_flow_source::PORTS,
        outputs: &[],
        build: |p| boxed(mass_flow_source::MassFlowSource::from_params(p)),
    },
    BlockType {
        name: "piston",
        doc: "moving mass with end stops",
        params: piston::PARAMS,
        ports: piston::PORTS,
        outputs: piston::OUTPUTS,
        build: |p| boxed(piston::Piston::from_params(p)),
    },
    BlockType {
        name: "friction",
        doc: "seal friction, Eq. 37, stick-slip (Karnopp 1985)",
        params: friction::PARAMS,
        ports: friction::PORTS,
        outputs: friction::OUTPUTS,
        build: |p| boxed(friction::Friction::from_params(p)),
    },
    BlockType {
        name: "spring",
        doc: "linear return spring",
        params: spring::PARAMS,
        ports: spring::PORTS,
        outputs: spring::OUTPUTS,
        build: |p| boxed(spring::Spring::from_params(p)),
    },
    BlockType {
        name: "schedule",
        doc: "time-table command signal",
        params: schedule::PARAMS,
        ports: schedule::PORTS,
        outputs: &[],
        build: |p| boxed(schedule::Schedule::from_params(p)),
    },
    BlockType {
        name: "cycler",
        doc: "limit-switch cycler (extend/retract for N cycles)",
        params: cycler::PARAMS,
        ports: cycler::PORTS,
        outputs: &[],
        build: |p| boxed(cycler::Cycler::from_params(p)),
    },
    BlockType {
        name: "delay",
        doc: "transport delay of a piecewise-constant signal",
        params: delay::PARAMS,
        ports: delay::PORTS,
        outputs: &[],
        build: |p| boxed(delay::Delay::from_params(p)),
    },
];

/// Look up a block type by name.
pub fn block_type(name: &str) -> Result<&'static BlockType, BlockError> {
    TYPES.iter().find(|t| t.name == name).ok_or_else(|| BlockError::UnknownType {
        name: name.to_string(),
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
