//! `pneumo report`.

use pneumo_app::report::{report, ReportOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct ReportArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Override a parameter: ID.PARAM=VALUE (repeatable, applied in order).
    #[arg(long = "set", value_name = "ID.PARAM=VALUE", allow_hyphen_values = true)]
    pub sets: Vec<String>,
    /// Number of actuator cycles to run (at least 1).
    #[arg(long, value_name = "N", conflicts_with = "t_end", value_parser = super::at_least_one::<u64>, allow_negative_numbers = true)]
    pub cycles: Option<u64>,
    /// End time [s].
    #[arg(long = "t-end", value_name = "SECONDS", allow_negative_numbers = true)]
    pub t_end: Option<f64>,
    /// Experiments manifest (as for `pneumo discrepancy`): add the discrepancy
    /// result (verdict, before/after plots with the measurements, estimates,
    /// candidates) to the page.
    #[arg(long, value_name = "E.json")]
    pub experiments: Option<PathBuf>,
    /// The page to write: one self-contained HTML file.
    #[arg(long = "out", short = 'o', value_name = "FILE.html")]
    pub out: PathBuf,
    #[command(flatten)]
    pub limits: super::Limits,
}

/// Run, write the page, print the cycle times; a run that did not complete
/// its cycles still writes its page, then fails with exit status 3.
pub fn run(a: ReportArgs) -> Result<(), AppError> {
    let o = ReportOptions { model: a.model, sets: a.sets, cycles: a.cycles, t_end: a.t_end, output: a.out, experiments: a.experiments };
    let r = report(&o, &mut |w| super::print_warnings(w))?;
    print!("{}", pneumo_app::simulate::run_text(&r));
    println!("wrote {}", pneumo_app::error::shown_path(&o.output));
    match r.incomplete {
        Some(why) => Err(AppError::Incomplete(why)),
        None => Ok(()),
    }
}
