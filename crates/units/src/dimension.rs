//! Physical dimensions as integer exponents of the SI base quantities.
//!
//! A [`Dimension`] is the tuple of exponents (mass, length, time,
//! temperature) of kg, m, s and K; e.g. pressure Pa = kg m^-1 s^-2 is
//! (1, -1, -2, 0). Multiplying quantities adds exponents, dividing subtracts
//! them, raising to an integer power multiplies them (SI Brochure, 9th ed.,
//! §2.3.3). Amount of substance, current and luminous intensity never occur
//! in pneumatics and are left out.
//!
//! Two named dimensions coincide and therefore share one name:
//! N/Pa = m² (`FORCE_PER_PRESSURE` = `AREA`, "area or force per pressure") and
//! N s/m = kg/s (`DAMPING` = `MASS_FLOW`, "mass flow or damping").

use std::fmt;

/// Exponents of the SI base dimensions mass, length, time, temperature.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
pub struct Dimension {
    pub mass: i8,
    pub length: i8,
    pub time: i8,
    pub temperature: i8,
}

const fn d(mass: i8, length: i8, time: i8, temperature: i8) -> Dimension {
    Dimension { mass, length, time, temperature }
}

/// Named dimensions used by pneumo's parameters.
pub mod dim {
    use super::{d, Dimension};

    /// Pure number.
    pub const DIMENSIONLESS: Dimension = d(0, 0, 0, 0);
    /// Pa = kg m^-1 s^-2.
    pub const PRESSURE: Dimension = d(1, -1, -2, 0);
    /// K.
    pub const TEMPERATURE: Dimension = d(0, 0, 0, 1);
    /// m.
    pub const LENGTH: Dimension = d(0, 1, 0, 0);
    /// m².
    pub const AREA: Dimension = d(0, 2, 0, 0);
    /// m³.
    pub const VOLUME: Dimension = d(0, 3, 0, 0);
    /// kg.
    pub const MASS: Dimension = d(1, 0, 0, 0);
    /// s.
    pub const TIME: Dimension = d(0, 0, 1, 0);
    /// Hz = s^-1.
    pub const FREQUENCY: Dimension = d(0, 0, -1, 0);
    /// N = kg m s^-2.
    pub const FORCE: Dimension = d(1, 1, -2, 0);
    /// m/s.
    pub const VELOCITY: Dimension = d(0, 1, -1, 0);
    /// m/s².
    pub const ACCELERATION: Dimension = d(0, 1, -2, 0);
    /// kg/s.
    pub const MASS_FLOW: Dimension = d(1, 0, -1, 0);
    /// m³/s.
    pub const VOLUME_FLOW: Dimension = d(0, 3, -1, 0);
    /// Sonic conductance C of ISO 6358, m³/(s Pa) = kg^-1 m^4 s.
    pub const CONDUCTANCE: Dimension = d(-1, 4, 1, 0);
    /// Viscous damping, N s/m = kg/s (same as [`MASS_FLOW`]).
    pub const DAMPING: Dimension = d(1, 0, -1, 0);
    /// Spring stiffness, N/m = kg s^-2.
    pub const STIFFNESS: Dimension = d(1, 0, -2, 0);
    /// Friction coefficient k1, N/Pa = m² (same as [`AREA`]).
    pub const FORCE_PER_PRESSURE: Dimension = d(0, 2, 0, 0);
    /// Friction coefficient k3, N s/(m Pa) = m s.
    pub const DAMPING_PER_PRESSURE: Dimension = d(0, 1, 1, 0);
    /// W/K = kg m² s^-3 K^-1.
    pub const HEAT_CONDUCTANCE: Dimension = d(1, 2, -3, -1);
    /// kg/m³.
    pub const DENSITY: Dimension = d(1, -3, 0, 0);
    /// J/(kg K) = m² s^-2 K^-1.
    pub const SPECIFIC_HEAT: Dimension = d(0, 2, -2, -1);
    /// W = kg m² s^-3.
    pub const POWER: Dimension = d(1, 2, -3, 0);
    /// J = kg m² s^-2.
    pub const ENERGY: Dimension = d(1, 2, -2, 0);
    /// Pa s (dynamic viscosity)
    pub const VISCOSITY: Dimension = d(1, -1, -1, 0);
}

/// Name and example units of every named dimension, in one place.
const NAMED: &[(Dimension, &str, &[&str])] = {
    use dim::*;
    &[
        (DIMENSIONLESS, "dimensionless", &[]),
        (PRESSURE, "pressure", &["Pa", "kPa", "MPa", "bar", "mbar", "psi", "atm", "barg", "psig"]),
        (TEMPERATURE, "temperature", &["K", "degC", "°C", "degF"]),
        (LENGTH, "length", &["m", "cm", "mm", "µm"]),
        (AREA, "area or force per pressure", &["m2", "cm2", "mm2", "N/Pa", "N/bar"]),
        (VOLUME, "volume", &["m3", "L", "dm3", "cm3", "mL"]),
        (MASS, "mass", &["kg", "g"]),
        (TIME, "time", &["s", "ms", "min", "h"]),
        (FREQUENCY, "frequency", &["Hz", "kHz", "1/s"]),
        (FORCE, "force", &["N", "kN"]),
        (VELOCITY, "velocity", &["m/s", "mm/s"]),
        (ACCELERATION, "acceleration", &["m/s^2"]),
        (MASS_FLOW, "mass flow or damping", &["kg/s", "g/s", "kg/h", "N s/m", "N s/mm"]),
        (VOLUME_FLOW, "volume flow", &["m3/s", "L/min", "L/s", "dm3/s"]),
        (CONDUCTANCE, "sonic conductance", &["m3/(s Pa)", "L/min/bar", "dm3/(s bar)"]),
        (STIFFNESS, "stiffness", &["N/m", "N/mm"]),
        (DAMPING_PER_PRESSURE, "damping per pressure", &["N s/(m Pa)", "N s/(m bar)"]),
        (HEAT_CONDUCTANCE, "heat conductance", &["W/K"]),
        (DENSITY, "density", &["kg/m3", "g/L", "g/cm3"]),
        (SPECIFIC_HEAT, "specific heat", &["J/(kg K)", "kJ/(kg K)"]),
        (POWER, "power", &["W", "kW"]),
        (ENERGY, "energy", &["J", "kJ", "W h"]),
        (VISCOSITY, "dynamic viscosity", &["Pa s", "µPa s", "mPa s"]),
    ]
};

impl Dimension {
    /// Human name: "pressure" for a named dimension, otherwise the SI base
    /// form such as "kg m^-1 s^-3".
    pub fn name(&self) -> String {
        if let Some((_, name, _)) = NAMED.iter().find(|(x, _, _)| x == self) {
            return (*name).to_string();
        }
        let parts: Vec<String> = [("kg", self.mass), ("m", self.length), ("s", self.time), ("K", self.temperature)]
            .iter()
            .filter(|(_, e)| *e != 0)
            .map(|(sym, e)| if *e == 1 { (*sym).to_string() } else { format!("{sym}^{e}") })
            .collect();
        parts.join(" ")
    }

    /// A few accepted units for this dimension (empty for unnamed dimensions
    /// and for pure numbers).
    pub fn example_units(&self) -> &'static [&'static str] {
        NAMED.iter().find(|(x, _, _)| x == self).map_or(&[], |(_, _, ex)| ex)
    }

    /// Name with an indefinite article, for messages: "a pressure", "an area",
    /// "a quantity of dimension kg m^-3 s".
    pub fn with_article(&self) -> String {
        let name = self.name();
        if *self == dim::DIMENSIONLESS {
            "a dimensionless number".to_string()
        } else if !NAMED.iter().any(|(x, _, _)| x == self) {
            format!("a quantity of dimension {name}")
        } else if name.starts_with(['a', 'e', 'i', 'o', 'u']) {
            format!("an {name}")
        } else {
            format!("a {name}")
        }
    }

    /// "Pa, kPa, MPa" or a fallback when no examples are known.
    pub(crate) fn accepted_list(&self) -> String {
        match self.example_units() {
            [] if *self == dim::DIMENSIONLESS => "a plain number".to_string(),
            [] => format!("any unit equivalent to {}", self.name()),
            ex => ex.join(", "),
        }
    }

    /// Product of two dimensions; `None` if an exponent overflows.
    pub(crate) fn mul(self, o: Dimension) -> Option<Dimension> {
        Some(d(
            self.mass.checked_add(o.mass)?,
            self.length.checked_add(o.length)?,
            self.time.checked_add(o.time)?,
            self.temperature.checked_add(o.temperature)?,
        ))
    }

    /// Integer power; `None` if an exponent overflows.
    pub(crate) fn pow(self, n: i8) -> Option<Dimension> {
        Some(d(self.mass.checked_mul(n)?, self.length.checked_mul(n)?, self.time.checked_mul(n)?, self.temperature.checked_mul(n)?))
    }
}

impl fmt::Display for Dimension {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}
