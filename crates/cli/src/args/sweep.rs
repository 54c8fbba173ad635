//! `pneumo sweep` (with a progress bar on a terminal) and `pneumo merge`.

use pneumo_app::sweep::{merge, MergeOptions, Sweep, SweepOptions, DEFAULT_MAX_CASES};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct SweepArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// A parameter and its values: ID.PARAM=V1,V2,... (e.g. "supply.p=4 bar,7 bar").
    /// Repeat for a full factorial; the last --vary changes fastest.
    #[arg(long = "vary", value_name = "ID.PARAM=V1,V2,...", required = true, allow_hyphen_values = true)]
    pub vary: Vec<String>,
    /// Override a parameter in every case: ID.PARAM=VALUE.
    #[arg(long = "set", value_name = "ID.PARAM=VALUE", allow_hyphen_values = true)]
    pub sets: Vec<String>,
    /// Number of actuator cycles per case (at least 1).
    #[arg(long, value_name = "N", value_parser = super::at_least_one::<u64>, allow_negative_numbers = true)]
    pub cycles: Option<u64>,
    /// End time of each case [s].
    #[arg(long = "t-end", value_name = "SECONDS", allow_negative_numbers = true)]
    pub t_end: Option<f64>,
    /// Most worker threads (default: the available parallelism); never more
    /// than the cases, nor than 4 per available core.
    #[arg(long, value_name = "N", value_parser = super::at_least_one::<usize>, allow_negative_numbers = true)]
    pub jobs: Option<usize>,
    /// Run only shard K of N (1-based K): the cases whose index mod N is K-1.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Write one row per case (CSV, or JSON if the name ends in .json).
    #[arg(long, value_name = "FILE.csv|FILE.json")]
    pub out: Option<PathBuf>,
    /// Most cases this process runs (the whole sweep, or its shard); raise it, or split the sweep with --shard.
    #[arg(long = "max-cases", value_name = "N", default_value_t = DEFAULT_MAX_CASES, allow_negative_numbers = true)]
    pub max_cases: usize,
    #[command(flatten)]
    pub limits: super::Limits,
}

#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Shard outputs to join (CSV or JSON, as written by `pneumo sweep`).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Merged file (CSV, or JSON if the name ends in .json).
    #[arg(long, value_name = "FILE.csv|FILE.json")]
    pub out: PathBuf,
    /// Most cases the merged sweep may hold.
    #[arg(long = "max-cases", value_name = "N", default_value_t = DEFAULT_MAX_CASES, allow_negative_numbers = true)]
    pub max_cases: usize,
    #[command(flatten)]
    pub limits: super::MemoryLimit,
}

pub fn run(a: SweepArgs) -> Result<(), AppError> {
    let o = SweepOptions {
        model: a.model,
        vary: a.vary,
        sets: a.sets,
        cycles: a.cycles,
        t_end: a.t_end,
        jobs: a.jobs,
        shard: a.shard,
        out: a.out,
        max_cases: a.max_cases,
    };
    let sweep = Sweep::new(&o)?;
    let bar = progress_bar(sweep.plan().selected().len());
    let done = sweep.run(&|| bar.inc(1))?;
    bar.finish_and_clear();
    print!("{}", done.text());
    Ok(())
}

pub fn run_merge(a: MergeArgs) -> Result<(), AppError> {
    let o = MergeOptions { inputs: a.inputs, out: a.out, max_cases: a.max_cases };
    let cases = merge(&o)?;
    println!("merged {cases} cases from {} files into {}", o.inputs.len(), o.out.display());
    Ok(())
}

/// A progress bar on stderr when it is a terminal; hidden otherwise.
fn progress_bar(n: usize) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(n as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} cases  {elapsed} elapsed, ETA {eta}") {
        bar.set_style(style);
    }
    bar
}
