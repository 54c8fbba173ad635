//! Quantities with units, parsed once at the boundary into SI `f64`.
//!
//! Users of pneumo write parameters in netlists and on the command line
//! either as a plain number, which is taken as already SI, or as text with a
//! unit. [`parse_quantity`] turns such text into the SI value of an expected
//! [`Dimension`]; everything inside pneumo then works in SI (kg, m, s, K and
//! units derived from them, e.g. Pa, m³/(s Pa)).
//!
//! ```
//! use units::{dim, parse_quantity, to_unit};
//! assert_eq!(parse_quantity("4 bar", dim::PRESSURE), Ok(4e5));
//! assert_eq!(parse_quantity("450 mm", dim::LENGTH), Ok(0.45));
//! assert_eq!(parse_quantity("3 barg", dim::PRESSURE), Ok(3e5 + 101_325.0));
//! assert_eq!(parse_quantity("19 degC", dim::TEMPERATURE), Ok(292.15));
//! assert_eq!(parse_quantity("1e-5", dim::CONDUCTANCE), Ok(1e-5)); // bare number: SI
//! let c = parse_quantity("13.2 L/min/bar", dim::CONDUCTANCE).unwrap();
//! assert!((c - 13.2e-3 / 60.0 / 1e5).abs() < 1e-22);
//! assert!(parse_quantity("450 mm", dim::PRESSURE).is_err());
//! assert!((to_unit(4e5, "bar").unwrap() - 4.0).abs() < 1e-15);
//! ```
//!
//! # Grammar
//!
//! ```text
//! quantity := NUMBER [whitespace] [unit]
//! unit     := OFFSET_UNIT | expr
//! expr     := factor (('*' | '·' | ' ') factor)* ('/' factor)*
//! factor   := (SYMBOL | '1' | '(' expr ')') [exponent]
//! exponent := '^' INTEGER | DIGITS written right after the symbol | '²' | '³'
//! ```
//!
//! * NUMBER is Rust/JSON float syntax with optional sign: `4`, `-0.5`,
//!   `1e-5`, `2.5E+3`. Without a unit the number is returned unchanged.
//! * SYMBOL is one of `m g s min h Hz K Pa bar psi atm N J W L l`, optionally
//!   with an SI prefix `n µ/u m c d k M G` (`mm`, `kg`, `ms`, `dm3`, `MPa`,
//!   `mL`). Prefixes are not combined with `min`, `h`, `psi`, `atm`. Symbols
//!   are case-sensitive, except that `l` and `L` are both litre; `m` alone is
//!   metre and `min` is minute.
//! * Exponents bind to the prefixed symbol: `cm3` = (0.01 m)³ = 1e-6 m³;
//!   `m^-1`, `s^2` and `m²` are also accepted.
//! * `/` is left-associative: `L/min/bar` = L/(min bar). A product after `/`
//!   ("J/kg K") is rejected as ambiguous: write `J/(kg K)`.
//! * OFFSET_UNIT is an affine temperature `degC`, `°C`, `degF`, `°F` or a
//!   gauge pressure `barg`, `mbarg`, `kPag`, `MPag`, `psig` (relative to
//!   [`STANDARD_ATMOSPHERE`]). These are only allowed as the whole unit:
//!   "degC/s" is an error (write "K/s"); `K` and `bar` are absolute.
//!
//! Errors ([`UnitError`]) are one-line messages naming what was found and
//! what would have been accepted, e.g.
//! `unit "mm" is a length, expected a pressure (accepted: Pa, kPa, ...)`.
//!
//! # Expressions
//!
//! Parameters written as `"= pi/4 * bore^2"` or `"= supply.p - 0.5 bar"` are
//! parsed by [`parse_expr`] and evaluated with dimension checking to a
//! [`Quantity`]; see the [`expr`] module for the grammar and rules.

mod dimension;
mod error;
pub mod expr;
mod parse;
pub mod show;

pub use dimension::{dim, Dimension};
pub use error::UnitError;
pub use expr::{is_expression, parse_expr, Expr, ExprError, ExprErrorKind, Quantity};

/// Standard atmosphere, the reference for gauge units such as "3 barg" \[Pa\].
pub const STANDARD_ATMOSPHERE: f64 = 101_325.0;

/// A unit: SI value = value · `factor` + `offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit {
    pub factor: f64,
    pub offset: f64,
    pub dimension: Dimension,
}

impl Unit {
    /// SI value of `value` expressed in this unit.
    pub fn to_si(self, value: f64) -> f64 {
        value * self.factor + self.offset
    }

    /// Value in this unit of the SI value `si`.
    pub fn in_unit(self, si: f64) -> f64 {
        (si - self.offset) / self.factor
    }
}

/// Parse "4 bar", "450 mm", "13.2 L/min/bar", "19 degC", "3 barg", "1e-5",
/// "0.98bar" into the SI value of `expected`.
/// A bare number (no unit) is taken as already SI.
pub fn parse_quantity(text: &str, expected: Dimension) -> Result<f64, UnitError> {
    let text = text.trim();
    if text.is_empty() {
        return Err(UnitError::Empty);
    }
    let bad_number = || UnitError::BadNumber { text: text.to_string() };
    let end = number_end(text).ok_or_else(bad_number)?;
    let (number, rest) = text.split_at(end);
    // "1.5.3 bar", "1,5 bar", "5-3": the number itself is malformed.
    if rest.starts_with(['.', ',', '+', '-']) {
        return Err(bad_number());
    }
    let value: f64 = number.parse().map_err(|_| bad_number())?;
    if !value.is_finite() {
        return Err(UnitError::NonFinite { text: text.to_string() });
    }
    let unit_text = rest.trim_start();
    if unit_text.is_empty() {
        return Ok(value);
    }
    // "5 /s" reads as 5 (1/s).
    let with_one;
    let unit_text = if unit_text.starts_with('/') {
        with_one = format!("1{unit_text}");
        &with_one
    } else {
        unit_text
    };
    let unit = parse::parse_unit_expr(unit_text).map_err(|e| match e {
        UnitError::UnknownUnit { unit, .. } => {
            UnitError::UnknownUnit { unit, accepted: format!("accepted for {}: {}", expected.name(), expected.accepted_list()) }
        }
        other => other,
    })?;
    if unit.dim != expected {
        return Err(UnitError::WrongDimension { unit: unit_text.to_string(), found: unit.dim, expected });
    }
    let si = unit.to_si(value);
    if si.is_finite() {
        Ok(si)
    } else {
        Err(UnitError::NonFinite { text: text.to_string() })
    }
}

/// Parse a unit expression alone ("L/min/bar") into (factor to SI, offset to
/// SI, dimension).
pub fn parse_unit(unit: &str) -> Result<Unit, UnitError> {
    let p = parse_trimmed(unit)?;
    Ok(Unit { factor: p.factor(), offset: p.offset, dimension: p.dim })
}

/// Convert an SI value into the given unit (for printing, e.g. "bar"):
/// (si - offset)/factor.
pub fn to_unit(si: f64, unit: &str) -> Result<f64, UnitError> {
    Ok(parse_trimmed(unit)?.in_unit(si))
}

fn parse_trimmed(unit: &str) -> Result<parse::Parsed, UnitError> {
    let unit = unit.trim();
    if unit.is_empty() {
        return Err(UnitError::Empty);
    }
    parse::parse_unit_expr(unit)
}

/// Byte length of the leading number `[+-] digits [. digits] [(e|E) [+-] digits]`
/// (at least one mantissa digit), or `None` if the text does not start with one.
fn number_end(s: &str) -> Option<usize> {
    let b = s.as_bytes();
    let digits_from = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        i
    };
    let mut i = usize::from(matches!(b.first(), Some(b'+' | b'-')));
    let int_end = digits_from(i);
    let mut mantissa_digits = int_end - i;
    i = int_end;
    if b.get(i) == Some(&b'.') {
        let frac_end = digits_from(i + 1);
        mantissa_digits += frac_end - (i + 1);
        i = frac_end;
    }
    if mantissa_digits == 0 {
        return None;
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        let mut j = i + 1;
        if matches!(b.get(j), Some(b'+' | b'-')) {
            j += 1;
        }
        let exp_end = digits_from(j);
        if exp_end > j {
            i = exp_end;
        }
    }
    Some(i)
}

#[cfg(test)]
mod tests;
