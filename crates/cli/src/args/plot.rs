//! `pneumo plot`.

use pneumo_app::plot::{plot, PlotOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct PlotArgs {
    /// Result CSV file(s) written by `pneumo simulate --out`; the same signals are overlaid.
    #[arg(value_name = "RESULT.csv", required_unless_present = "sweep", conflicts_with = "sweep")]
    pub inputs: Vec<PathBuf>,
    /// Signals to plot, comma separated (e.g. head.p,rod.p); default: every column.
    #[arg(long = "signals", value_delimiter = ',', value_name = "ID.SIGNAL,...")]
    pub signals: Vec<String>,
    /// Scale each file's time to [0, 1] of its duration and each trace to [0, 1] of its range.
    #[arg(long, conflicts_with = "sweep")]
    pub normalize: bool,
    /// Horizontal axis: a signal column instead of time (e.g. piston.x), or with --sweep the
    /// varied parameter column (e.g. flow_control.C).
    #[arg(long, value_name = "COLUMN")]
    pub x: Option<String>,
    /// Sweep table (CSV: varied parameters in SI, cycle_time_s, optional error column).
    #[arg(long, value_name = "SWEEP.csv")]
    pub sweep: Option<PathBuf>,
    /// Sweep column on the vertical axis [default: cycle_time_s].
    #[arg(long, value_name = "COLUMN", requires = "sweep")]
    pub y: Option<String>,
    /// Sweep column whose values give one line each (e.g. supply.p).
    #[arg(long, value_name = "COLUMN", requires = "sweep")]
    pub series: Option<String>,
    /// Picture to write (.png or .svg).
    #[arg(short = 'o', long = "output", value_name = "FILE.png|FILE.svg")]
    pub output: PathBuf,
    /// Title of the picture.
    #[arg(long)]
    pub title: Option<String>,
    /// Vertical range LO,HI in the axis' display units; points outside break the line
    /// (e.g. 0.5,2 for a polytropic index that runs off to infinity when ρ̇ = 0).
    #[arg(long = "y-range", value_name = "LO,HI", value_delimiter = ',', allow_negative_numbers = true)]
    pub y_range: Vec<f64>,
    #[command(flatten)]
    pub limits: super::MemoryLimit,
}

pub fn run(a: PlotArgs) -> Result<(), AppError> {
    let o = PlotOptions {
        inputs: a.inputs,
        signals: a.signals,
        normalize: a.normalize,
        x: a.x,
        sweep: a.sweep,
        y: a.y,
        series: a.series,
        output: a.output,
        title: a.title,
        y_range: a.y_range,
    };
    plot(&o)?;
    println!("wrote {}", pneumo_app::error::shown_path(&o.output));
    Ok(())
}
