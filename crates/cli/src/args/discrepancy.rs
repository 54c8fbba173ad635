//! `pneumo discrepancy`.

use pneumo_app::discrepancy::{discrepancy, text_summary, DiscrepancyOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct DiscrepancyArgs {
    /// Model netlist (JSON).
    pub input: Option<PathBuf>,
    /// Experiments manifest (JSON): data files, operating points, column mapping.
    #[arg(long, value_name = "EXPERIMENTS.json")]
    pub experiments: Option<PathBuf>,
    /// Write the augmented netlist, figures and report.md into this directory.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: DiscrepancyArgs) -> Result<(), AppError> {
    let model = a
        .input
        .ok_or_else(|| AppError::Usage("give the model netlist: pneumo discrepancy MODEL.json --experiments EXPERIMENTS.json".into()))?;
    let experiments = a.experiments.ok_or_else(|| AppError::Usage("give --experiments EXPERIMENTS.json".into()))?;
    let found = discrepancy(&DiscrepancyOptions { model, experiments, report: a.report })?;
    if a.json {
        println!("{}", found.summary_json);
    } else {
        print!("{}", text_summary(&found.outcome));
        for w in &found.written {
            println!("wrote {}", w.display());
        }
    }
    Ok(())
}
