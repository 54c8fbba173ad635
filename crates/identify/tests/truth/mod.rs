//! Independent truth for the discrepancy tests: measured-like records of the
//! meter-out rig made by `pneumo-rig` (a second implementation that shares no
//! code with pneumo), at the four operating points of the acceptance test.
//!
//! Shared by `tests/independent.rs` (CI set and the long matrix) and
//! `examples/independent.rs` (which also writes datasets with their
//! manifests for `pneumo discrepancy`).
//!
//! # What differs between the truth and the fitted model
//! Always (both variations): the rig's own integrator, junction solver and
//! event handling; exact check-valve switching; ISO 6358 without a laminar
//! end region; exact stick–slip; sensors with 5 mbar pressure noise and a
//! constant offset per channel and experiment (σ 10 mbar), position noise
//! 20 µm quantised to 10 µm, 1 kHz with 20 µs jitter. That is the setting of
//! the acceptance test ([`Variation::Nominal`]).
//!
//! [`Variation::Varied`] also draws, per seed, the modelling choices on
//! which two honest implementations differ (see [`draw_form`]): laminar end
//! region and subsonic index of every restriction, check-valve opening law,
//! limit-switch tolerance and latency, and the sensors' gain errors,
//! position offset, sampling jitter and dropouts, and a logger time skew.
//!
//! # Effects and their sizes
//! Drawn per seed around realistic values (see [`draw_effects`]); the leak
//! may follow ISO 6358 with either critical ratio or a laminar capillary
//! law, the Stribeck decay may be exponential or Gaussian — neither is the
//! catalogue's exact form.
//!
//! Units: SI everywhere; the manifests write supply pressure in bar and the
//! throttle in L/(min·bar).

#![allow(dead_code)]

use identify::data::Dataset;
use identify::experiment::Experiment;
use rig::sensors::{acquire, Channel, Measurements, Rng, SensorSpec};
use rig::{CheckLaw, Effects, LeakLaw, ModelForm, Restriction, Rig, RunSpec, Stribeck, StribeckShape, SubsonicLaw, SupplyLine, Switches};

/// The operating points: supply [bar absolute], throttle [L/(min·bar)].
pub const OPERATING_POINTS: [(f64, f64); 4] = [(4.0, 26.0), (4.0, 52.0), (7.0, 26.0), (7.0, 52.0)];

/// What is hidden in the data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Case {
    Null,
    Leak,
    ValveDelay,
    Stribeck,
    DeadVolume,
    SupplyDroop,
    LeakAndDelay,
    /// Data with wall heat exchange, model adiabatic.
    HeatTransfer,
    RealGas,
}

impl Case {
    pub const ALL: [Case; 9] = [
        Case::Null,
        Case::Leak,
        Case::ValveDelay,
        Case::Stribeck,
        Case::DeadVolume,
        Case::SupplyDroop,
        Case::LeakAndDelay,
        Case::HeatTransfer,
        Case::RealGas,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Case::Null => "none",
            Case::Leak => "piston_seal_leak",
            Case::ValveDelay => "valve_delay",
            Case::Stribeck => "stribeck_friction",
            Case::DeadVolume => "dead_volume",
            Case::SupplyDroop => "supply_droop",
            Case::LeakAndDelay => "piston_seal_leak+valve_delay",
            Case::HeatTransfer => "heat_transfer",
            Case::RealGas => "real_gas",
        }
    }

    pub fn by_name(name: &str) -> Option<Case> {
        Case::ALL.into_iter().find(|c| c.name() == name)
    }

    /// Effects that must be named (sorted).
    pub fn expected(self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = match self {
            Case::Null => vec![],
            Case::LeakAndDelay => vec!["piston_seal_leak", "valve_delay"],
            c => vec![c.name()],
        };
        v.sort();
        v
    }

    /// Whether the model handed to the workflow has adiabatic chambers.
    pub fn adiabatic_model(self) -> bool {
        self == Case::HeatTransfer
    }
}

/// How far the truth's modelling choices are from the fitted model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variation {
    /// The rig's defaults: the setting of the acceptance test.
    Nominal,
    /// Modelling choices and sensor imperfections drawn per seed.
    Varied,
}

/// Everything drawn for one seed.
#[derive(Debug, Clone)]
pub struct Truth {
    pub form: ModelForm,
    pub effects: Effects,
    pub sensors: SensorSpec,
    /// Thermal time constant of the data's chambers [s].
    pub tau_thermal: f64,
    /// Cracking pressure of the speed-control valve's check valve [Pa].
    pub check_cracking: f64,
    /// One line: what was drawn.
    pub description: String,
}

const L_MIN_BAR: f64 = rig::LPM_PER_BAR;

fn uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

/// Modelling choices on which two honest implementations differ.
///
/// Ranges: laminar end region absent or of width 5·10⁻⁴ … 5·10⁻³ (ISO
/// 6358-2 uses 10⁻³; pneumo 10⁻³), subsonic index 0.42 … 0.58 for every
/// restriction (ellipse ½; ISO 6358-1:2013 lets m differ from ½, and a
/// catalogue rarely gives it); check valve cracking at 0 … 0.3 bar (a
/// spring-loaded poppet; catalogues of speed-control valves quote
/// 0.1 … 0.5 bar) and opening exactly or linearly over 0.2 … 20 kPa (pneumo
/// 1 kPa); limit switches tripping 0 … 100 µm before the ends, 0 … 0.2 ms
/// latency. Returns the form, the check valve's cracking pressure [Pa] and a
/// description.
pub fn draw_form(rng: &mut Rng) -> (ModelForm, f64, String) {
    let laminar = if rng.uniform() < 0.3 { None } else { Some(uniform(rng, 5e-4, 5e-3)) };
    let index = uniform(rng, 0.42, 0.58);
    let cracking = uniform(rng, 0.0, 0.3e5);
    let check =
        if rng.uniform() < 0.4 { CheckLaw::Exact } else { CheckLaw::Linear { opening: (uniform(rng, 200f64.ln(), 20e3f64.ln())).exp() } };
    let switches = Switches { tolerance: uniform(rng, 0.0, 100e-6), latency: uniform(rng, 0.0, 0.2e-3), ..Switches::default() };
    let form = ModelForm { subsonic: SubsonicLaw { index, laminar_width: laminar }, check, switches, ..ModelForm::default() };
    let text = format!(
        "laminar {} index {index:.3} check cracking {:.0} mbar {} switch tol {:.0} µm latency {:.2} ms",
        laminar.map_or("none".to_string(), |w| format!("{w:.1e}")),
        cracking / 100.0,
        match check {
            CheckLaw::Exact => "exact".to_string(),
            CheckLaw::Linear { opening } => format!("linear {opening:.0} Pa"),
        },
        switches.tolerance * 1e6,
        switches.latency * 1e3
    );
    (form, cracking, text)
}

/// The sensors. Nominal: 5 mbar noise and 10 mbar offsets on pressures,
/// 20 µm noise quantised to 10 µm on position, 1 kHz with 20 µs jitter.
/// Varied adds: gain errors of σ 0.3 % on pressures, a position offset of
/// σ 50 µm, jitter 20 … 150 µs, up to 1 % dropped samples and a logger
/// time skew of up to ±1 ms.
pub fn draw_sensors(rng: &mut Rng, variation: Variation) -> (SensorSpec, String) {
    let mut s = SensorSpec {
        pressure: Channel { noise: 500.0, offset_sd: 1000.0, gain_sd: 0.0, quantum: 0.0 },
        position: Channel { noise: 20e-6, offset_sd: 0.0, gain_sd: 0.0, quantum: 10e-6 },
        ..SensorSpec::default()
    };
    if variation == Variation::Nominal {
        return (s, "nominal sensors".into());
    }
    s.pressure.gain_sd = 3e-3;
    s.position.offset_sd = 50e-6;
    s.jitter_sd = uniform(rng, 20e-6, 150e-6);
    s.dropout = uniform(rng, 0.0, 0.01);
    s.time_skew = uniform(rng, -1e-3, 1e-3);
    let text = format!("jitter {:.0} µs dropout {:.2} % skew {:+.2} ms", s.jitter_sd * 1e6, s.dropout * 100.0, s.time_skew * 1e3);
    (s, text)
}

/// The hidden effects of a case at realistic sizes, drawn per seed.
///
/// The leak's law cycles with the seed (seed mod 4: ISO b = 0.3, capillary,
/// linear in Δp, ISO b = 0.5), so that five seeds cover every law.
pub fn draw_effects(case: Case, seed: u64, rng: &mut Rng) -> (Effects, f64, String) {
    let mut e = Effects::default();
    let mut tau = 5.0;
    let mut text = Vec::new();
    let leak = |rng: &mut Rng, e: &mut Effects, text: &mut Vec<String>| {
        let c = uniform(rng, 0.25, 0.45);
        let law = match (seed % 4) as usize {
            0 => LeakLaw::Iso(Restriction::lpm_per_bar(c, 0.5)),
            1 => LeakLaw::Iso(Restriction::lpm_per_bar(c, 0.3)),
            // a capillary: k = 0.8·C passes the flow of the ISO leak at a
            // drop between a 10 % drop from 5 bar (ISO 1.6 × more) and
            // choked 4 bar → 1 bar (ISO 0.6 × as much)
            2 => LeakLaw::Laminar { k: 0.8 * c * L_MIN_BAR },
            // linear in Δp (the textbook seal leak): 0.8 × the ISO leak's
            // flow at 6 → 5 bar per bar of drop
            _ => LeakLaw::Linear { k_l: 0.8 * iso_flow_6_to_5(c) / 1e5 },
        };
        text.push(format!("leak {law:?}"));
        e.seal_leak = Some(law);
    };
    let delay = |rng: &mut Rng, e: &mut Effects, text: &mut Vec<String>| {
        e.valve_delay = uniform(rng, 0.010, 0.020);
        text.push(format!("valve delay {:.1} ms", e.valve_delay * 1e3));
    };
    match case {
        Case::Null | Case::RealGas => {}
        Case::Leak => leak(rng, &mut e, &mut text),
        Case::ValveDelay => delay(rng, &mut e, &mut text),
        Case::LeakAndDelay => {
            leak(rng, &mut e, &mut text);
            delay(rng, &mut e, &mut text);
        }
        Case::Stribeck => {
            let shape = if rng.uniform() < 0.5 { StribeckShape::Exponential } else { StribeckShape::Gaussian };
            let r = uniform(rng, 2.0, 3.0);
            let vs = uniform(rng, 0.01, 0.03);
            e.friction = Some(rig::FrictionVariant { breakaway_ratio: r, stribeck: Some(Stribeck { velocity: vs, shape }) });
            text.push(format!("stribeck r {r:.2} v_s {:.1} mm/s {shape:?}", vs * 1e3));
        }
        Case::DeadVolume => {
            let v = uniform(rng, 25e-6, 40e-6);
            if rng.uniform() < 0.7 {
                e.extra_volume_head = v;
            } else {
                e.extra_volume_rod = v;
            }
            text.push(format!("extra volume head {:.1} cm3 rod {:.1} cm3", e.extra_volume_head * 1e6, e.extra_volume_rod * 1e6));
        }
        Case::SupplyDroop => {
            let c = uniform(rng, 150.0, 250.0);
            let v = uniform(rng, 0.3e-3, 0.7e-3);
            e.supply_line = Some(SupplyLine { restriction: Restriction::lpm_per_bar(c, 0.3), volume: v, tau_thermal: 1.0 });
            text.push(format!("supply line C {c:.0} L/min/bar V {:.2} L", v * 1e3));
        }
        Case::HeatTransfer => {
            tau = uniform(rng, 3.0, 8.0);
            text.push(format!("tau_T {tau:.2} s (model adiabatic)"));
        }
    }
    if case == Case::RealGas {
        e.real_gas = true;
        text.push("real gas".into());
    }
    e.tau_thermal = Some(tau);
    (e, tau, text.join(", "))
}

/// Mass flow [kg/s] of an ISO 6358 restriction of C [L/(min·bar)], b = 0.5,
/// from 6 to 5 bar at 293.15 K (Eq. 33–35).
fn iso_flow_6_to_5(c: f64) -> f64 {
    let q: f64 = (5.0 / 6.0 - 0.5) / 0.5;
    c * L_MIN_BAR * rig::flow::RHO_N * 6e5 * (1.0 - q * q).sqrt()
}

/// Draw everything for one seed.
pub fn draw(case: Case, seed: u64, variation: Variation) -> Truth {
    let mut rng = Rng::stream(seed, 1000 + case as u64);
    let (effects, tau_thermal, etext) = draw_effects(case, seed, &mut rng);
    let (form, check_cracking, ftext) = match variation {
        Variation::Nominal => (ModelForm::default(), 0.0, "nominal form".to_string()),
        Variation::Varied => draw_form(&mut rng),
    };
    let (sensors, stext) = draw_sensors(&mut rng, variation);
    let description = format!("{}; {ftext}; {stext}", if etext.is_empty() { "nothing hidden".to_string() } else { etext });
    Truth { form, effects, sensors, tau_thermal, check_cracking, description }
}

/// One logged record.
pub struct Record {
    pub name: String,
    pub supply_bar: f64,
    pub throttle_lpm: f64,
    pub measured: Measurements,
}

/// Simulate and log the four operating points for `cycles` cycles.
pub fn records(truth: &Truth, seed: u64, cycles: usize) -> Result<Vec<Record>, String> {
    OPERATING_POINTS
        .iter()
        .enumerate()
        .map(|(k, &(p, c))| {
            let rig = Rig { check_cracking: truth.check_cracking, ..Rig::paper_bar_lpm(p, c) };
            let run = RunSpec { t_end: 60.0, rtol: 1e-7, ..RunSpec::cycles(cycles, 1e-3) };
            let (_, m) = acquire(&rig, &truth.form, &truth.effects, &run, &truth.sensors, seed.wrapping_mul(31).wrapping_add(k as u64))
                .map_err(|e| e.to_string())?;
            Ok(Record { name: format!("{}bar_{}", p, c), supply_bar: p, throttle_lpm: c, measured: m })
        })
        .collect()
}

/// The manifest's operating point of a record: only `supply.p` and the throttle.
pub fn sets(r: &Record) -> Vec<String> {
    vec![format!("supply.p={} bar", r.supply_bar), format!("flow_control.C={} L/min/bar", r.throttle_lpm)]
}

/// A record as a measured table.
pub fn dataset(r: &Record) -> Dataset {
    Dataset {
        origin: r.name.clone(),
        times: r.measured.t.clone(),
        names: r.measured.columns.iter().map(|c| c.0.clone()).collect(),
        values: r.measured.columns.iter().map(|c| c.1.iter().map(|v| Some(*v)).collect()).collect(),
        lines: vec![],
    }
}

/// The records as experiments for the workflow (time origin: first sample, as a manifest without `time_origin`).
pub fn experiments(records: &[Record]) -> Result<Vec<Experiment>, String> {
    records.iter().map(|r| Experiment::from_dataset(&r.name, &dataset(r), None, sets(r), None, &[])).collect()
}

/// The model handed to the workflow: models/meter_out.json, with adiabatic
/// chambers for [`Case::HeatTransfer`].
pub fn model(case: Case) -> graph::FlatNetlist {
    let text = model_text(case);
    let netlist = graph::expand::parse(&text, "meter_out.json").expect("parse");
    graph::expand::flatten(&identify::netlist_edit::NoFiles, &netlist, std::path::Path::new("."), 0).expect("flatten")
}

/// The model's JSON text (adiabatic: the parameter `tau_thermal` is "inf").
pub fn model_text(case: Case) -> String {
    let text = include_str!("../../../../models/meter_out.json").to_string();
    if case.adiabatic_model() {
        let from = r#""tau_thermal": { "value": "5 s""#;
        assert!(text.contains(from), "models/meter_out.json no longer declares tau_thermal as expected");
        text.replace(from, r#""tau_thermal": { "value": "inf""#)
    } else {
        text
    }
}

/// The manifest text for records written as `<name>.csv` beside it.
pub fn manifest_text(records: &[Record], description: &str) -> String {
    let rows: Vec<String> = records
        .iter()
        .map(|r| {
            format!(
                "    {{ \"name\": \"{}\", \"data\": \"{}.csv\", \"set\": {{ \"supply.p\": \"{} bar\", \"flow_control.C\": \"{} L/min/bar\" }} }}",
                r.name, r.name, r.supply_bar, r.throttle_lpm
            )
        })
        .collect();
    format!("{{\n  \"description\": \"{}\",\n  \"experiments\": [\n{}\n  ]\n}}\n", description.replace('"', "'"), rows.join(",\n"))
}

/// A declared effect (issue 23 item 6) for the leak case: an ISO 6358
/// orifice across the piston seal, in the manifest's `user_effects` syntax.
/// Shared by identify's and the command line's user-effect tests.
pub const SEAL_ORIFICE: &str = r#"{
    "name": "seal_orifice", "description": "ISO 6358 orifice across the piston seal",
    "components": [ { "id": "seal", "type": "conductance", "params": { "b": 0.5 } } ],
    "connections": [ ["head.port", "seal.a"], ["seal.b", "rod.port"] ],
    "free": { "seal.C": { "null": "0 L/min/bar", "start": "0.2 L/min/bar", "bounds": ["0 L/min/bar", "5 L/min/bar"],
                          "scan": ["0.03 L/min/bar", "0.1 L/min/bar", "0.3 L/min/bar", "1 L/min/bar", "3 L/min/bar"] } } }"#;
