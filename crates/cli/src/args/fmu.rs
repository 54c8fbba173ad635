//! `pneumo fmu`: export a netlist as an FMI 2.0 Co-Simulation FMU.

use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct FmuArgs {
    /// Netlist file (JSON) with an `interface` section.
    pub model: PathBuf,
    /// The FMU to write.
    #[arg(long, value_name = "FILE.fmu")]
    pub out: PathBuf,
    #[command(flatten)]
    pub limits: super::Limits,
}

pub fn run(a: FmuArgs) -> Result<(), AppError> {
    let runtime = pneumo_app::fmu::runtime_beside_executable()?;
    pneumo_app::fmu::export(&a.model, &a.out, &runtime)?;
    println!("wrote {}", a.out.display());
    Ok(())
}
