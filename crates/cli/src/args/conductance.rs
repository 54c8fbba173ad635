//! `pneumo conductance`.

use pneumo_app::conductance::{conductance, ConductanceOptions, Thermal};
use pneumo_app::AppError;
use std::path::PathBuf;

/// Thermal model named on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThermalArg {
    /// Fit τ_T (to p, and to T when the data have it) and keep a limit unless the data reject it.
    Auto,
    /// τ_T = ∞ (the assumption of Eq. 36).
    Adiabatic,
    /// τ_T → 0: the gas stays at the wall temperature.
    Isothermal,
}

#[derive(clap::Args, Debug)]
pub struct ConductanceArgs {
    /// Volume discharged (tank plus line), e.g. "1 L" (a bare number is m³).
    // quantities may start with '-': the use case explains why they must be positive
    #[arg(long, allow_hyphen_values = true)]
    pub volume: String,
    /// CSV file with header t,p (optionally T), SI units: s, Pa absolute, K.
    #[arg(long, value_name = "FILE.csv")]
    pub data: PathBuf,
    /// Atmospheric pressure downstream of the restriction (default: fitted
    /// with C and b, started at 1.01325 bar or at the end of the trace).
    #[arg(long = "p-atm", allow_hyphen_values = true)]
    pub p_atm: Option<String>,
    /// Initial gas (and wall) temperature (default: first T sample, else 293.15 K).
    #[arg(long = "T0", allow_hyphen_values = true)]
    pub t0: Option<String>,
    /// Thermal model of the tank.
    #[arg(long, value_enum, default_value_t = ThermalArg::Auto)]
    pub thermal: ThermalArg,
    /// Thermal time constant τ_T of the tank, known beforehand, e.g. "1 s"
    /// ("inf": adiabatic, "0": isothermal); replaces the fitted one.
    #[arg(long = "tau-thermal", allow_hyphen_values = true)]
    pub tau_thermal: Option<String>,
    /// Fit the pressure trace only, even when the data have a T column (T
    /// still gives T0).
    #[arg(long = "pressure-only")]
    pub pressure_only: bool,
    /// Critical ratio bounding the choked window of the unloading-time
    /// estimate (default: b from the model fit).
    #[arg(long = "b-window", allow_negative_numbers = true)]
    pub b_window: Option<f64>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Column of the tank pressure [default: p]; e.g. tank.p to read what
    /// `pneumo simulate --out` wrote.
    #[arg(long = "p-column", value_name = "COLUMN")]
    pub p_column: Option<String>,
    /// Column of the gas temperature [default: T, when there is one]; e.g. tank.T.
    #[arg(long = "T-column", value_name = "COLUMN")]
    pub t_column: Option<String>,
    #[command(flatten)]
    pub limits: super::MemoryLimit,
}

pub fn run(a: ConductanceArgs) -> Result<(), AppError> {
    let thermal = match a.thermal {
        ThermalArg::Auto => Thermal::Auto,
        ThermalArg::Adiabatic => Thermal::Adiabatic,
        ThermalArg::Isothermal => Thermal::Isothermal,
    };
    let o = ConductanceOptions {
        volume: a.volume,
        data: a.data,
        p_atm: a.p_atm,
        t0: a.t0,
        thermal,
        tau_thermal: a.tau_thermal,
        pressure_only: a.pressure_only,
        b_window: a.b_window,
        json: a.json,
        p_column: a.p_column,
        t_column: a.t_column,
    };
    let report = conductance(&o)?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    print!("{}", report.text);
    Ok(())
}
