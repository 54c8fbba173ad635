//! Reference vessels: one or two rigid chambers, optionally connected to a
//! reservoir and to each other through ISO 6358 restrictions, integrated
//! with the rig's own chamber equation (`model::temperature_rate`, paper
//! Eq. 13/14 and 16/17), flow law (`flow`, Eq. 33–35), gas (`gas`) and
//! integrator (`sdirk`). They exist so that the physics of the rig can be
//! checked against closed forms: adiabatic choked discharge, adiabatic
//! filling (T → γT_s), relaxation with the thermal time constant (Eq. 8),
//! and mass/energy conservation of a closed pair.
//!
//! States per vessel: m, T. Accounts (quadratures): boundary mass in,
//! boundary enthalpy in, wall heat in.

use crate::error::RigError;
use crate::flow::{Restriction, SubsonicLaw};
use crate::gas::Gas;
use crate::model::{temperature_rate, Inflow};
use crate::sdirk::{OdeSystem, Sdirk, SolverStats, StepError};

/// A rigid vessel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vessel {
    /// Volume [m³].
    pub volume: f64,
    /// Initial pressure [Pa].
    pub p0: f64,
    /// Initial temperature [K].
    pub t0: f64,
    /// Thermal time constant [s] (∞: adiabatic).
    pub tau_thermal: f64,
}

/// A reservoir (infinite capacity) at fixed state, connected to vessel 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reservoir {
    /// Pressure [Pa].
    pub p: f64,
    /// Temperature [K].
    pub t: f64,
    /// Restriction between the reservoir and vessel 0.
    pub restriction: Restriction,
}

/// One or two vessels and their connections.
#[derive(Debug, Clone, PartialEq)]
pub struct VesselSystem {
    /// Gas.
    pub gas: Gas,
    /// ISO 6358 subsonic law of every restriction.
    pub law: SubsonicLaw,
    /// Wall temperature [K].
    pub t_wall: f64,
    /// One or two vessels.
    pub vessels: Vec<Vessel>,
    /// Reservoir connected to vessel 0.
    pub reservoir: Option<Reservoir>,
    /// Restriction between vessels 0 and 1.
    pub link: Option<Restriction>,
    /// Wall heat by natural convection, in addition to the τ_T of each vessel.
    pub convection: Option<Convection>,
}

/// Turbulent natural convection at the vessel wall (W. H. McAdams, "Heat
/// Transmission", 3rd ed., 1954): Nu = c·Ra^⅓, so that the heat-transfer
/// coefficient does not depend on the wall's height,
/// h = c·k·(g·β·|T_w − T|·ρ²·c_p/(μ·k))^⅓ with β = 1/T, and
/// Q_w = h·A·(T_w − T). Gas viscosity and conductivity follow power laws
/// in T fitted to air and nitrogen near room temperature:
/// μ = 1.8·10⁻⁵ Pa s·(T/300 K)^0.7, k = 0.026 W/(m K)·(T/300 K)^0.8.
/// The coefficient grows with the density, so a vessel exchanges heat
/// faster full than empty — unlike a constant τ_T (paper Eq. 8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Convection {
    /// Inner wall area [m²].
    pub area: f64,
    /// c of Nu = c·Ra^⅓ (McAdams: 0.13 for a vertical wall).
    pub coefficient: f64,
}

impl Convection {
    /// h [W/(m² K)] at density ρ, gas temperature T, wall T_w, c_p.
    pub fn coefficient_at(&self, rho: f64, t: f64, t_wall: f64, cp: f64) -> f64 {
        let mu = 1.8e-5 * (t / 300.0).powf(0.7);
        let k = 0.026 * (t / 300.0).powf(0.8);
        let ra_per_l3 = 9.81 / t * (t_wall - t).abs() * rho * rho * cp / (mu * k);
        self.coefficient * k * ra_per_l3.cbrt()
    }
}

/// Result of [`run_vessels`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VesselTrace {
    /// Sample instants [s].
    pub t: Vec<f64>,
    /// Pressure of each vessel at each sample [Pa] (`p[vessel][sample]`).
    pub p: Vec<Vec<f64>>,
    /// Temperature [K].
    pub temp: Vec<Vec<f64>>,
    /// Gas mass [kg].
    pub m: Vec<Vec<f64>>,
    /// Internal energy of all vessels [J].
    pub energy: Vec<f64>,
    /// Boundary mass that entered [kg].
    pub mass_in: Vec<f64>,
    /// Boundary enthalpy that entered [J].
    pub enthalpy_in: Vec<f64>,
    /// Wall heat into the gas [J].
    pub wall_heat: Vec<f64>,
    /// Integrator counters.
    pub stats: SolverStats,
}

struct Sys<'a> {
    s: &'a VesselSystem,
}

impl Sys<'_> {
    fn n(&self) -> usize {
        self.s.vessels.len()
    }
}

fn inv(tau: f64) -> f64 {
    if tau.is_infinite() {
        0.0
    } else {
        1.0 / tau
    }
}

impl OdeSystem for Sys<'_> {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) -> bool {
        let s = self.s;
        let g = &s.gas;
        let n = self.n();
        let mut st = [(0.0, 0.0, 0.0, 0.0, 0.0); 2]; // (m, T, ρ, p, h)
        for i in 0..n {
            let (m, t) = (y[2 * i], y[2 * i + 1]);
            if !(m > 0.0 && t > 0.0) {
                return false;
            }
            let rho = m / s.vessels[i].volume;
            st[i] = (m, t, rho, g.pressure(rho, t), g.enthalpy(rho, t));
        }
        let mut inflow = [Inflow::default(); 2];
        let add = |f: &mut Inflow, q: f64, h_up: f64, h_self: f64| {
            f.mdot += q;
            if q > 0.0 {
                f.excess += q * (h_up - h_self);
            }
        };
        let (mut bm, mut bh) = (0.0, 0.0);
        if let Some(r) = s.reservoir {
            let (_, t0, _, p0, h0) = st[0];
            let h_res = g.enthalpy(g.density(r.p, r.t), r.t);
            let (q, h_up) = if r.p >= p0 {
                (r.restriction.forward(&s.law, r.p, r.t, p0), h_res)
            } else {
                (-r.restriction.forward(&s.law, p0, t0, r.p), h0)
            };
            add(&mut inflow[0], q, h_up, h0);
            bm += q;
            bh += q * h_up;
        }
        if let (Some(l), true) = (s.link, n == 2) {
            let (_, ta, _, pa, ha) = st[0];
            let (_, tb, _, pb, hb) = st[1];
            // positive from 0 to 1
            let (q, h_up) = if pa >= pb { (l.forward(&s.law, pa, ta, pb), ha) } else { (-l.forward(&s.law, pb, tb, pa), hb) };
            add(&mut inflow[0], -q, h_up, ha);
            add(&mut inflow[1], q, h_up, hb);
        }
        let mut qw = 0.0;
        for i in 0..n {
            let (m, t, rho, _, _) = st[i];
            let mut it = inv(s.vessels[i].tau_thermal);
            if let Some(c) = s.convection {
                it += c.coefficient_at(rho, t, s.t_wall, g.cp()) * c.area / (m * g.cv);
            }
            dy[2 * i] = inflow[i].mdot;
            dy[2 * i + 1] = temperature_rate(g, m, t, rho, inflow[i], 0.0, s.t_wall, it);
            qw += m * g.cv * (s.t_wall - t) * it;
        }
        dy[2 * n] = bm;
        dy[2 * n + 1] = bh;
        dy[2 * n + 2] = qw;
        true
    }
}

/// Integrates the vessels to `t_end`, sampling every `dt`, at relative
/// tolerance `rtol`.
pub fn run_vessels(s: &VesselSystem, t_end: f64, dt: f64, rtol: f64) -> Result<VesselTrace, RigError> {
    let n = s.vessels.len();
    if !(1..=2).contains(&n) {
        return Err(RigError::invalid("vessels.len", n as f64, "one or two vessels"));
    }
    s.gas.validate()?;
    s.law.validate()?;
    for v in &s.vessels {
        if !(v.volume > 0.0 && v.p0 > 0.0 && v.t0 > 0.0 && v.tau_thermal > 0.0) {
            return Err(RigError::invalid("vessels.volume/p0/t0/tau_thermal", v.volume, "must be positive"));
        }
    }
    if let Some(r) = s.reservoir {
        r.restriction.validate("vessels.reservoir")?;
    }
    if let Some(l) = s.link {
        l.validate("vessels.link")?;
    }
    if !(t_end > 0.0 && dt > 0.0 && (1e-12..=1e-2).contains(&rtol)) {
        return Err(RigError::invalid("vessels.run", t_end, "t_end, dt > 0 and rtol in [1e-12, 1e-2]"));
    }
    let g = &s.gas;
    let mut y = vec![0.0; 2 * n + 3];
    let mut floor = Vec::new();
    for (i, v) in s.vessels.iter().enumerate() {
        y[2 * i] = g.density(v.p0, v.t0) * v.volume;
        y[2 * i + 1] = v.t0;
        let p_ref = s.reservoir.map_or(v.p0, |r| r.p.max(v.p0));
        floor.push(1e-3 * g.density(p_ref, v.t0) * v.volume);
        floor.push(1.0);
    }
    let mut sys = Sys { s };
    let mut st = Sdirk::new(2 * n, 3, rtol, floor, f64::INFINITY);
    let err = |e: StepError| match e {
        StepError::TooSmall { t, h } => RigError::StepSizeTooSmall { t, h, state: "not recorded (vessel run)".into() },
        StepError::TooManySteps { t, h, attempts } => {
            RigError::StepLimit { t, h, attempts, limit: usize::MAX, state: "not recorded (vessel run)".into() }
        }
        StepError::NonPhysical { t } => RigError::NonPhysical { t, what: "vessel mass or temperature".into() },
    };
    st.restart(&mut sys, 0.0, &y).map_err(err)?;
    let mut out = VesselTrace { p: vec![Vec::new(); n], temp: vec![Vec::new(); n], m: vec![Vec::new(); n], ..VesselTrace::default() };
    let mut buf = vec![0.0; y.len()];
    let mut k = 0usize;
    let push = |t: f64, yv: &[f64], out: &mut VesselTrace| {
        out.t.push(t);
        let mut u = 0.0;
        for i in 0..n {
            let rho = yv[2 * i] / s.vessels[i].volume;
            out.p[i].push(g.pressure(rho, yv[2 * i + 1]));
            out.temp[i].push(yv[2 * i + 1]);
            out.m[i].push(yv[2 * i]);
            u += yv[2 * i] * g.internal_energy(rho, yv[2 * i + 1]);
        }
        out.energy.push(u);
        out.mass_in.push(yv[2 * n]);
        out.enthalpy_in.push(yv[2 * n + 1]);
        out.wall_heat.push(yv[2 * n + 2]);
    };
    push(0.0, &y, &mut out);
    k += 1;
    while st.t < t_end {
        st.advance(&mut sys, t_end).map_err(err)?;
        loop {
            let ts = k as f64 * dt;
            if ts > st.t || ts > t_end {
                break;
            }
            if ts >= st.t {
                buf.copy_from_slice(&st.y);
            } else {
                st.interpolate(ts, &mut buf);
            }
            push(ts, &buf, &mut out);
            k += 1;
        }
    }
    y.copy_from_slice(&st.y);
    out.stats = st.stats;
    Ok(out)
}
