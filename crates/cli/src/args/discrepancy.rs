//! `pneumo discrepancy`.

use pneumo_app::discrepancy::{discrepancy, text_summary, DiscrepancyOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct DiscrepancyArgs {
    /// Model netlist (JSON).
    #[arg(value_name = "MODEL.json")]
    pub input: PathBuf,
    /// Experiments manifest (JSON): data files, operating points, column mapping.
    #[arg(long, value_name = "EXPERIMENTS.json", required = true)]
    pub experiments: PathBuf,
    /// Write the augmented netlist, figures and report.md into this directory.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub limits: super::Limits,
}

pub fn run(a: DiscrepancyArgs) -> Result<(), AppError> {
    let found = discrepancy(&DiscrepancyOptions { model: a.input, experiments: a.experiments, report: a.report })?;
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
