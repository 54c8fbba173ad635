//! Inputs of a run, in SI units: the physical rig ([`Rig`]), the
//! independent modelling choices ([`ModelForm`]), the hidden effects a truth
//! generator may add ([`Effects`]) and the run itself ([`RunSpec`]).
//!
//! Defaults are the paper's Table 1/2 with the values it leaves open as in
//! `models/meter_out.json` (dead volume 20 cm³ per chamber, moving mass
//! 1 kg, friction k0..k4). Every struct is plain data with public fields;
//! [`Rig::validate`] and friends check ranges once, before a run, and name
//! the offending parameter.

use crate::error::RigError;
use crate::flow::{CheckLaw, LeakLaw, Restriction, SubsonicLaw, LPM_PER_BAR};
use crate::friction::{Eq37, FrictionVariant};
use crate::gas::Gas;

/// `v > 0` (false for NaN); may be +∞.
fn positive(v: f64) -> bool {
    v > 0.0
}

/// The physical rig of paper Fig. 1 (meter-out speed control).
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// Piston (bore) diameter [m].
    pub bore: f64,
    /// Rod diameter [m].
    pub rod: f64,
    /// Stroke [m] (end stops at 0 and `stroke`).
    pub stroke: f64,
    /// Moving mass [kg].
    pub mass: f64,
    /// Dead volume of the head chamber (chamber 1) at x = 0 [m³].
    pub dead_volume_head: f64,
    /// Dead volume of the rod chamber (chamber 2) at x = stroke [m³].
    pub dead_volume_rod: f64,
    /// External force on the rod, positive in the extend direction [N].
    pub external_force: f64,
    /// Supply pressure (absolute) [Pa].
    pub supply_pressure: f64,
    /// Supply temperature [K].
    pub supply_temperature: f64,
    /// Atmospheric (exhaust) pressure [Pa]; also acts on the rod area.
    pub atm_pressure: f64,
    /// Atmospheric temperature [K].
    pub atm_temperature: f64,
    /// Wall temperature of both chambers [K].
    pub wall_temperature: f64,
    /// Thermal time constant τ_T of both chambers (paper Eq. 8) [s];
    /// `f64::INFINITY` for adiabatic chambers.
    pub tau_thermal: f64,
    /// 5/2 valve, every path (ISO 6358).
    pub valve: Restriction,
    /// Throttle of the speed-control valve (ISO 6358), both directions.
    pub throttle: Restriction,
    /// Check valve of the speed-control valve (ISO 6358), into the rod chamber only.
    pub check: Restriction,
    /// Cracking pressure of the check valve [Pa].
    pub check_cracking: f64,
    /// Friction coefficients (paper Eq. 37).
    pub friction: Eq37,
    /// Working gas.
    pub gas: Gas,
    /// Initial state (at rest before t = 0).
    pub initial: InitialState,
}

/// The state of the rig before t = 0 (the valve is un-actuated until the
/// first extend command at t = 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialState {
    /// Head-chamber pressure [Pa].
    pub p_head: f64,
    /// Head-chamber temperature [K].
    pub t_head: f64,
    /// Rod-chamber pressure [Pa].
    pub p_rod: f64,
    /// Rod-chamber temperature [K].
    pub t_rod: f64,
    /// Piston position [m] (at rest).
    pub x: f64,
}

impl Rig {
    /// The paper's rig at supply pressure `supply_pa` [Pa absolute] with the
    /// speed-control throttle `throttle_c_si` [m³/(s Pa)]; initial state: head
    /// at atmosphere, rod chamber at supply, piston retracted.
    pub fn paper(supply_pa: f64, throttle_c_si: f64) -> Self {
        let atm = 0.98e5;
        let t0 = 292.0;
        Rig {
            bore: 0.045,
            rod: 0.015,
            stroke: 0.45,
            mass: 1.0,
            dead_volume_head: 20e-6,
            dead_volume_rod: 20e-6,
            external_force: 0.0,
            supply_pressure: supply_pa,
            supply_temperature: t0,
            atm_pressure: atm,
            atm_temperature: t0,
            wall_temperature: t0,
            tau_thermal: 5.0,
            valve: Restriction { c: 490.0 * LPM_PER_BAR, b: 0.3 },
            throttle: Restriction { c: throttle_c_si, b: 0.3 },
            check: Restriction { c: 490.0 * LPM_PER_BAR, b: 0.3 },
            check_cracking: 0.0,
            friction: Eq37::paper(),
            gas: Gas::default(),
            initial: InitialState { p_head: atm, t_head: t0, p_rod: supply_pa, t_rod: t0, x: 0.0 },
        }
    }

    /// Convenience: supply in bar (absolute), throttle in L/(min·bar).
    pub fn paper_bar_lpm(supply_bar: f64, throttle_lpm_per_bar: f64) -> Self {
        Rig::paper(supply_bar * 1e5, throttle_lpm_per_bar * LPM_PER_BAR)
    }

    /// Head (piston) area A1 [m²].
    pub fn area_head(&self) -> f64 {
        std::f64::consts::PI / 4.0 * self.bore * self.bore
    }

    /// Annulus area A2 [m²].
    pub fn area_rod_side(&self) -> f64 {
        std::f64::consts::PI / 4.0 * (self.bore * self.bore - self.rod * self.rod)
    }

    /// Rod cross-section A1 − A2 [m²].
    pub fn area_rod(&self) -> f64 {
        std::f64::consts::PI / 4.0 * self.rod * self.rod
    }

    /// Checks every parameter once.
    pub fn validate(&self) -> Result<(), RigError> {
        let pos = [
            ("rig.bore", self.bore),
            ("rig.stroke", self.stroke),
            ("rig.mass", self.mass),
            ("rig.supply_pressure", self.supply_pressure),
            ("rig.supply_temperature", self.supply_temperature),
            ("rig.atm_pressure", self.atm_pressure),
            ("rig.atm_temperature", self.atm_temperature),
            ("rig.wall_temperature", self.wall_temperature),
            ("rig.dead_volume_head", self.dead_volume_head),
            ("rig.dead_volume_rod", self.dead_volume_rod),
            ("rig.initial.p_head", self.initial.p_head),
            ("rig.initial.t_head", self.initial.t_head),
            ("rig.initial.p_rod", self.initial.p_rod),
            ("rig.initial.t_rod", self.initial.t_rod),
        ];
        for (n, v) in pos {
            if !(v > 0.0 && v.is_finite()) {
                return Err(RigError::invalid(n, v, "must be positive and finite"));
            }
        }
        if !(self.rod >= 0.0 && self.rod < self.bore) {
            return Err(RigError::invalid("rig.rod", self.rod, "must lie in [0, bore)"));
        }
        if !positive(self.tau_thermal) {
            return Err(RigError::invalid("rig.tau_thermal", self.tau_thermal, "must be positive (infinity: adiabatic)"));
        }
        if !self.external_force.is_finite() {
            return Err(RigError::invalid("rig.external_force", self.external_force, "must be finite"));
        }
        if !(self.check_cracking >= 0.0 && self.check_cracking.is_finite()) {
            return Err(RigError::invalid("rig.check_cracking", self.check_cracking, "must be non-negative and finite"));
        }
        if !(self.initial.x >= 0.0 && self.initial.x <= self.stroke) {
            return Err(RigError::invalid("rig.initial.x", self.initial.x, "must lie in [0, stroke]"));
        }
        self.valve.validate("rig.valve")?;
        self.throttle.validate("rig.throttle")?;
        self.check.validate("rig.check")?;
        self.friction.validate()?;
        self.gas.validate()?;
        Ok(())
    }
}

/// The limit-switch cycler.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Switches {
    /// The extend switch trips at x = stroke − tolerance, the retract switch
    /// at x = tolerance [m].
    pub tolerance: f64,
    /// Delay from a switch trip to the command change [s].
    pub latency: f64,
    /// Extra wait at the extended end before commanding retract [s].
    pub dwell_extended: f64,
    /// Extra wait at the retracted end before commanding extend [s].
    pub dwell_retracted: f64,
}

impl Default for Switches {
    fn default() -> Self {
        Switches { tolerance: 10e-6, latency: 0.0, dwell_extended: 0.0, dwell_retracted: 0.0 }
    }
}

/// The independent modelling choices.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelForm {
    /// ISO 6358 subsonic law (ellipse index, laminar end region).
    pub subsonic: SubsonicLaw,
    /// Check-valve opening law.
    pub check: CheckLaw,
    /// Limit switches and controller timing.
    pub switches: Switches,
    /// Friction variant (breakaway ratio, Stribeck decay).
    pub friction: FrictionVariant,
}

impl ModelForm {
    /// Checks every choice once.
    pub fn validate(&self, rig: &Rig) -> Result<(), RigError> {
        self.subsonic.validate()?;
        self.check.validate()?;
        self.friction.validate("form.friction")?;
        let s = &self.switches;
        if !(s.tolerance >= 0.0 && s.tolerance < 0.5 * rig.stroke) {
            return Err(RigError::invalid("form.switches.tolerance", s.tolerance, "must lie in [0, stroke/2)"));
        }
        for (n, v) in [
            ("form.switches.latency", s.latency),
            ("form.switches.dwell_extended", s.dwell_extended),
            ("form.switches.dwell_retracted", s.dwell_retracted),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(RigError::invalid(n, v, "must be non-negative and finite"));
            }
        }
        Ok(())
    }
}

/// Supply droop: the 5/2 valve is fed from a line volume that is refilled
/// from the ideal supply through a line restriction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyLine {
    /// Line restriction between the ideal supply and the line volume.
    pub restriction: Restriction,
    /// Line (and valve inlet) volume [m³].
    pub volume: f64,
    /// Thermal time constant of the line volume [s] (∞: adiabatic).
    pub tau_thermal: f64,
}

/// Effects a truth generator may add to the nominal rig. All off by default.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Effects {
    /// Piston seal leak between the chambers.
    pub seal_leak: Option<LeakLaw>,
    /// The 5/2 valve follows its command this late [s].
    pub valve_delay: f64,
    /// Extra dead volume of the head chamber [m³].
    pub extra_volume_head: f64,
    /// Extra dead volume of the rod chamber [m³].
    pub extra_volume_rod: f64,
    /// Replaces `ModelForm::friction` (breakaway ratio and Stribeck decay).
    pub friction: Option<FrictionVariant>,
    /// Supply through a line restriction and volume (supply droop).
    pub supply_line: Option<SupplyLine>,
    /// Replaces `Rig::tau_thermal` of both chambers [s] (∞: adiabatic).
    pub tau_thermal: Option<f64>,
    /// Real gas: the virial equation of state (see `gas`).
    pub real_gas: bool,
}

impl Effects {
    /// Checks every effect once.
    pub fn validate(&self) -> Result<(), RigError> {
        if let Some(l) = self.seal_leak {
            l.validate()?;
        }
        for (n, v) in [
            ("effects.valve_delay", self.valve_delay),
            ("effects.extra_volume_head", self.extra_volume_head),
            ("effects.extra_volume_rod", self.extra_volume_rod),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(RigError::invalid(n, v, "must be non-negative and finite"));
            }
        }
        if let Some(f) = self.friction {
            f.validate("effects.friction")?;
        }
        if let Some(s) = self.supply_line {
            s.restriction.validate("effects.supply_line")?;
            if !positive(s.restriction.c) {
                return Err(RigError::invalid("effects.supply_line.c", s.restriction.c, "must be positive"));
            }
            if !(s.volume > 0.0 && s.volume.is_finite()) {
                return Err(RigError::invalid("effects.supply_line.volume", s.volume, "must be positive and finite"));
            }
            if !positive(s.tau_thermal) {
                return Err(RigError::invalid("effects.supply_line.tau_thermal", s.tau_thermal, "must be positive"));
            }
        }
        if let Some(t) = self.tau_thermal {
            if !positive(t) {
                return Err(RigError::invalid("effects.tau_thermal", t, "must be positive (infinity: adiabatic)"));
            }
        }
        Ok(())
    }
}

/// When to record the trace.
#[derive(Debug, Clone, PartialEq)]
pub enum Sampling {
    /// Every `dt` seconds from t = 0.
    Every(f64),
    /// At these instants (sorted, non-decreasing) [s].
    At(Vec<f64>),
}

/// The run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    /// Stop when this many cycles are complete (`None`: run to `t_end`).
    pub cycles: Option<usize>,
    /// Hard end time [s].
    pub t_end: f64,
    /// Output instants.
    pub sampling: Sampling,
    /// Relative tolerance of the integrator (absolute parts scale with it,
    /// see `model` for the floors).
    pub rtol: f64,
    /// Largest step [s].
    pub max_step: f64,
    /// Stop with an error after this many discrete events.
    pub max_events: usize,
    /// Stop with an error after this many step attempts of the integrator
    /// (accepted, rejected and abandoned, over the whole run). The default,
    /// 500 000, is about 170 times the ≈ 3 000 that three cycles of the
    /// truth matrix take (rtol 10⁻⁷); a run of hundreds of cycles needs
    /// more. It bounds a step size that collapses without reaching the
    /// minimum step (which, at 10⁻¹⁴·t, would take hours).
    pub max_steps: usize,
}

impl Default for RunSpec {
    fn default() -> Self {
        RunSpec {
            cycles: Some(3),
            t_end: 600.0,
            sampling: Sampling::Every(1e-3),
            rtol: 1e-6,
            max_step: 0.05,
            max_events: 100_000,
            max_steps: 500_000,
        }
    }
}

impl RunSpec {
    /// `cycles` cycles, sampled every `dt`, other settings default.
    pub fn cycles(cycles: usize, dt: f64) -> Self {
        RunSpec { cycles: Some(cycles), sampling: Sampling::Every(dt), ..RunSpec::default() }
    }

    /// Checks the settings.
    pub fn validate(&self) -> Result<(), RigError> {
        if !(self.t_end > 0.0 && self.t_end.is_finite()) {
            return Err(RigError::invalid("run.t_end", self.t_end, "must be positive and finite"));
        }
        if !(self.rtol >= 1e-12 && self.rtol <= 1e-2) {
            return Err(RigError::invalid("run.rtol", self.rtol, "must lie in [1e-12, 1e-2]"));
        }
        if self.max_steps == 0 {
            return Err(RigError::invalid("run.max_steps", 0.0, "must be at least 1"));
        }
        if !positive(self.max_step) {
            return Err(RigError::invalid("run.max_step", self.max_step, "must be positive"));
        }
        match &self.sampling {
            Sampling::Every(dt) => {
                if !(*dt > 0.0 && dt.is_finite()) {
                    return Err(RigError::invalid("run.sampling.every", *dt, "must be positive and finite"));
                }
            }
            Sampling::At(ts) => {
                for w in ts.windows(2) {
                    if w[1] < w[0] || w[1].is_nan() {
                        return Err(RigError::invalid("run.sampling.at", w[1], "instants must be sorted"));
                    }
                }
                if let Some(&t) = ts.iter().find(|t| !t.is_finite()) {
                    return Err(RigError::invalid("run.sampling.at", t, "instants must be finite"));
                }
            }
        }
        Ok(())
    }
}
