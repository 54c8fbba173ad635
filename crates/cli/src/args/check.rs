//! `pneumo check` and `pneumo blocks`.

use pneumo_app::check::{check_file, CheckOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Override a parameter: ID.PARAM=VALUE.
    #[arg(long = "set", value_name = "ID.PARAM=VALUE", allow_hyphen_values = true)]
    pub sets: Vec<String>,
    /// Write the circuit as a Graphviz file.
    #[arg(long, value_name = "FILE.dot")]
    pub dot: Option<PathBuf>,
    #[command(flatten)]
    pub limits: super::Limits,
}

pub fn run(a: CheckArgs) -> Result<(), AppError> {
    let o = CheckOptions { model: a.model, sets: a.sets, dot: a.dot };
    let checked = check_file(&o, &mut |w| super::print_warnings(w))?;
    print!("{}", checked.text);
    println!("\nok: {} is a valid circuit", o.model.display());
    Ok(())
}

pub fn blocks() -> Result<(), AppError> {
    print!("{}", pneumo_app::check::block_listing());
    Ok(())
}
