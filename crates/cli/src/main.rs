//! `pneumo`: the command-line front end. The only crate that touches files,
//! terminals and exit codes. Every failure reaches the user as one line on
//! stderr and a non-zero exit; output files are written whole or not at all.

mod check;
mod conductance;
mod discrepancy;
mod error;
mod load;
mod output;
mod plot;
mod run;
mod simulate;
mod sweep;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Simulate pneumatic circuits written as JSON netlists.
#[derive(Parser, Debug)]
#[command(name = "pneumo", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Check a netlist: wiring, units, causality; print the causality table.
    Check(check::CheckArgs),
    /// Simulate a netlist and write traces, a summary and plots.
    Simulate(simulate::SimulateArgs),
    /// Run a full-factorial parameter study in parallel.
    Sweep(sweep::SweepArgs),
    /// Join the outputs of sweep shards into one file.
    Merge(sweep::MergeArgs),
    /// Plot signals from result CSV files, or a sweep.
    Plot(plot::PlotArgs),
    /// Estimate sonic conductance C (and b) from a measured discharge of a known volume (paper Eq. 36).
    Conductance(conductance::ConductanceArgs),
    /// Find where simulation and measurement disagree, name the missing effect, add it, show the gap shrink.
    Discrepancy(discrepancy::DiscrepancyArgs),
    /// Print the JSON Schema of the netlist format.
    Schema,
    /// List the block types and their parameters.
    Blocks,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check(a) => check::run(&a),
        Command::Simulate(a) => simulate::run(&a),
        Command::Sweep(a) => sweep::run(&a),
        Command::Merge(a) => sweep::merge(&a),
        Command::Plot(a) => plot::run(&a),
        Command::Conductance(a) => conductance::run(&a),
        Command::Discrepancy(a) => discrepancy::run(&a),
        Command::Schema => {
            println!("{}", serde_json::to_string_pretty(&graph::netlist::schema()).unwrap_or_default());
            Ok(())
        }
        Command::Blocks => {
            print!("{}", check::block_listing());
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
