//! The experiments manifest of `pneumo discrepancy`: which data files, at
//! which operating point, which columns are which model signals, and what
//! to calibrate.
//!
//! ```json
//! {
//!   "experiments": [
//!     { "data": "run1.csv", "set": { "supply.p": "4 bar", "flow_control.C": "13.2 L/min/bar" },
//!       "columns": { "p1_Pa": "head.p", "p2_Pa": "rod.p", "x_m": "piston.x" },
//!       "time_origin": "12.5 s", "name": "4 bar, switch 2" }
//!   ],
//!   "calibrate": { "friction.k0": ["1 N", "60 N"], "flow_control.C": ["5 L/min/bar", "60 L/min/bar"] },
//!   "noise": { "head.p": "5 mbar" },
//!   "effects": ["piston_seal_leak", "valve_delay"],
//!   "max_effects": 2,
//!   "fit_interval": "4 ms",
//!   "nuisance": { "offset": true, "gain": true, "skew": "1 ms", "switch_latency": "1 ms" },
//!   "sensors": { "tank.T": { "accuracy": "1.5 K" },
//!                "head.p": { "accuracy": "0.25 %FS", "full_scale": "10 bar", "gain": "0.3 %" } }
//! }
//! ```
//!
//! - `data`: CSV file, relative to the manifest ([`crate::data`]).
//! - `set`: the experiment's operating point, "id.param" → value (number in
//!   SI or text with a unit), applied like `--set`.
//! - `columns`: data column → model signal; omit it when the CSV already
//!   uses signal names (then every column but `t` is a signal).
//! - `time_origin`: data time of simulation time 0 (default: first sample).
//! - `calibrate`: parameters to fit with [lo, hi] bounds (default: see
//!   [`crate::params::default_calibration`]).
//! - `noise`: sensor noise σ per signal (default: estimated from the data).
//! - `effects`, `max_effects`, `fit_interval`: restrict the catalogue, the
//!   number of effects added (default 2), the spacing of fitted samples.
//! - `nuisance`: which sensor errors are fitted per experiment and channel
//!   ([`crate::nuisance`]): `offset` (default true), `gain` (default true,
//!   where the channel's prior has a gain), and per experiment the prior σ
//!   of the logger time skew, `skew` (default 1 ms; "0 s" fits none);
//!   `switch_latency`, the response time between a limit switch's trip and
//!   the valve's command that the model does not describe (default 1 ms;
//!   a valve delay below it is not named; "0 s" names any significant one).
//! - `sensors`: the specification of a signal's sensor, the prior of its
//!   offset and gain ([`crate::experiment::SensorPrior`]; defaults per
//!   quantity in [`crate::experiment`]): `accuracy`, the offset's σ, as a
//!   quantity of the signal's dimension ("1.5 K", "5 mbar"; read as a
//!   difference, so "1.5 degC" is 1.5 K) or as a percentage of the full
//!   scale ("0.25 %FS", then `full_scale` is required); `gain`, the σ of
//!   the relative gain error ("0.5 %" or a fraction; default: the
//!   quantity's default). "free" as `accuracy` leaves the offset without a
//!   prior (the old behaviour).
//!
//! - `user_effects`: candidate effects of the user's own, declared as
//!   netlist edits (components, connections, `set` values and `free`
//!   parameters with bounds, `null`, optional prior); see
//!   [`crate::effects::user`] and docs/discrepancy.md. They are tried with
//!   the built-ins (which `effects` may restrict) and judged the same way.
//!
//! Unknown keys are errors; errors name the file, line and column.

use graph::netlist::Value;
use serde::Deserialize;
use std::collections::BTreeMap;

/// The manifest file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Free text.
    #[serde(default)]
    pub description: Option<String>,
    pub experiments: Vec<ExperimentSpec>,
    #[serde(default)]
    pub calibrate: Option<BTreeMap<String, (Value, Value)>>,
    #[serde(default)]
    pub noise: BTreeMap<String, Value>,
    #[serde(default)]
    pub effects: Option<Vec<String>>,
    #[serde(default)]
    pub max_effects: Option<usize>,
    #[serde(default)]
    pub fit_interval: Option<Value>,
    #[serde(default)]
    pub nuisance: Option<NuisanceSpec>,
    #[serde(default)]
    pub sensors: BTreeMap<String, SensorSpec>,
    /// Candidate effects declared as netlist edits ([`crate::effects::user`]).
    #[serde(default)]
    pub user_effects: Vec<crate::effects::user::UserEffectSpec>,
    /// The file it was read from (set by [`parse`]; not part of the format).
    #[serde(skip)]
    pub origin: String,
}

/// One entry of the manifest's `sensors` section.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    pub accuracy: Value,
    #[serde(default)]
    pub full_scale: Option<Value>,
    #[serde(default)]
    pub gain: Option<Value>,
}

/// A number followed by a unit, split at the longest numeric prefix
/// ("0.25 %FS" → (0.25, "%FS"), "1.5K" → (1.5, "K")).
fn number_and_unit(text: &str) -> Option<(f64, &str)> {
    let text = text.trim();
    (1..=text.len())
        .rev()
        .filter(|&i| text.is_char_boundary(i))
        .find_map(|i| text[..i].trim().parse::<f64>().ok().map(|x| (x, text[i..].trim())))
}

/// SI size of a difference written with a unit of dimension `dim` (the
/// unit's offset ignored: "1.5 degC" is 1.5 K, "0.1 barg" is 0.1 bar).
fn difference(value: &Value, dim: units::Dimension, what: &str) -> Result<f64, String> {
    match value {
        Value::Number(x) => Ok(*x),
        Value::Text(t) => {
            let (x, unit) = number_and_unit(t).ok_or_else(|| format!("{what} = \"{t}\": expected a number and a unit"))?;
            if unit.is_empty() {
                return Ok(x);
            }
            let u = units::parse_unit(unit).map_err(|e| format!("{what} = \"{t}\": {e}"))?;
            if u.dimension != dim {
                return Err(format!("{what} = \"{t}\": the unit \"{unit}\" does not measure the signal's quantity"));
            }
            Ok(x * u.factor)
        }
        Value::List(_) => Err(format!("{what}: expected a single value")),
    }
}

/// The prior of one `sensors` entry for a signal of dimension `dim`;
/// `default` is the quantity's default (its gain is kept unless given).
pub fn sensor_prior(
    signal: &str,
    spec: &SensorSpec,
    dim: units::Dimension,
    default: &crate::experiment::SensorPrior,
) -> Result<crate::experiment::SensorPrior, String> {
    let what = format!("sensors \"{signal}\".accuracy");
    let (offset_sd, text) = match &spec.accuracy {
        Value::Text(t) if t.trim().eq_ignore_ascii_case("free") => (f64::INFINITY, "free offset".to_string()),
        Value::Text(t) if t.trim().to_ascii_uppercase().ends_with("%FS") => {
            let (x, _) = number_and_unit(t).ok_or_else(|| format!("{what} = \"{t}\": expected a percentage of full scale"))?;
            let fs =
                spec.full_scale.as_ref().ok_or_else(|| format!("{what} = \"{t}\" is relative to the full scale: give \"full_scale\""))?;
            let fs = difference(fs, dim, &format!("sensors \"{signal}\".full_scale"))?;
            if !(fs > 0.0 && fs.is_finite()) {
                return Err(format!("sensors \"{signal}\".full_scale must be positive, got {fs}"));
            }
            (x / 100.0 * fs, format!("{t} of {}", crate::params::significant(fs, 3)))
        }
        v => {
            let x = difference(v, dim, &what)?;
            (x, crate::params::significant(x, 3))
        }
    };
    if offset_sd.is_nan() || offset_sd <= 0.0 {
        return Err(format!("{what} must be positive, got {offset_sd}"));
    }
    let gain_sd = match &spec.gain {
        None => default.gain_sd,
        Some(v) => {
            let g = match v {
                Value::Number(x) => *x,
                Value::Text(t) => match number_and_unit(t) {
                    Some((x, "%")) => x / 100.0,
                    Some((x, "")) => x,
                    _ => return Err(format!("sensors \"{signal}\".gain = \"{t}\": expected a percentage (\"0.5 %\") or a fraction")),
                },
                Value::List(_) => return Err(format!("sensors \"{signal}\".gain: expected a single value")),
            };
            if !(0.0..1.0).contains(&g) {
                return Err(format!("sensors \"{signal}\".gain must be a fraction in [0, 1), got {g}"));
            }
            g
        }
    };
    Ok(crate::experiment::SensorPrior {
        offset_sd,
        gain_sd,
        source: format!("manifest: accuracy {text} SI, gain {}", crate::params::significant(gain_sd, 3)),
    })
}

/// The manifest's `nuisance` entry.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NuisanceSpec {
    #[serde(default)]
    pub offset: Option<bool>,
    #[serde(default)]
    pub gain: Option<bool>,
    #[serde(default)]
    pub skew: Option<Value>,
    #[serde(default)]
    pub switch_latency: Option<Value>,
}

/// One experiment of the manifest.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSpec {
    pub data: String,
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub set: BTreeMap<String, Value>,
    #[serde(default)]
    pub columns: Option<BTreeMap<String, String>>,
    #[serde(default)]
    pub time_origin: Option<Value>,
}

/// Why a manifest could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ManifestError {
    #[error("{file}:{line}:{column}: {message}")]
    Json { file: String, line: usize, column: usize, message: String },
    #[error("{file}: {message}")]
    Invalid { file: String, message: String },
}

/// Parse manifest text; `origin` names the file in errors.
pub fn parse(text: &str, origin: &str) -> Result<Manifest, ManifestError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut m: Manifest = serde_json::from_str(text).map_err(|e| ManifestError::Json {
        file: origin.to_string(),
        line: e.line(),
        column: e.column(),
        message: units::show::quoting(e.to_string().split(" at line ").next().unwrap_or_default()),
    })?;
    if m.experiments.is_empty() {
        return Err(ManifestError::Invalid { file: origin.into(), message: "\"experiments\" is empty".into() });
    }
    m.origin = origin.to_string();
    Ok(m)
}

/// "id.param=value" text of one `set` entry (numbers are SI).
pub fn set_text(target: &str, value: &Value) -> Result<String, String> {
    match value {
        Value::Number(x) => Ok(format!("{target}={x}")),
        Value::Text(s) => Ok(format!("{target}={s}")),
        Value::List(_) => Err(format!("set \"{target}\": expected a single value, got a list")),
    }
}

/// SI seconds of a time value ("12.5 s", 12.5).
pub fn seconds(value: &Value, what: &str) -> Result<f64, String> {
    match value {
        Value::Number(x) if x.is_finite() => Ok(*x),
        Value::Text(s) => units::parse_quantity(s, units::dim::TIME).map_err(|e| format!("{what} = \"{s}\": {e}")),
        _ => Err(format!("{what}: expected a time")),
    }
}

/// Units of the model's recorded signals ("head.p" → "Pa").
pub fn signal_units(flat: &graph::FlatNetlist) -> Result<BTreeMap<String, String>, String> {
    let circuit = graph::build(flat).map_err(|e| e.to_string())?;
    let model = solve::Model::new(circuit);
    Ok(model.output_names().into_iter().zip(model.output_units()).collect())
}

/// Reads a data file named in a manifest: (text, name for messages).
pub type ReadData<'a> = dyn Fn(&str) -> Result<(String, String), String> + 'a;

/// Everything the workflow needs from a manifest.
#[derive(Debug, Clone)]
pub struct Resolved {
    pub experiments: Vec<crate::experiment::Experiment>,
    pub calibrate: Vec<crate::params::CalibSpec>,
    pub options: crate::options::Options,
}

/// Turn a manifest into experiments, calibration targets and options.
/// `read(path)` returns the text of a data file named in the manifest
/// (paths as written, for the caller to resolve against the manifest).
pub fn resolve(m: &Manifest, flat: &graph::FlatNetlist, read: &ReadData) -> Result<Resolved, String> {
    // messages quote names and values from the manifest: the project's one
    // rule escapes what they echo and shortens every quoted part
    resolve_unescaped(m, flat, read).map_err(|e| units::show::quoting(&e))
}

fn resolve_unescaped(m: &Manifest, flat: &graph::FlatNetlist, read: &ReadData) -> Result<Resolved, String> {
    let units = signal_units(flat)?;
    let mut noise = Vec::new();
    for (signal, v) in &m.noise {
        let unit = units.get(signal).ok_or_else(|| format!("noise: \"{signal}\" is not a signal of the model"))?;
        let dim = units::parse_unit(unit).map(|u| u.dimension).unwrap_or(units::dim::DIMENSIONLESS);
        let sigma = match v {
            Value::Number(x) => *x,
            Value::Text(t) => units::parse_quantity(t, dim).map_err(|e| format!("noise \"{signal}\" = \"{t}\": {e}"))?,
            Value::List(_) => return Err(format!("noise \"{signal}\": expected a single value")),
        };
        noise.push((signal.clone(), sigma));
    }
    let mut experiments = Vec::new();
    for (k, spec) in m.experiments.iter().enumerate() {
        let (text, origin) = read(&spec.data)?;
        let data = crate::data::parse_csv(&text, &origin).map_err(|e| e.to_string())?;
        let sets = spec.set.iter().map(|(t, v)| set_text(t, v)).collect::<Result<Vec<_>, _>>()?;
        let t0 = spec.time_origin.as_ref().map(|v| seconds(v, "time_origin")).transpose()?;
        let name = spec.name.clone().unwrap_or_else(|| format!("exp{}", k + 1));
        let e = crate::experiment::Experiment::from_dataset(&name, &data, spec.columns.as_ref(), sets, t0, &noise)?;
        for c in &e.channels {
            if !units.contains_key(&c.signal) {
                return Err(format!(
                    "{}: \"{}\" is not a signal of the model (signals: {})",
                    origin,
                    c.signal,
                    units.keys().cloned().collect::<Vec<_>>().join(", ")
                ));
            }
        }
        experiments.push(e);
    }
    // sensor priors: the quantity's default, replaced where the manifest gives a specification
    crate::experiment::assign_default_priors(&mut experiments, |s| units.get(s).cloned().unwrap_or_default());
    for (signal, spec) in &m.sensors {
        let unit = units.get(signal).ok_or_else(|| format!("sensors: \"{signal}\" is not a signal of the model"))?;
        let dim = units::parse_unit(unit).map(|u| u.dimension).unwrap_or(units::dim::DIMENSIONLESS);
        for e in &mut experiments {
            for c in e.channels.iter_mut().filter(|c| &c.signal == signal) {
                let default = c.prior.clone().unwrap_or_else(|| crate::experiment::default_prior(unit, &[]));
                c.prior = Some(sensor_prior(signal, spec, dim, &default)?);
            }
        }
    }
    let calibrate = match &m.calibrate {
        None => crate::params::default_calibration(flat),
        Some(map) => map
            .iter()
            .map(|(target, (lo, hi))| {
                let (id, param) = crate::netlist_edit::split_target(target).map_err(|e| e.to_string())?;
                let lo = crate::netlist_edit::parse_for(flat, id, param, lo).map_err(|e| format!("calibrate: {e}"))?;
                let hi = crate::netlist_edit::parse_for(flat, id, param, hi).map_err(|e| format!("calibrate: {e}"))?;
                if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
                    return Err(format!("calibrate \"{target}\": lower bound {lo} is not below upper bound {hi}"));
                }
                Ok(crate::params::CalibSpec { target: target.clone(), bounds: Some((lo, hi)), prior: None })
            })
            .collect::<Result<Vec<_>, String>>()?,
    };
    let mut options = crate::options::Options::default();
    if let Some(names) = &m.effects {
        options.effects = Some(names.clone());
    }
    options.user_effects = user_effects(m, flat, &experiments)?;
    if let Some(n) = m.max_effects {
        options.max_effects = n;
    }
    if let Some(v) = &m.fit_interval {
        let dt = seconds(v, "fit_interval")?;
        if dt.is_nan() || dt <= 0.0 {
            return Err(format!("fit_interval must be > 0 s, got {dt}"));
        }
        options.fit_interval = dt;
    }
    if let Some(n) = &m.nuisance {
        options.sensors.offset = n.offset.unwrap_or(options.sensors.offset);
        options.sensors.gain = n.gain.unwrap_or(options.sensors.gain);
        if let Some(v) = &n.skew {
            let dt = seconds(v, "nuisance.skew")?;
            if dt.is_nan() || !(0.0..=1.0).contains(&dt) {
                return Err(format!("nuisance.skew must be between 0 s and 1 s, got {dt}"));
            }
            options.sensors.skew = dt;
        }
        if let Some(v) = &n.switch_latency {
            let dt = seconds(v, "nuisance.switch_latency")?;
            if dt.is_nan() || !(0.0..=1.0).contains(&dt) {
                return Err(format!("nuisance.switch_latency must be between 0 s and 1 s, got {dt}"));
            }
            options.switch_latency = dt;
        }
    }
    Ok(Resolved { experiments, calibrate, options })
}

/// The manifest's declared effects, checked against the model (the
/// declaration, then the nesting: simulated over the first experiment's
/// duration, at most [`NESTING_CHECK_SECONDS`], on the measured signals);
/// errors name the manifest.
fn user_effects(
    m: &Manifest,
    flat: &graph::FlatNetlist,
    experiments: &[crate::experiment::Experiment],
) -> Result<Vec<crate::effects::UserEffect>, String> {
    let file = if m.origin.is_empty() { "manifest" } else { m.origin.as_str() };
    let mut out: Vec<crate::effects::UserEffect> = Vec::new();
    let duration = experiments.first().and_then(|e| e.times.last().copied()).filter(|t| *t > 0.0).unwrap_or(1.0);
    let mut measured: Vec<String> = experiments.iter().flat_map(|e| e.channels.iter().map(|c| c.signal.clone())).collect();
    measured.sort();
    measured.dedup();
    // the nesting check runs at the first experiment's operating point
    let mut probe = flat.clone();
    for s in experiments.first().map(|e| e.sets.as_slice()).unwrap_or_default() {
        graph::apply_set(&mut probe, s).map_err(|e| format!("{file}: {e}"))?;
    }
    for spec in &m.user_effects {
        if out.iter().any(|u| u.name == spec.name) {
            return Err(format!("{file}: user effect \"{}\" is declared twice", spec.name));
        }
        let effect = crate::effects::UserEffect::declare(spec, flat).map_err(|e| format!("{file}: {e}"))?;
        effect.check_nested(&probe, duration.min(NESTING_CHECK_SECONDS), &measured).map_err(|e| format!("{file}: {e}"))?;
        out.push(effect);
    }
    Ok(out)
}

/// Longest simulation of the nesting check of a declared effect [s].
pub const NESTING_CHECK_SECONDS: f64 = 3.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_documented_example() {
        let text = r#"{
          "experiments": [
            { "data": "run1.csv", "set": { "supply.p": "4 bar", "flow_control.C": 2.2e-9 },
              "columns": { "p1_Pa": "head.p" }, "time_origin": "12.5 s" },
            { "data": "run2.csv" }
          ],
          "calibrate": { "friction.k0": ["1 N", "60 N"] },
          "noise": { "head.p": "5 mbar" },
          "max_effects": 1
        }"#;
        let m = parse(text, "m.json").unwrap();
        assert_eq!(m.experiments.len(), 2);
        assert_eq!(m.nuisance, None);
        assert_eq!(set_text("supply.p", &m.experiments[0].set["supply.p"]).unwrap(), "supply.p=4 bar");
        assert_eq!(set_text("flow_control.C", &m.experiments[0].set["flow_control.C"]).unwrap(), "flow_control.C=0.0000000022");
        assert_eq!(seconds(m.experiments[0].time_origin.as_ref().unwrap(), "t0").unwrap(), 12.5);
        let (lo, hi) = &m.calibrate.as_ref().unwrap()["friction.k0"];
        assert_eq!((lo, hi), (&Value::Text("1 N".into()), &Value::Text("60 N".into())));
        assert!(m.experiments[1].columns.is_none());
        assert_eq!(m.max_effects, Some(1));
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse("{\n  \"experiments\": [ { \"dat\": \"a.csv\" } ]\n}", "m.json").unwrap_err().to_string();
        assert!(e.starts_with("m.json:2:") && e.contains("dat"), "{e}");
        let e = parse("{\"experiments\": []}", "m.json").unwrap_err().to_string();
        assert!(e.contains("empty"), "{e}");
        let e =
            parse("{\"experiments\": [{\"data\": \"a\"}], \"calibrate\": {\"friction.k0\": [\"1 N\"]}}", "m.json").unwrap_err().to_string();
        assert!(e.starts_with("m.json:1:"), "{e}");
        assert!(set_text("a.b", &Value::List(vec![])).is_err());
        assert!(seconds(&Value::Text("3 bar".into()), "t0").is_err());
    }

    #[test]
    fn resolves_columns_noise_bounds_and_sets() {
        let flat = crate::netlist_edit::tests_support::meter_out();
        let text = r#"{ "experiments": [ { "data": "a.csv", "set": { "supply.p": "5 bar" }, "columns": { "p1": "head.p" }, "time_origin": 1.0 } ],
                        "calibrate": { "friction.k0": ["1 N", "60 N"] }, "noise": { "head.p": "5 mbar" }, "effects": ["valve_delay"],
                        "nuisance": { "gain": true, "skew": "2 ms", "switch_latency": "0.5 ms" } }"#;
        let m = parse(text, "m.json").unwrap();
        let csv: String = std::iter::once("t,p1,other\n".to_string())
            .chain((0..50).map(|i| format!("{},{},{}\n", 1.0 + i as f64 * 1e-3, 1e5 + i as f64, i)))
            .collect();
        let read = |p: &str| -> Result<(String, String), String> {
            if p == "a.csv" {
                Ok((csv.clone(), "dir/a.csv".into()))
            } else {
                Err(format!("no {p}"))
            }
        };
        let r = resolve(&m, &flat, &read).unwrap();
        let e = &r.experiments[0];
        assert_eq!(e.sets, vec!["supply.p=5 bar".to_string()]);
        assert_eq!(e.channels.len(), 1);
        assert!((e.channels[0].sigma - 500.0).abs() < 1e-9 && !e.channels[0].sigma_estimated);
        assert_eq!(e.times[0], 0.0);
        assert_eq!(r.calibrate[0].bounds, Some((1.0, 60.0)));
        assert_eq!(r.options.effects, Some(vec!["valve_delay".to_string()]));
        assert!(r.options.sensors.offset && r.options.sensors.gain);
        assert!((r.options.sensors.skew - 2e-3).abs() < 1e-15);
        assert!((r.options.switch_latency - 0.5e-3).abs() < 1e-15);
        // a skew bound that is not a time in [0, 1 s]
        for skew in [r#""-1 ms""#, r#""2 bar""#, "5"] {
            let text = format!(
                r#"{{ "experiments": [ {{ "data": "a.csv", "columns": {{ "p1": "head.p" }} }} ], "nuisance": {{ "skew": {skew} }} }}"#
            );
            let err = resolve(&parse(&text, "m.json").unwrap(), &flat, &read).unwrap_err();
            assert!(err.contains("skew"), "{err}");
        }
        // a column mapped to something that is not a signal
        let bad = parse(r#"{ "experiments": [ { "data": "a.csv", "columns": { "p1": "head.pressure" } } ] }"#, "m.json").unwrap();
        let err = resolve(&bad, &flat, &read).unwrap_err();
        assert!(err.contains("head.pressure") && err.contains("head.p"), "{err}");
        let bad = parse(r#"{ "experiments": [ { "data": "b.csv" } ] }"#, "m.json").unwrap();
        assert!(resolve(&bad, &flat, &read).unwrap_err().contains("no b.csv"));
        let bad = parse(
            r#"{ "experiments": [ { "data": "a.csv", "columns": { "p1": "head.p" } } ], "calibrate": { "friction.k0": ["9 N", "2 N"] } }"#,
            "m.json",
        )
        .unwrap();
        let err = resolve(&bad, &flat, &read).unwrap_err();
        assert!(err.contains("friction.k0") && err.contains("not below"), "{err}");
        // a hostile column target: escaped and shortened, one line
        let name = format!("head\u{1b}[2J\n{}", "x".repeat(5000));
        let quoted = serde_json::to_string(&name).unwrap();
        let text = format!(r#"{{ "experiments": [ {{ "data": "a.csv", "columns": {{ "p1": {quoted} }} }} ] }}"#);
        let err = resolve(&parse(&text, "m.json").unwrap(), &flat, &read).unwrap_err();
        assert!(!err.contains('\u{1b}') && !err.contains('\n'), "{err}");
        assert!(err.contains("\\u{1b}") && err.len() < 1000, "{} bytes: {err}", err.len());
    }

    #[test]
    fn declared_effects_reach_the_options_and_their_errors_name_the_manifest() {
        let flat = crate::netlist_edit::tests_support::meter_out();
        let csv: String = std::iter::once("t,p1\n".to_string()).chain((0..200).map(|i| format!("{},{}\n", i as f64 * 1e-3, 1e5))).collect();
        let read = |_: &str| -> Result<(String, String), String> { Ok((csv.clone(), "a.csv".into())) };
        let with = |effects: &str| {
            let text = format!(
                r#"{{ "experiments": [ {{ "data": "a.csv", "columns": {{ "p1": "head.p" }}, "set": {{ "supply.p": "6 bar" }} }} ], "effects": [], "user_effects": [{effects}] }}"#
            );
            resolve(&parse(&text, "dir/m.json").unwrap(), &flat, &read)
        };
        let leak = r#"{ "name": "bypass", "components": [ { "id": "bypass", "type": "capillary" } ],
                        "connections": [ ["head.port", "bypass.a"], ["bypass.b", "rod.port"] ],
                        "free": { "bypass.k": { "null": 0, "start": "0.1 L/min/bar", "bounds": ["0 L/min/bar", "2 L/min/bar"], "prior": { "center": 0, "sd": "0.5 L/min/bar" } } } }"#;
        let r = with(leak).unwrap();
        assert_eq!(r.options.effects, Some(vec![]));
        assert_eq!(r.options.user_effects.len(), 1);
        let p = &r.options.user_effects[0].free[0].spec;
        let lpm = 1e-3 / 60.0 / 1e5;
        assert_eq!((p.name.as_str(), p.unit.as_str(), p.lo, p.null), ("bypass.k", "L/min/bar", 0.0, Some(0.0)));
        let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-12;
        let (center, sd) = p.prior.unwrap();
        assert!(close(p.hi, 2.0 * lpm) && close(p.start, 0.1 * lpm) && center == 0.0 && close(sd, 0.5 * lpm), "{p:?}");
        // refusals: one line naming the manifest, the effect and what is wrong
        let wrong_null = r#"{ "name": "more_volume", "free": { "head.dead_volume": { "null": "0 cm3", "start": "30 cm3", "bounds": ["0 cm3", "100 cm3"] } } }"#;
        for (effects, words) in [
            (format!("{leak}, {leak}"), "user effect \"bypass\" is declared twice"),
            (leak.replace("\"2 L/min/bar\"", "\"3 bar\""), "user effect \"bypass\": free \"bypass.k\" upper bound"),
            (leak.replace("\"bypass\", \"comp", "\"dead_volume\", \"comp"), "user effect \"dead_volume\": the name is a built-in effect's"),
            (wrong_null.to_string(), "user effect \"more_volume\": the model does not return to the baseline"),
        ] {
            let err = with(&effects).unwrap_err();
            assert!(err.starts_with("dir/m.json: ") && err.contains(words) && !err.contains('\n'), "{err}");
        }
        // an unknown key in a declaration is a parse error with its position
        let err =
            parse(r#"{ "experiments": [ { "data": "a.csv" } ], "user_effects": [ { "name": "x", "fre": {} } ] }"#, "m.json").unwrap_err();
        assert!(err.to_string().starts_with("m.json:1:") && err.to_string().contains("fre"), "{err}");
    }

    #[test]
    fn sensor_specifications_become_priors() {
        let flat = crate::netlist_edit::tests_support::meter_out();
        let csv: String = std::iter::once("t,p1,x\n".to_string())
            .chain((0..50).map(|i| format!("{},{},{}\n", i as f64 * 1e-3, 4e5 + i as f64, 0.001 * i as f64)))
            .collect();
        let read = |_: &str| -> Result<(String, String), String> { Ok((csv.clone(), "a.csv".into())) };
        let with = |sensors: &str| {
            let text = format!(
                r#"{{ "experiments": [ {{ "data": "a.csv", "columns": {{ "p1": "head.p", "x": "piston.x" }} }} ], "sensors": {sensors} }}"#
            );
            resolve(&parse(&text, "m.json").unwrap(), &flat, &read)
        };
        // 0.25 % of a 10 bar full scale is 2500 Pa; the gain given in percent
        let r = with(r#"{ "head.p": { "accuracy": "0.25 %FS", "full_scale": "10 bar", "gain": "0.3 %" } }"#).unwrap();
        let p = r.experiments[0].channels[0].prior.clone().unwrap();
        assert!((p.offset_sd - 2500.0).abs() < 1e-9 && (p.gain_sd - 0.003).abs() < 1e-15, "{p:?}");
        // the unlisted channel keeps its quantity's default (0.1 % of the 49 mm span)
        let x = r.experiments[0].channels[1].prior.clone().unwrap();
        assert!((x.offset_sd - 0.049e-3).abs() < 1e-12, "{x:?}");
        // an absolute accuracy is a difference; the gain default of a pressure stays
        let p = with(r#"{ "head.p": { "accuracy": "5 mbar" } }"#).unwrap().experiments[0].channels[0].prior.clone().unwrap();
        assert!((p.offset_sd - 500.0).abs() < 1e-9 && (p.gain_sd - 0.005).abs() < 1e-15, "{p:?}");
        let p = with(r#"{ "head.p": { "accuracy": "free" } }"#).unwrap().experiments[0].channels[0].prior.clone().unwrap();
        assert!(p.offset_sd.is_infinite());
        // refusals name the signal and the reason
        for (bad, words) in [
            (r#"{ "head.p": { "accuracy": "0.25 %FS" } }"#, "full_scale"),
            (r#"{ "head.p": { "accuracy": "1.5 K" } }"#, "quantity"),
            (r#"{ "head.p": { "accuracy": "-5 mbar" } }"#, "positive"),
            (r#"{ "head.p": { "accuracy": "5 mbar", "gain": "120 %" } }"#, "fraction"),
            (r#"{ "head.q": { "accuracy": "5 mbar" } }"#, "not a signal"),
        ] {
            let err = with(bad).unwrap_err();
            assert!(err.contains(words), "{bad}: {err}");
        }
    }
}
