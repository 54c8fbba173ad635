//! The diagram use case (`pneumo draw`): the ISO 1219-1 circuit diagram of
//! a netlist file, with overrides applied, as SVG or PNG by the output's
//! extension. The drawing is made by `crates/draw`; this module reads the
//! files and writes the outputs together (or none).

use crate::error::shown_path;
use crate::load::Source;
use crate::output::Transaction;
use crate::AppError;
use std::path::{Path, PathBuf};

/// What to draw and where.
#[derive(Clone, Debug)]
pub struct DrawOptions {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Overrides `ID.PARAM=VALUE`; the labels show the new values.
    pub sets: Vec<String>,
    /// Pictures to write: `.svg` or `.png`.
    pub outputs: Vec<PathBuf>,
    /// Pixels per drawing unit of a PNG, in (0, 16].
    pub scale: f32,
}

/// The picture formats, by file extension.
enum Format {
    Svg,
    Png,
}

fn format_of(path: &Path) -> Result<Format, AppError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("svg") => Ok(Format::Svg),
        Some("png") => Ok(Format::Png),
        _ => Err(AppError::Usage(format!("--out {}: the file name must end in .svg or .png", shown_path(path)))),
    }
}

/// The diagram of a loaded model with its overrides applied. The
/// description is the free text of the top-level file, which the flat
/// netlist does not keep.
pub fn diagram_of(mut flat: graph::FlatNetlist, source: &Source, sets: &[String]) -> Result<draw::Diagram, AppError> {
    for s in sets {
        graph::apply_set(&mut flat, s)?;
    }
    let description =
        source.files.first().and_then(|(p, text)| graph::expand::parse(text, &p.display().to_string()).ok()).and_then(|n| n.description);
    Ok(draw::diagram(&flat, description.as_deref())?)
}

/// The diagram of the model at `path` with `sets` applied, and the files read.
pub fn diagram(path: &Path, sets: &[String]) -> Result<(draw::Diagram, Source), AppError> {
    let (flat, source) = Source::read(path)?;
    Ok((diagram_of(flat, &source, sets)?, source))
}

/// Draw the model and write every output, all or none.
pub fn draw(o: &DrawOptions) -> Result<(), AppError> {
    let formats: Vec<Format> = o.outputs.iter().map(|p| format_of(p)).collect::<Result<_, _>>()?;
    if !(o.scale.is_finite() && o.scale > 0.0 && o.scale <= 16.0) {
        return Err(AppError::Usage(format!("--scale {}: give a number in (0, 16]", o.scale)));
    }
    let (d, source) = diagram(&o.model, &o.sets)?;
    let inputs: Vec<&Path> = source.files.iter().map(|(p, _)| p.as_path()).collect();
    let mut outputs = Transaction::new(&inputs);
    let targets: Vec<&Path> = o.outputs.iter().map(PathBuf::as_path).collect();
    outputs.check_targets(&targets)?;
    for (path, format) in o.outputs.iter().zip(&formats) {
        let bytes = match format {
            Format::Svg => d.svg.as_bytes().to_vec(),
            Format::Png => draw::png(&d.svg, o.scale)?,
        };
        outputs.add(path, &bytes)?;
    }
    outputs.commit()
}
