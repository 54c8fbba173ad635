//! `pneumo simulate`.

use pneumo_app::simulate::{run_text, simulate, SimulateOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Override a parameter: ID.PARAM=VALUE (e.g. "flow_control.C=13.2 L/min/bar").
    #[arg(long = "set", value_name = "ID.PARAM=VALUE", allow_hyphen_values = true)]
    pub sets: Vec<String>,
    /// Number of actuator cycles to run (at least 1).
    #[arg(long, value_name = "N", conflicts_with = "t_end", value_parser = super::at_least_one::<u64>, allow_negative_numbers = true)]
    pub cycles: Option<u64>,
    /// End time [s].
    #[arg(long = "t-end", value_name = "SECONDS", allow_negative_numbers = true)]
    pub t_end: Option<f64>,
    /// Write time traces (CSV, SI units).
    #[arg(long, value_name = "FILE.csv")]
    pub out: Option<PathBuf>,
    /// Write the summary (JSON).
    #[arg(long, value_name = "FILE.json")]
    pub summary: Option<PathBuf>,
    /// Plot the written signals (PNG or SVG by extension).
    #[arg(long, value_name = "FILE.png|FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Write each column's SI unit in the CSV header ("head.p [Pa]"), as pandas users like it.
    #[arg(long = "header-units")]
    pub header_units: bool,
    /// Signals to write (default: the netlist's outputs, or all).
    #[arg(long = "signals", value_delimiter = ',')]
    pub signals: Vec<String>,
    #[command(flatten)]
    pub limits: super::Limits,
}

/// Run, print the cycle times and balances; a run that did not complete its
/// cycles still prints them, then fails with exit status 3.
pub fn run(a: SimulateArgs) -> Result<(), AppError> {
    let o = SimulateOptions {
        model: a.model,
        sets: a.sets,
        cycles: a.cycles,
        t_end: a.t_end,
        out: a.out,
        summary: a.summary,
        plot: a.plot,
        header_units: a.header_units,
        signals: a.signals,
    };
    let r = simulate(&o, &mut |w| super::print_warnings(w))?;
    print!("{}", run_text(&r));
    match r.incomplete {
        Some(why) => Err(AppError::Incomplete(why)),
        None => Ok(()),
    }
}
