//! `pneumo linearize`.

use pneumo_app::linearize::{linearize, text, LinearizeOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct LinearizeArgs {
    /// Netlist file (JSON) with an interface section (inputs, outputs).
    pub model: PathBuf,
    /// Operating point: "rest", a time of a simulation ("t=1.2 s") or a trim,
    /// conditions NAME=VALUE separated by ';' ("piston.x=200 mm; F=0 N; head.p=4 bar").
    #[arg(long, default_value = "rest", value_name = "rest|t=TIME|NAME=VALUE;...")]
    pub at: String,
    /// Override a parameter: ID.PARAM=VALUE.
    #[arg(long = "set", value_name = "ID.PARAM=VALUE")]
    pub sets: Vec<String>,
    /// Write A, B, C, D, modes, Bode data (CSV) and linear.json into this directory.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Draw a Bode picture (magnitude and phase of every output/input pair): FILE.svg or FILE.png.
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    pub bode: Option<PathBuf>,
    /// Print the result as JSON.
    #[arg(long)]
    pub json: bool,
    /// Keep the states that reach no output.
    #[arg(long)]
    pub all_states: bool,
    #[command(flatten)]
    pub limits: super::Limits,
}

pub fn run(a: LinearizeArgs) -> Result<(), AppError> {
    let o = LinearizeOptions { model: a.model, sets: a.sets, at: a.at, out: a.out, keep_all_states: a.all_states, bode: a.bode };
    let r = linearize(&o)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&r.json).unwrap_or_default());
    } else {
        print!("{}", text(&r));
    }
    Ok(())
}
