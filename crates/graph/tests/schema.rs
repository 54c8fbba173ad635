//! The JSON Schema (`pneumo schema`) accepts what the program accepts: every
//! component type and every `params`/`init` key of the shipped models,
//! built-in components (`"type": "cylinder"`) included, so that an editor
//! validating a netlist against it flags nothing the program would run.

use serde_json::Value;
use std::path::{Path, PathBuf};

fn models() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("models dir").flatten() {
            let p = entry.path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "json") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models"), &mut out);
    out.sort();
    out
}

/// The `params` properties the schema allows for a component type, or
/// `None` when it leaves them open.
fn allowed_keys(schema: &Value, kind: &str) -> Option<Vec<String>> {
    let rules = schema.pointer("/$defs/Component/allOf")?.as_array()?;
    let rule = rules.iter().find(|r| r.pointer("/if/properties/type/const").and_then(Value::as_str) == Some(kind))?;
    let params = rule.pointer("/then/properties/params")?;
    assert_eq!(params["additionalProperties"], Value::Bool(false), "{kind}: the schema should close its params");
    Some(params["properties"].as_object()?.keys().cloned().collect())
}

#[test]
fn the_schema_lists_every_type_and_parameter_the_shipped_models_use() {
    let schema = graph::netlist::schema();
    let types: Vec<&str> = schema
        .pointer("/$defs/Component/properties/type/enum")
        .and_then(Value::as_array)
        .expect("a type enum")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    for name in ["cylinder", "cylinder_cushioned", "cylinder_single_acting", "chamber", "subsystem"] {
        assert!(types.contains(&name), "the schema's types lack {name}: {types:?}");
    }
    let mut built_ins_seen = 0;
    let mut components_seen = 0;
    for path in models() {
        let text = std::fs::read_to_string(&path).expect("read model");
        let Ok(netlist) = serde_json::from_str::<graph::Netlist>(&text) else { continue };
        for c in &netlist.components {
            components_seen += 1;
            assert!(types.contains(&c.kind.as_str()), "{}: component {} has type {} that the schema refuses", path.display(), c.id, c.kind);
            if graph::library::get(&c.kind).is_some() {
                built_ins_seen += 1;
            }
            let Some(allowed) = allowed_keys(&schema, &c.kind) else {
                assert_eq!(c.kind, "subsystem", "{}: no parameter rule for type {}", path.display(), c.kind);
                continue;
            };
            for key in c.params.keys().chain(c.init.keys()) {
                assert!(allowed.contains(key), "{}: {}.{key} ({}) is not in the schema: {allowed:?}", path.display(), c.id, c.kind);
            }
        }
    }
    assert!(components_seen > 50 && built_ins_seen >= 5, "walked {components_seen} components, {built_ins_seen} built-ins");
}

#[test]
fn a_built_in_s_parameters_are_described_and_closed() {
    let schema = graph::netlist::schema();
    let allowed = allowed_keys(&schema, "cylinder").expect("a rule for the built-in cylinder");
    for key in ["bore", "stroke", "rod_diameter", "head_p0", "x0"] {
        assert!(allowed.iter().any(|k| k == key), "cylinder lacks {key}: {allowed:?}");
    }
    assert!(!allowed.iter().any(|k| k == "length_at_zero"), "an inner block's parameter is not the cylinder's");
    let bore = schema
        .pointer("/$defs/Component/allOf")
        .and_then(Value::as_array)
        .and_then(|rules| rules.iter().find(|r| r.pointer("/if/properties/type/const") == Some(&Value::from("cylinder"))))
        .and_then(|r| r.pointer("/then/properties/params/properties/bore/description"))
        .and_then(Value::as_str)
        .expect("bore described");
    assert!(bore.contains("piston diameter") && bore.contains("45 mm"), "{bore}");
}
