//! `pneumo draw`: the circuit diagram of a netlist (ISO 1219-1 symbols),
//! as SVG or PNG by the output's extension. The drawing is made by
//! `crates/draw`; this module reads the files and writes the outputs
//! together (or none).

use crate::error::CliError;
use crate::load::Source;
use crate::output::Transaction;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct DrawArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Override a parameter: ID.PARAM=VALUE (the labels show the new value).
    #[arg(long = "set", value_name = "ID.PARAM=VALUE")]
    pub sets: Vec<String>,
    /// Output picture: FILE.svg or FILE.png (repeat for both).
    #[arg(long = "out", short = 'o', value_name = "FILE.svg|FILE.png", required = true)]
    pub out: Vec<PathBuf>,
    /// Pixels per drawing unit of a PNG.
    #[arg(long, default_value_t = 2.0)]
    pub scale: f32,
}

/// The picture formats, by file extension.
enum Format {
    Svg,
    Png,
}

fn format_of(path: &Path) -> Result<Format, CliError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("svg") => Ok(Format::Svg),
        Some("png") => Ok(Format::Png),
        _ => Err(CliError::Usage(format!("--out {}: the file name must end in .svg or .png", crate::error::shown_path(path)))),
    }
}

/// The diagram of the model at `path` with `sets` applied: the SVG text.
pub fn diagram(path: &Path, sets: &[String]) -> Result<(draw::Diagram, Source), CliError> {
    let (mut flat, source) = Source::read(path)?;
    for s in sets {
        graph::apply_set(&mut flat, s)?;
    }
    // the description is free text of the top-level file, which the flat netlist does not keep
    let description =
        source.files.first().and_then(|(p, text)| graph::expand::parse(text, &p.display().to_string()).ok()).and_then(|n| n.description);
    let d = draw::diagram(&flat, description.as_deref()).map_err(CliError::from)?;
    Ok((d, source))
}

pub fn run(a: &DrawArgs) -> Result<(), CliError> {
    let formats: Vec<Format> = a.out.iter().map(|p| format_of(p)).collect::<Result<_, _>>()?;
    if !(a.scale.is_finite() && a.scale > 0.0 && a.scale <= 16.0) {
        return Err(CliError::Usage(format!("--scale {}: give a number in (0, 16]", a.scale)));
    }
    let (d, source) = diagram(&a.model, &a.sets)?;
    let inputs: Vec<&Path> = source.files.iter().map(|(p, _)| p.as_path()).collect();
    let mut outputs = Transaction::new(&inputs);
    let targets: Vec<&Path> = a.out.iter().map(PathBuf::as_path).collect();
    outputs.check_targets(&targets)?;
    for (path, format) in a.out.iter().zip(&formats) {
        let bytes = match format {
            Format::Svg => d.svg.as_bytes().to_vec(),
            Format::Png => draw::png(&d.svg, a.scale).map_err(CliError::from)?,
        };
        outputs.add(path, &bytes)?;
    }
    outputs.commit()?;
    Ok(())
}
