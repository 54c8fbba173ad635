//! `pneumo draw`.

use pneumo_app::draw::{draw, DrawOptions};
use pneumo_app::AppError;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct DrawArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Override a parameter: ID.PARAM=VALUE (the labels show the new value).
    #[arg(long = "set", value_name = "ID.PARAM=VALUE", allow_hyphen_values = true)]
    pub sets: Vec<String>,
    /// Output picture: FILE.svg or FILE.png (repeat for both).
    #[arg(long = "out", short = 'o', value_name = "FILE.svg|FILE.png", required = true)]
    pub out: Vec<PathBuf>,
    /// Pixels per drawing unit of a PNG.
    #[arg(long, default_value_t = 2.0)]
    pub scale: f32,
    #[command(flatten)]
    pub limits: super::Limits,
}

pub fn run(a: DrawArgs) -> Result<(), AppError> {
    draw(&DrawOptions { model: a.model, sets: a.sets, outputs: a.out, scale: a.scale })
}
