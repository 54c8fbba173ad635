//! The FMU's variables and value references follow the netlist's interface
//! section in the order the file writes it (docs/fmu.md, "Variables"):
//! value references 0, 1, … are the inputs as written, then the outputs as
//! written, then the top-level literal parameters (by name). Checked on the
//! list the runtime and the exporter share and in the exported
//! `modelDescription.xml` (the runtime library is only copied by the
//! exporter, so a stand-in file serves here).

use pneumo_app::fmu::{export, variables, Causality};
use std::io::Read;
use std::path::{Path, PathBuf};

fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/mid_stop_5_3.json")
}

const INPUTS: [&str; 2] = ["sol_14", "sol_12"];
const OUTPUTS: [&str; 6] = ["x", "v", "p_head", "p_rod", "spool", "air"];

#[test]
fn variables_are_the_inputs_then_the_outputs_in_the_order_written() {
    let (flat, _) = pneumo_app::load::netlist_with_files(&model(), &[]).unwrap_or_else(|e| panic!("{e}"));
    let vars = variables(&flat).unwrap_or_else(|e| panic!("{e}"));
    let named = |c: Causality| vars.iter().filter(|v| v.causality == c).map(|v| v.name.as_str()).collect::<Vec<_>>();
    assert_eq!(named(Causality::Input), INPUTS, "not alphabetical: sol_14 is written first");
    assert_eq!(named(Causality::Output), OUTPUTS);
    let parameters = named(Causality::Parameter);
    assert_eq!(parameters, ["T_ambient", "p_atm", "p_supply"]);
    let order: Vec<&str> = INPUTS.iter().chain(&OUTPUTS).chain(&parameters).copied().collect();
    assert_eq!(vars.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(), order);

    // the exported description numbers them in that order
    let dir = std::env::temp_dir().join(format!("pneumo-fmu-vars-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let runtime = dir.join("stand-in.so");
    std::fs::write(&runtime, b"not a library").unwrap();
    let fmu = dir.join("mid_stop.fmu");
    export(&model(), &fmu, &runtime).unwrap_or_else(|e| panic!("{e}"));
    let mut archive = zip::ZipArchive::new(std::fs::File::open(&fmu).unwrap()).unwrap();
    let mut xml = String::new();
    archive.by_name("modelDescription.xml").unwrap().read_to_string(&mut xml).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let listed: Vec<(String, usize)> = xml
        .split("<ScalarVariable ")
        .skip(1)
        .map(|v| {
            let attr = |name: &str| v.split(&format!("{name}=\"")).nth(1).and_then(|r| r.split('"').next()).unwrap().to_string();
            (attr("name"), attr("valueReference").parse().unwrap())
        })
        .collect();
    let expected: Vec<(String, usize)> = order.iter().enumerate().map(|(k, n)| (n.to_string(), k)).collect();
    assert_eq!(listed, expected);
}
