//! Unit symbol tables and the unit-expression parser.
//!
//! Grammar (whitespace between tokens is ignored except that it separates
//! symbols; juxtaposition means product):
//!
//! ```text
//! unit    := OFFSET_UNIT | expr            (OFFSET_UNIT: degC °C degF °F barg mbarg kPag MPag psig)
//! expr    := factor (('*' | '·' | ε) factor)* ('/' factor)*
//! factor  := primary exponent?
//! primary := SYMBOL | '1' | '(' expr ')'
//! exponent:= '^' ['+'|'-'] DIGITS | DIGITS directly after the symbol or ')' | '²' | '³'
//! ```
//!
//! Division is left-associative ("L/min/bar" = L/(min bar)). A product after
//! a '/' at the same level ("J/kg K") is rejected as ambiguous; write
//! "J/(kg K)". Exponents bind to the prefixed symbol: cm3 = (0.01 m)³.
//!
//! Conversion factors (exact by definition unless noted): min = 60 s,
//! h = 3600 s, bar = 1e5 Pa, atm = 101 325 Pa, L = 1e-3 m³,
//! deg = π/180 (an angle is a pure number, rad = 1),
//! psi = lbf/in² = 0.453 592 37 kg · 9.806 65 m/s² / (0.0254 m)²
//! ≈ 6894.757 Pa (NIST SP 811, App. B), degC: T = t + 273.15 K,
//! degF: T = (t + 459.67)·5/9 K.
//!
//! Factors are kept as (mantissa, power of ten) while parsing so that decimal
//! prefixes are applied by exact powers of ten: "450 mm" gives exactly the
//! double nearest to 0.45.

use crate::dimension::dim;
use crate::{Dimension, UnitError, STANDARD_ATMOSPHERE};

/// Pounds-force per square inch in Pa.
const PSI: f64 = 0.453_592_37 * 9.806_65 / (0.0254 * 0.0254);

/// (symbol, mantissa, power of ten, dimension, accepts SI prefixes)
type Symbol = (&'static str, f64, i32, Dimension, bool);

const SYMBOLS: &[Symbol] = &[
    ("m", 1.0, 0, dim::LENGTH, true),
    ("g", 1.0, -3, dim::MASS, true),
    ("s", 1.0, 0, dim::TIME, true),
    ("min", 60.0, 0, dim::TIME, false),
    ("h", 3600.0, 0, dim::TIME, false),
    ("Hz", 1.0, 0, dim::FREQUENCY, true),
    ("K", 1.0, 0, dim::TEMPERATURE, true),
    ("Pa", 1.0, 0, dim::PRESSURE, true),
    ("bar", 1.0, 5, dim::PRESSURE, true),
    ("psi", PSI, 0, dim::PRESSURE, false),
    ("atm", STANDARD_ATMOSPHERE, 0, dim::PRESSURE, false),
    ("N", 1.0, 0, dim::FORCE, true),
    ("J", 1.0, 0, dim::ENERGY, true),
    ("W", 1.0, 0, dim::POWER, true),
    ("L", 1.0, -3, dim::VOLUME, true),
    ("l", 1.0, -3, dim::VOLUME, true),
    // plane angles are pure numbers in SI (rad = m/m); the degree is π/180 rad
    ("rad", 1.0, 0, dim::DIMENSIONLESS, false),
    ("deg", std::f64::consts::PI / 180.0, 0, dim::DIMENSIONLESS, false),
];

/// SI prefixes (BIPM SI Brochure, Table 7), the subset useful here.
const PREFIXES: &[(&str, i32)] = &[
    ("n", -9),
    ("µ", -6), // U+00B5 micro sign
    ("μ", -6), // U+03BC Greek small mu
    ("u", -6),
    ("m", -3),
    ("c", -2),
    ("d", -1),
    ("k", 3),
    ("M", 6),
    ("G", 9),
];

/// Units with an offset, allowed only as the whole unit:
/// (symbol, factor, offset, dimension, offset-free unit to use in expressions).
const OFFSET_UNITS: &[(&str, f64, f64, Dimension, &str)] = &[
    ("degC", 1.0, 273.15, dim::TEMPERATURE, "K"),
    ("°C", 1.0, 273.15, dim::TEMPERATURE, "K"),
    ("degF", 5.0 / 9.0, 459.67 * 5.0 / 9.0, dim::TEMPERATURE, "K"),
    ("°F", 5.0 / 9.0, 459.67 * 5.0 / 9.0, dim::TEMPERATURE, "K"),
    ("barg", 1e5, STANDARD_ATMOSPHERE, dim::PRESSURE, "bar"),
    ("mbarg", 1e2, STANDARD_ATMOSPHERE, dim::PRESSURE, "mbar"),
    ("kPag", 1e3, STANDARD_ATMOSPHERE, dim::PRESSURE, "kPa"),
    ("MPag", 1e6, STANDARD_ATMOSPHERE, dim::PRESSURE, "MPa"),
    ("psig", PSI, STANDARD_ATMOSPHERE, dim::PRESSURE, "psi"),
];

/// A parsed unit: SI value = x · mant · 10^dec + offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Parsed {
    pub mant: f64,
    pub dec: i32,
    pub offset: f64,
    pub dim: Dimension,
}

/// x · 10^k using exact powers of ten (exact up to |k| = 22).
fn scale10(x: f64, k: i32) -> f64 {
    if k >= 0 {
        x * 10f64.powi(k)
    } else {
        x / 10f64.powi(-k)
    }
}

impl Parsed {
    const ONE: Parsed = Parsed { mant: 1.0, dec: 0, offset: 0.0, dim: dim::DIMENSIONLESS };

    pub fn to_si(self, x: f64) -> f64 {
        scale10(x * self.mant, self.dec) + self.offset
    }

    pub fn in_unit(self, si: f64) -> f64 {
        scale10((si - self.offset) / self.mant, -self.dec)
    }

    pub fn factor(self) -> f64 {
        scale10(self.mant, self.dec)
    }
}

/// One-line list of known symbols, for "unknown unit" messages.
pub(crate) fn known_symbols() -> String {
    let mut names: Vec<&str> = SYMBOLS.iter().map(|s| s.0).filter(|s| *s != "l").collect();
    names.extend(OFFSET_UNITS.iter().map(|s| s.0));
    format!("known: {}; prefixes n µ m c d k M G", names.join(", "))
}

/// Parse a whole unit string (already trimmed, non-empty).
pub(crate) fn parse_unit_expr(text: &str) -> Result<Parsed, UnitError> {
    if let Some(&(_, factor, offset, dim, _)) = OFFSET_UNITS.iter().find(|u| u.0 == text) {
        return Ok(Parsed { mant: factor, dec: 0, offset, dim });
    }
    let tokens = tokenize(text)?;
    let mut p = Parser { tokens, pos: 0, text, depth: 0 };
    let value = p.expr()?;
    if let Some(t) = p.peek() {
        return Err(p.syntax(format!("unexpected {}", t.describe())));
    }
    // Extreme exponents ("((km/m)^100)^100") over- or underflow the factor.
    let factor = value.factor();
    if !(factor.is_finite() && factor > 0.0) {
        return Err(p.syntax("conversion factor out of range"));
    }
    Ok(value)
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Sym(String),
    /// A standalone integer (only "1" is meaningful, as in "1/s").
    Num(String),
    /// An exponent, written "^-1", "^2", attached "3" or "²".
    Exp(i8),
    Mul,
    Div,
    Open,
    Close,
}

impl Tok {
    fn describe(&self) -> String {
        match self {
            Tok::Sym(s) => format!("\"{s}\""),
            Tok::Num(n) => format!("number {n} (write exponents as m^2 or m2)"),
            Tok::Exp(e) => format!("exponent {e}"),
            Tok::Mul => "'*'".into(),
            Tok::Div => "'/'".into(),
            Tok::Open => "'('".into(),
            Tok::Close => "')'".into(),
        }
    }
}

fn syntax(text: &str, reason: impl Into<String>) -> UnitError {
    UnitError::Syntax { expression: text.to_string(), reason: reason.into() }
}

fn tokenize(text: &str) -> Result<Vec<Tok>, UnitError> {
    let mut tokens = Vec::new();
    let mut chars = text.chars().peekable();
    while let Some(&c) = chars.peek() {
        let attached = matches!(tokens.last(), Some(Tok::Sym(_) | Tok::Close));
        if c.is_whitespace() {
            chars.next();
            // Whitespace ends a symbol, so "m 2" is not "m2".
            while chars.peek().is_some_and(|c| c.is_whitespace()) {
                chars.next();
            }
            if chars.peek().is_some_and(|c| c.is_ascii_digit()) {
                tokens.push(Tok::Num(take_while(&mut chars, |c| c.is_ascii_digit())));
            }
        } else if c.is_alphabetic() || c == '°' {
            tokens.push(Tok::Sym(take_while(&mut chars, |c| c.is_alphabetic() || c == '°')));
        } else if c.is_ascii_digit() {
            let digits = take_while(&mut chars, |c| c.is_ascii_digit());
            tokens.push(if attached { Tok::Exp(exponent(text, &digits)?) } else { Tok::Num(digits) });
        } else if c == '^' {
            chars.next();
            let mut s = String::new();
            if let Some(&sign @ ('-' | '+')) = chars.peek() {
                s.push(sign);
                chars.next();
            }
            s.push_str(&take_while(&mut chars, |c| c.is_ascii_digit()));
            tokens.push(Tok::Exp(exponent(text, &s)?));
        } else {
            chars.next();
            tokens.push(match c {
                '²' => Tok::Exp(2),
                '³' => Tok::Exp(3),
                '*' | '·' | '⋅' => Tok::Mul,
                '/' => Tok::Div,
                '(' => Tok::Open,
                ')' => Tok::Close,
                _ => return Err(syntax(text, format!("unexpected character '{c}'"))),
            });
        }
    }
    Ok(tokens)
}

fn take_while(chars: &mut std::iter::Peekable<std::str::Chars<'_>>, f: impl Fn(char) -> bool) -> String {
    let mut s = String::new();
    while let Some(&c) = chars.peek().filter(|c| f(**c)) {
        s.push(c);
        chars.next();
    }
    s
}

fn exponent(text: &str, s: &str) -> Result<i8, UnitError> {
    s.parse::<i8>().map_err(|_| syntax(text, format!("bad exponent \"{s}\" (write ^2, ^-1 or m2)")))
}

struct Parser<'a> {
    tokens: Vec<Tok>,
    pos: usize,
    text: &'a str,
    /// Current parenthesis depth, bounded to keep recursion shallow.
    depth: usize,
}

/// Deepest parenthesis nesting accepted.
const MAX_DEPTH: usize = 16;

impl Parser<'_> {
    fn syntax(&self, reason: impl Into<String>) -> UnitError {
        syntax(self.text, reason)
    }

    fn peek(&self) -> Option<&Tok> {
        self.tokens.get(self.pos)
    }

    fn expr(&mut self) -> Result<Parsed, UnitError> {
        let mut acc = self.factor()?;
        let mut divided = false;
        loop {
            match self.peek() {
                Some(Tok::Div) => {
                    self.pos += 1;
                    let f = self.factor()?;
                    acc = self.combine(acc, f, -1)?;
                    divided = true;
                }
                Some(Tok::Mul | Tok::Sym(_) | Tok::Open | Tok::Num(_)) => {
                    if divided {
                        return Err(self.syntax("ambiguous product after '/'; use parentheses, e.g. J/(kg K)"));
                    }
                    if self.peek() == Some(&Tok::Mul) {
                        self.pos += 1;
                    }
                    let f = self.factor()?;
                    acc = self.combine(acc, f, 1)?;
                }
                _ => return Ok(acc),
            }
        }
    }

    fn factor(&mut self) -> Result<Parsed, UnitError> {
        let tok = self.peek().cloned();
        self.pos += 1;
        let base = match tok {
            Some(Tok::Sym(s)) => lookup(&s, self.text)?,
            Some(Tok::Num(n)) if n == "1" => Parsed::ONE,
            Some(Tok::Open) => {
                if self.depth >= MAX_DEPTH {
                    return Err(self.syntax("too many nested parentheses"));
                }
                self.depth += 1;
                let inner = self.expr()?;
                self.depth -= 1;
                if self.peek() != Some(&Tok::Close) {
                    return Err(self.syntax("missing ')'"));
                }
                self.pos += 1;
                inner
            }
            Some(t) => return Err(self.syntax(format!("unexpected {}", t.describe()))),
            None => return Err(self.syntax("a unit is missing at the end")),
        };
        match self.peek() {
            Some(&Tok::Exp(n)) => {
                self.pos += 1;
                self.power(base, n)
            }
            _ => Ok(base),
        }
    }

    /// a · b (sign = 1) or a / b (sign = -1).
    fn combine(&self, a: Parsed, b: Parsed, sign: i8) -> Result<Parsed, UnitError> {
        let b_signed = self.power(b, sign)?;
        let dim = a.dim.mul(b_signed.dim);
        let dec = a.dec.checked_add(b_signed.dec);
        let (Some(dim), Some(dec)) = (dim, dec) else {
            return Err(self.syntax("exponent too large"));
        };
        // Divide rather than multiply by a rounded reciprocal.
        let mant = if sign > 0 { a.mant * b.mant } else { a.mant / b.mant };
        Ok(Parsed { mant, dec, offset: 0.0, dim })
    }

    fn power(&self, a: Parsed, n: i8) -> Result<Parsed, UnitError> {
        let dim = a.dim.pow(n);
        let dec = a.dec.checked_mul(i32::from(n));
        let (Some(dim), Some(dec)) = (dim, dec) else {
            return Err(self.syntax("exponent too large"));
        };
        Ok(Parsed { mant: a.mant.powi(n.into()), dec, offset: 0.0, dim })
    }
}

/// Resolve one symbol, possibly with an SI prefix.
fn lookup(sym: &str, text: &str) -> Result<Parsed, UnitError> {
    if let Some(u) = OFFSET_UNITS.iter().find(|u| u.0 == sym) {
        return Err(UnitError::OffsetInExpression { unit: sym.to_string(), expression: text.to_string(), instead: u.4 });
    }
    let plain = |s: &str| SYMBOLS.iter().find(|u| u.0 == s);
    if let Some(&(_, mant, dec, dim, _)) = plain(sym) {
        return Ok(Parsed { mant, dec, offset: 0.0, dim });
    }
    for &(prefix, p) in PREFIXES {
        if let Some(&(_, mant, dec, dim, true)) = sym.strip_prefix(prefix).and_then(plain) {
            return Ok(Parsed { mant, dec: dec + p, offset: 0.0, dim });
        }
    }
    Err(UnitError::UnknownUnit { unit: sym.to_string(), accepted: known_symbols() })
}
