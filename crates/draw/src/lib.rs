//! Circuit diagrams of pneumo netlists in the style of ISO 1219-1 (graphic
//! symbols) and ISO 1219-2 (circuit diagrams): an SVG any browser shows,
//! and a PNG of it.
//!
//! The pipeline runs one way: a [`graph::FlatNetlist`] is built into a
//! circuit (so only a valid circuit is drawn, with every parameter
//! evaluated), [`scene`] decides what is one symbol and what is one line,
//! [`symbols`] draws each symbol with its key parameters, [`layout`] places
//! them (supply at the bottom, valves in the middle, cylinders on top, one
//! column per actuator chain), [`route`] draws the lines on a grid, and
//! [`render`] writes the document. [`png`] rasterises it.
//!
//! Safe to share: every text from a netlist is escaped in one place
//! ([`svg`]), and the document holds no script, link or style sheet.
//! Deterministic: the same netlist gives the same bytes.
//!
//! Never knows: the solver, files, terminals (the command line reads and
//! writes; this crate turns a netlist into bytes).

pub mod catalogue;
pub mod format;
pub mod layout;
pub mod png;
pub mod render;
pub mod route;
pub mod scene;
pub mod shape;
pub mod svg;
pub mod symbols;
pub mod text;

pub use png::png;

/// Why a diagram could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum DrawError {
    #[error(transparent)]
    Graph(Box<graph::GraphError>),
    #[error("cannot render the picture: {0}")]
    Render(String),
    #[error("the picture would be {width} x {height} pixels, more than the {max} allowed; lower --scale")]
    TooLarge { width: u64, height: u64, max: u64 },
    #[error("internal error while drawing: {0}")]
    Internal(String),
}

impl From<graph::GraphError> for DrawError {
    fn from(e: graph::GraphError) -> Self {
        DrawError::Graph(Box::new(e))
    }
}

/// A drawn circuit.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagram {
    /// The SVG document.
    pub svg: String,
    /// Its size [px].
    pub width: f64,
    pub height: f64,
    /// Where each symbol went (for tests and tools that annotate the picture).
    pub placed: Vec<render::Placed>,
    /// Each line as drawn.
    pub nets: Vec<render::Drawn>,
}

/// Draw a netlist. `description` is the netlist's free text (shown, wrapped,
/// under the drawing); a flat netlist does not keep it.
pub fn diagram(flat: &graph::FlatNetlist, description: Option<&str>) -> Result<Diagram, DrawError> {
    let circuit = graph::build(flat)?;
    let scene = scene::build(flat, &circuit)?;
    let gas = format!("{:?} {:?}", flat.gas.model, flat.gas.species).to_lowercase();
    let title = render::TitleBlock { name: &flat.name, description, gas: &gas };
    let doc = render::document(&scene, &title);
    Ok(Diagram { svg: doc.svg, width: doc.width, height: doc.height, placed: doc.placed, nets: doc.nets })
}
