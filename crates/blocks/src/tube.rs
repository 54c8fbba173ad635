//! Tube (hose, pipe): a pneumatic line lumped into N segments, each a rigid
//! capacity with the energy balance of a chamber, joined by wall-friction
//! restrictions — laminar and turbulent — with optional gas inertia and
//! wall heat exchange.
//!
//! ```text
//!   a ─[½Δx]─ V₁ ─[Δx]─ V₂ ─ … ─[Δx]─ V_N ─[½Δx]─ b        Δx = L/N, V_i = A·Δx
//! ```
//!
//! # Ports
//! - `a`, `b` — pneumatic, flow (the half segments at the ends are
//!   restrictions, so a tube connects to a valve or a chamber alike).
//!
//! # Parameters (defaults in brackets)
//! - `length` [m, required, > 0], `diameter` [m, required, > 0]: inner
//!   diameter D; A = πD²/4.
//! - `segments` [count, 4, ≥ 1]: N (see the convergence study in
//!   docs/blocks.md: the arrival of a pressure step is within a few
//!   per cent of the wave travel time L/c with N ≥ L/(0.25 m)).
//! - `inertia` [`no`]: `yes` adds the momentum of the gas between segments
//!   (the interior joints carry the mass flow as a state; needs N ≥ 2) —
//!   needed for pressure waves, oscillations and the wave travel time.
//! - `viscosity` [Pa s, 18.1 µPa s]: dynamic viscosity at 20 °C; it follows
//!   the gas temperature by Sutherland's law (air, S = 110.4 K).
//! - thermal wall (shared with the chamber): `tau_thermal` [s, 5 s; "inf"
//!   adiabatic], `T_wall` [K, 293.15 K]. For a small bore the laminar
//!   Nusselt number (Nu = 3.66) gives τ_T ≈ ρ c_v D²/(4 Nu k), about 0.2 s
//!   for D = 4 mm at 6 bar.
//! - initial gas `p0` [Pa, 1.01325 bar], `T0` [K, 293.15 K]: uniform along
//!   the line, free for the rest state unless given.
//!
//! # Equations
//! - Each segment: mass and energy balance of a rigid chamber (paper Eq. 5,
//!   8, 13–17) with the flows of its two joints.
//! - Wall friction over a joint of length ℓ (Darcy–Weisbach):
//!   Δp_f = f(Re)·(ℓ/D)·ρ̄u²/2 = sign(ṁ)·f·Re²·ℓμ²/(2ρ̄D³), Re = |ṁ|D/(Aμ),
//!   with f = 64/Re (laminar, Hagen–Poiseuille) for Re ≤ 2000 and
//!   f = 0.3164·Re^(−1/4) (Blasius, smooth pipe) for Re ≥ 4000; between
//!   them f·Re² is the monotone cubic (Hermite) joining the two laws with
//!   their slopes, so the friction is continuous and invertible. ρ̄ and μ are
//!   taken at the mean state of the two sides.
//! - Without inertia every joint is quasi-steady: the friction flow ṁ_f
//!   solves Δp = Δp_f(ṁ_f), and the flow passed is limited by the sonic
//!   flow of the upstream state, ṁ* = A·p₀·√(γ/(RT₀))·(2/(γ+1))^((γ+1)/(2(γ−1))),
//!   as two resistances in series: ṁ = ṁ_f/√(1 + (ṁ_f/ṁ*)²) (a line
//!   vented into a low pressure chokes instead of emptying at an unbounded rate).
//!   With inertia the interior joints integrate the momentum balance
//!   dṁ/dt = (A/Δx)·(p_i − p_{i+1} − Δp(ṁ)), with Δp(ṁ) the drop that
//!   passes ṁ in steady flow by the same law; the end half joints stay
//!   quasi-steady.
//! - Energy flows carry the upstream enthalpy (kinetic energy neglected).
//!
//! # Assumptions
//! Friction law of fully developed incompressible pipe flow, used at the
//! mean density of each joint: accurate at low Mach number; near sonic
//! speed the series limit above stands in for Fanno choking (size the line
//! so that the valves, not the hose, are the sonic restrictions); rigid
//! smooth wall; uniform state within a segment.

use crate::block::*;
use crate::chamber::Chamber;
use crate::params::{ParamSpec, Params, Range};
use crate::support::intern;
use gas::GasState;
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    &[
        ParamSpec::quantity("length", dim::LENGTH, None, Range::Positive, "m", "length L"),
        ParamSpec::quantity("diameter", dim::LENGTH, None, Range::Positive, "mm", "inner diameter D"),
        ParamSpec::count("segments", Some(4.0), "number of lumped segments N (>= 1)"),
        ParamSpec::choice("inertia", &["no", "yes"], 0, "gas inertia between segments (needs N >= 2)"),
        ParamSpec::quantity("viscosity", dim::VISCOSITY, Some(18.1e-6), Range::Positive, "µPa s", "dynamic viscosity at 20 degC"),
    ],
    crate::chamber::THERMAL_WALL,
    crate::chamber::INITIAL_GAS
);
pub const PORTS: &[PortSpec] = &[PortSpec::new("a", PortKind::PneumaticFlow, "end a"), PortSpec::new("b", PortKind::PneumaticFlow, "end b")];
/// Recorded outputs listed for the catalogue (an instance records p1 … pN).
pub const OUTPUTS: &[OutputSpec] = &[
    OutputSpec { name: "mdot_a", unit: "kg/s" },
    OutputSpec { name: "mdot_b", unit: "kg/s" },
    OutputSpec { name: "p1", unit: "Pa" },
    OutputSpec { name: "pN", unit: "Pa" },
];

/// Largest number of segments accepted.
pub const MAX_SEGMENTS: usize = 1000;

/// Reynolds numbers bounding the laminar–turbulent transition.
const RE_LAMINAR: f64 = 2000.0;
const RE_TURBULENT: f64 = 4000.0;
/// Sutherland constant of air [K] (White, *Viscous Fluid Flow*, 3rd ed., Table 1-2).
const SUTHERLAND: f64 = 110.4;

/// The Hermite cubic of φ between the laminar and Blasius laws: its start
/// Re `a`, width `h`, and the end values and slopes it matches.
struct Transition {
    a: f64,
    h: f64,
    y0: f64,
    m0: f64,
    y1: f64,
    m1: f64,
}

impl Transition {
    fn new() -> Self {
        let (a, b) = (RE_LAMINAR, RE_TURBULENT);
        let y1 = 0.3164 * b.powf(1.75);
        Transition { a, h: b - a, y0: 64.0 * a, m0: 64.0, y1, m1: 1.75 * y1 / b }
    }
}

/// f(Re)·Re²: friction factor times Re² (Darcy–Weisbach in Reynolds form), monotone in Re.
pub fn phi(re: f64) -> f64 {
    let re = re.abs();
    if re <= RE_LAMINAR {
        64.0 * re
    } else if re >= RE_TURBULENT {
        0.3164 * re.powf(1.75)
    } else {
        let Transition { a, h, y0, m0, y1, m1 } = Transition::new();
        let t = (re - a) / h;
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * y0 + (t3 - 2.0 * t2 + t) * h * m0 + (-2.0 * t3 + 3.0 * t2) * y1 + (t3 - t2) * h * m1
    }
}

/// Slope dφ/dRe of [`phi`] (Re ≥ 0): 64 (laminar), 1.75·0.3164·Re^¾
/// (Blasius) and the derivative of the Hermite cubic between them.
pub fn phi_slope(re: f64) -> f64 {
    let re = re.abs();
    if re <= RE_LAMINAR {
        64.0
    } else if re >= RE_TURBULENT {
        1.75 * 0.3164 * re.powf(0.75)
    } else {
        let Transition { a, h, y0, m0, y1, m1 } = Transition::new();
        let t = (re - a) / h;
        let t2 = t * t;
        ((6.0 * t2 - 6.0 * t) * y0 + (3.0 * t2 - 4.0 * t + 1.0) * h * m0 + (-6.0 * t2 + 6.0 * t) * y1 + (3.0 * t2 - 2.0 * t) * h * m1) / h
    }
}

/// Re with phi(Re) = target (≥ 0).
pub fn phi_inverse(target: f64) -> f64 {
    if target.is_nan() || target <= 0.0 {
        return 0.0;
    }
    if target <= phi(RE_LAMINAR) {
        return target / 64.0;
    }
    if target >= phi(RE_TURBULENT) {
        return (target / 0.3164).powf(1.0 / 1.75);
    }
    // transition: bisection on the monotone cubic (a few dozen steps to machine precision)
    let (mut lo, mut hi) = (RE_LAMINAR, RE_TURBULENT);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if phi(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-13 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// One side of a joint: its gas state and how p, ρ, T and h move with the
/// two inputs it comes from (a port's p and T, a segment's m and T).
#[derive(Debug, Clone, Copy)]
struct Side {
    state: GasState,
    inputs: [In; 2],
    dp: [f64; 2],
    drho: [f64; 2],
    dt: [f64; 2],
    dh: [f64; 2],
}

/// Slopes of a joint's flow by one input.
#[derive(Debug, Clone, Copy, Default)]
struct Slope {
    mdot: f64,
    edot: f64,
}

/// One input of a joint and the slopes (∂ṁ, ∂Ė) of its flow by it.
type JointTerm = (In, f64, f64);

/// A joint's flow (a → b) and its slopes by the two inputs of each side.
#[derive(Debug, Clone, Copy)]
struct JointPartials {
    flow: PortFlow,
    d: [[Slope; 2]; 2],
}

/// (∂γ/∂ρ, ∂γ/∂T) at a state, by central differences of the gas model's γ
/// (as [`gas::GasModel::second_derivatives`] defaults; zero for the ideal gas).
fn gamma_slopes(gas: &dyn gas::GasModel, s: &GasState) -> [f64; 2] {
    let (dr, dt) = (1e-5 * s.rho.abs().max(1e-3), 1e-5 * s.t);
    [
        (gas.gamma(s.rho + dr, s.t) - gas.gamma(s.rho - dr, s.t)) / (2.0 * dr),
        (gas.gamma(s.rho, s.t + dt) - gas.gamma(s.rho, s.t - dt)) / (2.0 * dt),
    ]
}

#[derive(Debug, Clone, PartialEq)]
pub struct Tube {
    pub n: usize,
    pub length: f64,
    pub diameter: f64,
    pub area: f64,
    pub inertia: bool,
    pub mu20: f64,
    /// One segment as a rigid chamber (volume A·Δx, the thermal wall, the initial gas).
    pub segment: Chamber,
    states: Vec<StateSpec>,
    outputs: Vec<OutputSpec>,
}

impl Tube {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let n = p.get("segments") as usize;
        if n == 0 {
            return Err(crate::BlockError::invalid("segments", "must be at least 1"));
        }
        if n > MAX_SEGMENTS {
            return Err(crate::BlockError::invalid("segments", &format!("must be at most {MAX_SEGMENTS}")));
        }
        let inertia = p.choice("inertia") == 1;
        if inertia && n < 2 {
            return Err(crate::BlockError::invalid("segments", "must be at least 2 with inertia (the momentum lives between segments)"));
        }
        let (length, diameter) = (p.get("length"), p.get("diameter"));
        let area = std::f64::consts::PI / 4.0 * diameter * diameter;
        let segment = Chamber {
            dead_volume: area * length / n as f64,
            area: 0.0,
            sigma: 1.0,
            length_at_zero: 0.0,
            tau_thermal: p.get("tau_thermal"),
            t_wall: p.get("T_wall"),
            p0: p.get("p0"),
            t0: p.get("T0"),
            free: FreeInitial { pressure: !p.was_given("p0"), temperature: !p.was_given("T0"), position: false },
            diameters: None,
        };
        let mut states = Vec::new();
        for i in 1..=n {
            states.push(StateSpec { name: intern(&format!("m{i}")), unit: "kg" });
            states.push(StateSpec { name: intern(&format!("T{i}")), unit: "K" });
        }
        if inertia {
            for k in 1..n {
                states.push(StateSpec { name: intern(&format!("mdot{k}_{}", k + 1)), unit: "kg/s" });
            }
        }
        let mut outputs = vec![OutputSpec { name: "mdot_a", unit: "kg/s" }, OutputSpec { name: "mdot_b", unit: "kg/s" }];
        for i in 1..=n {
            outputs.push(OutputSpec { name: intern(&format!("p{i}")), unit: "Pa" });
        }
        Ok(Tube { n, length, diameter, area, inertia, mu20: p.get("viscosity"), segment, states, outputs })
    }

    fn dx(&self) -> f64 {
        self.length / self.n as f64
    }

    /// Dynamic viscosity at temperature t (Sutherland's law).
    pub fn viscosity(&self, t: f64) -> f64 {
        let t = t.max(1.0);
        self.mu20 * (t / 293.15).powf(1.5) * (293.15 + SUTHERLAND) / (t + SUTHERLAND)
    }

    /// κ = ℓμ²/(2D³) and the flow scale Aμ/D at the mean state of two sides.
    fn friction_scales(&self, a: &GasState, b: &GasState, len: f64) -> (f64, f64, f64) {
        let mu = self.viscosity(0.5 * (a.t + b.t));
        let rho = 0.5 * (a.rho + b.rho);
        (len * mu * mu / (2.0 * self.diameter.powi(3)), self.area * mu / self.diameter, rho)
    }

    /// Friction pressure drop [Pa] at mass flow `mdot` over a joint of length `len`.
    pub fn friction_drop(&self, mdot: f64, a: &GasState, b: &GasState, len: f64) -> f64 {
        let (kappa, flow_scale, rho) = self.friction_scales(a, b, len);
        mdot.signum() * phi(mdot.abs() / flow_scale) * kappa / rho
    }

    /// Sonic (choked) mass flow [kg/s] of the bore from an upstream state:
    /// ṁ* = A·p₀·√(γ/(R T₀))·(2/(γ+1))^((γ+1)/(2(γ−1))) (isentropic critical
    /// flow, e.g. Anderson, *Modern Compressible Flow*, §5.4).
    pub fn sonic_flow(&self, gas: &dyn gas::GasModel, up: &GasState) -> f64 {
        let gamma = gas.gamma(up.rho, up.t);
        let r = up.p / (up.rho * up.t);
        let k = (2.0 / (gamma + 1.0)).powf((gamma + 1.0) / (2.0 * (gamma - 1.0)));
        self.area * up.p * (gamma / (r * up.t)).sqrt() * k
    }

    /// Quasi-steady flow across a joint of length `len` from side a to side b:
    /// the friction flow ṁ_f, limited by the sonic flow ṁ* of the upstream
    /// state as two resistances in series, ṁ = ṁ_f/√(1 + (ṁ_f/ṁ*)²) (the
    /// line chokes instead of passing an unbounded flow into a low pressure).
    pub fn joint_flow(&self, gas: &dyn gas::GasModel, a: &GasState, b: &GasState, len: f64) -> PortFlow {
        let friction = self.friction_flow(a, b, len);
        if friction == 0.0 {
            return PortFlow::default();
        }
        let sonic = self.sonic_flow(gas, if friction > 0.0 { a } else { b });
        let mdot = friction / (1.0 + (friction / sonic).powi(2)).sqrt();
        PortFlow { mdot, edot: mdot * if mdot >= 0.0 { a.h } else { b.h } }
    }

    /// Mass flow [kg/s] the wall friction alone lets pass from a to b over length `len` (Δp = Δp_f(ṁ)).
    pub fn friction_flow(&self, a: &GasState, b: &GasState, len: f64) -> f64 {
        let dp = a.p - b.p;
        if dp == 0.0 || !dp.is_finite() {
            return 0.0;
        }
        let (kappa, flow_scale, rho) = self.friction_scales(a, b, len);
        dp.signum() * phi_inverse(dp.abs() * rho / kappa) * flow_scale
    }

    /// Pressure drop [Pa] a joint with gas inertia needs to pass `mdot` in
    /// steady flow: the friction drop of the friction flow that, limited by
    /// the sonic flow as in [`Tube::joint_flow`], gives `mdot`. It grows without
    /// bound as `mdot` nears the sonic flow (clipped at 0.9999 of it).
    pub fn joint_drop(&self, gas: &dyn gas::GasModel, mdot: f64, a: &GasState, b: &GasState, len: f64) -> f64 {
        let sonic = self.sonic_flow(gas, if mdot >= 0.0 { a } else { b });
        let ratio = (mdot.abs() / sonic).min(0.9999);
        let friction = mdot.abs() / (1.0 - ratio * ratio).sqrt();
        mdot.signum() * self.friction_drop(friction, a, b, len).abs()
    }

    /// dμ/dT of Sutherland's law, μ·(3/(2T) − 1/(T + S)) (0 below the 1 K clamp).
    fn viscosity_slope(&self, t: f64) -> f64 {
        if t < 1.0 {
            return 0.0;
        }
        self.viscosity(t) * (1.5 / t - 1.0 / (t + SUTHERLAND))
    }

    /// The quasi-steady flow of [`Tube::joint_flow`] from side a to side b
    /// and its partials by the two sides' inputs. Differentiated in steps:
    /// the friction flow F = sign(Δp)·φ⁻¹(|Δp|ρ̄/κ)·Aμ/D has ∂F/∂Δp =
    /// (Aμ/D)(ρ̄/κ)/φ′(Re) (finite at Δp = 0), ∂F/∂ρ̄ = Δp·∂F/∂Δp/ρ̄ and,
    /// with κ ∝ μ² and Aμ/D ∝ μ, ∂F/∂μ = (F − 2Δp·∂F/∂Δp)/μ, μ(T̄) by
    /// Sutherland; the sonic flow ṁ* = A·k(γ)·√(γρp) of the upstream side
    /// moves with its p, ρ and γ(ρ, T); the series limit ṁ = F/√(1 + q²),
    /// q = F/ṁ*, has ∂ṁ/∂F = (1 + q²)^(−3/2), ∂ṁ/∂ṁ* = q³(1 + q²)^(−3/2);
    /// Ė = ṁ·h_up.
    fn joint_partials(&self, gas: &dyn gas::GasModel, a: &Side, b: &Side, len: f64) -> JointPartials {
        let (sa, sb) = (&a.state, &b.state);
        let flow = self.joint_flow(gas, sa, sb, len);
        let mut out = JointPartials { flow, d: [[Slope::default(); 2]; 2] };
        let dp = sa.p - sb.p;
        if !dp.is_finite() {
            return out;
        }
        let (kappa, flow_scale, rho) = self.friction_scales(sa, sb, len);
        let friction = self.friction_flow(sa, sb, len);
        let re = (friction / flow_scale).abs();
        let f_dp = flow_scale * rho / (kappa * phi_slope(re));
        let f_rho = dp * f_dp / rho;
        let t_mean = 0.5 * (sa.t + sb.t);
        let f_mu = (friction - 2.0 * dp * f_dp) / self.viscosity(t_mean);
        let mu_t = self.viscosity_slope(t_mean);
        // slopes of ṁ by (p, ρ, T) of each side, then γ of the upstream side
        let (mut dm_f, mut dm_s) = (1.0, 0.0);
        let up = if friction > 0.0 { 0 } else { 1 };
        let up_state = if up == 0 { sa } else { sb };
        let mut sonic_by = [0.0; 3]; // ∂ṁ*/∂(p, ρ, γ)
        if friction != 0.0 {
            let sonic = self.sonic_flow(gas, up_state);
            let q = friction / sonic;
            let c = (1.0 + q * q).powf(-1.5);
            dm_f = c;
            dm_s = q * q * q * c;
            let gamma = gas.gamma(up_state.rho, up_state.t);
            let dlnk = -(2.0 / (gamma + 1.0)).ln() / ((gamma - 1.0) * (gamma - 1.0)) - 1.0 / (2.0 * (gamma - 1.0));
            sonic_by = [0.5 * sonic / up_state.p, 0.5 * sonic / up_state.rho, sonic * (dlnk + 0.5 / gamma)];
        } else {
            dm_f = if dp == 0.0 { dm_f } else { 0.0 };
        }
        let gamma_slopes = gamma_slopes(gas, up_state);
        for (k, side) in [a, b].into_iter().enumerate() {
            let sign = if k == 0 { 1.0 } else { -1.0 };
            // ∂ṁ by p, ρ, T of this side
            let mut by_p = dm_f * f_dp * sign;
            let mut by_rho = dm_f * f_rho * 0.5;
            let by_t_mu = dm_f * f_mu * mu_t * 0.5;
            let mut by_t = by_t_mu;
            if k == up && friction != 0.0 {
                by_p += dm_s * sonic_by[0];
                by_rho += dm_s * (sonic_by[1] + sonic_by[2] * gamma_slopes[0]);
                by_t += dm_s * sonic_by[2] * gamma_slopes[1];
            }
            for (u, slope) in out.d[k].iter_mut().enumerate() {
                slope.mdot = by_p * side.dp[u] + by_rho * side.drho[u] + by_t * side.dt[u];
            }
        }
        // Ė = ṁ h_up, the upstream side of the flow passed
        let h_side = if flow.mdot >= 0.0 { 0 } else { 1 };
        let h_up = if h_side == 0 { sa.h } else { sb.h };
        for k in 0..2 {
            for u in 0..2 {
                let s = &mut out.d[k][u];
                s.edot = s.mdot * h_up + if k == h_side { flow.mdot * [a, b][k].dh[u] } else { 0.0 };
            }
        }
        out
    }

    /// The steady drop of [`Tube::joint_drop`] and its slopes: by ṁ, and by
    /// the inputs of the two sides (D = sign(ṁ)·φ(Re)κ/ρ̄, Re = F/(Aμ/D),
    /// F = |ṁ|/√(1 − r²), r = |ṁ|/ṁ* unless clipped at 0.9999).
    fn drop_partials(&self, gas: &dyn gas::GasModel, mdot: f64, a: &Side, b: &Side, len: f64) -> (f64, f64, [[f64; 2]; 2]) {
        let (sa, sb) = (&a.state, &b.state);
        let drop = self.joint_drop(gas, mdot, sa, sb, len);
        let up = if mdot >= 0.0 { 0 } else { 1 };
        let up_state = if up == 0 { sa } else { sb };
        let sonic = self.sonic_flow(gas, up_state);
        let raw = mdot.abs() / sonic;
        let clipped = raw > 0.9999;
        let r = raw.min(0.9999);
        let w = 1.0 - r * r;
        let friction = mdot.abs() / w.sqrt();
        let (kappa, flow_scale, rho) = self.friction_scales(sa, sb, len);
        let re = friction / flow_scale;
        let s = mdot.signum();
        let (phi_re, phi_d) = (phi(re), phi_slope(re));
        // dD = s[φ′κ/ρ̄ dRe + φ dκ/ρ̄ − φκ dρ̄/ρ̄²], dRe = dF/(Aμ/D) − Re dμ/μ, dκ = 2κ dμ/μ
        let d_by_f = s * phi_d * kappa / (rho * flow_scale);
        let (f_mdot, f_sonic) = if clipped { (s / w.sqrt(), 0.0) } else { (s * w.powf(-1.5), -mdot.abs() * r * r / sonic * w.powf(-1.5)) };
        let t_mean = 0.5 * (sa.t + sb.t);
        let mu = self.viscosity(t_mean);
        let d_by_mu = s * (-phi_d * kappa / rho * re / mu + 2.0 * phi_re * kappa / (rho * mu));
        let d_by_rho = -s * phi_re * kappa / (rho * rho);
        let mu_t = self.viscosity_slope(t_mean);
        let gamma = gas.gamma(up_state.rho, up_state.t);
        let dlnk = -(2.0 / (gamma + 1.0)).ln() / ((gamma - 1.0) * (gamma - 1.0)) - 1.0 / (2.0 * (gamma - 1.0));
        let sonic_by = [0.5 * sonic / up_state.p, 0.5 * sonic / up_state.rho, sonic * (dlnk + 0.5 / gamma)];
        let gamma_slopes = gamma_slopes(gas, up_state);
        let mut by = [[0.0; 2]; 2];
        for (k, side) in [a, b].into_iter().enumerate() {
            let (mut by_p, mut by_rho, mut by_t) = (0.0, 0.5 * d_by_rho, 0.5 * d_by_mu * mu_t);
            if k == up {
                let c = d_by_f * f_sonic;
                by_p += c * sonic_by[0];
                by_rho += c * (sonic_by[1] + sonic_by[2] * gamma_slopes[0]);
                by_t += c * sonic_by[2] * gamma_slopes[1];
            }
            for (u, v) in by[k].iter_mut().enumerate() {
                *v = by_p * side.dp[u] + by_rho * side.drho[u] + by_t * side.dt[u];
            }
        }
        (drop, d_by_f * f_mdot, by)
    }

    /// A port's gas state and its slopes by the port's (p, T).
    fn port_side(gas: &dyn gas::GasModel, state: &GasState, k: usize) -> Side {
        let g = crate::support::GasSlopes::at(gas, state);
        Side { state: *state, inputs: [In::P(k), In::T(k)], dp: [1.0, 0.0], drho: [g.drho_dp, g.drho_dt], dt: [0.0, 1.0], dh: [g.dh_dp, g.dh_dt] }
    }

    /// Segment i's gas state and its slopes by its states (m, T), ρ = m/V.
    fn segment_side(&self, ctx: &Ctx, i: usize) -> Side {
        let state = self.segment_state(ctx, i);
        let v = self.segment.dead_volume;
        let (rho, t) = (state.rho, state.t);
        let p_rho = ctx.gas.dp_drho(rho, t);
        let p_t = ctx.gas.t_dp_dt(rho, t) / t;
        let (h_rho, h_t) = crate::support::enthalpy_slopes(ctx.gas, rho, t);
        Side {
            state,
            inputs: [In::State(2 * i), In::State(2 * i + 1)],
            dp: [p_rho / v, p_t],
            drho: [1.0 / v, 0.0],
            dt: [0.0, 1.0],
            dh: [h_rho / v, h_t],
        }
    }

    fn segment_state(&self, ctx: &Ctx, i: usize) -> GasState {
        self.segment.gas_state(ctx.gas, ctx.states[2 * i], ctx.states[2 * i + 1], 0.0)
    }

    /// Flows through all N + 1 joints, positive from a towards b.
    fn joint_flows(&self, ctx: &Ctx, seg: &[GasState]) -> Vec<PortFlow> {
        let dx = self.dx();
        let mut f = Vec::with_capacity(self.n + 1);
        f.push(self.joint_flow(ctx.gas, &ctx.pneumatic[0], &seg[0], 0.5 * dx));
        for k in 1..self.n {
            if self.inertia {
                let mdot = ctx.states[2 * self.n + k - 1];
                f.push(PortFlow { mdot, edot: mdot * if mdot >= 0.0 { seg[k - 1].h } else { seg[k].h } });
            } else {
                f.push(self.joint_flow(ctx.gas, &seg[k - 1], &seg[k], dx));
            }
        }
        f.push(self.joint_flow(ctx.gas, &seg[self.n - 1], &ctx.pneumatic[1], 0.5 * dx));
        f
    }

    fn segments(&self, ctx: &Ctx) -> Vec<GasState> {
        (0..self.n).map(|i| self.segment_state(ctx, i)).collect()
    }
}

impl Block for Tube {
    fn type_name(&self) -> &'static str {
        "tube"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Capacity
    }
    fn states(&self) -> &[StateSpec] {
        &self.states
    }
    fn state_scales(&self, init: &[f64], out: &mut [f64]) {
        let m = init[0].abs().max(1e-12);
        for i in 0..self.n {
            out[2 * i] = m;
            out[2 * i + 1] = 300.0;
        }
        // a flow of 10 m/s at the initial density
        let rho = m / self.segment.dead_volume;
        for s in out[2 * self.n..].iter_mut() {
            *s = rho * self.area * 10.0;
        }
    }
    fn free_initial(&self) -> FreeInitial {
        self.segment.free
    }
    fn set_initial_gas(&mut self, p: f64, t: f64) {
        self.segment.p0 = p;
        self.segment.t0 = t;
    }
    fn initial_gas(&self) -> Option<(f64, f64)> {
        Some((self.segment.p0, self.segment.t0))
    }
    fn initial_states(&self, ctx: &InitCtx, out: &mut [f64]) {
        let m = ctx.gas.density(self.segment.p0, self.segment.t0) * self.segment.dead_volume;
        for i in 0..self.n {
            out[2 * i] = m;
            out[2 * i + 1] = self.segment.t0;
        }
        out[2 * self.n..].fill(0.0);
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let dx = self.dx();
        out[0] = self.joint_flow(ctx.gas, &ctx.pneumatic[0], &self.segment_state(ctx, 0), 0.5 * dx);
        out[1] = -self.joint_flow(ctx.gas, &self.segment_state(ctx, self.n - 1), &ctx.pneumatic[1], 0.5 * dx);
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        let seg = self.segments(ctx);
        let f = self.joint_flows(ctx, &seg);
        for i in 0..self.n {
            let mut inflow = f[i];
            inflow += -f[i + 1];
            let r = self.segment.rates(ctx.gas, ctx.states[2 * i], ctx.states[2 * i + 1], MechState::default(), inflow);
            out[2 * i] = r.dm;
            out[2 * i + 1] = r.dt;
        }
        if self.inertia {
            let dx = self.dx();
            for k in 1..self.n {
                let mdot = ctx.states[2 * self.n + k - 1];
                let drop = self.joint_drop(ctx.gas, mdot, &seg[k - 1], &seg[k], dx);
                out[2 * self.n + k - 1] = self.area / dx * (seg[k - 1].p - seg[k].p - drop);
            }
        }
    }
    /// Exact partials: the port flows and the segments' balances by the
    /// chain rule over the joints' slopes ([`Tube::joint_partials`], and for
    /// gas inertia the interior joints' momentum balance with the slopes of
    /// [`Tube::drop_partials`]); each segment's temperature rate by
    /// [`Chamber::temperature_rate_partials`] of its net inflow; the wall heat
    /// as the chamber's.
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        let n = self.n;
        let dx = self.dx();
        match phase {
            Phase::Flows => {
                let ends = [
                    (Self::port_side(ctx.gas, &ctx.pneumatic[0], 0), self.segment_side(ctx, 0), 1.0),
                    (self.segment_side(ctx, n - 1), Self::port_side(ctx.gas, &ctx.pneumatic[1], 1), -1.0),
                ];
                for (port, (a, b, sign)) in ends.iter().enumerate() {
                    let j = self.joint_partials(ctx.gas, a, b, 0.5 * dx);
                    for (side, slopes) in [a, b].into_iter().zip(&j.d) {
                        for (u, slope) in slopes.iter().enumerate() {
                            d.add(Out::Mdot(port), side.inputs[u], sign * slope.mdot);
                            d.add(Out::Edot(port), side.inputs[u], sign * slope.edot);
                        }
                    }
                }
            }
            Phase::Derivatives => {
                let seg: Vec<Side> = (0..n).map(|i| self.segment_side(ctx, i)).collect();
                let ports = [Self::port_side(ctx.gas, &ctx.pneumatic[0], 0), Self::port_side(ctx.gas, &ctx.pneumatic[1], 1)];
                // every joint's flow and its slopes: (input, ∂ṁ, ∂Ė)
                let mut joints: Vec<(PortFlow, Vec<JointTerm>)> = Vec::with_capacity(n + 1);
                for k in 0..=n {
                    let (a, b, len) = match k {
                        0 => (&ports[0], &seg[0], 0.5 * dx),
                        k if k == n => (&seg[n - 1], &ports[1], 0.5 * dx),
                        k => (&seg[k - 1], &seg[k], dx),
                    };
                    if self.inertia && k > 0 && k < n {
                        let state = 2 * n + k - 1;
                        let mdot = ctx.states[state];
                        let up = if mdot >= 0.0 { a } else { b };
                        let mut terms = vec![(In::State(state), 1.0, up.state.h)];
                        terms.extend((0..2).map(|u| (up.inputs[u], 0.0, mdot * up.dh[u])));
                        joints.push((PortFlow { mdot, edot: mdot * up.state.h }, terms));
                    } else {
                        let j = self.joint_partials(ctx.gas, a, b, len);
                        let mut terms = Vec::with_capacity(4);
                        for (side, slopes) in [a, b].into_iter().zip(&j.d) {
                            terms.extend((0..2).map(|u| (side.inputs[u], slopes[u].mdot, slopes[u].edot)));
                        }
                        joints.push((j.flow, terms));
                    }
                }
                for i in 0..n {
                    let (m, t) = (ctx.states[2 * i], ctx.states[2 * i + 1]);
                    let mut inflow = joints[i].0;
                    inflow += -joints[i + 1].0;
                    let r = self.segment.temperature_rate_partials(ctx.gas, m, t, MechState::default(), inflow);
                    d.add(Out::Rate(2 * i + 1), In::State(2 * i), r[0]);
                    d.add(Out::Rate(2 * i + 1), In::State(2 * i + 1), r[1]);
                    for (joint, sign) in [(i, 1.0), (i + 1, -1.0)] {
                        for &(input, dm, de) in &joints[joint].1 {
                            d.add(Out::Rate(2 * i), input, sign * dm);
                            d.add(Out::Rate(2 * i + 1), input, sign * (r[4] * dm + r[5] * de));
                        }
                    }
                }
                if self.inertia {
                    let c = self.area / dx;
                    for k in 1..n {
                        let state = 2 * n + k - 1;
                        let (a, b) = (&seg[k - 1], &seg[k]);
                        let (_, by_mdot, by) = self.drop_partials(ctx.gas, ctx.states[state], a, b, dx);
                        d.add(Out::Rate(state), In::State(state), -c * by_mdot);
                        for (s, (side, sign)) in [(a, 1.0), (b, -1.0)].into_iter().enumerate() {
                            for ((input, dp), by_u) in side.inputs.iter().zip(side.dp).zip(by[s]) {
                                d.add(Out::Rate(state), *input, c * (sign * dp - by_u));
                            }
                        }
                    }
                }
            }
            Phase::Exchange if self.segment.tau_thermal.is_finite() => {
                // Q_w = Σ m_i c_v (T_w − T_i)/τ_T, ρ_i = m_i/V
                let v = self.segment.dead_volume;
                for i in 0..n {
                    let (m, t) = (ctx.states[2 * i], ctx.states[2 * i + 1]);
                    let rho = m / v;
                    let cv = ctx.gas.cv(rho, t);
                    let [cv_rho, cv_t, _, _] = ctx.gas.second_derivatives(rho, t);
                    let wall = (self.segment.t_wall - t) / self.segment.tau_thermal;
                    d.add(Out::Heat, In::State(2 * i), (cv + m * cv_rho / v) * wall);
                    d.add(Out::Heat, In::State(2 * i + 1), m * (cv_t * wall - cv / self.segment.tau_thermal));
                }
            }
            _ => {}
        }
        true
    }
    fn stored(&self, ctx: &Ctx) -> Option<Stored> {
        let mut s = Stored::default();
        for i in 0..self.n {
            let g = self.segment_state(ctx, i);
            let m = ctx.states[2 * i];
            s.mass += m;
            s.energy += m * ctx.gas.internal_energy(g.rho, g.t);
        }
        Some(s)
    }
    fn exchange(&self, ctx: &Ctx, _balances: &Balances) -> Exchange {
        let mut heat = 0.0;
        for i in 0..self.n {
            let r = self.segment.rates(ctx.gas, ctx.states[2 * i], ctx.states[2 * i + 1], MechState::default(), PortFlow::default());
            heat += r.q_wall;
        }
        Exchange { heat, work: 0.0 }
    }
    fn outputs(&self) -> &[OutputSpec] {
        &self.outputs
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        let seg = self.segments(ctx);
        let f = self.joint_flows(ctx, &seg);
        out[0] = Some(f[0].mdot);
        out[1] = Some(f[self.n].mdot);
        for (o, s) in out[2..].iter_mut().zip(&seg) {
            *o = Some(s.p);
        }
    }
}

/// Registry entry of `tube`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "tube",
    family: crate::registry::Family::Capacities,
    doc: "hose or pipe: N segments, wall friction, optional gas inertia, wall heat",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Tube::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;
    use gas::GasModel;

    fn tube(extra: &[(&str, RawValue)]) -> Result<Tube, crate::BlockError> {
        let mut raw = vec![("length", RawValue::Text("5 m".into())), ("diameter", RawValue::Text("4 mm".into()))];
        raw.extend(extra.iter().cloned());
        Tube::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v)))?)
    }

    #[test]
    fn friction_law_is_continuous_and_monotone_and_inverts() {
        let mut last = 0.0;
        for k in 1..20_000 {
            let re = k as f64 * 0.5;
            let v = phi(re);
            assert!(v > last, "monotone at Re = {re}");
            last = v;
            let back = phi_inverse(v);
            assert!((back - re).abs() < 1e-9 * re, "inverse at Re = {re}: {back}");
        }
        // continuous at both ends of the transition
        for re in [RE_LAMINAR, RE_TURBULENT] {
            assert!((phi(re * (1.0 + 1e-12)) - phi(re * (1.0 - 1e-12))).abs() < 1e-6 * phi(re));
        }
    }

    #[test]
    fn laminar_flow_is_hagen_poiseuille() {
        // ṁ = ρ π D⁴ Δp /(128 μ ℓ) for laminar flow in a tube
        let t = tube(&[]).unwrap();
        let gas = gas::IdealGas::air();
        let (p, dp) = (3e5, 10.0);
        let (a, b) = (gas.state_pt(p + dp / 2.0, 293.15), gas.state_pt(p - dp / 2.0, 293.15));
        let f = t.friction_flow(&a, &b, 1.0);
        let rho = 0.5 * (a.rho + b.rho);
        let hp = rho * std::f64::consts::PI * 0.004f64.powi(4) * dp / (128.0 * 18.1e-6 * 1.0);
        assert!((f - hp).abs() < 1e-9 * hp, "{f} vs {hp}");
        assert!(f * 0.004 / (t.area * 18.1e-6) < RE_LAMINAR);
        // far below the sonic flow the joint passes the friction flow
        assert!((t.joint_flow(&gas, &a, &b, 1.0).mdot - f).abs() < 1e-5 * f);
        // turbulent: Blasius, Δp = 0.3164 Re^-¼ (ℓ/D) ρ u²/2
        let dp = 0.5e5;
        let (a, b) = (gas.state_pt(p + dp / 2.0, 293.15), gas.state_pt(p - dp / 2.0, 293.15));
        let f = t.friction_flow(&a, &b, 1.0);
        let rho = 0.5 * (a.rho + b.rho);
        let re = f * 0.004 / (t.area * 18.1e-6);
        let u = f / (rho * t.area);
        let blasius = 0.3164 * re.powf(-0.25) * (1.0 / 0.004) * rho * u * u / 2.0;
        assert!(re > RE_TURBULENT && (blasius - dp).abs() < 1e-9 * dp, "Re {re}: {blasius} vs {dp}");
        // and the drop of a given flow inverts the flow of a given drop
        assert!((t.friction_drop(f, &a, &b, 1.0) - dp).abs() < 1e-6 * dp);
        // with inertia, the steady drop of the limited flow is the drop that produced it
        let limited = t.joint_flow(&gas, &a, &b, 1.0).mdot;
        assert!(limited < f && (t.joint_drop(&gas, limited, &a, &b, 1.0) - dp).abs() < 1e-6 * dp);
    }

    #[test]
    fn a_line_vented_into_vacuum_chokes_at_the_sonic_flow() {
        let t = tube(&[]).unwrap();
        let gas = gas::IdealGas::air();
        let (a, b) = (gas.state_pt(6e5, 293.15), gas.state_pt(1.0, 293.15));
        let f = t.joint_flow(&gas, &a, &b, 1e-4).mdot;
        // ṁ* = 0.6847 A p0/√(R T0) for γ = 1.4
        let sonic = 0.68473 * t.area * 6e5 / (287.05f64 * 293.15).sqrt();
        assert!(f < sonic * 1.0001 && f > 0.99 * sonic, "{f} vs {sonic}");
    }

    /// States (m, T per segment, then the interior flows) at the given
    /// segment pressures and temperatures, and their typical sizes.
    fn states_at(t: &Tube, segs: &[(f64, f64)], flows: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let gas = gas::IdealGas::air();
        let v = t.segment.dead_volume;
        let mut x = Vec::new();
        let mut sizes = Vec::new();
        for &(p, temp) in segs {
            x.extend([gas.density(p, temp) * v, temp]);
            sizes.extend([gas.density(1e5, 293.15) * v, 300.0]);
        }
        x.extend_from_slice(flows);
        sizes.extend(flows.iter().map(|_| 1e-4));
        (x, sizes)
    }

    fn check_all_phases(t: &Tube, segs: &[(f64, f64)], flows: &[f64], ports: [(f64, f64); 2]) {
        check_with_step(t, segs, flows, ports, 1e-4);
    }

    /// Differences of pressures of a few pascals need steps far below 1e-4 of 3 bar.
    fn check_with_step(t: &Tube, segs: &[(f64, f64)], flows: &[f64], ports: [(f64, f64); 2], relative_step: f64) {
        use crate::partials_check::point;
        let (x, sizes) = states_at(t, segs, flows);
        for phase in [Phase::Flows, Phase::Derivatives, Phase::Exchange] {
            point(&x, &ports, &[]).with_state_sizes(&sizes).with_relative_step(relative_step).check(t, phase);
        }
    }

    #[test]
    fn partials_equal_central_differences_in_subsonic_and_choking_flow_both_ways() {
        let t = tube(&[("segments", RawValue::Number(3.0))]).unwrap();
        // a → b, turbulent joints, the end joint limited by its sonic flow
        check_all_phases(&t, &[(4e5, 300.0), (3e5, 295.0), (2e5, 290.0)], &[], [(5e5, 305.0), (1e5, 293.15)]);
        // b → a, warmer downstream
        check_all_phases(&t, &[(1.6e5, 290.0), (2.2e5, 300.0), (2.9e5, 310.0)], &[], [(1.2e5, 280.0), (3.3e5, 320.0)]);
        // laminar: drops of tens of pascals
        check_with_step(&t, &[(3e5 - 20.0, 300.0), (3e5, 299.0), (3e5 + 30.0, 298.0)], &[], [(3e5 - 50.0, 301.0), (3e5 + 45.0, 297.0)], 1e-7);
        // a line of 20 segments vented into 0.5 bar: the short end joint
        // chokes (friction flow over twice the sonic flow, q > 2)
        let fine = tube(&[("segments", RawValue::Number(20.0))]).unwrap();
        let air = gas::IdealGas::air();
        let (a, b) = (air.state_pt(5e5, 293.15), air.state_pt(0.5e5, 293.15));
        let q = fine.friction_flow(&a, &b, 0.5 * fine.dx()) / fine.sonic_flow(&air, &a);
        assert!(q > 2.0, "the point should choke: q = {q}");
        let segs: Vec<(f64, f64)> = (0..20).map(|i| (6e5 - 5e3 * i as f64, 300.0 - 0.3 * i as f64)).collect();
        check_with_step(&fine, &segs, &[], [(6.1e5, 300.0), (0.5e5, 293.15)], 1e-5);
        // one segment: both ends on the same states
        let one = tube(&[("segments", RawValue::Number(1.0))]).unwrap();
        check_all_phases(&one, &[(3e5, 300.0)], &[], [(4e5, 300.0), (2e5, 290.0)]);
        // the laminar-turbulent transition (Re between 2000 and 4000) at an end joint
        let gas = gas::IdealGas::air();
        let re = |pa: f64, pb: f64| t.friction_flow(&gas.state_pt(pa, 300.0), &gas.state_pt(pb, 300.0), 0.5 * t.dx()) * t.diameter / (t.area * t.viscosity(300.0));
        let p = 3e5;
        let dp = (1..2000).map(|k| k as f64 * 2.0).find(|&dp| re(p + dp, p) > 3000.0).expect("a drop in the transition");
        assert!(re(p + dp, p) < RE_TURBULENT);
        check_with_step(&t, &[(p, 300.0), (p - 10.0, 300.0), (p - 20.0, 300.0)], &[], [(p + dp, 300.0), (p - 25.0, 300.0)], 1e-7);
    }

    #[test]
    fn partials_equal_central_differences_with_gas_inertia() {
        let t = tube(&[("segments", RawValue::Number(3.0)), ("inertia", RawValue::Text("yes".into()))]).unwrap();
        let segs = [(4e5, 300.0), (3e5, 295.0), (2e5, 290.0)];
        let ports = [(5e5, 305.0), (1e5, 293.15)];
        // flows with and against the pressure gradient
        check_all_phases(&t, &segs, &[2e-3, -5e-4], ports);
        // an interior flow beyond the sonic flow: the drop's ratio is clipped
        let gas = gas::IdealGas::air();
        let sonic = t.sonic_flow(&gas, &gas.state_pt(4e5, 300.0));
        check_all_phases(&t, &segs, &[1.5 * sonic, 1e-3], ports);
        check_all_phases(&t, &segs, &[0.7 * sonic, -1.2 * sonic], ports);
    }

    #[test]
    fn sutherland_viscosity() {
        let t = tube(&[]).unwrap();
        assert!((t.viscosity(293.15) - 18.1e-6).abs() < 1e-18);
        // air at 400 K: about 23 µPa s
        assert!((t.viscosity(400.0) - 22.9e-6).abs() < 0.5e-6, "{}", t.viscosity(400.0));
    }

    #[test]
    fn bad_segment_counts_name_the_parameter() {
        let e = tube(&[("segments", RawValue::Number(0.0))]).unwrap_err().to_string();
        assert!(e.contains("segments") && e.contains("at least 1"), "{e}");
        let e = tube(&[("segments", RawValue::Number(1.0)), ("inertia", RawValue::Text("yes".into()))]).unwrap_err().to_string();
        assert!(e.contains("segments") && e.contains("inertia"), "{e}");
        assert_eq!(tube(&[("segments", RawValue::Number(8.0)), ("inertia", RawValue::Text("yes".into()))]).unwrap().states().len(), 16 + 7);
    }

    #[test]
    fn mass_is_conserved_between_the_ports_and_the_segments() {
        let t = tube(&[("segments", RawValue::Number(3.0)), ("inertia", RawValue::Text("yes".into()))]).unwrap();
        let gas = gas::IdealGas::air();
        let v = t.segment.dead_volume;
        let states = [gas.density(4e5, 300.0) * v, 300.0, gas.density(3e5, 290.0) * v, 290.0, gas.density(2e5, 295.0) * v, 295.0, 1e-4, -2e-5];
        let ports = [gas.state_pt(5e5, 293.15), gas.state_pt(1e5, 293.15)];
        let ctx = Ctx { t: 0.0, gas: &gas, states: &states, pneumatic: &ports, mechanical: &[], signals: &[] };
        let mut d = [0.0; 8];
        t.derivatives(&ctx, &Balances { pneumatic: &[], mechanical: &[] }, &mut d);
        let mut f = [PortFlow::default(); 2];
        t.flows(&ctx, &mut f);
        let stored_rate = d[0] + d[2] + d[4];
        assert!((stored_rate - (f[0].mdot + f[1].mdot)).abs() < 1e-15, "{stored_rate} vs {}", f[0].mdot + f[1].mdot);
    }
}
