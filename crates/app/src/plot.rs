//! Pictures of results: time traces of a simulation (`simulate --plot`), the
//! same signals overlaid from several result files (`pneumo plot`), and a
//! sweep's cycle time against a varied parameter (`pneumo plot --sweep`, the
//! layout of the paper's Figs. 4–5; `--normalize` gives the normalised
//! trajectories of its Fig. 6).
//!
//! No physics is computed here; the only arithmetic is unit conversion and
//! normalisation:
//! - display value = SI value converted with `units::parse_unit(display)`
//!   (pressures are shown in bar, parameters in their registry display unit,
//!   e.g. conductance C in L/(min·bar));
//! - normalised time  τ = (t − t_first) / (t_last − t_first) of each file;
//! - normalised value y* = (y − y_min) / (y_max − y_min) of each trace
//!   (0 when the trace is constant).
//!
//! Data are SI f64 (Pa, K, m, m/s, kg/s, s). Undefined samples (`None`, an
//! empty CSV cell, or a non-finite number) break the drawn line. Signals are
//! grouped by physical quantity into at most [`MAX_PANELS`] stacked panels
//! (pressure, temperature, position, velocity first: each quantity on its own
//! axis, so a 0.45 m stroke is not squashed under ±4 m/s velocity spikes;
//! pressures are absolute, labelled "bar (abs)"); signals that do not fit
//! are named in a note under the picture rather than silently dropped.
//!
//! Output is PNG or SVG, chosen by the file extension. Text is drawn with the
//! bundled DejaVu Sans (assets/fonts, Bitstream Vera licence), registered with
//! plotters' ab_glyph support, so no system fonts are needed. PNGs are
//! rendered into a private scratch directory and read back; the caller writes
//! the returned bytes with [`crate::output::Transaction`].

use crate::error::AppError;
use plotters::coord::Shift;
use plotters::prelude::{
    BitMapBackend, ChartBuilder, Circle, Color, DrawingArea, DrawingAreaErrorKind, DrawingBackend, FontStyle, IntoDrawingArea, IntoFont,
    IntoLogRange, LineSeries, PathElement, RGBColor, SVGBackend, SeriesLabelPosition, TextStyle, BLACK, WHITE,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// At most this many stacked panels in one picture.
pub const MAX_PANELS: usize = 4;

const FONT_FAMILY: &str = "sans-serif";
static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

const WIDTH: u32 = 1200;
const PANEL_HEIGHT: u32 = 320;
const TITLE_HEIGHT: u32 = 60;
const NOTE_HEIGHT: u32 = 30;

/// Distinguishable line colours (the "tab10" set).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// A picture from result files or a sweep table (`pneumo plot`).
#[derive(Debug, Clone, Default)]
pub struct PlotOptions {
    /// Result CSV files written by `pneumo simulate --out`; the same signals are overlaid.
    pub inputs: Vec<PathBuf>,
    /// Signals to plot (empty: every column).
    pub signals: Vec<String>,
    /// Scale each file's time to [0, 1] of its duration and each trace to [0, 1] of its range.
    pub normalize: bool,
    /// Horizontal axis: a signal column instead of time (e.g. piston.x), or
    /// with `sweep` the varied parameter column (e.g. flow_control.C).
    pub x: Option<String>,
    /// Sweep table (CSV: varied parameters in SI, cycle_time_s, optional error column).
    pub sweep: Option<PathBuf>,
    /// Sweep column on the vertical axis (None: cycle_time_s).
    pub y: Option<String>,
    /// Sweep column whose values give one line each (e.g. supply.p).
    pub series: Option<String>,
    /// Picture to write (.png or .svg).
    pub output: PathBuf,
    /// Title of the picture.
    pub title: Option<String>,
    /// Vertical range [LO, HI] in the axis' display units (empty: automatic);
    /// points outside break the line.
    pub y_range: Vec<f64>,
}

/// Draw the picture `o` asks for and write it.
pub fn plot(o: &PlotOptions) -> Result<(), AppError> {
    format_of(&o.output)?;
    let inputs: Vec<&Path> = o.inputs.iter().chain(o.sweep.iter()).map(|p| p.as_path()).collect();
    let mut outputs = crate::output::Transaction::new(&inputs);
    outputs.check_targets(&[&o.output])?;
    let figure = match &o.sweep {
        Some(sweep) => {
            if !o.signals.is_empty() {
                return Err(AppError::Usage("--signals does not apply to --sweep (use --y and --series)".into()));
            }
            let x = o
                .x
                .as_deref()
                .ok_or_else(|| AppError::Usage("--sweep needs --x <column of the varied parameter> (e.g. --x flow_control.C)".into()))?;
            let y = o.y.as_deref().unwrap_or("cycle_time_s");
            sweep_figure(&read_table(sweep)?, x, y, o.series.as_deref(), o.title.as_deref())?
        }
        None => {
            let mut tables = Vec::with_capacity(o.inputs.len());
            for p in &o.inputs {
                tables.push(read_table(p)?);
            }
            overlay_figure(&tables, &o.signals, o.x.as_deref(), o.normalize, o.title.as_deref())?
        }
    };
    let mut figure = figure;
    if !o.y_range.is_empty() && o.y_range.len() != 2 {
        return Err(AppError::Usage("--y-range takes two numbers: LO,HI".into()));
    }
    if let [lo, hi] = o.y_range[..] {
        if lo.is_nan() || hi.is_nan() || lo >= hi {
            return Err(AppError::Usage(format!("--y-range needs LO < HI, got {lo},{hi}")));
        }
        clip_vertical(&mut figure, lo, hi);
    }
    let bytes = render(&figure, &o.output)?;
    outputs.add(&o.output, &bytes)?;
    outputs.commit()
}

/// The title of a run's plot: the model, the parameters changed from the
/// netlist (`--set`, in the order given) and the time span, shortened to
/// one line a plot can hold.
pub fn run_title(model: &str, sets: &[String], t0: f64, t1: f64) -> String {
    const MAX: usize = 110;
    let span = format!("t = {} … {} s", fmt_num(t0), fmt_num(t1));
    let model = crate::error::one_line(model);
    let mut title = if sets.is_empty() {
        format!("{model} (as in the netlist), {span}")
    } else {
        let changed: Vec<String> = sets.iter().map(|s| crate::error::one_line(s.trim())).collect();
        format!("{model} with {}, {span}", changed.join(", "))
    };
    if title.chars().count() > MAX {
        title = title.chars().take(MAX - 1).collect::<String>() + "…";
    }
    title
}

/// Render the given columns of a result over time under `title`; PNG or SVG
/// by the path's extension.
pub fn traces_image(result: &solve::SimResult, columns: &[usize], path: &Path, title: Option<&str>) -> Result<Vec<u8>, AppError> {
    format_of(path)?;
    if columns.is_empty() {
        return Err(AppError::Usage("nothing to plot: no signals selected".into()));
    }
    let mut items = Vec::with_capacity(columns.len());
    for &c in columns {
        let name = result.columns.get(c).ok_or_else(|| AppError::Usage(format!("no result column number {c} to plot")))?;
        let q = quantity_of_unit(result.units.get(c).map(String::as_str).unwrap_or(""));
        let points = result.times.iter().zip(&result.rows).map(|(&t, row)| (t, row.get(c).copied().flatten().map(|v| q.show(v)))).collect();
        items.push((q, Trace { label: name.clone(), points, markers: false }));
    }
    let (panels, dropped) = group_panels(items);
    let (t0, t1) = (result.times.first().copied().unwrap_or(0.0), result.t_final);
    let figure = Figure {
        title: title.map(str::to_string).unwrap_or_else(|| format!("Simulated traces, t = {} … {} s", fmt_num(t0), fmt_num(t1))),
        x_desc: "time [s]".into(),
        panels,
        note: dropped_note(&dropped),
        x_log: false,
    };
    render(&figure, path)
}

/// A Bode picture (`pneumo linearize --bode`): magnitude [dB] and phase
/// [deg] of each input–output pair against frequency [Hz] on a logarithmic
/// axis, one panel each; PNG or SVG by the path's extension. `pairs` are
/// (label, magnitudes, phases) at the frequencies `f_hz`; a non-finite value
/// (a pair that is identically zero has −∞ dB) breaks the line.
pub fn bode_image(title: &str, f_hz: &[f64], pairs: &[(String, Vec<f64>, Vec<f64>)], path: &Path) -> Result<Vec<u8>, AppError> {
    format_of(path)?;
    if pairs.is_empty() || f_hz.is_empty() {
        return Err(AppError::Usage("no Bode picture: the linear model has no input–output pair".into()));
    }
    let trace = |label: &str, values: &[f64]| Trace {
        label: label.to_string(),
        points: f_hz.iter().zip(values).map(|(&f, &v)| (f, v.is_finite().then_some(v))).collect(),
        markers: false,
    };
    let figure = Figure {
        title: title.to_string(),
        x_desc: "frequency [Hz] (log scale)".into(),
        panels: vec![
            Panel { y_desc: "magnitude [dB]".into(), traces: pairs.iter().map(|(l, m, _)| trace(l, m)).collect() },
            Panel { y_desc: "phase [deg]".into(), traces: pairs.iter().map(|(l, _, p)| trace(l, p)).collect() },
        ],
        note: None,
        x_log: true,
    };
    render(&figure, path)
}

/// Drop points outside [lo, hi] so that the axes span only that range.
fn clip_vertical(figure: &mut Figure, lo: f64, hi: f64) {
    for panel in &mut figure.panels {
        for trace in &mut panel.traces {
            for (_, y) in &mut trace.points {
                if matches!(y, Some(v) if *v < lo || *v > hi) {
                    *y = None;
                }
            }
        }
    }
}

// ---------------------------------------------------------------- figures

/// One drawn line: (x, y) in display units; `None` breaks the line.
#[derive(Debug, Clone)]
struct Trace {
    label: String,
    points: Vec<(f64, Option<f64>)>,
    markers: bool,
}

#[derive(Debug, Clone)]
struct Panel {
    y_desc: String,
    traces: Vec<Trace>,
}

#[derive(Debug, Clone)]
struct Figure {
    title: String,
    x_desc: String,
    panels: Vec<Panel>,
    note: Option<String>,
    /// A logarithmic horizontal axis (sweeps whose values span decades).
    x_log: bool,
}

/// Values that span at least two decades, all positive, are read on a log axis
/// (a sweep over C = 1.41 … 210 L/min/bar would otherwise crowd three of its
/// four points into the left edge).
fn spans_decades(values: impl Iterator<Item = f64>) -> bool {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        if !(v > 0.0 && v.is_finite()) {
            return false;
        }
        lo = lo.min(v);
        hi = hi.max(v);
    }
    lo.is_finite() && hi / lo >= 100.0
}

/// How a quantity is grouped and shown.
#[derive(Debug, Clone)]
pub(crate) struct Quantity {
    /// Panel key: quantities with the same group share a panel.
    group: String,
    /// Axis words, e.g. "pressure".
    name: String,
    /// Display unit, e.g. "bar" ("-" for dimensionless).
    pub(crate) display: String,
    /// Conversion from SI to the display unit (None = identity).
    unit: Option<units::Unit>,
}

impl Quantity {
    fn new(group: &str, name: &str, si: &str, display: &str) -> Self {
        // Keep the SI unit when the display unit cannot be parsed, so the label never lies.
        match units::parse_unit(display) {
            Ok(u) if display != si => Quantity { group: group.into(), name: name.into(), display: display.into(), unit: Some(u) },
            _ => Quantity {
                group: group.into(),
                name: name.into(),
                display: if si.is_empty() || si == "1" { "-".into() } else { si.into() },
                unit: None,
            },
        }
    }
    pub(crate) fn show(&self, si: f64) -> f64 {
        match self.unit {
            Some(u) => u.in_unit(si),
            None => si,
        }
    }
    pub(crate) fn axis(&self) -> String {
        // pressures inside are absolute (docs/netlist.md); say so where a gauge reading is common
        let display = if self.display == "bar" { "bar (abs)" } else { &self.display };
        format!("{} [{display}]", self.name)
    }
}

/// Grouping and display of a signal by its SI unit string (as in `SimResult::units`).
pub(crate) fn quantity_of_unit(si: &str) -> Quantity {
    match si {
        "Pa" => Quantity::new("pressure", "pressure", si, "bar"),
        "K" => Quantity::new("temperature", "temperature", si, "K"),
        "m" => Quantity::new("position", "position", si, "mm"),
        "m/s" => Quantity::new("velocity", "velocity", si, "m/s"),
        "m/s2" => Quantity::new("acceleration", "acceleration", si, "m/s2"),
        "kg/s" => Quantity::new("mass flow", "mass flow", si, "kg/s"),
        "N" => Quantity::new("force", "force", si, "N"),
        "W" => Quantity::new("heat flow", "heat flow", si, "W"),
        "kg" => Quantity::new("mass", "mass", si, "kg"),
        "m3" => Quantity::new("volume", "volume", si, "cm3"),
        "kg/m3" => Quantity::new("density", "density", si, "kg/m3"),
        "m3/s" => Quantity::new("volume flow", "volume flow", si, "L/min"),
        "" | "1" => Quantity::new("dimensionless", "dimensionless", si, "-"),
        other => Quantity::new(other, "value", other, other),
    }
}

/// SI unit of a result column from its signal name, for CSV files whose
/// header carries no units (written without `--header-units`): the unit the
/// block contract declares for a signal output or recorded output of that
/// name, when every block type that has one agrees on it (the registry is
/// the only unit table). Per-segment pressures of a tube ("p1", "p12")
/// are pressures.
fn unit_of_signal(column: &str) -> &'static str {
    let signal = column.rsplit('.').next().unwrap_or(column);
    let mut found: Option<&'static str> = None;
    for t in blocks::registry::TYPES {
        let ports = t.ports.iter().filter(|p| p.kind == blocks::block::PortKind::SignalOut).map(|p| (p.name, p.unit));
        for (name, unit) in ports.chain(t.outputs.iter().map(|o| (o.name, o.unit))) {
            if name == signal && !unit.is_empty() {
                match found {
                    None => found = Some(unit),
                    Some(u) if u != unit => return "",
                    Some(_) => {}
                }
            }
        }
    }
    if found.is_none() && signal.len() > 1 && signal.starts_with('p') && signal[1..].chars().all(|c| c.is_ascii_digit()) {
        return "Pa";
    }
    found.unwrap_or("")
}

/// Order of panels: the paper's quantities first, the rest as they come.
fn group_rank(group: &str) -> usize {
    match group {
        "pressure" => 0,
        "temperature" => 1,
        "position" => 2,
        "velocity" => 3,
        _ => 4,
    }
}

/// Group traces into panels by quantity; returns the panels and the labels that did not fit.
fn group_panels(items: Vec<(Quantity, Trace)>) -> (Vec<Panel>, Vec<String>) {
    let mut groups: Vec<(String, Vec<Quantity>, Vec<Trace>)> = Vec::new();
    for (q, t) in items {
        match groups.iter_mut().find(|g| g.0 == q.group) {
            Some(g) => {
                g.1.push(q);
                g.2.push(t);
            }
            None => groups.push((q.group.clone(), vec![q], vec![t])),
        }
    }
    // stable sort keeps first-appearance order within a rank
    groups.sort_by_key(|g| group_rank(&g.0));
    let mut panels = Vec::new();
    let mut dropped = Vec::new();
    for (i, (_, qs, traces)) in groups.into_iter().enumerate() {
        if i >= MAX_PANELS {
            dropped.extend(traces.into_iter().map(|t| t.label));
            continue;
        }
        let mut axes: Vec<String> = Vec::new();
        for q in &qs {
            let a = q.axis();
            if !axes.contains(&a) {
                axes.push(a);
            }
        }
        panels.push(Panel { y_desc: axes.join(", "), traces });
    }
    (panels, dropped)
}

fn dropped_note(dropped: &[String]) -> Option<String> {
    if dropped.is_empty() {
        return None;
    }
    const SHOWN: usize = 8;
    let mut s = format!("not shown (at most {MAX_PANELS} panels): {}", dropped[..dropped.len().min(SHOWN)].join(", "));
    if dropped.len() > SHOWN {
        s.push_str(&format!(" and {} more", dropped.len() - SHOWN));
    }
    Some(s)
}

// ---------------------------------------------------------------- CSV input

/// One column of numbers; `None` = undefined.
type Samples = Vec<Option<f64>>;

/// A CSV file as text cells, with the line number of every row for messages.
struct Table {
    path: PathBuf,
    columns: Vec<String>,
    /// Unit written in a header cell ("head.p [Pa]"), if any.
    units: Vec<Option<String>>,
    rows: Vec<Vec<String>>,
    lines: Vec<u64>,
}

fn read_table(path: &Path) -> Result<Table, AppError> {
    let text = crate::load::read_input(path, "result").map_err(|e| AppError::io(path, e))?;
    let mut reader = csv::ReaderBuilder::new().has_headers(true).trim(csv::Trim::All).from_reader(text.as_slice());
    let csv_error = |e: csv::Error| match e.position() {
        Some(pos) => AppError::Data(format!("{}: line {}: {}", path.display(), pos.line(), csv_message(&e))),
        None => AppError::Data(format!("{}: {}", path.display(), csv_message(&e))),
    };
    let header: Vec<(String, Option<String>)> = reader.headers().map_err(csv_error)?.iter().map(crate::output::split_header).collect();
    let (columns, units): (Vec<String>, Vec<Option<String>>) = header.into_iter().unzip();
    if columns.iter().all(|c| c.is_empty()) {
        return Err(AppError::Data(format!("{}: line 1: no header row", path.display())));
    }
    let mut rows = Vec::new();
    let mut lines = Vec::new();
    for record in reader.records() {
        let record = record.map_err(csv_error)?;
        lines.push(record.position().map(|p| p.line()).unwrap_or(0));
        rows.push(record.iter().map(str::to_string).collect());
    }
    Ok(Table { path: path.to_path_buf(), columns, units, rows, lines })
}

/// The csv crate's message without its own position prefix (we add file and line).
fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
            format!("{len} fields, but the header has {expected_len}")
        }
        csv::ErrorKind::Utf8 { .. } => "not valid UTF-8 text".into(),
        _ => e.to_string(),
    }
}

impl Table {
    fn name(&self) -> String {
        self.path.display().to_string()
    }

    /// SI unit of a column: written in its header, or known from its signal name.
    fn unit(&self, col: usize) -> &str {
        match self.units.get(col) {
            Some(Some(u)) => u,
            _ => unit_of_signal(&self.columns[col]),
        }
    }

    fn stem(&self) -> String {
        self.path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| self.name())
    }

    /// Column index by exact name, or an error listing the available columns.
    fn column(&self, name: &str) -> Result<usize, AppError> {
        self.columns
            .iter()
            .position(|c| c == name)
            .ok_or_else(|| AppError::Data(format!("{}: no column \"{name}\" (available: {})", self.name(), self.columns.join(", "))))
    }

    /// Number in a cell: empty or non-finite = undefined; other text is an error naming file and line.
    fn value(&self, row: usize, col: usize) -> Result<Option<f64>, AppError> {
        let cell = self.rows.get(row).and_then(|r| r.get(col)).map(String::as_str).unwrap_or("");
        if cell.is_empty() {
            return Ok(None);
        }
        let v: f64 = cell.parse().map_err(|_| {
            AppError::Data(format!(
                "{}: line {}: column \"{}\": \"{cell}\" is not a number",
                self.name(),
                self.lines.get(row).copied().unwrap_or(0),
                self.columns.get(col).map(String::as_str).unwrap_or("?")
            ))
        })?;
        Ok(v.is_finite().then_some(v))
    }

    /// Columns x and y as numbers, row by row.
    fn pair(&self, x: usize, y: usize) -> Result<(Samples, Samples), AppError> {
        let mut xs = Vec::with_capacity(self.rows.len());
        let mut ys = Vec::with_capacity(self.rows.len());
        for r in 0..self.rows.len() {
            xs.push(self.value(r, x)?);
            ys.push(self.value(r, y)?);
        }
        Ok((xs, ys))
    }
}

/// Map `values` linearly onto [0, 1] over their defined range (constant → 0).
fn normalise(values: &mut [Option<f64>]) {
    let (lo, hi) = values.iter().flatten().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
    let span = hi - lo;
    for v in values.iter_mut().flatten() {
        *v = if span > 0.0 && span.is_finite() { (*v - lo) / span } else { 0.0 };
    }
}

/// Time time scaled to [0, 1] of the file's duration: first and last defined time.
fn normalise_time(values: &mut [Option<f64>]) {
    let first = values.iter().flatten().next().copied();
    let last = values.iter().rev().flatten().next().copied();
    if let (Some(t0), Some(t1)) = (first, last) {
        let span = t1 - t0;
        for v in values.iter_mut().flatten() {
            *v = if span > 0.0 { (*v - t0) / span } else { 0.0 };
        }
    }
}

/// Overlay the same signals from several result files.
fn overlay_figure(tables: &[Table], signals: &[String], x: Option<&str>, normalize: bool, title: Option<&str>) -> Result<Figure, AppError> {
    let first = tables.first().ok_or_else(|| AppError::Usage("pneumo plot needs at least one result CSV".into()))?;
    let x_name = x.unwrap_or("t");
    let signals: Vec<String> =
        if signals.is_empty() { first.columns.iter().filter(|c| *c != x_name && *c != "t").cloned().collect() } else { signals.to_vec() };
    if signals.is_empty() {
        return Err(AppError::Data(format!("{}: no signal columns to plot", first.name())));
    }
    let x_q = match x {
        Some(_) => quantity_of_unit(first.unit(first.column(x_name)?)),
        None => Quantity::new("time", "time", "s", "s"),
    };
    let stems: Vec<String> = tables.iter().map(Table::stem).collect();
    let unique_stems = stems.iter().enumerate().all(|(i, s)| !stems[..i].contains(s));
    let mut items = Vec::new();
    for (k, table) in tables.iter().enumerate() {
        let xc = table.column(x_name)?;
        for s in &signals {
            let yc = table.column(s)?;
            let (mut xs, mut ys) = table.pair(xc, yc)?;
            let y_q = quantity_of_unit(table.unit(yc));
            if normalize {
                if x.is_some() {
                    normalise(&mut xs);
                } else {
                    normalise_time(&mut xs);
                }
                normalise(&mut ys);
            } else {
                xs.iter_mut().flatten().for_each(|v| *v = x_q.show(*v));
                ys.iter_mut().flatten().for_each(|v| *v = y_q.show(*v));
            }
            let file = if unique_stems { stems[k].clone() } else { table.name() };
            let label = match (tables.len(), signals.len()) {
                (1, _) => s.clone(),
                (_, 1) => file,
                _ => format!("{file}: {s}"),
            };
            // a row without x cannot be placed: it breaks the line like an undefined y
            let points = xs.into_iter().zip(ys).filter_map(|(xv, yv)| xv.map(|xv| (xv, yv))).collect();
            let q = if normalize { Quantity::new("normalised", "normalised value", "1", "-") } else { y_q };
            items.push((q, Trace { label, points, markers: false }));
        }
    }
    let (panels, dropped) = group_panels(items);
    let x_desc = match (normalize, x) {
        (true, None) => "normalised time [-]".to_string(),
        (true, Some(n)) => format!("normalised {n} [-]"),
        (false, None) => x_q.axis(),
        (false, Some(n)) => format!("{n} [{}]", x_q.display),
    };
    let default_title = {
        let what = signals.join(", ");
        let prefix = if normalize { "normalised " } else { "" };
        if tables.len() == 1 {
            format!("{prefix}{what} ({})", stems[0])
        } else {
            format!("{prefix}{what} ({} runs)", tables.len())
        }
    };
    Ok(Figure { title: title.map(str::to_string).unwrap_or(default_title), x_desc, panels, note: dropped_note(&dropped), x_log: false })
}

/// Display unit of a swept parameter column "id.param" from the block registry,
/// when every block type that has a quantity parameter of that name agrees on it.
fn parameter_quantity(column: &str) -> Quantity {
    let param = column.rsplit('.').next().unwrap_or(column);
    let mut display: Option<&str> = None;
    let mut agree = true;
    for t in blocks::registry::TYPES {
        for p in t.params.iter().filter(|p| p.name == param) {
            if !matches!(p.kind, blocks::params::ParamKind::Quantity(_)) {
                continue;
            }
            match display {
                None => display = Some(p.display_unit),
                Some(d) if d != p.display_unit => agree = false,
                Some(_) => {}
            }
        }
    }
    match display {
        Some(d) if agree && !d.is_empty() => match units::parse_unit(d) {
            Ok(u) => Quantity { group: "parameter".into(), name: column.into(), display: d.into(), unit: Some(u) },
            Err(_) => Quantity::new("parameter", column, "", ""),
        },
        _ => Quantity::new("parameter", column, "", ""),
    }
}

/// Words and unit of a sweep result column such as "cycle_time_s".
fn result_quantity(column: &str) -> Quantity {
    match column.strip_suffix("_s") {
        Some(base) => Quantity::new("time", &base.replace('_', " "), "s", "s"),
        None => Quantity::new("value", &column.replace('_', " "), "", ""),
    }
}

/// Sweep column by name; "cycle_time" also finds "cycle_time_s".
fn sweep_column(table: &Table, name: &str) -> Result<usize, AppError> {
    let alt = format!("{name}_s");
    match table.columns.iter().position(|c| c == name || *c == alt) {
        Some(i) => Ok(i),
        None => table.column(name),
    }
}

/// Cycle time (or another result column) against a swept parameter, one line per series value.
fn sweep_figure(table: &Table, x: &str, y: &str, series: Option<&str>, title: Option<&str>) -> Result<Figure, AppError> {
    let xc = sweep_column(table, x)?;
    let yc = sweep_column(table, y)?;
    let sc = series.map(|s| sweep_column(table, s)).transpose()?;
    let ec = table.columns.iter().position(|c| c == "error");
    let x_q = parameter_quantity(&table.columns[xc]);
    let y_q = result_quantity(&table.columns[yc]);
    let s_q = sc.map(|c| parameter_quantity(&table.columns[c]));
    // series value (as bits, for exact grouping) → points
    let mut groups: BTreeMap<u64, (f64, Vec<(f64, f64)>)> = BTreeMap::new();
    let (mut failed, mut used) = (0usize, 0usize);
    for r in 0..table.rows.len() {
        if let Some(e) = ec {
            if table.rows[r].get(e).is_some_and(|cell| !cell.is_empty()) {
                failed += 1;
                continue;
            }
        }
        let (Some(xv), Some(yv)) = (table.value(r, xc)?, table.value(r, yc)?) else { continue };
        let sv = match sc {
            Some(c) => match table.value(r, c)? {
                Some(v) => v,
                None => continue,
            },
            None => 0.0,
        };
        groups.entry(sv.to_bits()).or_insert((sv, Vec::new())).1.push((x_q.show(xv), y_q.show(yv)));
        used += 1;
    }
    if used == 0 {
        return Err(AppError::Data(format!(
            "{}: no rows to plot ({} rows, {failed} with errors, the rest without {} or {})",
            table.name(),
            table.rows.len(),
            table.columns[xc],
            table.columns[yc]
        )));
    }
    let mut ordered: Vec<(f64, Vec<(f64, f64)>)> = groups.into_values().collect();
    ordered.sort_by(|a, b| a.0.total_cmp(&b.0));
    let traces = ordered
        .into_iter()
        .map(|(sv, mut pts)| {
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let label = match (&s_q, sc) {
                (Some(q), Some(c)) => {
                    let unit = if q.display == "-" { String::new() } else { format!(" {}", q.display) };
                    format!("{} = {}{unit}", table.columns[c], fmt_num(q.show(sv)))
                }
                _ => table.columns[yc].clone(),
            };
            Trace { label, points: pts.into_iter().map(|(a, b)| (a, Some(b))).collect(), markers: true }
        })
        .collect();
    let x_desc = if x_q.display == "-" { x_q.name.clone() } else { x_q.axis() };
    let traces: Vec<Trace> = traces;
    let x_log = spans_decades(traces.iter().flat_map(|t| t.points.iter().map(|p| p.0)));
    Ok(Figure {
        title: title.map(str::to_string).unwrap_or_else(|| format!("{} vs {}", y_q.name, table.columns[xc])),
        x_desc: if x_log { format!("{x_desc} (log scale)") } else { x_desc },
        panels: vec![Panel { y_desc: y_q.axis(), traces }],
        note: None,
        x_log,
    })
}

/// A short number for labels: four significant digits, no trailing zeros.
fn fmt_num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor();
    if (-3.0..6.0).contains(&mag) {
        let decimals = (3.0 - mag).max(0.0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.3e}")
    }
}

// ---------------------------------------------------------------- drawing

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Png,
    Svg,
}

fn format_of(path: &Path) -> Result<Format, AppError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Ok(Format::Png),
        Some("svg") => Ok(Format::Svg),
        _ => Err(AppError::Usage(format!("cannot plot to {}: the file name must end in .png or .svg", path.display()))),
    }
}

/// Register the bundled font once per process.
fn ensure_font() -> Result<(), AppError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT).is_ok());
    if ok {
        Ok(())
    } else {
        Err(AppError::Data("the bundled font DejaVuSans.ttf could not be read".into()))
    }
}

/// A private directory under the system temp dir, removed on drop.
struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    fn new() -> Result<Self, AppError> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let base = std::env::temp_dir();
        let mut last_err = None;
        for _ in 0..16 {
            let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.subsec_nanos()).unwrap_or(0);
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let path = base.join(format!("pneumo-plot-{}-{n}-{nanos}", std::process::id()));
            match std::fs::create_dir(&path) {
                Ok(()) => return Ok(ScratchDir { path }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last_err = Some(e),
                Err(e) => return Err(AppError::io(&path, e)),
            }
        }
        Err(AppError::io(&base, last_err.map(|e| e.to_string()).unwrap_or_default()))
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Draw a figure into PNG or SVG bytes (by the extension of `path`, which is not written).
fn render(fig: &Figure, path: &Path) -> Result<Vec<u8>, AppError> {
    let format = format_of(path)?;
    if fig.panels.is_empty() {
        return Err(AppError::Usage("nothing to plot".into()));
    }
    ensure_font()?;
    let height = TITLE_HEIGHT + PANEL_HEIGHT * fig.panels.len() as u32 + if fig.note.is_some() { NOTE_HEIGHT } else { 0 };
    let size = (WIDTH, height);
    let fail = |e: String| AppError::Data(format!("cannot draw {}: {e}", path.display()));
    match format {
        Format::Svg => {
            let mut text = String::new();
            {
                let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
                draw(&root, fig).map_err(fail)?;
                root.present().map_err(|e| fail(e.to_string()))?;
            }
            Ok(text.into_bytes())
        }
        Format::Png => png_via_scratch(|file| {
            let root = BitMapBackend::new(file, size).into_drawing_area();
            draw(&root, fig).map_err(fail)?;
            root.present().map_err(|e| fail(e.to_string()))
        }),
    }
}

/// Let `draw` write a PNG file into a private scratch directory and return its
/// bytes (plotters' bitmap backend writes to a path; the caller then writes
/// the bytes through [`crate::output::Transaction`], which knows about devices and links).
pub fn png_via_scratch(draw: impl FnOnce(&Path) -> Result<(), AppError>) -> Result<Vec<u8>, AppError> {
    let dir = ScratchDir::new()?;
    let file = dir.path.join("plot.png");
    draw(&file)?;
    std::fs::read(&file).map_err(|e| AppError::io(&file, e))
}

/// Largest magnitude drawn: values beyond it are drawn at it (an axis over
/// ±1e308 would overflow the tick computation).
const DRAWN_MAX: f64 = 1e300;

/// Smallest and largest finite value, padded so the range is never empty,
/// always finite with lo < hi (non-finite values are skipped, huge ones clipped).
fn axis_range(values: impl Iterator<Item = f64>, pad_fraction: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .map(|v| v.clamp(-DRAWN_MAX, DRAWN_MAX))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(v), h.max(v)));
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    let (a, b) = if span > 1e-12 * lo.abs().max(hi.abs()) && span > 1e-290 {
        (lo - pad_fraction * span, hi + pad_fraction * span)
    } else {
        let half = if lo.abs() > 1e-290 { 0.05 * lo.abs() } else { 0.5 };
        (lo - half, hi + half)
    };
    if a.is_finite() && b.is_finite() && a < b {
        (a, b)
    } else {
        (0.0, 1.0)
    }
}

/// Runs of consecutive defined points.
fn segments(points: &[(f64, Option<f64>)]) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut current = Vec::new();
    for &(x, y) in points {
        match y {
            Some(y) if y.is_finite() && x.is_finite() => current.push((x.clamp(-DRAWN_MAX, DRAWN_MAX), y.clamp(-DRAWN_MAX, DRAWN_MAX))),
            _ => {
                if !current.is_empty() {
                    out.push(std::mem::take(&mut current));
                }
            }
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out
}

/// Mesh, traces and legend of one panel, for a linear or a logarithmic
/// horizontal axis (two chart types with the same drawing calls). Tick
/// labels are short numbers, at most eight along the time or sweep axis so
/// that they never overlap.
macro_rules! fill_panel {
    ($chart:ident, $panel:ident, $last:ident, $fig:ident, $e:ident) => {{
        let mut chart = $chart;
        let (panel, last, fig, e) = ($panel, $last, $fig, $e);
        let x_format = |v: &f64| fmt_num(*v);
        let y_format = |v: &f64| fmt_num(*v);
        let mut mesh = chart.configure_mesh();
        mesh.x_labels(8).y_labels(8).x_label_formatter(&x_format).y_label_formatter(&y_format);
        mesh.y_desc(panel.y_desc.as_str())
            .label_style((FONT_FAMILY, 14))
            .axis_desc_style((FONT_FAMILY, 16))
            .light_line_style(RGBColor(235, 235, 235));
        if last {
            mesh.x_desc(fig.x_desc.as_str());
        }
        mesh.draw().map_err(e)?;
        for (k, trace) in panel.traces.iter().enumerate() {
            let color = PALETTE[k % PALETTE.len()];
            // an empty series carries the legend entry, so every trace is listed even if undefined throughout
            chart
                .draw_series(LineSeries::new(std::iter::empty::<(f64, f64)>(), color.stroke_width(2)))
                .map_err(e)?
                .label(trace.label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(2)));
            for seg in segments(&trace.points) {
                if seg.len() >= 2 {
                    chart.draw_series(LineSeries::new(seg.iter().copied(), color.stroke_width(2))).map_err(e)?;
                }
                if trace.markers || seg.len() == 1 {
                    chart.draw_series(seg.iter().map(|&p| Circle::new(p, 4, color.filled()))).map_err(e)?;
                }
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT_FAMILY, 14))
            .draw()
            .map_err(e)?;
    }};
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &Figure) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let body = root.titled(&fig.title, (FONT_FAMILY, 24)).map_err(e)?;
    let body = match &fig.note {
        Some(note) => {
            let h = body.dim_in_pixel().1 as i32;
            let (main, foot) = body.split_vertically(h - NOTE_HEIGHT as i32);
            foot.draw_text(note, &TextStyle::from((FONT_FAMILY, 14).into_font()), (12, 6)).map_err(e)?;
            main
        }
        None => body,
    };
    let areas = body.split_evenly((fig.panels.len(), 1));
    let x_all = fig.panels.iter().flat_map(|p| p.traces.iter()).flat_map(|t| t.points.iter().map(|p| p.0));
    let (x_lo, x_hi) = axis_range(x_all, 0.0);
    for (i, (area, panel)) in areas.iter().zip(&fig.panels).enumerate() {
        let last = i + 1 == fig.panels.len();
        let y_all = panel.traces.iter().flat_map(|t| t.points.iter().filter_map(|p| p.1));
        let (y_lo, y_hi) = axis_range(y_all, 0.05);
        let mut builder = ChartBuilder::on(area);
        builder.margin(10).margin_right(30).x_label_area_size(if last { 50 } else { 30 }).y_label_area_size(90);
        if fig.x_log {
            let chart = builder.build_cartesian_2d((x_lo..x_hi).log_scale(), y_lo..y_hi).map_err(e)?;
            fill_panel!(chart, panel, last, fig, e);
        } else {
            let chart = builder.build_cartesian_2d(x_lo..x_hi, y_lo..y_hi).map_err(e)?;
            fill_panel!(chart, panel, last, fig, e);
        }
    }
    Ok(())
}

#[cfg(test)]
mod clip_tests {
    use super::*;

    #[test]
    fn vertical_range_breaks_lines_outside_it() {
        let mut f = Figure {
            title: String::new(),
            x_desc: String::new(),
            panels: vec![Panel {
                y_desc: String::new(),
                traces: vec![Trace {
                    label: "n".into(),
                    points: vec![(0.0, Some(1.2)), (1.0, Some(300.0)), (2.0, Some(-5.0)), (3.0, Some(1.4))],
                    markers: false,
                }],
            }],
            x_log: false,
            note: None,
        };
        clip_vertical(&mut f, 0.5, 2.0);
        let ys: Vec<_> = f.panels[0].traces[0].points.iter().map(|p| p.1).collect();
        assert_eq!(ys, vec![Some(1.2), None, None, Some(1.4)]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two chambers' pressures, one temperature, a position; one undefined stretch.
    fn synthetic() -> solve::SimResult {
        let times: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
        let rows = times
            .iter()
            .map(|&t| {
                vec![
                    Some(1e5 + 3e5 * t),
                    Some(4e5 - 2e5 * t),
                    Some(292.0 - 40.0 * t),
                    Some(0.45 * t),
                    if (0.3..0.5).contains(&t) { None } else { Some(1.0 + 0.4 * t) },
                    Some(0.45),
                ]
            })
            .collect();
        solve::SimResult {
            rest: Default::default(),
            final_state: Default::default(),
            stroke_statistics: Vec::new(),
            cycle_statistics: Vec::new(),
            run_statistics: Vec::new(),
            cycle_controllers: Vec::new(),
            columns: vec!["head.p".into(), "rod.p".into(), "head.T".into(), "piston.x".into(), "head.n".into(), "piston.v".into()],
            units: vec!["Pa".into(), "Pa".into(), "K".into(), "m".into(), "1".into(), "m/s".into()],
            times,
            rows,
            cycles: Vec::new(),
            events: Vec::new(),
            balance: Default::default(),
            t_final: 1.0,
            stats: Default::default(),
            ..Default::default()
        }
    }

    fn temp_file(name: &str, text: &str) -> (ScratchDir, PathBuf) {
        let dir = ScratchDir::new().expect("scratch dir");
        let path = dir.path.join(name);
        std::fs::write(&path, text).expect("write");
        (dir, path)
    }

    #[test]
    fn png_has_signature_and_size() {
        let r = synthetic();
        let bytes = traces_image(&r, &[0, 1, 2, 3], Path::new("fig.png"), None).expect("png");
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        // IHDR width and height (big endian) at bytes 16..24: three panels stacked
        let w = u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]);
        let h = u32::from_be_bytes([bytes[20], bytes[21], bytes[22], bytes[23]]);
        assert_eq!(w, WIDTH);
        assert_eq!(h, TITLE_HEIGHT + 3 * PANEL_HEIGHT);
    }

    #[test]
    fn svg_names_legend_and_units() {
        let r = synthetic();
        let bytes = traces_image(&r, &[0, 1, 2, 3], Path::new("fig.SVG"), None).expect("svg");
        let svg = String::from_utf8(bytes).expect("utf8");
        assert!(svg.starts_with("<svg"), "{}", &svg[..40.min(svg.len())]);
        for name in ["head.p", "rod.p", "head.T", "piston.x", "pressure [bar (abs)]", "temperature [K]", "position [mm]", "time [s]"] {
            assert!(svg.contains(name), "SVG lacks {name}");
        }
        // position and velocity on separate axes; dimensionless head.n would be a 5th panel: not drawn but named in the note
        let with_n = String::from_utf8(traces_image(&r, &[0, 2, 3, 5, 4], Path::new("f.svg"), None).expect("svg")).expect("utf8");
        assert!(with_n.contains("velocity [m/s]") && with_n.contains("position [mm]"));
        assert!(with_n.contains("not shown (at most 4 panels): head.n"));
    }

    #[test]
    fn pressures_are_shown_in_bar_and_grouped() {
        let r = synthetic();
        let items: Vec<_> = [0usize, 2, 1, 3]
            .iter()
            .map(|&c| {
                let q = quantity_of_unit(&r.units[c]);
                (q, Trace { label: r.columns[c].clone(), points: Vec::new(), markers: false })
            })
            .collect();
        let (panels, dropped) = group_panels(items);
        assert!(dropped.is_empty());
        let labels: Vec<Vec<&str>> = panels.iter().map(|p| p.traces.iter().map(|t| t.label.as_str()).collect()).collect();
        assert_eq!(labels, vec![vec!["head.p", "rod.p"], vec!["head.T"], vec!["piston.x"]]);
        assert_eq!(panels[0].y_desc, "pressure [bar (abs)]");
        assert_eq!(panels[2].y_desc, "position [mm]");
        let q = quantity_of_unit("Pa");
        assert!((q.show(4e5) - 4.0).abs() < 1e-12);
        let m = quantity_of_unit("m/s");
        assert!((m.show(0.3) - 0.3).abs() < 1e-15);
    }

    #[test]
    fn undefined_values_break_the_line() {
        let pts = [(0.0, Some(1.0)), (1.0, Some(2.0)), (2.0, None), (3.0, Some(3.0)), (4.0, Some(f64::NAN)), (5.0, Some(4.0))];
        let segs = segments(&pts);
        assert_eq!(segs, vec![vec![(0.0, 1.0), (1.0, 2.0)], vec![(3.0, 3.0)], vec![(5.0, 4.0)]]);
    }

    #[test]
    fn bad_extension_is_a_usage_error() {
        let r = synthetic();
        for name in ["fig.jpg", "fig", "fig.png.txt"] {
            match traces_image(&r, &[0], Path::new(name), None) {
                Err(AppError::Usage(m)) => assert!(m.contains(".png") && m.contains(".svg") && m.contains(name), "{m}"),
                other => panic!("{name}: expected a usage error, got {other:?}"),
            }
        }
    }

    #[test]
    fn missing_column_names_the_available_ones() {
        let (_dir, path) = temp_file("r.csv", "t,head.p,rod.p\n0,1e5,4e5\n0.1,2e5,\n");
        let table = read_table(&path).expect("read");
        let err = overlay_figure(&[table], &["head.q".to_string()], None, false, None).expect_err("missing column");
        let msg = err.to_string();
        assert!(msg.contains("r.csv") && msg.contains("\"head.q\"") && msg.contains("t, head.p, rod.p"), "{msg}");
    }

    #[test]
    fn bad_csv_names_file_and_line() {
        let (_dir, path) = temp_file("bad.csv", "t,head.p\n0,1e5\n0.1,abc\n");
        let table = read_table(&path).expect("read");
        let msg = overlay_figure(&[table], &[], None, false, None).expect_err("bad number").to_string();
        assert!(msg.contains("bad.csv: line 3") && msg.contains("abc"), "{msg}");
        let (_dir2, path2) = temp_file("short.csv", "t,head.p\n0,1e5\n0.1\n");
        let msg = read_table(&path2).err().expect("ragged row").to_string();
        assert!(msg.contains("short.csv: line 3"), "{msg}");
    }

    #[test]
    fn empty_cells_are_undefined_and_overlay_labels_are_file_stems() {
        let (_d1, a) = temp_file("slow.csv", "t,rod.p\n0,4e5\n1,\n2,5e5\n");
        let (_d2, b) = temp_file("fast.csv", "t,rod.p\n0,4e5\n1,4.5e5\n");
        let tables = vec![read_table(&a).expect("a"), read_table(&b).expect("b")];
        let fig = overlay_figure(&tables, &["rod.p".into()], None, false, None).expect("figure");
        assert_eq!(fig.panels.len(), 1);
        let t = &fig.panels[0].traces;
        assert_eq!(t[0].label, "slow");
        assert_eq!(t[1].label, "fast");
        assert_eq!(t[0].points, vec![(0.0, Some(4.0)), (1.0, None), (2.0, Some(5.0))]);
        assert_eq!(fig.panels[0].y_desc, "pressure [bar (abs)]");
    }

    #[test]
    fn normalize_maps_time_and_value_to_unit_interval() {
        let (_d, a) = temp_file("r.csv", "t,piston.x\n2,0.1\n3,0.2\n4,\n6,0.5\n");
        let fig = overlay_figure(&[read_table(&a).expect("read")], &["piston.x".into()], None, true, None).expect("fig");
        let pts = &fig.panels[0].traces[0].points;
        let expect = [(0.0, Some(0.0)), (0.25, Some(0.25)), (0.5, None), (1.0, Some(1.0))];
        assert_eq!(pts.len(), expect.len());
        for (p, e) in pts.iter().zip(expect) {
            assert!((p.0 - e.0).abs() < 1e-12, "{p:?} vs {e:?}");
            match (p.1, e.1) {
                (Some(u), Some(v)) => assert!((u - v).abs() < 1e-12, "{p:?} vs {e:?}"),
                (None, None) => {}
                _ => panic!("{p:?} vs {e:?}"),
            }
        }
        assert_eq!(fig.x_desc, "normalised time [-]");
    }

    #[test]
    fn sweep_groups_series_skips_errors_and_converts_units() {
        // C in SI: 1 L/(min·bar) = 1e-3 m3 / 60 s / 1e5 Pa
        let c = |l_min_bar: f64| l_min_bar * 1e-3 / 60.0 / 1e5;
        let text = format!(
            "flow_control.C,supply.p,cycle_time_s,error\n{},700000,2.0,\n{},400000,3.3,\n{},400000,2.2,\n{},700000,3.0,\n{},400000,,stalled\n",
            c(13.2),
            c(2.68),
            c(13.2),
            c(2.68),
            c(5.0)
        );
        let (_d, path) = temp_file("sweep.csv", &text);
        let table = read_table(&path).expect("read");
        let fig = sweep_figure(&table, "flow_control.C", "cycle_time", Some("supply.p"), None).expect("figure");
        let traces = &fig.panels[0].traces;
        assert_eq!(traces.len(), 2);
        assert_eq!(traces[0].label, "supply.p = 4 bar");
        assert_eq!(traces[1].label, "supply.p = 7 bar");
        // sorted by x, in L/min/bar; the errored row is gone
        let xs: Vec<f64> = traces[0].points.iter().map(|p| p.0).collect();
        assert_eq!(xs.len(), 2);
        assert!((xs[0] - 2.68).abs() < 1e-9 && (xs[1] - 13.2).abs() < 1e-9, "{xs:?}");
        assert_eq!(traces[0].points[0].1, Some(3.3));
        assert_eq!(fig.x_desc, "flow_control.C [L/min/bar]");
        assert_eq!(fig.panels[0].y_desc, "cycle time [s]");
        let svg = String::from_utf8(render(&fig, Path::new("f.svg")).expect("svg")).expect("utf8");
        assert!(svg.contains("supply.p = 7 bar"));
        let err = sweep_figure(&table, "flow_control.C", "extend_s", None, None).expect_err("no such column");
        assert!(err.to_string().contains("available: flow_control.C, supply.p, cycle_time_s, error"), "{err}");
    }

    #[test]
    fn run_titles_name_the_model_and_what_was_changed() {
        let t = run_title("meter_out", &[], 0.0, 7.735);
        assert_eq!(t, "meter_out (as in the netlist), t = 0 … 7.735 s");
        let sets = vec!["flow_control.C=2.68 L/min/bar".to_string(), " supply.p=7 bar".to_string()];
        let t = run_title("meter_out", &sets, 0.0, 35.45);
        assert_eq!(t, "meter_out with flow_control.C=2.68 L/min/bar, supply.p=7 bar, t = 0 … 35.45 s");
        let many: Vec<String> = (0..20).map(|i| format!("c{i}.p=1 bar")).collect();
        let t = run_title("m", &many, 0.0, 1.0);
        assert!(t.chars().count() == 110 && t.ends_with('…'), "{t}");
        // the title reaches the picture
        let svg =
            String::from_utf8(traces_image(&synthetic(), &[0], Path::new("f.svg"), Some("meter_out with supply.p=7 bar")).expect("svg"))
                .expect("utf8");
        assert!(svg.contains("meter_out with supply.p=7 bar") && !svg.contains("Simulated traces"));
    }

    #[test]
    fn sweeps_spanning_decades_get_a_log_axis_with_readable_ticks() {
        let c = |l_min_bar: f64| l_min_bar * 1e-3 / 60.0 / 1e5;
        let rows: String = [1.41, 2.68, 13.2, 210.0].iter().map(|&v| format!("{},2.5\n", c(v))).collect();
        let (_d, path) = temp_file("decades.csv", &format!("flow_control.C,cycle_time_s\n{rows}"));
        let fig = sweep_figure(&read_table(&path).expect("read"), "flow_control.C", "cycle_time_s", None, None).expect("figure");
        assert!(fig.x_log, "1.41 … 210 spans two decades");
        assert!(fig.x_desc.contains("log"), "{}", fig.x_desc);
        let svg = String::from_utf8(render(&fig, Path::new("f.svg")).expect("svg")).expect("utf8");
        let labels: Vec<&str> = svg.lines().map(str::trim).collect();
        assert!(labels.contains(&"10") && labels.contains(&"100"), "decade ticks are labelled");
        // one decade or less stays linear; a zero or negative value cannot be on a log axis
        let (_d, path) = temp_file("narrow.csv", "supply.p,cycle_time_s\n400000,2.4\n700000,2.2\n");
        assert!(!sweep_figure(&read_table(&path).expect("read"), "supply.p", "cycle_time_s", None, None).expect("figure").x_log);
        assert!(!spans_decades([0.0, 1.0, 1000.0].into_iter()));
        assert!(spans_decades([0.5, 50.0].into_iter()) && !spans_decades([0.5, 49.0].into_iter()));
    }

    #[test]
    fn number_labels_are_short() {
        assert_eq!(fmt_num(4.0), "4");
        assert_eq!(fmt_num(13.2), "13.2");
        assert_eq!(fmt_num(2.68), "2.68");
        assert_eq!(fmt_num(0.0012346), "0.001235");
        assert_eq!(fmt_num(1.5e-9), "1.500e-9");
    }
}
