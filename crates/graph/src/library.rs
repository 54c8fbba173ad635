//! Built-in sub-circuits: components made of blocks, found by name from any
//! netlist (`"type": "cylinder"`, or `"type": "subsystem", "file":
//! "lib:cylinder"`) rather than by a path relative to the user's file.
//!
//! Their netlists are the files in `models/lib/`, compiled into the program,
//! so a netlist anywhere on disk (or given as text) finds the same
//! component. Each is expanded exactly as a subsystem file would be: its
//! `parameters` are what an instance may set, its `interface` names the ports
//! and initial values it exposes (docs/netlist.md, "Built-in components").

/// One built-in sub-circuit.
#[derive(Debug, Clone, Copy)]
pub struct Entry {
    /// Type name (`"cylinder"`).
    pub name: &'static str,
    /// Its netlist (JSON).
    pub text: &'static str,
}

/// The built-in sub-circuits, by name.
pub const ENTRIES: &[Entry] = &[
    Entry { name: "cylinder", text: include_str!("../../../models/lib/cylinder.json") },
    Entry { name: "cylinder_cushioned", text: include_str!("../../../models/lib/cylinder_cushioned.json") },
    Entry { name: "cylinder_single_acting", text: include_str!("../../../models/lib/cylinder_single_acting.json") },
];

/// Prefix of a built-in written as a subsystem file (`"file": "lib:cylinder"`).
pub const FILE_PREFIX: &str = "lib:";

/// The built-in of this type name.
pub fn get(name: &str) -> Option<&'static Entry> {
    ENTRIES.iter().find(|e| e.name == name)
}

/// The built-in a subsystem file names (`lib:cylinder`), if it names one
/// (`Err` with the known names when the prefix is there but the name is not).
pub fn from_file(file: &str) -> Option<Result<&'static Entry, String>> {
    let name = file.strip_prefix(FILE_PREFIX)?;
    Some(get(name).ok_or_else(|| {
        let hint = blocks::suggest::did_you_mean(name, ENTRIES.iter().map(|e| e.name));
        format!("no built-in component \"{}\"{hint} (built in: {})", crate::escape(name), names().join(", "))
    }))
}

/// Names of all built-ins.
pub fn names() -> Vec<&'static str> {
    ENTRIES.iter().map(|e| e.name).collect()
}

/// The parsed netlist of a built-in.
pub fn netlist(entry: &Entry) -> Result<crate::Netlist, crate::GraphError> {
    crate::expand::parse(entry.text, &origin(entry))
}

/// How a built-in is named as the origin of its components in messages.
pub fn origin(entry: &Entry) -> String {
    format!("{FILE_PREFIX}{}", entry.name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_parses_and_names_no_block_type() {
        for e in ENTRIES {
            let n = netlist(e).unwrap_or_else(|err| panic!("{}: {err}", e.name));
            assert_eq!(n.name.as_deref(), Some(e.name), "the file's name is the type name");
            assert!(blocks::registry::block_type(e.name).is_err(), "{} is also a block type", e.name);
            assert_ne!(e.name, "subsystem");
            let interface = n.interface.expect("a built-in declares its ports");
            assert!(interface.ports.contains_key("head_port") && interface.ports.contains_key("rod"), "{}", e.name);
        }
    }

    #[test]
    fn lib_prefix_finds_a_built_in_or_suggests_one() {
        assert_eq!(from_file("lib:cylinder").unwrap().unwrap().name, "cylinder");
        assert!(from_file("lib/cylinder.json").is_none());
        let e = from_file("lib:cylnder").unwrap().unwrap_err();
        assert!(e.contains("did you mean \"cylinder\"") && e.contains("cylinder_single_acting"), "{e}");
    }
}
