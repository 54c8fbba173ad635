//! The discrepancy section of a report page (`pneumo report --experiments`):
//! the graded verdict with its reasons, before/after panels per experiment
//! and measured channel (measurements as markers, the model as simulated,
//! the fitted sensor errors taken off the data — see
//! [`identify::diagnose::Trace`]), the estimates with 95 % intervals in the
//! parameters' units and the candidates tried. The workflow is the app
//! layer's ([`crate::discrepancy::analyse`]); the table cells are the ones
//! `report.md` is written from ([`crate::discrepancy::estimate_cells`],
//! [`crate::discrepancy::candidate_cells`],
//! [`crate::discrepancy::sensor_cells`]). Every string here reaches the page
//! through [`super::html_text`] or the JSON data block.

use super::{html_text, round, table};
use crate::discrepancy::{candidate_cells, display, estimate_cells, sensor_cells, CANDIDATE_HEAD};
use identify::diagnose::Trace;
use identify::report::{ModelSummary, Outcome};
use serde_json::{json, Value};
use std::fmt::Write;

/// Most measured samples per panel sent as markers; longer records are
/// thinned by an even stride (said on the page).
pub const MAX_MARKERS: usize = 1_500;

/// The section's HTML (the plots are drawn by the page's script into
/// `#fit-plots` from [`panels`]).
pub fn section(o: &Outcome, manifest_name: &str) -> String {
    let s = &o.summary;
    let mut h = String::from("<section id=\"discrepancy\">\n<h2>Model and measurements</h2>\n");
    let _ = writeln!(h, "<p class=\"provenance\">Experiments <code>{}</code>: {} record(s), analysed by the discrepancy workflow (<code>pneumo discrepancy</code>, docs/discrepancy.md).</p>", html_text(manifest_name), o.before.len());
    let grade = serde_json::to_value(s.grade).ok().and_then(|v| v.as_str().map(|g| g.replace('_', " "))).unwrap_or_default();
    let _ = writeln!(h, "<p class=\"verdict\"><strong>Verdict ({}):</strong> {}.</p>", html_text(&grade), html_text(&s.verdict));
    let mut reasons: Vec<String> = Vec::new();
    for sel in &s.selected {
        reasons.push(format!("{} added: it passed every test of the selection.", sel.effect));
    }
    if !s.ambiguous.is_empty() {
        reasons.push(format!("ambiguous between {}: their χ² reductions are too close to tell apart.", s.ambiguous.join(" and ")));
    }
    for (effect, why) in &s.dropped {
        reasons.push(format!("{effect} dropped again: {why}"));
    }
    for r in &s.remainder {
        reasons.push(format!(
            "{} is not explained: normalised RMSE {:.2}, most of the excess in the {} phase ({:.2}, {:.0} % of it).",
            r.channel,
            r.rmse_normalized,
            r.phase.name(),
            r.phase_rmse_normalized,
            100.0 * r.share
        ));
    }
    if !reasons.is_empty() {
        h.push_str("<ul class=\"reasons\">\n");
        for r in &reasons {
            let _ = writeln!(h, "<li>{}</li>", html_text(r));
        }
        h.push_str("</ul>\n");
    }
    let rm = |m: &ModelSummary| m.rmse_normalized.iter().map(|(k, v)| format!("{k} {v:.2}")).collect::<Vec<_>>().join(", ");
    let mut rows = vec![vec!["calibrated baseline".to_string(), rm(&s.baseline), format!("{:.3}", s.baseline.heldout_rmse)]];
    if !s.selected.is_empty() {
        rows.push(vec![format!("with {}", s.after.effects.join(" + ")), rm(&s.after), format!("{:.3}", s.after.heldout_rmse)]);
    }
    h.push_str("<h3>Gap before and after</h3>\n<p class=\"hint\">Normalised RMSE per channel (1 = the sensor noise level) and held-out RMSE.</p>\n");
    h.push_str(&table(&["model", "normalised RMSE", "held-out RMSE"], &rows));
    h.push_str("<h3>Before and after</h3>\n<p class=\"hint\">Measured (markers, fitted sensor offset and gain taken off), the calibrated baseline (orange) and the model with the missing effect (blue), as simulated. One panel per experiment and measured channel; drag to zoom.</p>\n<div id=\"fit-plots\"></div>\n");
    models_tables(&mut h, "Calibrated baseline", &s.baseline);
    if !s.selected.is_empty() {
        models_tables(&mut h, "With the missing effect", &s.after);
    }
    h.push_str("<h3>Candidates</h3>\n");
    let rows: Vec<Vec<String>> = s.candidates.iter().map(|c| candidate_cells(&s.candidates, c)).collect();
    if rows.is_empty() {
        h.push_str("<p>No candidate was tried.</p>\n");
    } else {
        h.push_str(&table(&CANDIDATE_HEAD, &rows));
    }
    let _ = writeln!(h, "<p class=\"hint\">{} simulations of all experiments, {:.1} s.</p>\n</section>", s.evaluations, s.seconds);
    h
}

fn models_tables(h: &mut String, title: &str, m: &ModelSummary) {
    let _ = writeln!(h, "<h3>Estimates: {}</h3>", html_text(title));
    let rows: Vec<Vec<String>> = m.params.iter().map(estimate_cells).collect();
    if rows.is_empty() {
        h.push_str("<p>No parameter was fitted.</p>\n");
    } else {
        h.push_str(&table(&["parameter", "estimate", "95 % interval"], &rows));
    }
    if !m.sensors.is_empty() {
        h.push_str("<p class=\"hint\">Sensor errors, fitted with every model (95 % intervals):</p>\n");
        let rows: Vec<Vec<String>> = m.sensors.iter().map(sensor_cells).collect();
        h.push_str(&table(&["experiment", "channel", "offset", "gain error", "logger time skew"], &rows));
    }
}

/// The before/after panels as the page's script reads them: each with its
/// own time axis, the measurements as a marker series.
pub fn panels(o: &Outcome) -> Vec<Value> {
    let has_after = !o.summary.selected.is_empty();
    let mut out = Vec::new();
    for (k, before) in o.before.iter().enumerate() {
        let after = if has_after { o.after.get(k) } else { None };
        out.extend(experiment_panels(before, after));
    }
    out
}

fn experiment_panels(before: &Trace, after: Option<&Trace>) -> Vec<Value> {
    let n = before.times.len();
    let stride = n.div_ceil(MAX_MARKERS).max(1);
    let rows: Vec<usize> = (0..n).step_by(stride).collect();
    let time: Vec<Value> = rows.iter().map(|&i| json!(round(before.times[i]))).collect();
    (0..before.signals.len())
        .map(|c| {
            let (scale, label) = display(&before.signals[c]);
            let values = |v: &[Option<f64>]| -> Vec<Value> {
                rows.iter()
                    .map(|&i| match v.get(i).copied().flatten() {
                        Some(y) if y.is_finite() => json!(round(y * scale)),
                        _ => Value::Null,
                    })
                    .collect()
            };
            let mut series = vec![
                json!({"label": "measured", "values": values(&before.measured[c]), "markers": true, "color": "#555555"}),
                json!({"label": "baseline", "values": values(&before.simulated[c]), "color": "#ff7f0e"}),
            ];
            if let Some(a) = after.filter(|a| a.times.len() == n) {
                series.push(json!({"label": "with effect", "values": values(&a.simulated[c]), "color": "#1f77b4"}));
            }
            let title = format!("{}: {label}", before.name);
            let note = (stride > 1).then(|| format!("every {stride}th of {n} samples shown"));
            json!({"title": title, "y_label": label, "time": time, "series": series, "host": "fit-plots", "sync": format!("fit-{}", before.name), "note": note})
        })
        .collect()
}
