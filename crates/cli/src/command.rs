//! The `pneumo` command line as a library function: argument parsing and
//! dispatch to the subcommands' modules (`src/args/`), one-line errors and
//! exit statuses. Used by the binary (`src/main.rs`) and by the Python
//! package (`python -m pneumo`), so both are the same program.

use crate::args::{check, conductance, discrepancy, draw, fmu, linearize, plot, report, simulate, sweep};
use clap::{Parser, Subcommand};
use pneumo_app::error::one_line;

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
    /// Linear model (A, B, C, D), modes and Bode data about an operating point.
    Linearize(linearize::LinearizeArgs),
    /// Export a netlist with an interface as an FMI 2.0 Co-Simulation FMU (docs/fmu.md).
    Fmu(fmu::FmuArgs),
    /// Draw the circuit diagram (ISO 1219-1 symbols) as SVG or PNG.
    Draw(draw::DrawArgs),
    /// Run a netlist and write one self-contained HTML page: diagram, interactive traces, summary tables.
    Report(report::ReportArgs),
    /// Print the JSON Schema of the netlist format.
    Schema,
    /// List the block types and their parameters.
    Blocks,
}

/// Run `pneumo` with these arguments (the first is the program name) and
/// return its exit status (0 ok, 1 error, 2 usage error, 3 incomplete run).
/// Errors are printed as one line on stderr.
pub fn run<I, T>(args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => return usage_error(e),
    };
    let result = match cli.command {
        Command::Check(a) => {
            a.limits.apply();
            check::run(a)
        }
        Command::Simulate(a) => {
            a.limits.apply();
            simulate::run(a)
        }
        Command::Sweep(a) => {
            a.limits.apply();
            sweep::run(a)
        }
        Command::Merge(a) => {
            a.limits.apply();
            sweep::run_merge(a)
        }
        Command::Plot(a) => {
            a.limits.apply();
            plot::run(a)
        }
        Command::Conductance(a) => {
            a.limits.apply();
            conductance::run(a)
        }
        Command::Discrepancy(a) => {
            a.limits.apply();
            discrepancy::run(a)
        }
        Command::Linearize(a) => {
            a.limits.apply();
            linearize::run(a)
        }
        Command::Fmu(a) => {
            a.limits.apply();
            fmu::run(a)
        }
        Command::Draw(a) => {
            a.limits.apply();
            draw::run(a)
        }
        Command::Report(a) => {
            a.limits.apply();
            report::run(a)
        }
        Command::Schema => {
            println!("{}", serde_json::to_string_pretty(&graph::netlist::schema()).unwrap_or_default());
            Ok(())
        }
        Command::Blocks => check::blocks(),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {}", one_line(&e.to_string()));
            e.exit_code()
        }
    }
}

/// clap's errors in one line (its first line, with the command to get help);
/// `--help` and `--version` keep their full text on stdout.
fn usage_error(e: clap::Error) -> u8 {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            0
        }
        _ => {
            // the message is the text before clap's "Usage:" and tip lines
            let text = e.render().to_string();
            let lines: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .filter(|l| !l.is_empty() && !l.starts_with("tip:"))
                .collect();
            let joined = lines.join(" ");
            let message = joined.strip_prefix("error: ").unwrap_or(&joined);
            let message = if message.is_empty() { "invalid arguments" } else { message };
            eprintln!("error: {} (see pneumo --help)", one_line(message));
            2
        }
    }
}
