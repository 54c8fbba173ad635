//! The discrepancy analysis (`pneumo discrepancy`, Python's
//! `pneumo.discrepancy`): where a model disagrees with measurements, which
//! physical effect it is missing, and the model with that effect added.
//!
//! Reads the model netlist and an experiments manifest
//! ([`identify::manifest`]: data CSV files relative to the manifest, each
//! with its operating point and column mapping), runs the workflow of
//! [`identify::workflow`] (calibrate → diagnose → try the catalogue of
//! candidate effects → select by held-out error, information criterion and
//! parameter significance → show the gap shrink), and returns the outcome
//! with the verdict as text ([`text_summary`]) and the whole summary as JSON.
//!
//! With a report directory it writes, each file whole or not at all:
//! - `model_with_<effect>.json` (or `model_with_<A>+<B>.json`): the
//!   augmented netlist with the fitted values, runnable with
//!   `pneumo simulate`; one per alternative when the verdict is ambiguous;
//!   `model_calibrated.json` when nothing is missing;
//! - `fit_<experiment>.png`: measured vs simulated before and after;
//! - `residuals_by_phase.png`: normalised RMSE per phase of the cycle;
//! - `report.md`: the verdict, parameter estimates with 95 % intervals, the
//!   diagnosis tables and the figures;
//! - `summary.json`: the `--json` output.
//!
//! Figures: PNG drawn with plotters and the bundled DejaVu Sans
//! (assets/fonts, Bitstream Vera licence). Pressures are shown in bar,
//! positions in mm, everything else in SI; no physics is computed here.

use crate::error::AppError;
use crate::output::Transaction;
use identify::candidates::{Candidate, Estimate};
use identify::diagnose::Trace;
use identify::phases::Phase;
use identify::report::{ModelSummary, Outcome, SensorEstimate};
use plotters::prelude::{
    BitMapBackend, ChartBuilder, Circle, Color, FontStyle, IntoDrawingArea, IntoLogRange, LineSeries, PathElement, RGBColor, Rectangle,
    SeriesLabelPosition, BLACK, WHITE,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A discrepancy analysis as `pneumo discrepancy` takes it.
#[derive(Debug, Clone, Default)]
pub struct DiscrepancyOptions {
    /// Model netlist (JSON).
    pub model: PathBuf,
    /// Experiments manifest (JSON): data files, operating points, column mapping.
    pub experiments: PathBuf,
    /// Write the augmented netlist, figures and report.md into this directory.
    pub report: Option<PathBuf>,
}

/// What an analysis found: the workflow's outcome, its summary as JSON
/// (what `--json` prints and `summary.json` holds) and the report files
/// written.
pub struct Found {
    pub outcome: Outcome,
    pub summary_json: String,
    pub written: Vec<PathBuf>,
}

/// The experiments of a manifest, read and checked against a model, with
/// every file read for them (the manifest and its data files).
pub struct Experiments {
    pub resolved: identify::manifest::Resolved,
    pub files: Vec<PathBuf>,
}

/// Read the manifest at `manifest_path` and its data files (which must lie
/// in its folder or below) and resolve them against the model `flat`.
pub fn read_experiments(flat: &graph::FlatNetlist, manifest_path: &Path) -> Result<Experiments, AppError> {
    let text = crate::load::read_input_text(manifest_path, "manifest").map_err(|e| AppError::io(manifest_path, e))?;
    let manifest = identify::manifest::parse(&text, &manifest_path.display().to_string()).map_err(|e| AppError::Data(e.to_string()))?;
    let dir = manifest_path.parent().map(Path::to_path_buf).unwrap_or_default();
    let data_files = std::cell::RefCell::new(Vec::new());
    let folder = std::fs::canonicalize(if dir.as_os_str().is_empty() { Path::new(".") } else { &dir }).unwrap_or_else(|_| dir.clone());
    let read = |name: &str| -> Result<(String, String), String> {
        let path = dir.join(name);
        // a relative data path is read from the manifest's folder and below
        // only: "../" cannot make pneumo read (and quote) a file elsewhere;
        // an absolute path is the user's explicit choice
        match std::fs::canonicalize(&path) {
            Ok(real) if Path::new(name).is_relative() && !real.starts_with(&folder) => {
                return Err(format!(
                    "{}: a relative data path leads outside the manifest's folder {} (put the data beside the manifest or below it, or give an absolute path)",
                    crate::error::shown_path(&path),
                    crate::error::shown_path(&folder)
                ))
            }
            Err(e) => return Err(format!("{}: {}", crate::error::shown_path(&path), graph::escape(&e.to_string()))),
            Ok(_) => {}
        }
        data_files.borrow_mut().push(path.clone());
        crate::load::read_input_text(&path, "data")
            .map(|t| (t, path.display().to_string()))
            .map_err(|e| format!("{}: {e}", crate::error::shown_path(&path)))
    };
    let resolved = identify::manifest::resolve(&manifest, flat, &read).map_err(AppError::Data)?;
    let mut files = vec![manifest_path.to_path_buf()];
    files.extend(data_files.into_inner());
    Ok(Experiments { resolved, files })
}

/// Run the workflow (calibrate, diagnose, try the catalogue, select).
pub fn analyse(flat: &graph::FlatNetlist, e: &Experiments) -> Result<Outcome, AppError> {
    identify::run(flat, &e.resolved.experiments, &e.resolved.calibrate, &e.resolved.options).map_err(|e| AppError::Data(e.to_string()))
}

/// The file names a report directory receives besides the netlists and fit figures.
pub const REPORT_FILES: [&str; 3] = ["summary.json", "report.md", "residuals_by_phase.png"];

/// Refuse a report directory that holds an input under a name the report writes.
pub fn check_report_dir(out: &Path, inputs: &[PathBuf]) -> Result<(), AppError> {
    let targets: Vec<PathBuf> = REPORT_FILES.iter().map(|n| out.join(n)).collect();
    let refs: Vec<&Path> = targets.iter().map(|p| p.as_path()).collect();
    let ins: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    Transaction::new(&ins).check_targets(&refs)
}

/// Read the model and the experiments of `o`, run the workflow and write
/// the report directory if asked.
pub fn discrepancy(o: &DiscrepancyOptions) -> Result<Found, AppError> {
    let (flat, files) = crate::load::netlist_with_files(&o.model, &[])?;
    run_workflow(&flat, &files, &o.model, &o.experiments, o.report.as_deref())
}

/// The workflow for a model already loaded: `flat`, read from `model_files`
/// (the netlist at `model_path` and its subsystems, which no output may
/// overwrite), against the manifest at `manifest_path`; with `report`,
/// the report directory is written (every file or none).
pub fn run_workflow(
    flat: &graph::FlatNetlist,
    model_files: &[PathBuf],
    model_path: &Path,
    manifest_path: &Path,
    report: Option<&Path>,
) -> Result<Found, AppError> {
    let experiments = read_experiments(flat, manifest_path)?;
    let mut inputs = model_files.to_vec();
    inputs.extend(experiments.files.iter().cloned());
    if let Some(out) = report {
        check_report_dir(out, &inputs)?;
    }
    let outcome = analyse(flat, &experiments)?;
    let summary_json = serde_json::to_string_pretty(&outcome.summary).map_err(|e| AppError::Data(e.to_string()))?;
    let written = match report {
        Some(out) => write_report(out, &inputs, model_path, manifest_path, &outcome, &summary_json)?,
        None => Vec::new(),
    };
    Ok(Found { outcome, summary_json, written })
}

// ---------------------------------------------------------------- text

/// Fixed decimals, "–" for a value that is not a number.
fn fmt_fixed(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        "–".into()
    }
}

fn fmt(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        format!("{v:.3e}")
    } else {
        identify::params::significant(v, 5)
    }
}

/// "12.3 L/min/bar" for an estimate (its own unit when it converts, else SI).
fn shown(e: &Estimate, v: f64) -> String {
    match (e.unit.is_empty(), units::to_unit(v, &e.unit)) {
        (false, Ok(x)) if x.is_finite() => format!("{} {}", fmt(x), e.unit),
        _ => fmt(v),
    }
}

/// An effect parameter value in the unit its effect declares ("0.3 L/min/bar"):
/// a built-in's, else (a user-declared effect) the unit of its estimate
/// among the candidates tried.
fn effect_value(cands: &[Candidate], effect: &str, param: &str, v: f64) -> String {
    let full = format!("{effect}.{param}");
    let unit =
        identify::effects::by_name(effect).and_then(|e| e.params().into_iter().find(|p| p.name == param)).map(|p| p.unit).or_else(|| {
            cands.iter().filter(|c| c.effect == effect).flat_map(|c| &c.estimates).find(|e| e.name == full).map(|e| e.unit.clone())
        });
    match unit.as_deref().map(|u| (u, units::to_unit(v, u))) {
        Some((u, Ok(x))) if !u.is_empty() && x.is_finite() => format!("{} {u}", fmt(x)),
        _ => fmt(v),
    }
}

/// A noise level in the unit a person reads it in: mbar, µm, K, m/s.
fn noise_text(signal: &str, sigma: f64) -> String {
    match signal.rsplit('.').next().unwrap_or("") {
        "p" => format!("{} mbar", fmt(sigma * 1e-2)),
        "x" => format!("{} µm", fmt(sigma * 1e6)),
        "T" => format!("{} K", fmt(sigma)),
        "v" => format!("{} mm/s", fmt(sigma * 1e3)),
        _ => fmt(sigma),
    }
}

/// One row of the sensor-error table: offset in the channel's unit, gain in %, skew in ms.
fn sensor_row(x: &SensorEstimate) -> String {
    let ci = |c: Option<(f64, f64)>, f: &dyn Fn(f64) -> String| c.map(|(a, b)| format!(" [{}, {}]", f(a), f(b))).unwrap_or_default();
    let offset = |v: f64| noise_text(&x.signal, v);
    let gain = |v: f64| format!("{} %", fmt(100.0 * v));
    let skew = |v: f64| format!("{} ms", fmt(1e3 * v));
    format!(
        "| {} | {} | {}{} | {}{} | {}{} |\n",
        x.experiment,
        x.signal,
        offset(x.offset),
        ci(x.offset_ci95, &offset),
        gain(x.gain),
        ci(x.gain_ci95, &gain),
        skew(x.time_skew),
        ci(x.time_skew_ci95, &skew)
    )
}

/// The 95 % interval of an estimate as text; at a bound, which one, and
/// the one-sided interval (see [`identify::candidates::Estimate::ci95`]).
fn interval_text(e: &Estimate) -> String {
    let ci = e.ci95.map(|(a, b)| format!("[{}, {}]", shown(e, a), shown(e, b)));
    if !e.at_bound {
        return ci.unwrap_or_else(|| "–".into());
    }
    let side = if (e.value - e.lo).abs() <= (e.hi - e.value).abs() { "lower" } else { "upper" };
    match ci {
        Some(ci) => format!("at the {side} bound; one-sided {ci}"),
        None => format!("at the {side} bound"),
    }
}

fn estimate_row(e: &Estimate) -> String {
    format!("| {} | {} | {} |\n", e.name, shown(e, e.value), interval_text(e))
}

/// The phases that hold samples, in their fixed order: a vessel test shows
/// charge, discharge and hold, a cylinder its cycle phases.
fn phases_present(m: &ModelSummary) -> Vec<Phase> {
    Phase::ALL.iter().copied().filter(|ph| m.diagnosis.phases.iter().any(|p| p.phase == *ph && p.n > 0)).collect()
}

/// A markdown table; with no rows, a sentence saying so (an empty table is not valid markdown).
fn table(md: &mut String, header: &[&str], rows: &[Vec<String>], empty: &str) {
    if rows.is_empty() || header.is_empty() {
        let _ = writeln!(md, "{empty}");
        return;
    }
    let _ = writeln!(md, "| {} |\n|{}", header.join(" | "), "---|".repeat(header.len()));
    for r in rows {
        let _ = writeln!(md, "| {} |", r.join(" | "));
    }
}

/// The verdict and the candidates tried, as printed by `pneumo discrepancy`.
pub fn text_summary(o: &Outcome) -> String {
    let s = &o.summary;
    let mut t = String::new();
    let _ = writeln!(t, "verdict: {}", s.verdict);
    let rm = |m: &ModelSummary| m.rmse_normalized.iter().map(|(k, v)| format!("{k} {v:.2}")).collect::<Vec<_>>().join(", ");
    let _ = writeln!(t, "baseline: normalised RMSE {} (1 = noise level); held-out {:.3}", rm(&s.baseline), s.baseline.heldout_rmse);
    for c in &s.candidates {
        let params =
            c.params.iter().map(|(k, v)| format!("{k} = {}", effect_value(&s.candidates, &c.effect, k, *v))).collect::<Vec<_>>().join(", ");
        let _ = writeln!(
            t,
            "  round {} {:<18} ΔIC {:>12} held-out {:>9} {} {}",
            c.round,
            c.effect,
            fmt(c.delta_ic),
            fmt(c.heldout_rmse),
            if c.accepted { "passes" } else { "rejected" },
            params
        );
    }
    if !s.selected.is_empty() {
        let _ = writeln!(t, "after: normalised RMSE {}; held-out {:.3}", rm(&s.after), s.after.heldout_rmse);
    }
    let _ = writeln!(t, "{} simulations in {:.1} s", s.evaluations, s.seconds);
    t
}

// ---------------------------------------------------------------- netlists

/// A flat netlist as a runnable netlist file (JSON text), with this description.
pub fn netlist_json(flat: &graph::FlatNetlist, description: String) -> Result<String, AppError> {
    // Expressions written inside subsystems refer to names of their scope;
    // in a flat file they become their values. Ids of expanded subsystems
    // ("cyl.head") are written with '_' ("cyl_head"), as file ids cannot
    // contain '.'.
    let (concrete, _) = graph::params::concrete(flat)?;
    let rename = |id: &str| id.replace('.', "_");
    let port = |r: &str| match graph::netlist::split_ref(r) {
        Some((id, p)) => format!("{}.{p}", rename(id)),
        None => r.to_string(),
    };
    let components = concrete
        .components
        .iter()
        .map(|c| {
            let mut c = c.clone();
            c.id = rename(&c.id);
            c
        })
        .collect();
    let parameters = flat
        .parameters
        .iter()
        .filter(|p| !p.name.contains('.'))
        .map(|p| {
            let decl = graph::netlist::ParameterDecl::Full { value: p.value.clone(), description: p.description.clone() };
            (p.name.clone(), decl)
        })
        .collect();
    let n = graph::Netlist {
        name: Some(flat.name.clone()),
        description: Some(description),
        gas: flat.gas.clone(),
        parameters,
        components,
        connections: concrete.connections.iter().map(|(a, b)| graph::netlist::Connection::Pair([port(a), port(b)])).collect(),
        simulation: flat.simulation.clone(),
        interface: None,
    };
    serde_json::to_string_pretty(&n).map(|s| s + "\n").map_err(|e| AppError::Data(e.to_string()))
}

/// An analysed model as the file written for it: the user's own netlist
/// with the analysis's edits ([`crate::written_model`]), or, when the
/// user's file cannot express them (or is not at hand), the flat netlist,
/// with the reason in its description.
pub fn augmented_json(source: Option<&crate::load::Source>, flat: &graph::FlatNetlist, description: String) -> Result<String, AppError> {
    let why = match source.map(|s| crate::written_model::user_netlist_json(s, flat, &description)) {
        Some(Ok(text)) => return Ok(text),
        Some(Err(e)) => e,
        None => "the model's files are not at hand".to_string(),
    };
    netlist_json(flat, format!("{description} Written flat, subsystems expanded: {why}."))
}

/// File name of an augmented netlist for a structure label ("a+b").
pub fn model_file(label: &str) -> String {
    if label == "baseline" {
        "model_calibrated.json".into()
    } else {
        format!("model_with_{label}.json")
    }
}

// ---------------------------------------------------------------- figures

const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
/// Fewer measured points than this in a panel are drawn as markers.
const SPARSE_POINTS: usize = 300;
const MEASURED: RGBColor = RGBColor(150, 150, 150);
const BEFORE: RGBColor = RGBColor(255, 127, 14);
const AFTER: RGBColor = RGBColor(31, 119, 180);

fn ensure_font() -> Result<(), AppError> {
    static OK: OnceLock<bool> = OnceLock::new();
    if *OK.get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok()) {
        Ok(())
    } else {
        Err(AppError::Data("the bundled font DejaVuSans.ttf could not be read".into()))
    }
}

/// Display scale and axis label of a signal.
fn display(signal: &str) -> (f64, String) {
    match signal.rsplit('.').next().unwrap_or("") {
        "p" => (1e-5, format!("{signal} [bar]")),
        "x" => (1e3, format!("{signal} [mm]")),
        "T" => (1.0, format!("{signal} [K]")),
        "v" => (1.0, format!("{signal} [m/s]")),
        _ => (1.0, signal.to_string()),
    }
}

/// A drawn line: label, colour, width, points.
type Series = (&'static str, RGBColor, u32, Vec<(f64, f64)>);

/// Render with `draw` and stage the PNG for `path` in the report's transaction.
fn png(out: &mut Transaction, path: &Path, draw: impl FnOnce(&Path) -> Result<(), String>) -> Result<(), AppError> {
    ensure_font()?;
    let bytes = crate::plot::png_via_scratch(|file| {
        draw(file).map_err(|e| AppError::Data(format!("cannot draw {}: {e}", crate::error::shown_path(path))))
    })?;
    out.add(path, &bytes)
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(v), h.max(v)));
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 * lo.abs().max(1e-9) };
    (lo - pad, hi + pad)
}

/// Measured vs simulated before (and after) for one experiment: per channel
/// a panel of the traces and a panel of the residuals (simulated − measured)
/// with the ±σ noise band. The model is drawn as simulated; the fitted
/// sensor errors are taken off the data (see [`identify::diagnose::Trace`]);
/// sparse data are drawn as markers.
fn fit_figure(out: &mut Transaction, path: &Path, before: &Trace, after: Option<&Trace>) -> Result<(), AppError> {
    let n = before.signals.len().max(1);
    let size = (1200u32, 60 + 2 * 230 * n as u32);
    png(out, path, |file| {
        let root = BitMapBackend::new(file, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let title = format!(
            "{}: measured (grey), calibrated baseline (orange){}",
            before.name,
            if after.is_some() { ", with the missing effect (blue)" } else { "" }
        );
        let body = root.titled(&title, (FONT, 22)).map_err(|e| e.to_string())?;
        let areas = body.split_evenly((2 * n, 1));
        let (t0, t1) = range(before.times.iter().copied());
        for c in 0..before.signals.len() {
            let (scale, label) = display(&before.signals[c]);
            let pts = |v: &[Option<f64>]| -> Vec<(f64, f64)> {
                before.times.iter().zip(v).filter_map(|(t, y)| y.map(|y| (*t, y * scale))).collect()
            };
            let res = |t: &Trace| -> Vec<(f64, f64)> {
                (0..t.times.len()).filter_map(|i| t.residual(c, i).map(|r| (t.times[i], r * scale))).collect()
            };
            let meas = pts(&before.measured[c]);
            let sim0 = pts(&before.simulated[c]);
            let sim1 = after.map(|a| pts(&a.simulated[c]));
            let res0 = res(before);
            let res1 = after.map(res);
            let sigma = before.sigma[c] * scale;
            // traces
            let (y0, y1) = range(meas.iter().chain(&sim0).map(|p| p.1));
            let mut chart = ChartBuilder::on(&areas[2 * c])
                .margin(8)
                .x_label_area_size(30)
                .y_label_area_size(80)
                .build_cartesian_2d(t0..t1, y0..y1)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .y_desc(label.as_str())
                .label_style((FONT, 13))
                .axis_desc_style((FONT, 14))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| e.to_string())?;
            // sparse data (a vessel logged every few seconds) as markers: a
            // line between samples would invent a trajectory
            let sparse = meas.len() < SPARSE_POINTS;
            let mut series: Vec<Series> = if sparse {
                let marks = meas.iter().map(|&p| Circle::new(p, 3, MEASURED.filled()));
                chart
                    .draw_series(marks)
                    .map_err(|e| e.to_string())?
                    .label("measured")
                    .legend(|(x, y)| Circle::new((x + 10, y), 3, MEASURED.filled()));
                vec![("baseline", BEFORE, 2, sim0)]
            } else {
                vec![("measured", MEASURED, 1, meas), ("baseline", BEFORE, 2, sim0)]
            };
            if let Some(s1) = sim1 {
                series.push(("with effect", AFTER, 2, s1));
            }
            for (name, color, width, data) in series {
                chart
                    .draw_series(LineSeries::new(data, color.stroke_width(width)))
                    .map_err(|e| e.to_string())?
                    .label(name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 13))
                .draw()
                .map_err(|e| e.to_string())?;
            // residuals
            let (r0, r1) = range(res0.iter().chain(res1.iter().flatten()).map(|p| p.1).chain([-3.0 * sigma, 3.0 * sigma]));
            let mut chart = ChartBuilder::on(&areas[2 * c + 1])
                .margin(8)
                .x_label_area_size(40)
                .y_label_area_size(80)
                .build_cartesian_2d(t0..t1, r0..r1)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc("t [s]")
                .y_desc(format!("residual {}", label.split(' ').next_back().unwrap_or("")))
                .label_style((FONT, 13))
                .axis_desc_style((FONT, 14))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| e.to_string())?;
            for (points, color) in std::iter::once((res0, BEFORE)).chain(res1.map(|r| (r, AFTER))) {
                if sparse {
                    chart.draw_series(points.into_iter().map(|p| Circle::new(p, 3, color.filled()))).map_err(|e| e.to_string())?;
                } else {
                    chart.draw_series(LineSeries::new(points, color.stroke_width(1))).map_err(|e| e.to_string())?;
                }
            }
            for band in [-sigma, sigma] {
                chart.draw_series(LineSeries::new(vec![(t0, band), (t1, band)], BLACK.stroke_width(1))).map_err(|e| e.to_string())?;
            }
        }
        root.present().map_err(|e| e.to_string())
    })
}

/// Normalised RMSE per phase and channel, before and after (log scale).
fn phase_figure(out: &mut Transaction, path: &Path, before: &ModelSummary, after: Option<&ModelSummary>) -> Result<(), AppError> {
    let channels: Vec<String> = before.diagnosis.channels.keys().cloned().collect();
    let n = channels.len().max(1);
    let phases = phases_present(before);
    let size = (1200u32, 60 + 280 * n as u32);
    let value = |m: &ModelSummary, ch: &str, ph: Phase| {
        m.diagnosis.phases.iter().find(|p| p.channel == ch && p.phase == ph).map(|p| p.rmse_normalized)
    };
    png(out, path, |file| {
        let root = BitMapBackend::new(file, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let title = format!(
            "normalised RMSE per phase (1 = noise level): baseline (orange){}",
            if after.is_some() { ", with the missing effect (blue)" } else { "" }
        );
        let body = root.titled(&title, (FONT, 22)).map_err(|e| e.to_string())?;
        let areas = body.split_evenly((n, 1));
        for (ch, area) in channels.iter().zip(areas.iter()) {
            let all: Vec<f64> =
                phases.iter().flat_map(|&ph| [value(before, ch, ph), after.and_then(|a| value(a, ch, ph))]).flatten().collect();
            let hi = all.iter().copied().fold(2.0_f64, f64::max) * 1.5;
            let lo = all.iter().copied().filter(|v| *v > 0.0).fold(1.0_f64, f64::min).min(1.0) * 0.5;
            let mut chart = ChartBuilder::on(area)
                .margin(8)
                .x_label_area_size(40)
                .y_label_area_size(80)
                .build_cartesian_2d(0.0..phases.len().max(1) as f64, (lo..hi).log_scale())
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .y_desc(format!("{ch}: RMSE/σ"))
                .x_labels(phases.len() * 2 + 1)
                .x_label_formatter(&|x| {
                    let k = x.floor() as usize;
                    if (x - k as f64 - 0.5).abs() < 0.26 {
                        phases.get(k).map(|p| p.name().to_string()).unwrap_or_default()
                    } else {
                        String::new()
                    }
                })
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 15))
                .disable_x_mesh()
                .draw()
                .map_err(|e| e.to_string())?;
            for (k, &ph) in phases.iter().enumerate() {
                let x = k as f64;
                if let Some(v) = value(before, ch, ph) {
                    chart
                        .draw_series(std::iter::once(Rectangle::new([(x + 0.15, lo), (x + 0.5, v.max(lo))], BEFORE.filled())))
                        .map_err(|e| e.to_string())?;
                }
                if let Some(v) = after.and_then(|a| value(a, ch, ph)) {
                    chart
                        .draw_series(std::iter::once(Rectangle::new([(x + 0.5, lo), (x + 0.85, v.max(lo))], AFTER.filled())))
                        .map_err(|e| e.to_string())?;
                }
            }
            chart
                .draw_series(LineSeries::new(vec![(0.0, 1.0), (phases.len() as f64, 1.0)], BLACK.stroke_width(1)))
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())
    })
}

// ---------------------------------------------------------------- report

fn safe(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
}

fn model_section(md: &mut String, title: &str, m: &ModelSummary) {
    let _ = writeln!(md, "### {title}\n");
    let effects = if m.effects.is_empty() { "none (the model as given)".to_string() } else { m.effects.join(", ") };
    let _ = writeln!(md, "Effects added: {effects}. Fit: {} ({}).\n", if m.converged { "converged" } else { "stopped" }, m.fit_message);
    let _ = writeln!(md, "| parameter | estimate | 95 % interval |\n|---|---|---|");
    for e in &m.params {
        md.push_str(&estimate_row(e));
    }
    if !m.sensors.is_empty() {
        let _ = writeln!(
            md,
            "\nSensor errors, fitted with every model and never a missing effect (95 % intervals):\n\n| experiment | channel | offset | gain error | logger time skew |\n|---|---|---|---|---|"
        );
        for x in &m.sensors {
            md.push_str(&sensor_row(x));
        }
    }
    let _ = writeln!(md, "\n| channel | RMSE | RMSE / σ | bias | lag-1 autocorrelation | Ljung–Box Q/L |\n|---|---|---|---|---|---|");
    for (ch, c) in &m.diagnosis.channels {
        let w = m.diagnosis.whiteness.get(ch);
        let _ = writeln!(
            md,
            "| {ch} | {} | {:.2} | {} | {} | {} |",
            fmt(c.rmse),
            c.rmse_normalized,
            fmt(c.bias),
            w.map(|w| fmt_fixed(w.lag1, 3)).unwrap_or_else(|| "–".into()),
            w.map(|w| fmt_fixed(w.ljung_box_per_lag, 1)).unwrap_or_else(|| "–".into())
        );
    }
    let _ = writeln!(md, "\nNormalised RMSE per phase of the test (share of Σ(r/σ)² in brackets):\n");
    let chans: Vec<&String> = m.diagnosis.channels.keys().collect();
    let rows: Vec<Vec<String>> = phases_present(m)
        .into_iter()
        .map(|ph| {
            let cells = chans.iter().map(|ch| {
                m.diagnosis
                    .phases
                    .iter()
                    .find(|p| p.phase == ph && &p.channel == *ch)
                    .map(|p| format!("{:.2} ({:.0} %)", p.rmse_normalized, 100.0 * p.share))
                    .unwrap_or_else(|| "–".into())
            });
            std::iter::once(ph.name().to_string()).chain(cells).collect()
        })
        .collect();
    let header: Vec<&str> = std::iter::once("phase").chain(chans.iter().map(|c| c.as_str())).collect();
    table(md, &header, &rows, "No samples to divide into phases.");
    let _ = writeln!(md, "\nCorrelation of the residuals with candidate regressors:\n");
    let regs: Vec<String> = m.diagnosis.correlations.values().flat_map(|r| r.keys().cloned()).fold(Vec::new(), |mut v, k| {
        if !v.contains(&k) {
            v.push(k);
        }
        v
    });
    let rows: Vec<Vec<String>> = m
        .diagnosis
        .correlations
        .iter()
        .map(|(ch, r)| {
            std::iter::once(ch.clone()).chain(regs.iter().map(|k| r.get(k).map(|v| format!("{v:+.2}")).unwrap_or_default())).collect()
        })
        .collect();
    let header: Vec<&str> = std::iter::once("channel").chain(regs.iter().map(|r| r.as_str())).collect();
    let rows = if regs.is_empty() { Vec::new() } else { rows };
    table(md, &header, &rows, "No candidate regressor applies to this circuit.");
    md.push('\n');
}

fn candidate_rows(md: &mut String, cands: &[Candidate]) {
    let _ = writeln!(md, "| round | effect | ΔIC | held-out RMSE | parameters | verdict |\n|---|---|---|---|---|---|");
    for c in cands {
        let params = if c.estimates.is_empty() {
            c.params.iter().map(|(k, v)| format!("{k} = {}", effect_value(cands, &c.effect, k, *v))).collect::<Vec<_>>().join(", ")
        } else {
            c.estimates
                .iter()
                .map(|e| {
                    format!(
                        "{} = {}{}",
                        e.name.split_once('.').map_or(e.name.as_str(), |(_, rest)| rest),
                        shown(e, e.value),
                        e.std_error.map(|s| format!(" ± {}", shown(e, s).split(' ').next().unwrap_or(""))).unwrap_or_default()
                    )
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let verdict = if c.accepted { "passes every test".to_string() } else { c.reasons.join("; ") };
        let dic = if c.screened_out { format!("{} (first part)", fmt(c.delta_ic)) } else { fmt(c.delta_ic) };
        let _ = writeln!(md, "| {} | {} | {} | {} | {} | {} |", c.round, c.effect, dic, fmt(c.heldout_rmse), params, verdict);
    }
    md.push('\n');
}

/// Write the report directory as one transaction: every file or none (a
/// directory this call created is removed again if writing fails).
pub fn write_report(
    out: &Path,
    inputs: &[PathBuf],
    model_path: &Path,
    manifest_path: &Path,
    o: &Outcome,
    json: &str,
) -> Result<Vec<PathBuf>, AppError> {
    let created = !out.exists();
    std::fs::create_dir_all(out).map_err(|e| AppError::io(out, e))?;
    let inputs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    let mut tx = Transaction::new(&inputs);
    let result = stage_report(&mut tx, out, model_path, manifest_path, o, json).and_then(|written| tx.commit().map(|()| written));
    if result.is_err() && created {
        let _ = std::fs::remove_dir(out);
    }
    result
}

/// A file name not used yet in this report ("fit_run.png", "fit_run_2.png", ...).
fn unique(used: &mut Vec<String>, stem: &str, ext: &str) -> String {
    let mut name = format!("{stem}.{ext}");
    let mut k = 2;
    while used.contains(&name) {
        name = format!("{stem}_{k}.{ext}");
        k += 1;
    }
    used.push(name.clone());
    name
}

fn stage_report(
    tx: &mut Transaction,
    out: &Path,
    model_path: &Path,
    manifest_path: &Path,
    o: &Outcome,
    json: &str,
) -> Result<Vec<PathBuf>, AppError> {
    let s = &o.summary;
    let mut written = Vec::new();
    let mut used: Vec<String> = REPORT_FILES.iter().map(|n| n.to_string()).collect();
    // netlists
    let mut model_files = Vec::new();
    let source = crate::load::Source::read(model_path).ok().map(|(_, s)| s);
    for (label, flat) in &o.augmented {
        let name = model_file(label);
        let description = format!(
            "{} with the discrepancy workflow's result: {}. Calibrated values written in; per-experiment values are in report.md.",
            model_path.display(),
            if label == "baseline" { "no missing effect".to_string() } else { format!("added {label}") }
        );
        let path = out.join(&name);
        used.push(name.clone());
        tx.add(&path, augmented_json(source.as_ref(), flat, description)?.as_bytes())?;
        written.push(path);
        model_files.push(name);
    }
    // figures
    let has_after = !s.selected.is_empty();
    let mut figures = Vec::new();
    for (k, b) in o.before.iter().enumerate() {
        let name = unique(&mut used, &format!("fit_{}", safe(&b.name)), "png");
        let path = out.join(&name);
        fit_figure(tx, &path, b, if has_after { o.after.get(k) } else { None })?;
        written.push(path);
        figures.push(name);
    }
    let phase_name = "residuals_by_phase.png".to_string();
    let path = out.join(&phase_name);
    phase_figure(tx, &path, &s.baseline, if has_after { Some(&s.after) } else { None })?;
    written.push(path);
    // summary
    let path = out.join("summary.json");
    tx.add(&path, json.as_bytes())?;
    written.push(path);
    // report.md
    let mut md = String::new();
    let _ = writeln!(md, "# Discrepancy report\n");
    let _ = writeln!(md, "Model `{}`, experiments `{}`.\n", model_path.display(), manifest_path.display());
    let _ = writeln!(md, "**Verdict: {}.**\n", s.verdict);
    if !s.selected.is_empty() {
        for sel in &s.selected {
            let params = sel
                .params
                .iter()
                .map(|(k, v)| {
                    let full = format!("{}.{k}", sel.effect);
                    let ci = s.after.params.iter().find(|e| e.name == full).and_then(|e| e.ci95.map(|(a, b)| (e, a, b)));
                    let ci = ci.map(|(e, a, b)| format!(", 95 % interval [{}, {}]", shown(e, a), shown(e, b))).unwrap_or_default();
                    format!("{k} = {}{ci}", effect_value(&s.candidates, &sel.effect, k, *v))
                })
                .collect::<Vec<_>>()
                .join("; ");
            let _ = writeln!(md, "- added `{}`: {params}", sel.effect);
        }
        let _ = writeln!(
            md,
            "\nAugmented netlist: {} (run it with `pneumo simulate`).\n",
            model_files.iter().map(|f| format!("`{f}`")).collect::<Vec<_>>().join(", ")
        );
    } else if !s.ambiguous.is_empty() {
        let _ = writeln!(
            md,
            "Both alternatives are written: {}.\n",
            model_files.iter().map(|f| format!("`{f}`")).collect::<Vec<_>>().join(", ")
        );
    }
    let _ = writeln!(md, "## Data\n\n| experiment | channel | noise σ |\n|---|---|---|");
    for (e, chans) in &s.noise {
        for (ch, sigma) in chans {
            let _ = writeln!(md, "| {e} | {ch} | {} |", noise_text(ch, *sigma));
        }
    }
    let _ = writeln!(md, "\n## Before and after\n");
    for f in &figures {
        let _ = writeln!(md, "![{f}]({f})\n");
    }
    let _ = writeln!(md, "![residuals per phase]({phase_name})\n");
    let rm = |m: &ModelSummary| m.rmse_normalized.iter().map(|(k, v)| format!("{k} {v:.2}")).collect::<Vec<_>>().join(", ");
    let _ = writeln!(md, "Normalised RMSE (1 = sensor noise): baseline {}; after {}.", rm(&s.baseline), rm(&s.after));
    let _ = writeln!(md, "Held-out RMSE: baseline {:.3}, after {:.3}.\n", s.baseline.heldout_rmse, s.after.heldout_rmse);
    let _ = writeln!(md, "## Models\n");
    model_section(&mut md, "Calibrated baseline", &s.baseline);
    if has_after {
        model_section(&mut md, "With the missing effect", &s.after);
    }
    let _ = writeln!(md, "## Candidates\n");
    let th = &s.thresholds;
    let _ = writeln!(
        md,
        "Accepted when ΔIC < −{} (BIC), the held-out RMSE drops by at least {:.0} %, a parameter lies more than {} standard errors from its null value and none sits at a bound that is not its null. Two passing candidates whose χ² reductions are within {:.0} % of each other are ambiguous.\n",
        th.ic,
        100.0 * th.heldout_gain,
        th.z_null,
        100.0 * th.ambiguity
    );
    candidate_rows(&mut md, &s.candidates);
    let _ = writeln!(md, "{} simulations of all experiments, {:.1} s.", s.evaluations, s.seconds);
    let path = out.join("report.md");
    tx.add(&path, md.as_bytes())?;
    written.push(path);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_units_are_shown_shortly() {
        assert_eq!(fmt(12.5), "12.5");
        assert_eq!(fmt(3.0), "3");
        assert_eq!(fmt(-77224.7824), "-77225");
        assert_eq!(fmt(1.02413), "1.0241");
        assert_eq!(fmt(2.5e-9), "2.500e-9");
        assert_eq!(fmt(f64::NAN), "–");
        let e = Estimate {
            name: "flow_control.C".into(),
            value: 13.2e-3 / 60.0 / 1e5,
            unit: "L/min/bar".into(),
            shown: None,
            std_error: None,
            ci95: None,
            shown_ci95: None,
            lo: 0.0,
            hi: 1.0,
            at_bound: false,
        };
        assert_eq!(shown(&e, e.value), "13.2 L/min/bar");
        assert_eq!(model_file("piston_seal_leak"), "model_with_piston_seal_leak.json");
        assert_eq!(model_file("baseline"), "model_calibrated.json");
        assert_eq!(safe("4 bar, C=2"), "4_bar__C_2");
        assert_eq!(display("head.p").0, 1e-5);
        assert_eq!(effect_value(&[], "piston_seal_leak", "C", 0.3e-3 / 60.0 / 1e5), "0.3 L/min/bar");
        assert_eq!(effect_value(&[], "no_such_effect", "C", 2.5), "2.5");
        assert_eq!(noise_text("head.p", 500.0), "5 mbar");
        assert_eq!(noise_text("piston.x", 2e-5), "20 µm");
        let x = SensorEstimate {
            experiment: "4bar".into(),
            signal: "head.p".into(),
            offset: 1000.0,
            offset_ci95: Some((900.0, 1100.0)),
            gain: 0.0,
            gain_ci95: None,
            time_skew: 4e-4,
            time_skew_ci95: Some((3e-4, 5e-4)),
            offset_prior_sd: f64::INFINITY,
            gain_prior_sd: 0.0,
            prior_source: String::new(),
            offset_z: 0.0,
            gain_z: 0.0,
            skew_z: 0.0,
            symptom: None,
        };
        assert_eq!(sensor_row(&x), "| 4bar | head.p | 10 mbar [9 mbar, 11 mbar] | 0 % | 0.4 ms [0.3 ms, 0.5 ms] |\n");
    }
}
