//! Fitted parameters: what each acts on, its bounds and its scaled fit
//! coordinate; the default calibration set of a cylinder circuit; one
//! parameter per distinct setting of a calibrated value; the parameters an
//! effect adds.
//!
//! # Fit coordinates
//! Each parameter is fitted in a scaled coordinate u so that all are O(1):
//! linear u = θ/θ_typ, or logarithmic u = ln(θ/θ_typ) for strictly positive
//! quantities known only to a factor (conductances, friction levels), or
//! u = −ln((1 − θ)/(1 − θ_start)) (increasing in θ) for a ratio below 1 known by its distance
//! from 1 (an ISO 6358 laminar ratio `b_lam`).
//! Calibration parameters that the experiments set to different values
//! (e.g. one throttle setting per experiment) are fitted once per distinct
//! setting, each applying to the experiments with that setting.
//!
//! # Priors
//! A parameter may carry a Gaussian prior ([`Prior`]; on ln θ for a
//! logarithmic coordinate): the fit then minimises the posterior, with the
//! row (θ − μ)/s appended to the residual vector ([`crate::problem`]). The
//! form parameters of the default calibration have priors (see
//! [`default_calibration`]); a manifest may give any target one.
//!
//! Units: values and bounds SI; `unit` is only the unit shown to people.

use crate::effects::{Effect, Scale};
use crate::experiment::Experiment;
use crate::netlist_edit::{param_si, parse_for, split_target};
use graph::FlatNetlist;

/// What a fitted parameter acts on.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// A netlist parameter "id.param", for the listed experiments (all if `None`).
    Netlist { id: String, param: String, experiments: Option<Vec<usize>> },
    /// Parameter `k` of effect slot `slot` of the problem.
    Effect { slot: usize, k: usize },
}

/// A fitted parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct FitParam {
    /// "friction.k0", "flow_control.C@13.2 L/min/bar", "piston_seal_leak.C".
    pub name: String,
    /// Unit shown to people; values are SI.
    pub unit: String,
    pub lo: f64,
    pub hi: f64,
    /// Starting value [SI].
    pub start: f64,
    /// Scale of the fit coordinate [SI].
    pub typical: f64,
    pub scale: Scale,
    /// Null value of an effect parameter.
    pub null: Option<f64>,
    pub target: Target,
    /// Gaussian prior, if any.
    pub prior: Option<Prior>,
}

/// A Gaussian prior of a parameter: θ ~ N(center, sd²) on a linear
/// coordinate (and on a [`Scale::LogGap`] one: the prior is on θ itself), ln θ ~ N(ln center, (sd/center)²) on a logarithmic one
/// (`sd` is then the relative spread at the center). SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    pub center: f64,
    pub sd: f64,
}

impl FitParam {
    /// Fit coordinate of an SI value.
    pub fn to_u(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => v / self.typical,
            Scale::Log => (v / self.typical).ln(),
            Scale::LogGap => (self.typical / (1.0 - v).max(f64::MIN_POSITIVE)).ln(),
        }
    }
    /// SI value of a fit coordinate.
    pub fn from_u(&self, u: f64) -> f64 {
        match self.scale {
            Scale::Linear => u * self.typical,
            Scale::Log => self.typical * u.exp(),
            Scale::LogGap => 1.0 - self.typical * (-u).exp(),
        }
    }
    /// Whether this is an effect parameter.
    pub fn is_effect(&self) -> bool {
        matches!(self.target, Target::Effect { .. })
    }
    /// The prior row of an SI value (see [`Prior`]); `None` without a prior.
    pub fn prior_row(&self, v: f64) -> Option<f64> {
        let p = self.prior?;
        Some(match self.scale {
            Scale::Linear | Scale::LogGap => (v - p.center) / p.sd,
            Scale::Log => (v.max(f64::MIN_POSITIVE) / p.center).ln() / (p.sd / p.center),
        })
    }
}

/// A calibration target with optional bounds and prior (SI).
#[derive(Debug, Clone, PartialEq)]
pub struct CalibSpec {
    pub target: String,
    pub bounds: Option<(f64, f64)>,
    pub prior: Option<Prior>,
}

impl CalibSpec {
    /// A target with default bounds and no prior.
    pub fn plain(target: &str) -> Self {
        CalibSpec { target: target.to_string(), bounds: None, prior: None }
    }
}

/// Prior σ of an ISO 6358 subsonic index m around the netlist's value
/// (ISO 6358-1:2013 introduced m because measured characteristics are not
/// the ellipse quarter m = ½; values of 0.3 … 0.7 are reported for valves
/// and fittings).
pub const SUBSONIC_INDEX_SD: f64 = 0.1;
/// Bounds of a calibrated subsonic index.
pub const SUBSONIC_INDEX_BOUNDS: (f64, f64) = (0.25, 0.85);
/// Prior σ [Pa] and upper bound of a check valve's cracking pressure
/// (speed-control valves are catalogued at 0.1 … 0.5 bar, or "free flow").
pub const CRACKING_SD: f64 = 0.2e5;
pub const CRACKING_MAX: f64 = 1.0e5;
/// Prior σ of an ISO 6358 restriction's laminar pressure ratio `b_lam`
/// around the netlist's value, and its bounds. The laminar end of the
/// characteristic is not given by catalogues; MathWorks' Simscape ISO 6358
/// orifice documents it as "a value between 0.999 and 0.995" (its default
/// 0.999, ours too), so σ is that range's width halved and the bounds
/// widen it by its width on either side; a restriction measured without a
/// laminar end sits near the upper bound.
pub const LAMINAR_RATIO_SD: f64 = 0.002;
pub const LAMINAR_RATIO_BOUNDS: (f64, f64) = (0.99, 0.9999);

/// The default calibration set of a cylinder circuit (docs/discrepancy.md
/// gives the reasons):
/// - Coulomb and viscous friction at zero pressure (k0, k2), bounds
///   [value/3, 3·value], no prior;
/// - every throttle's C and the directional valve's C, likewise;
/// - the form parameters an engineer never knows exactly, with priors
///   around the netlist's value: the ISO 6358 subsonic index m of every
///   throttle and of the directional valve (σ 0.1, [`SUBSONIC_INDEX_SD`]),
///   the cracking pressure of every throttle's check valve (σ 0.2 bar,
///   [`CRACKING_SD`], in [0, 1 bar]), and the laminar pressure ratio
///   `b_lam` of every throttle and of the directional valve (σ 0.002,
///   [`LAMINAR_RATIO_SD`]).
///
/// Parameters that are zero in the netlist are skipped where they need a
/// scale (k0, k2, C).
pub fn default_calibration(flat: &FlatNetlist) -> Vec<CalibSpec> {
    let topo = crate::netlist_edit::Topology::of(flat);
    let mut scaled = Vec::new();
    if let Some(f) = &topo.friction {
        scaled.push(format!("{f}.k0"));
        scaled.push(format!("{f}.k2"));
    }
    for t in &topo.throttles {
        scaled.push(format!("{t}.C"));
    }
    if let Some(v) = &topo.valve {
        scaled.push(format!("{v}.C"));
    }
    let value = |t: &str| split_target(t).ok().and_then(|(id, p)| param_si(flat, id, p).ok());
    let mut out: Vec<CalibSpec> =
        scaled.into_iter().filter(|t| value(t).is_some_and(|v| v > 0.0)).map(|target| CalibSpec::plain(&target)).collect();
    let index = |id: &str| -> Option<CalibSpec> {
        let target = format!("{id}.m");
        let v = value(&target)?;
        Some(CalibSpec {
            target,
            bounds: Some(SUBSONIC_INDEX_BOUNDS),
            prior: Some(Prior { center: v.clamp(SUBSONIC_INDEX_BOUNDS.0, SUBSONIC_INDEX_BOUNDS.1), sd: SUBSONIC_INDEX_SD }),
        })
    };
    let laminar = |id: &str| -> Option<CalibSpec> {
        let target = format!("{id}.b_lam");
        let v = value(&target)?;
        let (lo, hi) = LAMINAR_RATIO_BOUNDS;
        Some(CalibSpec { target, bounds: Some((lo.min(v), hi.max(v))), prior: Some(Prior { center: v, sd: LAMINAR_RATIO_SD }) })
    };
    for t in &topo.throttles {
        out.extend(index(t));
        let target = format!("{t}.cracking_pressure");
        if let Some(v) = value(&target) {
            out.push(CalibSpec { target, bounds: Some((0.0, CRACKING_MAX.max(v))), prior: Some(Prior { center: v, sd: CRACKING_SD }) });
        }
    }
    if let Some(v) = &topo.valve {
        out.extend(index(v));
    }
    for id in topo.throttles.iter().chain(&topo.valve) {
        out.extend(laminar(id));
    }
    // a vessel test (no cylinder): every restriction's C, and its b and m with priors
    if topo.piston.is_none() && !topo.vessels.is_empty() {
        for r in &topo.restrictions {
            let c = format!("{r}.C");
            if value(&c).is_some_and(|v| v > 0.0) {
                out.push(CalibSpec::plain(&c));
            }
            let b = format!("{r}.b");
            if let Some(v) = value(&b) {
                out.push(CalibSpec {
                    target: b,
                    bounds: Some(CRITICAL_RATIO_BOUNDS),
                    prior: Some(Prior { center: v.clamp(CRITICAL_RATIO_BOUNDS.0, CRITICAL_RATIO_BOUNDS.1), sd: CRITICAL_RATIO_SD }),
                });
            }
            out.extend(index(r));
        }
    }
    out
}

/// Prior σ and bounds of a calibrated ISO 6358 critical ratio b of a vessel
/// test's restriction (the paper's valves have 0.3; ISO 6358 values of
/// orifices and valves range over 0.1 … 0.6).
pub const CRITICAL_RATIO_SD: f64 = 0.15;
pub const CRITICAL_RATIO_BOUNDS: (f64, f64) = (0.05, 0.9);

/// The initial state of every rigid vessel whose pressure or temperature
/// is measured, one parameter per experiment: "the data's first samples fix
/// the initial state". p0 (T0) starts at the channel's first sample, with a
/// prior there (`initial_state_prior`) whose σ combines the sensor's offset
/// prior (a sensor offset and a wrong initial state are otherwise the same
/// thing at t = 0), its noise and how far the state can have moved before
/// that sample, bounded at ±6 σ (and above zero). Without them the sensor
/// offsets would have to absorb a netlist initial state that differs from
/// the rig's.
pub fn initial_state_params(flat: &FlatNetlist, experiments: &[Experiment]) -> Vec<FitParam> {
    let topo = crate::netlist_edit::Topology::of(flat);
    let mut out = Vec::new();
    for v in &topo.vessels {
        for (signal, param, unit) in [("p", "p0", "bar"), ("T", "T0", "K")] {
            for (k, e) in experiments.iter().enumerate() {
                let Some(ch) = e.channels.iter().find(|c| c.signal == format!("{v}.{signal}")) else { continue };
                let offset_sd = ch.prior.as_ref().map(|p| p.offset_sd).filter(|s| s.is_finite() && *s > 0.0).unwrap_or(ch.sigma);
                let Some(Prior { center, sd }) = initial_state_prior(&e.times, &ch.values, offset_sd, ch.sigma) else { continue };
                let (lo, hi) = ((center - 6.0 * sd).max(1e-3 * center.abs()), center + 6.0 * sd);
                out.push(FitParam {
                    name: if experiments.len() == 1 { format!("{v}.{param}") } else { format!("{v}.{param}@{}", e.name) },
                    unit: unit.to_string(),
                    lo,
                    hi,
                    start: center,
                    typical: sd.max(1e-12),
                    scale: Scale::Linear,
                    null: None,
                    target: Target::Netlist { id: v.clone(), param: param.to_string(), experiments: Some(vec![k]) },
                    prior: Some(Prior { center, sd }),
                });
            }
        }
    }
    out
}

/// Prior of a vessel's initial p0 or T0 from its channel's first samples:
/// centred on the first sample, with σ² = offset_sd² + noise² + Δ², where
/// Δ = |y₂ − y₁|·t₁/(t₂ − t₁) is the change the channel's first step says
/// the state can have made between t = 0 and that first sample at t₁. On a
/// record logged from t = 0 at a high rate Δ is nil and the prior is the
/// sensor's; on a sparse record (a vessel test read every few seconds, a
/// curve digitised from a paper) the first sample can be seconds into a
/// blowdown, and a prior as narrow as the sensor's would pin the initial
/// state to where the gas already was at t₁ (a filling's first temperature
/// sample 0.04 s in, a blowdown's 3.6 s in, 12 K below the start). `None`
/// without any sample.
pub fn initial_state_prior(times: &[f64], values: &[Option<f64>], offset_sd: f64, noise: f64) -> Option<Prior> {
    let mut present = times.iter().zip(values).filter_map(|(&t, v)| v.map(|v| (t, v)));
    let (t1, y1) = present.next()?;
    let moved = match present.next() {
        Some((t2, y2)) if t2 > t1 => (y2 - y1).abs() * t1.max(0.0) / (t2 - t1),
        _ => 0.0,
    };
    let sd = (offset_sd * offset_sd + noise * noise + moved * moved).sqrt();
    Some(Prior { center: y1, sd: if sd > 0.0 && sd.is_finite() { sd } else { noise.max(f64::MIN_POSITIVE) } })
}

/// Turn calibration targets into fit parameters, one per distinct setting
/// among the experiments.
pub fn calibration_params(flat: &FlatNetlist, experiments: &[Experiment], specs: &[CalibSpec]) -> Result<Vec<FitParam>, String> {
    let mut out = Vec::new();
    for spec in specs {
        let (id, param) = split_target(&spec.target).map_err(|e| e.to_string())?;
        let base = param_si(flat, id, param).map_err(|e| format!("calibrate {}: {e}", spec.target))?;
        let unit = crate::netlist_edit::spec_of(flat, id, param).map_err(|e| e.to_string())?.display_unit.to_string();
        // nominal value of each experiment, grouped
        let mut groups: Vec<(f64, String, Vec<usize>)> = Vec::new();
        for (k, e) in experiments.iter().enumerate() {
            let mut v = base;
            let mut label = String::new();
            for s in &e.sets {
                if let Some((t, val)) = s.split_once('=') {
                    if t.trim() == spec.target {
                        v = parse_for(flat, id, param, &graph::expand::value_from_text(val)).map_err(|e| e.to_string())?;
                        label = val.trim().to_string();
                    }
                }
            }
            match groups.iter_mut().find(|g| g.0 == v) {
                Some(g) => g.2.push(k),
                None => groups.push((v, label, vec![k])),
            }
        }
        let single = groups.len() == 1;
        for (v, label, members) in groups {
            let (lo, hi) = match spec.bounds {
                Some(b) => b,
                None if v > 0.0 => (v / 3.0, v * 3.0),
                None => return Err(format!("calibrate {}: the value is {v}; give bounds [lo, hi]", spec.target)),
            };
            if lo >= hi || !lo.is_finite() || !hi.is_finite() {
                return Err(format!("calibrate {}: bounds [{lo}, {hi}] are not an interval", spec.target));
            }
            let start = v.clamp(lo, hi);
            // a laminar ratio is known by its distance from 1, to a factor
            let (scale, typical) = if param == "b_lam" && hi < 1.0 {
                (Scale::LogGap, 1.0 - start)
            } else if lo > 0.0 && spec.prior.is_none() {
                (Scale::Log, start)
            } else {
                (Scale::Linear, start.abs().max((hi - lo) / 10.0))
            };
            let name = if single {
                spec.target.clone()
            } else if label.is_empty() {
                format!("{}@netlist value", spec.target)
            } else if label.parse::<f64>().is_ok() {
                // a plain SI number: show it in the parameter's display unit
                match units::to_unit(v, &unit) {
                    Ok(x) if !unit.is_empty() => format!("{}@{} {unit}", spec.target, significant(x, 4)),
                    _ => format!("{}@{}", spec.target, significant(v, 4)),
                }
            } else {
                format!("{}@{label}", spec.target)
            };
            out.push(FitParam {
                name,
                unit: unit.clone(),
                lo,
                hi,
                start,
                typical,
                scale,
                null: None,
                target: Target::Netlist {
                    id: id.to_string(),
                    param: param.to_string(),
                    experiments: if single { None } else { Some(members) },
                },
                prior: spec.prior,
            });
        }
    }
    Ok(out)
}

/// `x` with `digits` significant digits, without trailing zeros.
pub fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Fit parameters of an effect placed in slot `slot`.
pub fn effect_params(effect: &dyn Effect, slot: usize) -> Vec<FitParam> {
    effect
        .params()
        .into_iter()
        .enumerate()
        .map(|(k, p)| FitParam {
            name: format!("{}.{}", effect.name(), p.name),
            unit: p.unit.clone(),
            lo: p.lo,
            hi: p.hi,
            start: p.start,
            typical: p.typical,
            scale: p.scale,
            null: p.null,
            target: Target::Effect { slot, k },
            prior: p.prior.map(|(center, sd)| Prior { center, sd }),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::tests::dataset;
    use crate::netlist_edit::tests_support::meter_out;

    #[test]
    fn calibration_groups_per_distinct_setting() {
        let flat = meter_out();
        let d = dataset(&["head.p"], 20);
        let mk = |c: &str| {
            Experiment::from_dataset("e", &d, None, vec![format!("flow_control.C={c}"), "supply.p=4 bar".into()], None, &[]).unwrap()
        };
        let exps = vec![mk("13.2 L/min/bar"), mk("26 L/min/bar"), mk("13.2 L/min/bar")];
        let specs =
            vec![CalibSpec::plain("flow_control.C"), CalibSpec { target: "friction.k0".into(), bounds: Some((1.0, 60.0)), prior: None }];
        let ps = calibration_params(&flat, &exps, &specs).unwrap();
        assert_eq!(ps.len(), 3);
        assert_eq!(ps[0].name, "flow_control.C@13.2 L/min/bar");
        assert_eq!(ps[0].target, Target::Netlist { id: "flow_control".into(), param: "C".into(), experiments: Some(vec![0, 2]) });
        assert!((ps[1].start - 26e-3 / 60.0 / 1e5).abs() < 1e-20);
        assert_eq!((ps[2].name.as_str(), ps[2].lo, ps[2].hi, ps[2].start), ("friction.k0", 1.0, 60.0, 10.0));
        // log coordinate round trip, and linear for a bound at zero
        let p = &ps[2];
        assert!((p.from_u(p.to_u(33.0)) - 33.0).abs() < 1e-12);
        let specs = vec![CalibSpec { target: "friction.k0".into(), bounds: Some((0.0, 60.0)), prior: None }];
        let q = &calibration_params(&flat, &exps, &specs).unwrap()[0];
        assert_eq!(q.scale, Scale::Linear);
        assert!((q.from_u(q.to_u(12.0)) - 12.0).abs() < 1e-12);
    }

    #[test]
    fn significant_digits() {
        assert_eq!(significant(29.87654, 4), "29.88");
        assert_eq!(significant(0.000123456, 3), "0.000123");
        assert_eq!(significant(1500.0, 3), "1500");
        assert_eq!(significant(13.2, 4), "13.2");
        // a group named by an SI number is shown in the display unit
        let flat = meter_out();
        let d = dataset(&["head.p"], 20);
        let e = Experiment::from_dataset("e", &d, None, vec!["flow_control.C=4.4e-9".into()], None, &[]).unwrap();
        let f = Experiment::from_dataset("f", &d, None, vec!["flow_control.C=13.2 L/min/bar".into()], None, &[]).unwrap();
        let ps = calibration_params(&flat, &[e, f], &[CalibSpec::plain("flow_control.C")]).unwrap();
        assert_eq!(ps[0].name, "flow_control.C@26.4 L/min/bar");
        assert_eq!(ps[1].name, "flow_control.C@13.2 L/min/bar");
    }

    #[test]
    fn default_calibration_of_meter_out() {
        let specs = default_calibration(&meter_out());
        let names: Vec<&str> = specs.iter().map(|c| c.target.as_str()).collect();
        assert_eq!(
            names,
            vec![
                "friction.k0",
                "friction.k2",
                "flow_control.C",
                "dcv.C",
                "flow_control.m",
                "flow_control.cracking_pressure",
                "dcv.m",
                "flow_control.b_lam",
                "dcv.b_lam"
            ]
        );
        let m = &specs[4];
        assert_eq!(m.prior, Some(Prior { center: 0.5, sd: SUBSONIC_INDEX_SD }));
        // a prior is a row of the residual vector: 0 at the center, 1 one σ away
        let d = dataset(&["head.p"], 20);
        let e = Experiment::from_dataset("e", &d, None, vec![], None, &[]).unwrap();
        let ps = calibration_params(&meter_out(), &[e], &specs).unwrap();
        let pm = ps.iter().find(|p| p.name == "flow_control.m").unwrap();
        assert_eq!(pm.scale, Scale::Linear);
        assert_eq!(pm.prior_row(0.5), Some(0.0));
        assert!((pm.prior_row(0.6).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(ps[0].prior_row(10.0), None);
    }

    #[test]
    fn a_laminar_ratio_is_fitted_by_its_distance_from_one() {
        let specs = default_calibration(&meter_out());
        let spec = specs.iter().find(|c| c.target == "dcv.b_lam").unwrap();
        assert_eq!(spec.prior, Some(Prior { center: 0.999, sd: LAMINAR_RATIO_SD }));
        assert_eq!(spec.bounds, Some(LAMINAR_RATIO_BOUNDS));
        let d = dataset(&["head.p"], 20);
        let e = Experiment::from_dataset("e", &d, None, vec![], None, &[]).unwrap();
        let ps = calibration_params(&meter_out(), &[e], std::slice::from_ref(spec)).unwrap();
        let p = &ps[0];
        assert_eq!(p.scale, Scale::LogGap);
        // increasing in b_lam (the bounds map to lower < upper), round trip exact
        let (lo, hi) = (p.to_u(p.lo), p.to_u(p.hi));
        assert!(lo < p.to_u(0.999) && p.to_u(0.999) < hi && p.to_u(0.999).abs() < 1e-12, "{lo} {hi}");
        assert!((p.from_u(p.to_u(0.9973)) - 0.9973).abs() < 1e-15);
        // the fit's finite-difference step (1e-3 in u) moves b_lam by a
        // millionth, not by half a prior σ as a coordinate b_lam/0.999 would
        let step = p.from_u(p.to_u(0.999) + 1e-3) - 0.999;
        assert!(step > 0.0 && step < 1e-5 * LAMINAR_RATIO_SD / 1e-3, "{step}");
        // the prior is on b_lam itself
        assert!((p.prior_row(0.997).unwrap() + 1.0).abs() < 1e-9);
    }
}
