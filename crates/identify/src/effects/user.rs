//! Effects declared by the user in the experiments manifest
//! (`"user_effects"`, see [`crate::manifest`]): netlist edits written in the
//! netlist's own syntax — components to add, connections, fixed values
//! (`set`) and free parameters with bounds, an optional prior and the
//! value at which the effect vanishes (`null`). Once declared such an effect
//! is an [`Effect`] like the built-ins and is tried and judged the same way.
//!
//! ```json
//! { "name": "seal_bypass",
//!   "description": "laminar leak past the piston seal",
//!   "components": [ { "id": "bypass", "type": "capillary" } ],
//!   "connections": [ ["head.port", "bypass.a"], ["bypass.b", "rod.port"] ],
//!   "free": { "bypass.k": { "null": "0 L/min/bar", "start": "0.1 L/min/bar", "bounds": ["0 L/min/bar", "2 L/min/bar"] } } }
//! ```
//!
//! Values are parsed once, here, against the declared unit of the parameter
//! they belong to (a bound in bar for a conductance is refused).
//!
//! Nesting: the model without the effect must be a member of the effect's
//! family, at the `null` values. [`UserEffect::apply`] enforces the
//! structural part: when every free parameter that has a `null` is at it,
//! nothing is applied (the model is the baseline), and an added component
//! whose free parameters with a `null` are all at it is left out with its
//! connections (a conductance of size 0 that its block would refuse). The
//! physical part — that the effect fades continuously into the baseline as
//! its parameters approach the null, rather than jumping — cannot be proved
//! from the declaration; [`UserEffect::check_nested`] tests it by simulating
//! the baseline and the effect just off its null.

use super::{check_len, Effect, EffectError, EffectParam, Scale};
use crate::netlist_edit::{component, parse_for, set_param_si, spec_of, split_target};
use graph::netlist::{Component, Connection, Value};
use graph::FlatNetlist;
use serde::Deserialize;
use std::collections::BTreeMap;

/// One `user_effects` entry as written.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UserEffectSpec {
    pub name: String,
    #[serde(default)]
    pub description: Option<String>,
    /// Components to add, as in a netlist (block types only).
    #[serde(default)]
    pub components: Vec<Component>,
    /// Connections to add, as in a netlist.
    #[serde(default)]
    pub connections: Vec<Connection>,
    /// Fixed values applied with the effect, "id.param" → value.
    #[serde(default)]
    pub set: BTreeMap<String, Value>,
    /// Fitted parameters, "id.param" → declaration.
    pub free: BTreeMap<String, FreeSpec>,
}

/// One free parameter as written.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreeSpec {
    /// Value at which the effect vanishes (omit for a shape parameter).
    #[serde(default)]
    pub null: Option<Value>,
    /// Starting value of the fit (not the null: no gradient there).
    pub start: Value,
    /// [lower, upper].
    pub bounds: (Value, Value),
    /// Further starting values tried (default: `start` only).
    #[serde(default)]
    pub scan: Vec<Value>,
    /// "linear" (default) or "log".
    #[serde(default)]
    pub scale: Option<String>,
    /// Typical size (default: |start − null|, else the bound width / 10).
    #[serde(default)]
    pub typical: Option<Value>,
    /// Gaussian prior.
    #[serde(default)]
    pub prior: Option<PriorSpec>,
    /// Unit shown in the report (default: the unit the upper bound is written in).
    #[serde(default)]
    pub unit: Option<String>,
}

/// A Gaussian prior as written.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorSpec {
    pub center: Value,
    pub sd: Value,
}

/// A free parameter of a declared effect.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeParam {
    pub id: String,
    pub param: String,
    /// `spec.name` is "id.param".
    pub spec: EffectParam,
}

/// A declared, checked effect.
#[derive(Debug, Clone, PartialEq)]
pub struct UserEffect {
    pub name: String,
    pub summary: String,
    pub components: Vec<Component>,
    pub connections: Vec<(String, String)>,
    /// Fixed SI values: (id, param, value).
    pub set: Vec<(String, String, f64)>,
    pub free: Vec<FreeParam>,
}

/// The unit a value is written in ("1e-8 m3/s/Pa" → "m3/s/Pa").
fn written_unit(v: &Value) -> Option<String> {
    let Value::Text(t) = v else { return None };
    let t = t.trim();
    let split = (1..=t.len()).rev().filter(|&i| t.is_char_boundary(i)).find(|&i| t[..i].trim().parse::<f64>().is_ok())?;
    let unit = t[split..].trim();
    (!unit.is_empty() && units::parse_unit(unit).is_ok()).then(|| unit.to_string())
}

/// A computed value for a message: 4 significant digits, in `unit` when
/// it converts ("0.0005 L/min/bar"), else SI.
fn shown(x: f64, unit: &str) -> String {
    let short = |v: f64| units::show::num(format!("{v:.3e}").parse().unwrap_or(v));
    match units::to_unit(x, unit) {
        Ok(v) if !unit.is_empty() && v.is_finite() => format!("{} {unit}", short(v)),
        _ => short(x),
    }
}

fn valid_id(id: &str) -> bool {
    !id.is_empty() && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

impl UserEffect {
    /// Check a declaration against the model it will be tried on and turn it
    /// into an effect; the error is one line naming the effect and what is wrong.
    pub fn declare(spec: &UserEffectSpec, base: &FlatNetlist) -> Result<UserEffect, String> {
        let name = spec.name.clone();
        let fail = |m: String| format!("user effect \"{name}\": {m}");
        if !valid_id(&name) {
            return Err(fail("the name may use only letters, digits, '_' and '-'".into()));
        }
        if super::names().iter().any(|n| n == &name) {
            return Err(fail("the name is a built-in effect's; choose another".into()));
        }
        // the components, on a copy of the model
        let mut edited = base.clone();
        for c in &spec.components {
            if !valid_id(&c.id) {
                return Err(fail(format!("component id \"{}\" may use only letters, digits, '_' and '-'", c.id)));
            }
            if component(&edited, &c.id).is_some() {
                return Err(fail(format!("component \"{}\" exists already in the model or the effect", c.id)));
            }
            if c.file.is_some() {
                return Err(fail(format!("component \"{}\": only block types may be added, not subsystem files", c.id)));
            }
            blocks::registry::block_type(&c.kind).map_err(|e| fail(format!("component \"{}\": {e}", c.id)))?;
            let mut added = c.clone();
            added.origin = base.origin.clone();
            edited.components.push(added);
        }
        let mut connections = Vec::new();
        for conn in &spec.connections {
            let (a, b) = conn.ends();
            for end in [a, b] {
                let (id, port) = graph::netlist::split_ref(end).ok_or_else(|| fail(format!("connection \"{end}\": expected ID.PORT")))?;
                let c = component(&edited, id).ok_or_else(|| fail(format!("connection \"{end}\": no component \"{id}\"")))?;
                let ty = blocks::registry::block_type(&c.kind).map_err(|e| fail(e.to_string()))?;
                // a sequencer names its ports by its parameters and lists none
                if !ty.ports.is_empty() && !ty.ports.iter().any(|p| p.name == port) {
                    let known: Vec<&str> = ty.ports.iter().map(|p| p.name).collect();
                    return Err(fail(format!("connection \"{end}\": {} has no port \"{port}\" (ports: {})", c.kind, known.join(", "))));
                }
            }
            connections.push((a.to_string(), b.to_string()));
        }
        edited.connections.extend(connections.iter().cloned());
        let mut set = Vec::new();
        for (target, v) in &spec.set {
            let (id, param) = split_target(target).map_err(|e| fail(format!("set: {e}")))?;
            let x = parse_for(&edited, id, param, v).map_err(|e| fail(format!("set: {e}")))?;
            set.push((id.to_string(), param.to_string(), x));
        }
        let mut free = Vec::new();
        for (target, f) in &spec.free {
            let (id, param) = split_target(target).map_err(|e| fail(format!("free: {e}")))?;
            spec_of(&edited, id, param).map_err(|e| fail(format!("free: {e}")))?;
            let si = |v: &Value, what: &str| {
                parse_for(&edited, id, param, v).map_err(|e| fail(format!("free \"{target}\" {what}: {e}"))).and_then(|x| {
                    if x.is_finite() {
                        Ok(x)
                    } else {
                        Err(fail(format!("free \"{target}\" {what}: not a finite number")))
                    }
                })
            };
            let (lo, hi) = (si(&f.bounds.0, "lower bound")?, si(&f.bounds.1, "upper bound")?);
            let start = si(&f.start, "start")?;
            let null = f.null.as_ref().map(|v| si(v, "null")).transpose()?;
            let unit = match &f.unit {
                Some(u) => {
                    let parsed = units::parse_unit(u).map_err(|e| fail(format!("free \"{target}\" unit: {e}")))?;
                    let dim = match spec_of(&edited, id, param).map(|s| s.kind) {
                        Ok(blocks::params::ParamKind::Quantity(d)) => d,
                        _ => parsed.dimension,
                    };
                    if parsed.dimension != dim {
                        return Err(fail(format!("free \"{target}\": unit \"{u}\" does not measure this parameter")));
                    }
                    u.clone()
                }
                None => written_unit(&f.bounds.1).unwrap_or_default(),
            };
            let show = |x: f64| shown(x, &unit);
            if lo >= hi {
                return Err(fail(format!("free \"{target}\": lower bound {} is not below upper bound {}", show(lo), show(hi))));
            }
            for (what, x) in [("start", Some(start)), ("null", null)] {
                if let Some(x) = x.filter(|x| !(lo..=hi).contains(x)) {
                    return Err(fail(format!("free \"{target}\": {what} {} is outside the bounds [{}, {}]", show(x), show(lo), show(hi))));
                }
            }
            if null == Some(start) {
                return Err(fail(format!("free \"{target}\": start equals null (the fit has no gradient there)")));
            }
            let scale = match f.scale.as_deref().map(str::trim) {
                None | Some("linear") => Scale::Linear,
                Some("log") if lo > 0.0 => Scale::Log,
                Some("log") => return Err(fail(format!("free \"{target}\": a log scale needs a lower bound above 0"))),
                Some(other) => return Err(fail(format!("free \"{target}\": scale \"{other}\" is neither \"linear\" nor \"log\""))),
            };
            let mut scan = Vec::new();
            for v in &f.scan {
                let x = si(v, "scan value")?;
                if !(lo..=hi).contains(&x) {
                    return Err(fail(format!("free \"{target}\": scan value {} is outside the bounds", show(x))));
                }
                scan.push(x);
            }
            let typical = match &f.typical {
                Some(v) => si(v, "typical")?.abs(),
                None => Some((start - null.unwrap_or(0.0)).abs()).filter(|t| *t > 0.0).unwrap_or((hi - lo) / 10.0),
            };
            if typical <= 0.0 {
                return Err(fail(format!("free \"{target}\": typical size must be > 0")));
            }
            let prior = match &f.prior {
                None => None,
                Some(p) => {
                    let (c, sd) = (si(&p.center, "prior center")?, si(&p.sd, "prior sd")?);
                    if sd <= 0.0 {
                        return Err(fail(format!("free \"{target}\": prior sd must be > 0")));
                    }
                    Some((c, sd))
                }
            };
            let spec = EffectParam { name: target.clone(), unit, lo, hi, start, typical, null, prior, scale, scan };
            free.push(FreeParam { id: id.to_string(), param: param.to_string(), spec });
        }
        if !free.iter().any(|p| p.spec.null.is_some()) {
            return Err(fail("no free parameter declares a \"null\" (the value at which the effect vanishes); one must".into()));
        }
        let effect = UserEffect {
            summary: spec.description.clone().unwrap_or_else(|| format!("user effect {name}")),
            name: name.clone(),
            components: spec.components.clone(),
            connections,
            set,
            free,
        };
        // the whole edit at its start values must build (required values, ports, ranges)
        let mut at_start = base.clone();
        let start: Vec<f64> = effect.free.iter().map(|p| p.spec.start).collect();
        effect.apply(&mut at_start, &start).map_err(|e| fail(e.message))?;
        graph::build(&at_start).map_err(|e| fail(format!("at its start values the model does not build: {e}")))?;
        Ok(effect)
    }

    /// Check that the effect fades into the baseline: simulate `base` for
    /// `t_end` seconds, and again with every free parameter that has a null
    /// moved a small step off it (1e-4 of its bound width; shape parameters
    /// at their start). It nests when each of `signals` (the measured ones)
    /// agrees within 1e-3 of its range, a margin well above the solver's
    /// tolerance — or, when it does not, when the largest difference
    /// shrinks at least in half as the step is cut tenfold: an effect that
    /// fades continuously into the model (a leak conductance → 0), however
    /// wide its bounds, is accepted, and a null that is not the baseline (a
    /// difference that stays as the step shrinks) is refused.
    pub fn check_nested(&self, base: &FlatNetlist, t_end: f64, signals: &[String]) -> Result<(), String> {
        let fail = |m: String| format!("user effect \"{}\": {m}", self.name);
        let near = |fraction: f64| -> Vec<f64> {
            self.free
                .iter()
                .map(|p| match p.spec.null {
                    Some(n) => {
                        let step = fraction * (p.spec.hi - p.spec.lo);
                        if n + step <= p.spec.hi {
                            n + step
                        } else {
                            n - step
                        }
                    }
                    None => p.spec.start,
                })
                .collect()
        };
        let run = |flat: &FlatNetlist| -> Result<solve::SimResult, String> {
            let circuit = graph::build(flat).map_err(|e| e.to_string())?;
            let mut opts = solve::options_from(&circuit.simulation).map_err(|e| e.to_string())?;
            opts.cycles = None;
            opts.t_end = t_end;
            opts.sample_interval = t_end / 500.0;
            solve::simulate(&mut solve::Model::new(circuit), &opts).map_err(|e| e.to_string())
        };
        let a = run(base).map_err(|e| fail(format!("the model without it does not simulate: {e}")))?;
        // the largest difference from the baseline, as a fraction of the
        // signal's range, with the column and time where it is
        let worst = |values: &[f64]| -> Result<(f64, String, f64, f64), String> {
            let mut edited = base.clone();
            self.apply(&mut edited, values).map_err(|e| fail(e.message))?;
            let b = run(&edited).map_err(|e| fail(format!("just off its null the model does not simulate: {e}")))?;
            let mut worst = (0.0, String::new(), 0.0, 0.0);
            for col in signals {
                let (Some(sa), Some(sb)) = (a.series(col), b.series(col)) else { continue };
                let finite = || sa.iter().map(|(_, v)| *v).filter(|v| v.is_finite());
                let (lo, hi) = (finite().fold(f64::INFINITY, f64::min), finite().fold(f64::NEG_INFINITY, f64::max));
                let range = (hi - lo).max(1e-9 * lo.abs().max(hi.abs())).max(f64::MIN_POSITIVE);
                for ((t, va), (_, vb)) in sa.iter().zip(&sb) {
                    let d = (va - vb).abs() / range;
                    if va.is_finite() && vb.is_finite() && d > worst.0 {
                        worst = (d, col.clone(), *t, range);
                    }
                }
            }
            Ok(worst)
        };
        let first = near(1e-4);
        let (d, col, t, range) = worst(&first)?;
        if d <= 1e-3 {
            return Ok(());
        }
        let (d_tenth, ..) = worst(&near(1e-5))?;
        if d_tenth <= 0.5 * d {
            return Ok(()); // fades continuously into the baseline
        }
        let at: Vec<String> = self.free.iter().zip(&first).map(|(p, v)| format!("{} = {}", p.spec.name, shown(*v, &p.spec.unit))).collect();
        Err(fail(format!(
            "the model does not return to the baseline at the null: just off it ({}), {col} differs by {} at t = {} s (range {}), and by {} of its range with a step ten times smaller; declare the value that removes the effect as \"null\"",
            at.join(", "),
            shown(d * range, ""),
            shown(t, ""),
            shown(range, ""),
            shown(d_tenth, "")
        )))
    }

    /// Whether every free parameter that has a null is at it, among `which`.
    fn at_null(&self, values: &[f64], mut which: impl FnMut(&FreeParam) -> bool) -> bool {
        let mut any = false;
        for (p, v) in self.free.iter().zip(values) {
            if let Some(n) = p.spec.null.filter(|_| which(p)) {
                any = true;
                if *v != n {
                    return false;
                }
            }
        }
        any
    }
}

impl Effect for UserEffect {
    fn name(&self) -> &str {
        &self.name
    }
    fn summary(&self) -> &str {
        &self.summary
    }
    fn params(&self) -> Vec<EffectParam> {
        self.free.iter().map(|p| p.spec.clone()).collect()
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        let added = |id: &str| self.components.iter().any(|c| c.id == id);
        let exists = |id: &str| added(id) || component(flat, id).is_some();
        self.components.iter().all(|c| component(flat, &c.id).is_none())
            && self.connections.iter().all(|(a, b)| [a, b].iter().all(|e| graph::netlist::split_ref(e).is_some_and(|(id, _)| exists(id))))
            && self.set.iter().all(|(id, _, _)| exists(id))
            && self.free.iter().all(|p| exists(&p.id))
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        if self.at_null(values, |_| true) {
            return Ok(()); // the baseline: nothing added
        }
        let omitted: Vec<&str> = self.components.iter().filter(|c| self.at_null(values, |p| p.id == c.id)).map(|c| c.id.as_str()).collect();
        for c in self.components.iter().filter(|c| !omitted.contains(&c.id.as_str())) {
            if component(flat, &c.id).is_some() {
                return Err(EffectError::new(&self.name, format!("component \"{}\" exists already", c.id)));
            }
            let mut c = c.clone();
            c.origin = flat.origin.clone();
            flat.components.push(c);
        }
        let kept = |end: &str| graph::netlist::split_ref(end).is_none_or(|(id, _)| !omitted.contains(&id));
        flat.connections.extend(self.connections.iter().filter(|(a, b)| kept(a) && kept(b)).cloned());
        for (id, param, v) in self.set.iter().filter(|(id, _, _)| !omitted.contains(&id.as_str())) {
            set_param_si(flat, id, param, *v).map_err(|e| EffectError::new(&self.name, e))?;
        }
        for (p, v) in self.free.iter().zip(values).filter(|(p, _)| !omitted.contains(&p.id.as_str())) {
            set_param_si(flat, &p.id, &p.param, *v).map_err(|e| EffectError::new(&self.name, e))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{max_diff, meter_out, run};
    use crate::effects::PistonSealLeak;

    /// An ISO 6358 orifice (b = 0.5) across the piston seal: the built-in
    /// `piston_seal_leak` at law 0, written as a user would.
    pub(crate) const SEAL_ORIFICE: &str = r#"{
        "name": "seal_orifice", "description": "ISO 6358 orifice across the piston seal",
        "components": [ { "id": "seal", "type": "conductance", "params": { "b": 0.5 } } ],
        "connections": [ ["head.port", "seal.a"], ["seal.b", "rod.port"] ],
        "free": { "seal.C": { "null": "0 L/min/bar", "start": "0.2 L/min/bar", "bounds": ["0 L/min/bar", "5 L/min/bar"],
                              "scan": ["0.1 L/min/bar", "1 L/min/bar"] } } }"#;

    fn signals() -> Vec<String> {
        ["head.p", "rod.p", "piston.x"].map(String::from).to_vec()
    }

    fn declare(text: &str) -> Result<UserEffect, String> {
        let spec: UserEffectSpec = serde_json::from_str(text).map_err(|e| format!("json: {}", units::show::quoting(&e.to_string())))?;
        UserEffect::declare(&spec, &meter_out())
    }

    /// `SEAL_ORIFICE` with `from` replaced by `to` (which must occur).
    fn variant(from: &str, to: &str) -> String {
        assert!(SEAL_ORIFICE.contains(from), "{from}");
        SEAL_ORIFICE.replacen(from, to, 1)
    }

    #[test]
    fn a_declared_orifice_behaves_like_the_built_in_leak() {
        let e = declare(SEAL_ORIFICE).unwrap();
        let p = &e.params()[0];
        assert_eq!((p.name.as_str(), p.unit.as_str(), p.null, p.lo), ("seal.C", "L/min/bar", Some(0.0), 0.0));
        let lpm = 1e-3 / 60.0 / 1e5;
        assert!((p.hi / (5.0 * lpm) - 1.0).abs() < 1e-12 && (p.start / (0.2 * lpm) - 1.0).abs() < 1e-12);
        assert_eq!(p.scan.len(), 2);
        let base = meter_out();
        assert!(e.applies_to(&base));
        let (mut user, mut builtin) = (base.clone(), base.clone());
        e.apply(&mut user, &[2.0 * lpm]).unwrap();
        PistonSealLeak.apply(&mut builtin, &[2.0 * lpm, 0.0]).unwrap();
        let (a, b, c) = (run(&user), run(&builtin), run(&base));
        for col in ["head.p", "rod.p", "piston.x"] {
            let same = max_diff(&a, &b, col);
            let effect = max_diff(&a, &c, col);
            assert!(same <= 1e-9 * effect.max(1.0) && effect > 0.0, "{col}: user vs built-in {same}, effect {effect}");
        }
        // at the null nothing is added; once applied it no longer applies
        let mut same = base.clone();
        e.apply(&mut same, &[0.0]).unwrap();
        assert_eq!(same, base);
        assert!(!e.applies_to(&user));
        assert!(e.apply(&mut user, &[1.0]).is_err());
        e.check_nested(&base, 1.0, &signals()).unwrap();
    }

    #[test]
    fn malformed_declarations_are_refused_with_the_reason() {
        let cases: Vec<(String, &str)> = vec![
            (variant("\"conductance\"", "\"conductanse\""), "unknown component type \"conductanse\"; did you mean \"conductance\""),
            (variant("\"seal.b\"", "\"seal.c\""), "conductance has no port \"c\""),
            (variant("\"rod.port\"", "\"rods.port\""), "no component \"rods\""),
            (variant("\"seal.C\"", "\"seal.K\""), "no parameter \"K\""),
            (variant("\"5 L/min/bar\"", "\"5 bar\""), "upper bound"),
            (variant("\"seal_orifice\"", "\"piston_seal_leak\""), "built-in"),
            (variant("\"null\": \"0 L/min/bar\", ", ""), "\"null\""),
            (
                variant("\"start\": \"0.2 L/min/bar\"", "\"start\": \"9 L/min/bar\""),
                "start 9 L/min/bar is outside the bounds [0 L/min/bar, 5 L/min/bar]",
            ),
            (variant("\"start\": \"0.2 L/min/bar\"", "\"start\": \"0 L/min/bar\""), "start equals null"),
            (variant("\"id\": \"seal\"", "\"id\": \"head\""), "exists already"),
            (variant("\"bounds\"", "\"bound\""), "json"),
        ];
        for (text, words) in cases {
            let err = declare(&text).unwrap_err();
            assert!(err.contains(words), "expected \"{words}\" in: {err}");
            if !words.starts_with("json") {
                assert!(err.starts_with("user effect \""), "{err}");
            }
        }
    }

    #[test]
    fn an_effect_whose_null_is_not_the_baseline_is_refused() {
        // the model writes 20 cm3 of dead volume; a "null" of 0 cm3 replaces it
        let wrong = r#"{ "name": "more_volume", "free": { "head.dead_volume": { "null": "0 cm3", "start": "30 cm3", "bounds": ["0 cm3", "100 cm3"] } } }"#;
        let e = declare(wrong).unwrap();
        let err = e.check_nested(&meter_out(), 1.0, &signals()).unwrap_err();
        assert!(err.contains("does not return to the baseline") && err.contains("head.dead_volume"), "{err}");
        // declared at the model's own value it nests
        let right = wrong.replace("\"null\": \"0 cm3\"", "\"null\": \"20 cm3\"");
        declare(&right).unwrap().check_nested(&meter_out(), 1.0, &signals()).unwrap();
    }

    #[test]
    fn a_leak_with_wide_bounds_still_nests() {
        // 1e-4 of [0, 50 000] L/min/bar is a 5 L/min/bar leak: far off the
        // baseline at the first step (the check once refused it, so its
        // verdict depended on the bounds), but the difference falls tenfold
        // with the step — the leak fades continuously into the model
        let wide = variant("\"5 L/min/bar\"]", "\"50000 L/min/bar\"]");
        let e = declare(&wide).unwrap();
        e.check_nested(&meter_out(), 1.0, &signals()).unwrap();
        // while a null that is not the model's value stays refused whatever the step
        let wrong = r#"{ "name": "more_volume", "free": { "head.dead_volume": { "null": "0 cm3", "start": "0.5 cm3", "bounds": ["0 cm3", "1 cm3"] } } }"#;
        let err = declare(wrong).unwrap().check_nested(&meter_out(), 1.0, &signals()).unwrap_err();
        assert!(err.contains("with a step ten times smaller"), "{err}");
    }
}
