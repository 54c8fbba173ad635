//! The report use case (`pneumo report`): one self-contained HTML page of a
//! run — the circuit diagram (inline SVG from `crates/draw`), interactive
//! trace plots (one panel per quantity, units on the axes; uPlot, vendored
//! in `src/report/vendor/` with its licence), and the summary tables
//! (cycle times, mean polytropic index, air consumption, balances, solver
//! work) built from the same summary JSON that `pneumo simulate --summary`
//! writes.
//!
//! With `--experiments E.json` the page adds the discrepancy result
//! ([`fit`]): the workflow of [`crate::discrepancy`] run on the model and
//! the manifest's records, shown as the graded verdict, before/after
//! panels with the measurements as markers, the estimates and the
//! candidates.
//!
//! Safe to share: every string from a netlist or the results reaches the
//! page through [`html_text`] (markup characters become entities) or inside
//! the JSON data block through [`script_json`] (no `<`, `>` or `&` at all),
//! the diagram's own text was escaped by `crates/draw`, and a
//! Content-Security-Policy allows only the page's own two scripts and its
//! own style (by SHA-256 hash), no network, no forms, no frames.

use crate::draw::diagram_of;
use crate::error::{shown_path, AppError};
use crate::load::Source;
use crate::output::Transaction;
use crate::plot::{quantity_of_unit, Quantity};
use crate::run::{execute, prepare, Run, RunSpec};
use crate::simulate::summary_of;
use serde_json::{json, Value};
use std::fmt::Write;
use std::path::PathBuf;

pub mod fit;

/// uPlot 1.6.32 (MIT, © Leon Sorokin), the minified browser build.
const UPLOT_JS: &str = include_str!("report/vendor/uPlot.iife.min.js");
const UPLOT_CSS: &str = include_str!("report/vendor/uPlot.min.css");
const UPLOT_LICENSE: &str = include_str!("report/vendor/uPlot.LICENSE");
/// The page's own script: builds the plots from the JSON data block.
const REPORT_JS: &str = include_str!("report/report.js");
const REPORT_CSS: &str = include_str!("report/report.css");

/// Most samples per trace sent to the page; longer runs are thinned by an
/// even stride (said on the page).
pub const MAX_POINTS: usize = 20_000;

/// One run and its report page.
#[derive(Debug, Clone, Default)]
pub struct ReportOptions {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Overrides `ID.PARAM=VALUE`, applied in order (the diagram shows them too).
    pub sets: Vec<String>,
    /// Number of actuator cycles to run.
    pub cycles: Option<u64>,
    /// End time [s].
    pub t_end: Option<f64>,
    /// The page to write (.html).
    pub output: PathBuf,
    /// An experiments manifest: add the discrepancy result to the page.
    pub experiments: Option<PathBuf>,
}

/// Run the model of `o` and write its report page; `warn` receives the
/// circuit's warnings before the run. An incomplete run is still reported
/// (the page says so) and returned with [`Run::incomplete`] set.
pub fn report(o: &ReportOptions, warn: &mut dyn FnMut(&[graph::Warning])) -> Result<Run, AppError> {
    match o.output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("html" | "htm") => {}
        _ => return Err(AppError::Usage(format!("--out {}: the file name must end in .html", shown_path(&o.output)))),
    }
    let (flat, source) = Source::read(&o.model)?;
    let experiments = o.experiments.as_deref().map(|m| crate::discrepancy::read_experiments(&flat, m)).transpose()?;
    let mut inputs: Vec<&std::path::Path> = source.files.iter().map(|(p, _)| p.as_path()).collect();
    inputs.extend(experiments.iter().flat_map(|e| e.files.iter().map(PathBuf::as_path)));
    let mut outputs = Transaction::new(&inputs);
    outputs.check_targets(&[o.output.as_path()])?;
    let diagram = diagram_of(flat.clone(), &source, &o.sets)?;
    let description =
        source.files.first().and_then(|(p, text)| graph::expand::parse(text, &p.display().to_string()).ok()).and_then(|n| n.description);
    let spec = RunSpec { sets: o.sets.clone(), cycles: o.cycles, t_end: o.t_end, cancel: None };
    let discrepancy = match (&experiments, &o.experiments) {
        (Some(e), Some(m)) => {
            let outcome = crate::discrepancy::analyse(&flat, e)?;
            Some(Discrepancy { html: fit::section(&outcome, &shown_path(m)), panels: fit::panels(&outcome) })
        }
        _ => None,
    };
    let prepared = prepare(flat, &spec)?;
    warn(&prepared.warnings);
    let run = execute(prepared)?;
    let page =
        Page { source_name: source.name(), sha256: source.sha256(), description, sets: o.sets.clone(), svg: diagram.svg, discrepancy };
    let text = html(&page, &run);
    outputs.add(&o.output, text.as_bytes())?;
    outputs.commit()?;
    Ok(run)
}

/// What the page says besides the run itself.
pub struct Page {
    /// The model file as given (already escaped for messages).
    pub source_name: String,
    /// SHA-256 of the model's files.
    pub sha256: String,
    /// The netlist's free-text description.
    pub description: Option<String>,
    /// The overrides applied.
    pub sets: Vec<String>,
    /// The diagram (an SVG document, its text escaped by `crates/draw`).
    pub svg: String,
    /// The discrepancy section, with `--experiments`.
    pub discrepancy: Option<Discrepancy>,
}

/// The discrepancy result as the page shows it.
pub struct Discrepancy {
    /// The section's HTML (every string escaped).
    pub html: String,
    /// Its before/after panels, for the data block.
    pub panels: Vec<Value>,
}

/// The whole page.
pub fn html(page: &Page, run: &Run) -> String {
    let summary = summary_of(run);
    let mut data = plot_data(&run.result);
    if let (Some(d), Some(panels)) = (&page.discrepancy, data["panels"].as_array_mut()) {
        panels.extend(d.panels.iter().cloned());
    }
    let data_block = script_json(&data);
    let style = format!("{UPLOT_CSS}\n{REPORT_CSS}");
    let csp = format!(
        "default-src 'none'; script-src {} {}; style-src {}; img-src data:; base-uri 'none'; form-action 'none'",
        csp_hash(UPLOT_JS),
        csp_hash(REPORT_JS),
        csp_hash(&style)
    );
    let title = format!("{} — pneumo report", run.name);
    let mut h = String::with_capacity(UPLOT_JS.len() + data_block.len() + page.svg.len() + 16_384);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"{csp}\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"generator\" content=\"pneumo {}\">\n<title>{}</title>\n<style>{style}</style>\n</head>\n<body>\n",
        env!("CARGO_PKG_VERSION"),
        html_text(&title)
    );
    let _ = writeln!(h, "<header>\n<h1>{}</h1>", html_text(&run.name));
    if let Some(d) = &page.description {
        for para in d.split("\n\n") {
            let _ = writeln!(h, "<p class=\"description\">{}</p>", html_text(para));
        }
    }
    let _ = writeln!(
        h,
        "<p class=\"provenance\">Model <code>{}</code> (SHA-256 <code>{}</code>), simulated by pneumo {} to t = {} s.</p>",
        html_text(&page.source_name),
        html_text(&page.sha256),
        env!("CARGO_PKG_VERSION"),
        number(run.result.t_final)
    );
    if !page.sets.is_empty() {
        let sets: Vec<String> = page.sets.iter().map(|s| format!("<code>{}</code>", html_text(s))).collect();
        let _ = writeln!(h, "<p class=\"provenance\">Overrides: {}.</p>", sets.join(", "));
    }
    if let Some(why) = &run.incomplete {
        let _ = writeln!(h, "<p class=\"warning\">Incomplete run: {}</p>", html_text(why));
    }
    h.push_str("</header>\n<nav><a href=\"#circuit\">Circuit</a> · <a href=\"#summary\">Summary</a> · <a href=\"#traces\">Traces</a>");
    if page.discrepancy.is_some() {
        h.push_str(" · <a href=\"#discrepancy\">Model and measurements</a>");
    }
    h.push_str("</nav>\n");
    h.push_str("<section id=\"circuit\">\n<h2>Circuit</h2>\n<div class=\"diagram\">\n");
    h.push_str(svg_element(&page.svg));
    h.push_str("\n</div>\n</section>\n");
    h.push_str("<section id=\"summary\">\n<h2>Summary</h2>\n");
    h.push_str(&summary_tables(&summary));
    h.push_str("</section>\n");
    h.push_str("<section id=\"traces\">\n<h2>Traces</h2>\n");
    h.push_str("<p class=\"hint\">Drag across a plot to zoom in time (all panels follow), double-click to zoom out; the legend shows the values under the cursor. Click a legend entry to hide its line.</p>\n");
    if let Some(note) = data["note"].as_str() {
        let _ = writeln!(h, "<p class=\"hint\">{}</p>", html_text(note));
    }
    h.push_str(
        "<noscript><p class=\"warning\">The plots need JavaScript (the page's own script only); the tables above do not.</p></noscript>\n",
    );
    h.push_str("<div id=\"plots\"></div>\n</section>\n");
    if let Some(d) = &page.discrepancy {
        h.push_str(&d.html);
        h.push('\n');
    }
    let _ = writeln!(
        h,
        "<footer><p>Plots drawn with uPlot 1.6.32, embedded under its licence:</p><pre class=\"licence\">{}</pre></footer>",
        html_text_keep_lines(UPLOT_LICENSE)
    );
    let _ = write!(h, "<script type=\"application/json\" id=\"pneumo-data\">{data_block}</script>\n<script>{UPLOT_JS}</script>\n<script>{REPORT_JS}</script>\n</body>\n</html>\n");
    h
}

/// The `<svg>` element of an SVG document (its XML declaration dropped).
fn svg_element(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => "",
    }
}

/// The traces as the page's script reads them: shared time axis, one panel
/// per quantity (display unit on the axis), values converted to the display
/// unit, undefined values null.
fn plot_data(result: &solve::SimResult) -> Value {
    let n = result.times.len();
    let stride = n.div_ceil(MAX_POINTS).max(1);
    let rows: Vec<usize> =
        (0..n).step_by(stride).chain((stride > 1 && n > 0 && !(n - 1).is_multiple_of(stride)).then_some(n - 1)).collect();
    let mut panels: Vec<(String, Quantity, Vec<usize>)> = Vec::new();
    for c in 0..result.columns.len() {
        let q = quantity_of_unit(result.units.get(c).map(String::as_str).unwrap_or(""));
        // dimensionless signals mean different things: one panel per signal name
        let key = if q.display == "-" { format!("{} [-]", result.columns[c].rsplit('.').next().unwrap_or("")) } else { q.axis() };
        match panels.iter_mut().find(|p| p.0 == key) {
            Some(p) => p.2.push(c),
            None => panels.push((key, q, vec![c])),
        }
    }
    let time: Vec<Value> = rows.iter().map(|&i| json!(round(result.times[i]))).collect();
    let panels: Vec<Value> = panels
        .into_iter()
        .map(|(key, q, cols)| {
            let signal = key.split(' ').next().unwrap_or("");
            // the polytropic index runs off to ±∞ where ρ̇ = 0: a fixed range keeps the strokes readable
            let range = (q.display == "-" && (signal == "n" || signal == "n_est")).then(|| json!([0.0, 3.0]));
            let series: Vec<Value> = cols
                .iter()
                .map(|&c| {
                    let values: Vec<Value> = rows
                        .iter()
                        .map(|&i| match result.rows[i][c] {
                            Some(v) if v.is_finite() => json!(round(q.show(v))),
                            _ => Value::Null,
                        })
                        .collect();
                    json!({"label": result.columns[c], "values": values})
                })
                .collect();
            json!({"title": key, "y_label": key, "range": range, "series": series})
        })
        .collect();
    let note = (stride > 1).then(|| format!("{n} samples; every {stride}th is plotted (at most {MAX_POINTS} per trace)."));
    json!({"time": time, "x_label": "time [s]", "panels": panels, "note": note})
}

/// Seven significant digits: what a plot can show, and a third of the bytes.
fn round(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.6e}").parse().unwrap_or(x)
}

/// The summary as tables.
fn summary_tables(s: &Value) -> String {
    let mut h = String::new();
    // cycle times
    let cycles = s["cycles"].as_array().cloned().unwrap_or_default();
    h.push_str("<h3>Cycle times</h3>\n");
    if cycles.is_empty() {
        h.push_str("<p>No completed cycle.</p>\n");
    } else {
        let rows: Vec<Vec<String>> = cycles
            .iter()
            .map(|c| {
                vec![
                    c["controller"].as_str().unwrap_or("").to_string(),
                    c["cycle"].to_string(),
                    seconds(&c["start_s"]),
                    seconds(&c["extend_s"]),
                    seconds(&c["retract_s"]),
                    seconds(&c["total_s"]),
                ]
            })
            .collect();
        h.push_str(&table(&["controller", "cycle", "start [s]", "extend [s]", "retract [s]", "total [s]"], &rows));
    }
    // mean polytropic index, per chamber and stroke, one column per cycle
    let poly = &s["mean_polytropic_index"];
    let mut rows = Vec::new();
    let mut add = |controller: &str, chambers: &serde_json::Map<String, Value>| {
        for (id, strokes) in chambers {
            for stroke in ["extend", "retract"] {
                let values: Vec<String> = strokes[stroke]
                    .as_array()
                    .map(|l| l.iter().map(|v| v.as_f64().map_or("–".into(), |x| format!("{x:.3}"))).collect())
                    .unwrap_or_default();
                if !values.is_empty() {
                    rows.push(vec![controller.to_string(), id.clone(), stroke.to_string(), values.join(", ")]);
                }
            }
        }
    };
    if let Some(m) = poly.as_object() {
        if m.values().all(|v| v.get("extend").is_some()) {
            add("", m);
        } else {
            for (controller, chambers) in m {
                if let Some(c) = chambers.as_object() {
                    add(controller, c);
                }
            }
        }
    }
    if !rows.is_empty() {
        h.push_str("<h3>Mean polytropic index</h3>\n<p class=\"hint\">n of each chamber over each stroke (paper Eq. 35), one value per cycle.</p>\n");
        h.push_str(&table(&["controller", "chamber", "stroke", "n per cycle"], &rows));
    }
    // air consumption
    if let Some(sources) = s["air_consumption"]["sources"].as_object() {
        let rows: Vec<Vec<String>> = sources
            .iter()
            .map(|(id, a)| {
                let per_cycle: Vec<String> = a["per_cycle_L"]
                    .as_object()
                    .map(|m| m.values().flat_map(|l| l.as_array().cloned().unwrap_or_default()).map(|v| fixed(&v, 3)).collect())
                    .unwrap_or_default();
                vec![id.clone(), fixed(&a["free_air_L"], 3), fixed(&a["mean_L_per_min"], 2), per_cycle.join(", ")]
            })
            .collect();
        if !rows.is_empty() {
            h.push_str("<h3>Air consumption</h3>\n");
            let _ = writeln!(h, "<p class=\"hint\">{}</p>", html_text(s["air_consumption"]["reference"].as_str().unwrap_or("")));
            h.push_str(&table(&["supply", "free air [L ANR]", "mean flow [L/min ANR]", "per cycle [L ANR]"], &rows));
        }
    }
    // balances
    let b = &s["conservation"];
    h.push_str("<h3>Balances</h3>\n<p class=\"hint\">Mass and energy of the gas over the run; the residual is what the integration lost, relative to what moved.</p>\n");
    let rows = vec![
        vec![
            "mass [kg]".into(),
            sci(&b["mass_initial_kg"]),
            sci(&b["mass_in_kg"]),
            "".into(),
            "".into(),
            sci(&b["mass_final_kg"]),
            sci(&b["mass_residual"]),
        ],
        vec![
            "energy [J]".into(),
            sci(&b["energy_initial_J"]),
            sci(&b["energy_in_J"]),
            sci(&b["heat_in_J"]),
            sci(&b["work_out_J"]),
            sci(&b["energy_final_J"]),
            sci(&b["energy_residual"]),
        ],
    ];
    h.push_str(&table(&["", "initial", "in (ports)", "heat in", "work out", "final", "residual"], &rows));
    // solver
    let v = &s["solver"];
    h.push_str("<h3>Solver</h3>\n");
    let rows = vec![vec![
        v["steps"].to_string(),
        v["rejected"].to_string(),
        v["rhs_evaluations"].to_string(),
        v["jacobians"].to_string(),
        v["events"].to_string(),
        v["samples"].to_string(),
    ]];
    h.push_str(&table(&["steps", "rejected", "evaluations", "Jacobians", "events", "samples"], &rows));
    // signal ranges
    if let Some(signals) = s["signals"].as_object() {
        let rows: Vec<Vec<String>> = signals
            .iter()
            .map(|(name, r)| {
                let q = quantity_of_unit(r["unit"].as_str().unwrap_or(""));
                let show = |v: &Value| v.as_f64().map_or("–".to_string(), |x| number(q.show(x)));
                vec![name.clone(), show(&r["min"]), show(&r["max"]), q.display.clone()]
            })
            .collect();
        h.push_str("<h3>Signal ranges</h3>\n");
        h.push_str(&table(&["signal", "min", "max", "unit"], &rows));
    }
    h
}

/// A table; every cell is escaped here.
fn table(head: &[&str], rows: &[Vec<String>]) -> String {
    let mut h = String::from("<table>\n<thead><tr>");
    for c in head {
        let _ = write!(h, "<th>{}</th>", html_text(c));
    }
    h.push_str("</tr></thead>\n<tbody>\n");
    for r in rows {
        h.push_str("<tr>");
        for c in r {
            let _ = write!(h, "<td>{}</td>", html_text(c));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</tbody>\n</table>\n");
    h
}

fn seconds(v: &Value) -> String {
    fixed(v, 4)
}

fn fixed(v: &Value, decimals: usize) -> String {
    v.as_f64().map_or("–".into(), |x| format!("{x:.decimals$}"))
}

fn sci(v: &Value) -> String {
    v.as_f64().map_or("–".into(), number)
}

/// A number as a person reads it: up to 6 significant digits, exponent
/// form outside 1e-3 … 1e6.
fn number(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        format!("{x:.4e}")
    } else {
        let s = format!("{x:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".into()
        } else {
            s.into()
        }
    }
}

/// `s` as HTML text or a double-quoted attribute value: markup characters
/// as entities, control characters (but line breaks, which collapse to
/// spaces) dropped, bidirectional overrides dropped.
pub fn html_text(s: &str) -> String {
    draw::svg::text(s)
}

/// As [`html_text`], keeping line breaks (for `<pre>`).
fn html_text_keep_lines(s: &str) -> String {
    s.lines().map(html_text).collect::<Vec<_>>().join("\n")
}

/// JSON for a `<script type="application/json">` block: `<`, `>` and `&`
/// as `\u` escapes (so that no `</script>` or `<!--` can appear), and the
/// line separators that older JavaScript parsers choke on.
pub fn script_json(v: &Value) -> String {
    let text = serde_json::to_string(v).unwrap_or_else(|_| "null".into());
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '<' => out.push_str("\\u003c"),
            '>' => out.push_str("\\u003e"),
            '&' => out.push_str("\\u0026"),
            '\u{2028}' => out.push_str("\\u2028"),
            '\u{2029}' => out.push_str("\\u2029"),
            c => out.push(c),
        }
    }
    out
}

/// A CSP source expression allowing exactly this inline script or style.
fn csp_hash(text: &str) -> String {
    use base64::Engine;
    use sha2::{Digest, Sha256};
    format!("'sha256-{}'", base64::engine::general_purpose::STANDARD.encode(Sha256::digest(text.as_bytes())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn script_json_cannot_close_its_element() {
        let v = json!({"label": "</script><script>alert(1)</script><!-- & \u{2028}"});
        let s = script_json(&v);
        assert!(!s.contains('<') && !s.contains('>') && !s.contains('&') && !s.contains('\u{2028}'), "{s}");
        let back: Value = serde_json::from_str(&s).unwrap();
        assert_eq!(back, v, "the escapes are JSON and decode to the same text");
    }

    #[test]
    fn the_embedded_assets_cannot_close_their_elements() {
        for (name, text) in [("uPlot.js", UPLOT_JS), ("report.js", REPORT_JS)] {
            let lower = text.to_ascii_lowercase();
            assert!(!lower.contains("</script") && !lower.contains("<!--") && !lower.contains("<script"), "{name}");
        }
        for (name, text) in [("uPlot.css", UPLOT_CSS), ("report.css", REPORT_CSS)] {
            assert!(!text.to_ascii_lowercase().contains("</style"), "{name}");
        }
    }

    #[test]
    fn numbers_read_as_a_person_writes_them() {
        assert_eq!(number(1.5), "1.5");
        assert_eq!(number(0.0), "0");
        assert_eq!(number(1e300), "1.0000e300");
        assert_eq!(number(-2.5e-7), "-2.5000e-7");
        assert_eq!(round(1.234_567_891_23), 1.234_568);
    }

    #[test]
    fn the_hash_is_the_base64_sha256_browsers_compare() {
        // echo -n "alert(1)" | openssl dgst -sha256 -binary | base64
        assert_eq!(csp_hash("alert(1)"), "'sha256-bhHHL3z2vDgxUt0W3dWQOrprscmda2Y5pLsLg4GF+pI='");
    }
}
