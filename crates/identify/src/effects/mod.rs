//! The catalogue of candidate effects: named transformations of a netlist,
//! each with its own parameters, bounds and "null" values (the value at
//! which the effect vanishes).
//!
//! An effect is tried by applying it to the calibrated baseline netlist and
//! refitting its parameters together with the baseline's calibration
//! parameters (see [`crate::workflow`]). The catalogue is open: a new effect
//! is one new file implementing [`Effect`] plus one line in [`catalogue`].
//!
//! | effect | what it adds | parameters (null) |
//! |---|---|---|
//! | `piston_seal_leak` | orifice (ISO 6358) and laminar capillary between the chambers | C (0), laminar share |
//! | `dead_volume` | extra volume in either chamber | extra_head, extra_rod (0, 0) |
//! | `valve_delay` | dead time between command and valve (a `delay` block) | T (0) |
//! | `stribeck_friction` | breakaway above the Coulomb level, decaying with speed | breakaway_ratio (1), stribeck_velocity |
//! | `heat_transfer` | wall heat exchange, paper Eq. 8, in an adiabatic model | rate = 1/τ_T (0) |
//! | `supply_droop` | finite supply line: conductance + volume before the valve | C_line (∞ ≙ upper bound), V_line |
//! | `real_gas` | virial equation of state (paper Eq. 12–14) | — |
//!
//! Besides these built-ins, an experiments manifest may declare its own
//! effects as netlist edits ([`user`]); they are tried and judged the same way.
//!
//! Units: every parameter value is SI; `unit` is only the unit shown to people.

use graph::FlatNetlist;

mod dead_volume;
mod heat_transfer;
mod piston_seal_leak;
mod real_gas;
mod stribeck_friction;
mod supply_droop;
pub mod user;
mod valve_delay;

pub use dead_volume::DeadVolume;
pub use heat_transfer::HeatTransfer;
pub use piston_seal_leak::PistonSealLeak;
pub use real_gas::RealGas;
pub use stribeck_friction::StribeckFriction;
pub use supply_droop::SupplyDroop;
pub use user::UserEffect;
pub use valve_delay::ValveDelay;

/// How a parameter is scaled inside the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scale {
    /// Fitted as value / typical.
    Linear,
    /// Fitted as ln(value / start) (needs lo > 0).
    Log,
    /// Fitted as −ln((1 − value)/typical), `typical` the start's distance
    /// from 1 (needs hi < 1): a ratio known by its distance from 1 to a
    /// factor, such as an ISO 6358 laminar ratio (calibration only).
    LogGap,
}

/// One parameter of an effect.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectParam {
    pub name: String,
    /// Unit shown in reports ("L/min/bar"); values are SI.
    pub unit: String,
    /// Bounds [SI].
    pub lo: f64,
    pub hi: f64,
    /// Starting value of the fit [SI] (away from the null, where the fit has a gradient).
    pub start: f64,
    /// Typical size [SI]: the scale of a linear parameter in the fit.
    pub typical: f64,
    /// Value at which the effect vanishes; `None` for a shape parameter that
    /// only matters when another one is away from its null.
    pub null: Option<f64>,
    /// Gaussian prior (center, sd) [SI] on the fit coordinate, if any (see
    /// [`crate::params`]); only user-declared effects set one.
    pub prior: Option<(f64, f64)>,
    pub scale: Scale,
    /// Values tried when looking for a starting point (the fit starts from
    /// the best point of the grid formed by all parameters' scan values).
    pub scan: Vec<f64>,
}

/// The starting-point grid of an effect: every combination of its
/// parameters' scan values (a parameter without scan values keeps `start`).
pub fn scan_grid(params: &[EffectParam]) -> Vec<Vec<f64>> {
    let mut grid: Vec<Vec<f64>> = vec![vec![]];
    for p in params {
        let values: Vec<f64> = if p.scan.is_empty() { vec![p.start] } else { p.scan.clone() };
        grid = grid
            .iter()
            .flat_map(|g| {
                values.iter().map(move |v| {
                    let mut h = g.clone();
                    h.push(*v);
                    h
                })
            })
            .collect();
    }
    // the all-null point is the model without the effect: not a start
    grid.retain(|g| !params.iter().zip(g).all(|(p, v)| p.null == Some(*v)));
    grid
}

/// The smallest size of an effect that has a consequence an engineer could
/// act on. A fit below it that passes every statistical test is not named:
/// the verdict says what it fitted and why it is below
/// (docs/discrepancy.md, "Selection", test 5).
#[derive(Debug, Clone, PartialEq)]
pub struct LeastSize {
    /// Index of the parameter (in [`Effect::params`]) the size applies to.
    pub param: usize,
    /// Smallest distance from the parameter's null of consequence [SI].
    pub size: f64,
    /// What sets it, completing "below …" in the verdict.
    pub why: String,
}

/// What the data can resolve, which sets the effects' [`LeastSize`]s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    /// Response time between a limit switch's trip and the valve's command
    /// that the model does not describe (switch and controller) [s].
    pub switch_latency: f64,
}

/// Why an effect could not be applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("effect {effect}: {message}")]
pub struct EffectError {
    pub effect: String,
    pub message: String,
}

impl EffectError {
    pub fn new(effect: &str, message: impl std::fmt::Display) -> Self {
        EffectError { effect: effect.to_string(), message: message.to_string() }
    }
}

/// A candidate missing effect.
pub trait Effect: Send + Sync + std::fmt::Debug {
    /// Name used in reports and on the command line ("piston_seal_leak").
    fn name(&self) -> &str;
    /// One line: what the effect is physically.
    fn summary(&self) -> &str;
    /// Parameters with bounds and null values (possibly none).
    fn params(&self) -> Vec<EffectParam>;
    /// Whether the effect makes sense for this netlist (components present,
    /// effect not already modelled).
    fn applies_to(&self, flat: &FlatNetlist) -> bool;
    /// Transform the netlist; `values` are SI, one per parameter. At the null
    /// values the transformed netlist behaves like the original one.
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError>;
    /// Smallest sizes of practical consequence; the effect counts as of
    /// practical size when any one of its parameters reaches its size. None
    /// (the default): every statistically significant size counts.
    fn least_size(&self, _resolution: &Resolution) -> Vec<LeastSize> {
        Vec::new()
    }
}

/// Every known effect.
pub fn catalogue() -> Vec<Box<dyn Effect>> {
    vec![
        Box::new(PistonSealLeak),
        Box::new(DeadVolume),
        Box::new(ValveDelay),
        Box::new(StribeckFriction),
        Box::new(HeatTransfer),
        Box::new(SupplyDroop),
        Box::new(RealGas),
    ]
}

/// The effect of this name.
pub fn by_name(name: &str) -> Option<Box<dyn Effect>> {
    catalogue().into_iter().find(|e| e.name() == name)
}

/// Names of all built-in effects, for messages.
pub fn names() -> Vec<String> {
    catalogue().iter().map(|e| e.name().to_string()).collect()
}

pub(crate) fn check_len(effect: &dyn Effect, values: &[f64]) -> Result<(), EffectError> {
    let n = effect.params().len();
    if values.len() != n {
        return Err(EffectError::new(effect.name(), format!("expected {n} parameter values, got {}", values.len())));
    }
    if let Some(v) = values.iter().find(|v| !v.is_finite()) {
        return Err(EffectError::new(effect.name(), format!("parameter value {v} is not finite")));
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub fn meter_out() -> FlatNetlist {
        crate::netlist_edit::tests_support::meter_out()
    }

    /// Simulate 1.2 s of the first extend stroke and return the result.
    pub fn run(flat: &FlatNetlist) -> solve::SimResult {
        let circuit = graph::build(flat).expect("build");
        let mut opts = solve::options_from(&circuit.simulation).expect("options");
        opts.cycles = None;
        opts.t_end = 1.2;
        opts.sample_interval = 1e-3;
        let mut model = solve::Model::new(circuit);
        solve::simulate(&mut model, &opts).expect("simulate")
    }

    /// Largest absolute difference of a column between two runs on the common time grid.
    pub fn max_diff(a: &solve::SimResult, b: &solve::SimResult, col: &str) -> f64 {
        let sa = a.series(col).expect("column");
        let sb = b.series(col).expect("column");
        let mut d: f64 = 0.0;
        for (t, v) in &sa {
            if let Some((_, w)) = sb.iter().find(|(u, _)| (u - t).abs() < 1e-12) {
                d = d.max((v - w).abs());
            }
        }
        d
    }

    #[test]
    fn names_are_unique_and_params_consistent() {
        let cat = catalogue();
        let mut names: Vec<_> = cat.iter().map(|e| e.name().to_string()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), cat.len());
        for e in &cat {
            for p in e.params() {
                assert!(p.lo <= p.start && p.start <= p.hi, "{}.{}", e.name(), p.name);
                assert!(p.typical > 0.0, "{}.{}", e.name(), p.name);
                if p.scale == Scale::Log {
                    assert!(p.lo > 0.0, "{}.{}", e.name(), p.name);
                }
                if let Some(n) = p.null {
                    assert!(p.lo <= n && n <= p.hi, "{}.{}", e.name(), p.name);
                    assert!(n != p.start, "{}.{} starts at its null (no gradient there)", e.name(), p.name);
                }
                assert!(p.scan.iter().all(|v| (p.lo..=p.hi).contains(v)), "{}.{} scan outside bounds", e.name(), p.name);
            }
            assert!(by_name(e.name()).is_some());
        }
    }

    #[test]
    fn the_scan_grid_is_the_product_without_the_null_point() {
        let p = |name: &str, null, scan: &[f64]| EffectParam {
            name: name.into(),
            unit: String::new(),
            lo: 0.0,
            hi: 10.0,
            start: 1.0,
            typical: 1.0,
            null,
            prior: None,
            scale: Scale::Linear,
            scan: scan.to_vec(),
        };
        let g = scan_grid(&[p("a", Some(0.0), &[0.0, 1.0, 2.0]), p("b", Some(0.0), &[0.0, 5.0])]);
        assert_eq!(g, vec![vec![0.0, 5.0], vec![1.0, 0.0], vec![1.0, 5.0], vec![2.0, 0.0], vec![2.0, 5.0]]);
        let g = scan_grid(&[p("a", Some(0.0), &[]), p("b", None, &[3.0, 4.0])]);
        assert_eq!(g, vec![vec![1.0, 3.0], vec![1.0, 4.0]]);
        // no parameters: nothing to scan
        assert!(scan_grid(&[]).is_empty());
    }

    #[test]
    fn every_effect_applies_to_meter_out_except_those_already_modelled() {
        let flat = meter_out();
        for e in catalogue() {
            let expect = e.name() != "heat_transfer"; // meter_out has tau_thermal = 5 s
            assert_eq!(e.applies_to(&flat), expect, "{}", e.name());
        }
    }

    #[test]
    fn applied_netlists_build_and_wrong_lengths_are_errors() {
        for e in catalogue() {
            let mut flat = meter_out();
            if e.name() == "heat_transfer" {
                for id in ["head", "rod"] {
                    crate::netlist_edit::set_param_si(&mut flat, id, "tau_thermal", f64::INFINITY).unwrap();
                }
            }
            let start: Vec<f64> = e.params().iter().map(|p| p.start).collect();
            let mut f = flat.clone();
            e.apply(&mut f, &start).unwrap();
            graph::build(&f).unwrap_or_else(|err| panic!("{}: {err}", e.name()));
            let mut g = flat.clone();
            assert!(e.apply(&mut g, &[1.0; 5]).is_err(), "{}", e.name());
        }
    }

    #[test]
    fn at_the_null_values_the_outputs_do_not_change() {
        // null for every parameter that has one; shape parameters at their start value
        let base = meter_out();
        let reference = run(&base);
        for e in catalogue() {
            if e.name() == "heat_transfer" || e.name() == "real_gas" {
                continue; // no null point for real_gas; heat_transfer is checked in its own file
            }
            let values: Vec<f64> = e.params().iter().map(|p| p.null.unwrap_or(p.start)).collect();
            let mut f = base.clone();
            e.apply(&mut f, &values).unwrap();
            let r = run(&f);
            let dp = max_diff(&reference, &r, "head.p");
            let dx = max_diff(&reference, &r, "piston.x");
            // supply_droop's null is a very large line conductance, not exactly infinity
            let (tol_p, tol_x) = if e.name() == "supply_droop" { (300.0, 2e-4) } else { (1e-3, 1e-9) };
            assert!(dp < tol_p && dx < tol_x, "{}: dp {dp} Pa, dx {dx} m", e.name());
        }
    }
}
