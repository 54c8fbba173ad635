//! `pneumo linearize`: the linear model of a circuit about an operating
//! point (issue 25) — A, B, C, D with named states, inputs and outputs in
//! SI, its modes (eigenvalues, natural frequencies, damping ratios), the
//! mode of every mechanical node, and Bode data, written to a directory as
//! one transaction.
//!
//! Operating points: `rest` (the netlist's start state), `t=1.2 s` (the
//! netlist run by itself to that time, its state carried into the model
//! driven from outside, see `solve::linearize::point`) or a trim,
//! `NAME=VALUE` conditions separated by `;` or `,` (`piston.x=200 mm;
//! F=0 N; head.p=4 bar`: states, interface inputs, recorded values, each
//! value in a unit of its own dimension), solved from the netlist's start
//! state by `solve::linearize::trim`. Inputs and outputs
//! are the netlist's interface section, in the order it writes them. The
//! derivatives come through one seam (`solve::linearize::jacobians::jacobians`:
//! A exact, B, C, D central differences). Each output/input pair gets its
//! poles, zeros and gain (`linear::zeros`); `--bode FILE.svg|png` draws the
//! Bode data (`crate::plot::bode_image`).

use crate::error::AppError;
use crate::load::netlist_with_files;
use crate::output::Transaction;
use linear::Matrix;
use solve::linearize::{self, LinearModel, Options, PointKind};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// What to linearise and where to write it.
#[derive(Debug, Clone, Default)]
pub struct LinearizeOptions {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Overrides `ID.PARAM=VALUE`, applied in order.
    pub sets: Vec<String>,
    /// "rest", "t=1.2 s" or a trim "piston.x=200 mm; F=0 N; head.p=4 bar".
    pub at: String,
    /// Directory for A.csv, B.csv, C.csv, D.csv, modes.csv, bode.csv, linear.json.
    pub out: Option<PathBuf>,
    /// Keep the states that reach no output.
    pub keep_all_states: bool,
    /// A Bode picture (magnitude and phase of every pair), PNG or SVG by the extension.
    pub bode: Option<PathBuf>,
}

/// Bode data: frequencies [Hz] and (pair "output/input", magnitudes [dB], phases [deg]).
pub type BodeData = (Vec<f64>, Vec<(String, Vec<f64>, Vec<f64>)>);

/// Poles, zeros and gain of one input–output pair (its minimal realisation).
pub struct Pair {
    pub output: String,
    pub input: String,
    pub pole_zero: linear::zeros::PoleZero,
}

/// The linear model and its report.
pub struct Linearized {
    pub model: LinearModel,
    pub modes: Vec<linear::modal::Mode>,
    /// Every output/input pair, output-major (output i, input j at `i * m + j`).
    pub pairs: Vec<Pair>,
    /// Everything as JSON (what `--json` prints and `linear.json` holds).
    pub json: serde_json::Value,
}

fn data(e: impl std::fmt::Display) -> AppError {
    AppError::Data(e.to_string())
}

/// The operating point named by `--at`.
enum At {
    Rest,
    Time(f64),
    /// Trim conditions (name, value text), as written.
    Trim(Vec<(String, String)>),
}

fn parse_at(text: &str) -> Result<At, AppError> {
    let t = text.trim();
    if t == "rest" {
        return Ok(At::Rest);
    }
    if let Some(rest) = t.strip_prefix("t=").or_else(|| t.strip_prefix("t =")) {
        let v = units::parse_quantity(rest.trim(), units::dim::TIME)
            .map_err(|e| AppError::Usage(format!("operating point \"{}\": {e}", graph::escape(text))))?;
        return Ok(At::Time(v));
    }
    if t.contains('=') {
        let mut conditions = Vec::new();
        for part in t.split([';', ',']).map(str::trim).filter(|p| !p.is_empty()) {
            match part.split_once('=') {
                Some((name, value)) if !name.trim().is_empty() && !value.trim().is_empty() => {
                    conditions.push((name.trim().to_string(), value.trim().to_string()))
                }
                _ => {
                    return Err(AppError::Usage(format!(
                        "operating point \"{}\": \"{}\" is not NAME=VALUE",
                        graph::escape(text),
                        graph::escape(part)
                    )))
                }
            }
        }
        return Ok(At::Trim(conditions));
    }
    Err(AppError::Usage(format!(
        "operating point \"{}\": expected rest, t=TIME (e.g. \"t=1.2 s\") or trim conditions NAME=VALUE; ... (e.g. \"piston.x=200 mm; F=0 N; head.p=4 bar\")",
        graph::escape(text)
    )))
}

/// The trim conditions resolved against `model`: each name a state, an
/// interface input or a recorded value, each value parsed in its dimension.
fn trim_constraints(model: &solve::Model, conditions: &[(String, String)]) -> Result<Vec<linearize::trim::Constraint>, AppError> {
    conditions
        .iter()
        .map(|(name, value)| {
            let shown = || format!("trim condition {}={}", graph::escape(name), graph::escape(value));
            let (target, unit) = linearize::trim::target(model, name).ok_or_else(|| {
                AppError::Usage(format!("{}: no state, interface input or recorded value is called \"{}\"", shown(), graph::escape(name)))
            })?;
            let dimension = units::parse_unit(&unit).map(|u| u.dimension).unwrap_or(units::dim::DIMENSIONLESS);
            let value = units::parse_quantity(value, dimension).map_err(|e| AppError::Usage(format!("{}: {e}", shown())))?;
            Ok(linearize::trim::Constraint { name: name.clone(), target, value })
        })
        .collect()
}

/// Linearise the netlist of `o` and write the outputs (all or none).
pub fn linearize(o: &LinearizeOptions) -> Result<Linearized, AppError> {
    let at = parse_at(&o.at)?;
    let (mut flat, inputs) = netlist_with_files(&o.model, &[])?;
    let inputs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    let mut outputs = Transaction::new(&inputs);
    let files = ["A.csv", "B.csv", "C.csv", "D.csv", "modes.csv", "bode.csv", "linear.json"];
    let mut targets: Vec<PathBuf> = o.out.iter().flat_map(|d| files.iter().map(move |f| d.join(f))).collect();
    targets.extend(o.bode.iter().cloned());
    outputs.check_targets(&targets.iter().map(|p| p.as_path()).collect::<Vec<_>>())?;
    for s in &o.sets {
        graph::apply_set(&mut flat, s)?;
    }
    let r = linearize_at(&flat, at, o.keep_all_states)?;
    if let Some(dir) = &o.out {
        let lm = &r.model;
        let bode = r.bode_csv()?;
        std::fs::create_dir_all(dir).map_err(|e| AppError::io(dir, e))?;
        let state_names: Vec<&str> = lm.states.iter().map(|s| s.name.as_str()).collect();
        let input_names: Vec<&str> = lm.inputs.iter().map(|s| s.name.as_str()).collect();
        let output_names: Vec<&str> = lm.outputs.iter().map(|s| s.name.as_str()).collect();
        outputs.add(&dir.join("A.csv"), matrix_csv(&lm.a, &state_names, &state_names).as_bytes())?;
        outputs.add(&dir.join("B.csv"), matrix_csv(&lm.b, &state_names, &input_names).as_bytes())?;
        outputs.add(&dir.join("C.csv"), matrix_csv(&lm.c, &output_names, &state_names).as_bytes())?;
        outputs.add(&dir.join("D.csv"), matrix_csv(&lm.d, &output_names, &input_names).as_bytes())?;
        outputs.add(&dir.join("modes.csv"), modes_csv(&r.modes).as_bytes())?;
        outputs.add(&dir.join("bode.csv"), bode.as_bytes())?;
        outputs.add(&dir.join("linear.json"), serde_json::to_string_pretty(&r.json).unwrap_or_default().as_bytes())?;
    }
    if let Some(path) = &o.bode {
        let (f, pairs) = r.bode_data()?;
        let title =
            format!("Bode: {} at {}", o.model.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(), o.at.trim());
        let image = crate::plot::bode_image(&title, &f, &pairs, path)?;
        outputs.add(path, &image)?;
    }
    outputs.commit()?;
    Ok(r)
}

/// Linearise a netlist already loaded (overrides applied) at the operating
/// point `at` ("rest" or "t=1.2 s"); writes nothing. The Python package's
/// `Model.linearize` calls this.
pub fn linearize_netlist(flat: &graph::FlatNetlist, at: &str, keep_all_states: bool) -> Result<Linearized, AppError> {
    linearize_at(flat, parse_at(at)?, keep_all_states)
}

fn linearize_at(flat: &graph::FlatNetlist, at: At, keep_all_states: bool) -> Result<Linearized, AppError> {
    let mut driven = solve::Model::new(graph::build_with(flat, graph::Drive::External)?);
    let op = match at {
        At::Rest => linearize::point::rest(&mut driven).map_err(data)?,
        At::Time(t) => {
            let circuit = graph::build(flat)?;
            let opts = solve::options_from(&circuit.simulation)?;
            linearize::point::at_time(solve::Model::new(circuit), &mut driven, &opts, t).map_err(data)?
        }
        At::Trim(conditions) => {
            let constraints = trim_constraints(&driven, &conditions)?;
            let guess = driven.initial_state();
            linearize::trim::trim(&mut driven, &guess, &constraints, linearize::Friction::default()).map_err(data)?
        }
    };
    let lm = linearize::linearize(&mut driven, &op, &Options { keep_all_states, ..Options::default() }).map_err(data)?;
    let modes = linear::modal::modes(&lm.a).map_err(data)?;
    let pairs = pairs(&lm)?;
    let json = to_json(&lm, &modes, &pairs);
    Ok(Linearized { model: lm, modes, pairs, json })
}

/// Poles, zeros and gain of every output/input pair.
fn pairs(lm: &LinearModel) -> Result<Vec<Pair>, AppError> {
    let mut out = Vec::new();
    for (i, output) in lm.outputs.iter().enumerate() {
        for (j, input) in lm.inputs.iter().enumerate() {
            let b: Vec<f64> = (0..lm.states.len()).map(|k| lm.b[(k, j)]).collect();
            let c: Vec<f64> = (0..lm.states.len()).map(|k| lm.c[(i, k)]).collect();
            let pole_zero = linear::zeros::pole_zero(&lm.a, &b, &c, lm.d[(i, j)]).map_err(data)?;
            out.push(Pair { output: output.name.clone(), input: input.name.clone(), pole_zero });
        }
    }
    Ok(out)
}

/// Roots as text, a complex pair once as "re ± imj" (sorted as [`linear::zeros`] sorts them).
fn roots_text(roots: &[linear::Complex]) -> String {
    let shown: Vec<String> = roots
        .iter()
        .filter(|z| z.im >= 0.0)
        .map(|z| if z.im > 0.0 { format!("{:.6e} ± {:.6e}j", z.re, z.im) } else { format!("{:.6e}", z.re) })
        .collect();
    if shown.is_empty() {
        "none".to_string()
    } else {
        shown.join(", ")
    }
}

impl Linearized {
    /// The default Bode frequencies [Hz]: whole decades around the modes'
    /// natural frequencies, 50 points a decade.
    pub fn bode_frequencies(&self) -> Vec<f64> {
        let (lo, hi) = linear::frequency::default_range(&self.modes.iter().map(|m| m.natural_frequency).collect::<Vec<_>>());
        linear::frequency::log_grid(lo, hi, 50)
    }

    /// H(j 2π f) at every frequency [Hz]: p × m values per frequency,
    /// row-major (output i, input j at `i * m + j`).
    pub fn frequency_response(&self, f_hz: &[f64]) -> Result<Vec<Vec<linear::Complex>>, AppError> {
        let lm = &self.model;
        if let Some(bad) = f_hz.iter().find(|f| !f.is_finite() || **f < 0.0) {
            return Err(AppError::Usage(format!("frequency {} Hz: frequencies must be finite and not negative", units::show::num(*bad))));
        }
        linear::frequency::response(&lm.a, &lm.b, &lm.c, &lm.d, f_hz).map_err(data)
    }

    /// Bode data of every input–output pair at the default frequencies:
    /// the frequencies [Hz] and, per pair "output/input" (output-major),
    /// magnitudes [dB] and unwrapped phases [deg].
    pub fn bode_data(&self) -> Result<BodeData, AppError> {
        let f = self.bode_frequencies();
        let h = self.frequency_response(&f)?;
        let lm = &self.model;
        let (p, m) = (lm.outputs.len(), lm.inputs.len());
        let mut pairs = Vec::new();
        for i in 0..p {
            for j in 0..m {
                let (mag, phase) = linear::frequency::bode(&h.iter().map(|hk| hk[i * m + j]).collect::<Vec<_>>());
                pairs.push((format!("{}/{}", lm.outputs[i].name, lm.inputs[j].name), mag, phase));
            }
        }
        Ok((f, pairs))
    }

    /// [`Linearized::bode_data`] as `bode.csv`: frequency [Hz], then
    /// magnitude [dB] and phase [deg] per pair.
    pub fn bode_csv(&self) -> Result<String, AppError> {
        let (f, columns) = self.bode_data()?;
        let mut s = String::from("f [Hz]");
        for (pair, _, _) in &columns {
            let _ = write!(s, ",{pair} magnitude [dB],{pair} phase [deg]");
        }
        s.push('\n');
        for (k, fk) in f.iter().enumerate() {
            let _ = write!(s, "{fk:e}");
            for (_, mag, phase) in &columns {
                let _ = write!(s, ",{:e},{:e}", mag[k], phase[k]);
            }
            s.push('\n');
        }
        Ok(s)
    }
}

/// A matrix with row names in the first column and column names in the header.
fn matrix_csv(m: &Matrix, rows: &[&str], cols: &[&str]) -> String {
    let mut s = String::from("row");
    for c in cols {
        let _ = write!(s, ",{c}");
    }
    s.push('\n');
    for (i, r) in rows.iter().enumerate() {
        s.push_str(r);
        for j in 0..cols.len() {
            let _ = write!(s, ",{:e}", m[(i, j)]);
        }
        s.push('\n');
    }
    s
}

fn modes_csv(modes: &[linear::modal::Mode]) -> String {
    let mut s = String::from("re [1/s],im [1/s],natural_frequency [rad/s],frequency [Hz],damping [1]\n");
    for m in modes {
        let _ = writeln!(s, "{:e},{:e},{:e},{:e},{:e}", m.eigenvalue.re, m.eigenvalue.im, m.natural_frequency, m.frequency_hz(), m.damping);
    }
    s
}

fn to_json(lm: &LinearModel, modes: &[linear::modal::Mode], pairs: &[Pair]) -> serde_json::Value {
    let complex = |v: &[linear::Complex]| v.iter().map(|z| serde_json::json!({ "re": z.re, "im": z.im })).collect::<Vec<_>>();
    let finite = |x: f64| if x.is_finite() { serde_json::json!(x) } else { serde_json::Value::Null };
    let named = |v: &[linearize::Named]| v.iter().map(|n| serde_json::json!({ "name": n.name, "unit": n.unit })).collect::<Vec<_>>();
    serde_json::json!({
        "operating_point": { "t": lm.t, "kind": match lm.kind { PointKind::Time => "time", PointKind::Rest => "rest", PointKind::Trim => "trim" },
                             "x0": lm.x0, "u0": lm.u0, "y0": lm.y0, "dx0": lm.dx0 },
        "method": lm.method.name(),
        "finite_difference_blocks": lm.finite_difference_blocks,
        "difference_inputs": lm.difference_inputs,
        "difference_outputs": lm.difference_outputs,
        "record_difference_outputs": lm.record_difference_outputs,
        "states": named(&lm.states),
        "inputs": named(&lm.inputs),
        "outputs": named(&lm.outputs),
        "A": lm.a.to_rows(), "B": lm.b.to_rows(), "C": lm.c.to_rows(), "D": lm.d.to_rows(),
        "modes": modes.iter().map(|m| serde_json::json!({
            "re": m.eigenvalue.re, "im": m.eigenvalue.im, "pair": m.pair,
            "natural_frequency_rad_s": m.natural_frequency, "frequency_hz": m.frequency_hz(),
            "damping": if m.damping.is_finite() { serde_json::json!(m.damping) } else { serde_json::Value::Null },
        })).collect::<Vec<_>>(),
        "pairs": pairs.iter().map(|p| serde_json::json!({
            "output": p.output, "input": p.input, "order": p.pole_zero.order,
            "poles": complex(&p.pole_zero.poles), "zeros": complex(&p.pole_zero.zeros),
            "gain": finite(p.pole_zero.gain), "dc_gain": p.pole_zero.dc_gain.map(finite),
        })).collect::<Vec<_>>(),
        "mechanics": lm.mechanics.iter().map(|n| serde_json::json!({ "id": n.id, "mode": n.description })).collect::<Vec<_>>(),
        "left_out": lm.left_out.iter().map(|(s, why)| serde_json::json!({ "state": s, "why": why })).collect::<Vec<_>>(),
        "skipped_outputs": lm.skipped_outputs.iter().map(|(s, why)| serde_json::json!({ "output": s, "why": why })).collect::<Vec<_>>(),
        "trim": lm.trim.as_ref().map(|t| {
            let values = |v: &[linearize::trim::TrimValue]| {
                v.iter().map(|v| serde_json::json!({ "name": v.name, "value": v.value, "unit": v.unit })).collect::<Vec<_>>()
            };
            serde_json::json!({ "held": values(&t.held), "solved": values(&t.solved), "iterations": t.iterations, "residual": t.residual,
                                "untouched": t.untouched.iter().map(|(s, why)| serde_json::json!({ "state": s, "why": why })).collect::<Vec<_>>() })
        }),
    })
}

/// What `pneumo linearize` prints.
pub fn text(r: &Linearized) -> String {
    let lm = &r.model;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "operating point: {} (t = {} s); derivatives by {}",
        r.json["operating_point"]["kind"].as_str().unwrap_or(""),
        lm.t,
        lm.method.name()
    );
    if !lm.finite_difference_blocks.is_empty() {
        let _ = writeln!(s, "blocks differentiated by central differences (no partials): {}", lm.finite_difference_blocks.join(", "));
    }
    if !lm.difference_inputs.is_empty() {
        let _ = writeln!(s, "inputs differentiated by central differences (no live partials): {}", lm.difference_inputs.join(", "));
    }
    if !lm.difference_outputs.is_empty() {
        let _ = writeln!(s, "outputs differentiated by central differences of the whole model: {}", lm.difference_outputs.join(", "));
    }
    if !lm.record_difference_outputs.is_empty() {
        let _ = writeln!(
            s,
            "outputs whose recording block was differentiated alone by central differences (no partials): {}",
            lm.record_difference_outputs.join(", ")
        );
    }
    let list = |v: &[linearize::Named]| v.iter().map(|n| format!("{} [{}]", n.name, n.unit)).collect::<Vec<_>>().join(", ");
    let _ = writeln!(s, "states ({}): {}", lm.states.len(), list(&lm.states));
    let _ = writeln!(s, "inputs ({}): {}", lm.inputs.len(), list(&lm.inputs));
    let _ = writeln!(s, "outputs ({}): {}", lm.outputs.len(), list(&lm.outputs));
    for n in &lm.mechanics {
        let _ = writeln!(s, "{}: {}", n.id, n.description);
    }
    for (state, why) in &lm.left_out {
        let _ = writeln!(s, "left out: {state} ({why})");
    }
    let _ = writeln!(s, "modes:");
    for m in &r.modes {
        let lambda =
            if m.pair { format!("{:.6e} ± {:.6e}j", m.eigenvalue.re, m.eigenvalue.im) } else { format!("{:.6e}", m.eigenvalue.re) };
        let _ =
            writeln!(s, "  λ = {lambda} 1/s: ω_n = {:.6} rad/s ({:.4} Hz), ζ = {:.4}", m.natural_frequency, m.frequency_hz(), m.damping);
    }
    if !r.pairs.is_empty() {
        let _ = writeln!(s, "poles and zeros per pair, G(s) = k Π(s − z)/Π(s − p) of its minimal realisation:");
    }
    let unit = |v: &[linearize::Named], name: &str| v.iter().find(|n| n.name == name).map(|n| n.unit.clone()).unwrap_or_default();
    for p in &r.pairs {
        let pz = &p.pole_zero;
        let per = format!("{}/{}", unit(&lm.outputs, &p.output), unit(&lm.inputs, &p.input));
        let dc = match pz.dc_gain {
            Some(g) => format!("{g:.6e} {per}"),
            None => "none (a pole at 0)".to_string(),
        };
        let _ = writeln!(s, "  {}/{}: order {}, k = {:.6e}, DC gain {dc}", p.output, p.input, pz.order, pz.gain);
        let _ = writeln!(s, "    poles: {}", roots_text(&pz.poles));
        let _ = writeln!(s, "    zeros: {}", roots_text(&pz.zeros));
    }
    if let Some(t) = &lm.trim {
        let list = |v: &[linearize::trim::TrimValue]| {
            v.iter()
                .map(|v| format!("{} = {} {}", v.name, units::show::num(v.value), v.unit).trim_end().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(s, "trim ({} iterations, residual {:.1e}): held {}", t.iterations, t.residual, list(&t.held));
        let _ = writeln!(s, "  solved: {}", list(&t.solved));
        for (state, why) in &t.untouched {
            let _ = writeln!(s, "  untouched: {state} ({why})");
        }
    }
    s
}
