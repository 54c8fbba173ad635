//! `pneumo check`: validate a netlist and print its causality table, or
//! write it as Graphviz with `--dot`.

use crate::error::CliError;
use crate::load::flat_netlist;
use crate::output::write_atomic;
use std::fmt::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Override a parameter: ID.PARAM=VALUE.
    #[arg(long = "set", value_name = "ID.PARAM=VALUE")]
    pub sets: Vec<String>,
    /// Write the circuit as a Graphviz file.
    #[arg(long, value_name = "FILE.dot")]
    pub dot: Option<PathBuf>,
}

pub fn run(a: &CheckArgs) -> Result<(), CliError> {
    let flat = flat_netlist(&a.model, &a.sets)?;
    let circuit = graph::build(&flat)?;
    solve::options_from(&circuit.simulation)?;
    if let Some(path) = &a.dot {
        write_atomic(path, graph::report::dot(&circuit).as_bytes())?;
    }
    print!("{}", graph::report::causality_table(&circuit));
    println!("\nok: {} is a valid circuit", a.model.display());
    Ok(())
}

/// All block types with their parameters (for `pneumo blocks`).
pub fn block_listing() -> String {
    let mut s = String::new();
    for t in blocks::registry::TYPES {
        let _ = writeln!(s, "{} — {}", t.name, t.doc);
        for p in t.params {
            let default = match (p.default, p.kind) {
                (None, _) => "required".to_string(),
                (Some(d), blocks::params::ParamKind::Choice(opts)) => opts.get(d as usize).copied().unwrap_or("").to_string(),
                (Some(d), _) if d.is_infinite() => "inf".into(),
                (Some(d), _) => display_default(d, p.display_unit),
            };
            let _ = writeln!(s, "    {:<20} {:<12} default {:<10} {}", p.name, p.display_unit, default, p.doc);
        }
    }
    s
}

/// A default (stored in SI) in the parameter's display unit, as listed beside it.
fn display_default(si: f64, display_unit: &str) -> String {
    let v = if display_unit.is_empty() { si } else { units::to_unit(si, display_unit).unwrap_or(si) };
    // 12 significant digits hide conversion noise such as 19.999999999999996
    let rounded: f64 = format!("{v:.11e}").parse().unwrap_or(v);
    format!("{rounded}")
}
