//! Parameter declarations and validated parameter sets.
//!
//! Each block type declares its parameters once as [`ParamSpec`]s (name,
//! dimension, default, valid range, doc). Raw values from a netlist or the
//! command line (`4`, `"4 bar"`, `"extend"`) are turned into SI numbers here,
//! once, by [`Params::from_raw`]; blocks then read plain f64s. Unknown names,
//! wrong units and out-of-range values are errors that name the parameter.

use std::collections::BTreeMap;
use units::{parse_quantity, Dimension};

/// A raw parameter value as written by a user.
#[derive(Debug, Clone, PartialEq)]
pub enum RawValue {
    Number(f64),
    Text(String),
    /// A list of values (JSON array), for list parameters.
    List(Vec<RawValue>),
}

impl std::fmt::Display for RawValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            // as a message shows input: numbers readable, text escaped and
            // shortened, long lists cut (units::show)
            RawValue::Number(x) => write!(f, "{}", units::show::num(*x)),
            RawValue::Text(s) => write!(f, "\"{}\"", units::show::text(s)),
            RawValue::List(items) => {
                const SHOWN: usize = 6;
                let parts: Vec<String> = items.iter().take(SHOWN).map(|v| v.to_string()).collect();
                let more = if items.len() > SHOWN { format!(", … ({} items)", items.len()) } else { String::new() };
                write!(f, "[{}{more}]", parts.join(", "))
            }
        }
    }
}

/// What kind of value a parameter takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamKind {
    /// A physical quantity of this dimension (number in SI, or text with a unit).
    Quantity(Dimension),
    /// One word out of a list; stored as its index.
    Choice(&'static [&'static str]),
    /// A non-negative whole number.
    Count,
    /// A list of quantities of this dimension (JSON array, or text "0, 2 s, 4 s").
    List(Dimension),
    /// Free text, one or more lines (JSON array of strings, or one string):
    /// the steps and transitions of a sequencer, the names of its ports.
    Words,
}

/// Valid range of a quantity (SI), checked after unit conversion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Range {
    Any,
    /// x > 0
    Positive,
    /// x ≥ 0
    NonNegative,
    /// 0 < x < 1
    OpenUnit,
    /// lo ≤ x ≤ hi
    Closed(f64, f64),
    /// x > 0 or +∞ allowed ("inf")
    PositiveOrInfinite,
    /// An absolute temperature the gas models cover [K]: [`TEMPERATURE_MIN`, `TEMPERATURE_MAX`].
    GasTemperature,
    /// An absolute pressure: 0 < p ≤ [`PRESSURE_MAX`] [Pa].
    AbsolutePressure,
}

/// Lowest temperature accepted for gas [K] (below it air is no longer a gas at any useful pressure).
pub const TEMPERATURE_MIN: f64 = 20.0;
/// Highest temperature accepted for gas [K] (above it air dissociates; the cp(T) fits end at 6000 K).
pub const TEMPERATURE_MAX: f64 = 3000.0;
/// Highest absolute pressure accepted [Pa] (10 000 bar, far beyond pneumatics and the real-gas fit).
pub const PRESSURE_MAX: f64 = 1e9;

impl Range {
    fn check(self, x: f64) -> Result<(), String> {
        let ok = match self {
            Range::Any => x.is_finite(),
            Range::Positive => x.is_finite() && x > 0.0,
            Range::NonNegative => x.is_finite() && x >= 0.0,
            Range::OpenUnit => x > 0.0 && x < 1.0,
            Range::Closed(lo, hi) => x >= lo && x <= hi,
            Range::PositiveOrInfinite => x > 0.0 && !x.is_nan(),
            Range::GasTemperature => (TEMPERATURE_MIN..=TEMPERATURE_MAX).contains(&x),
            Range::AbsolutePressure => x > 0.0 && x <= PRESSURE_MAX,
        };
        if ok {
            Ok(())
        } else {
            Err(match self {
                Range::Any => "must be finite".into(),
                Range::Positive => "must be > 0".into(),
                Range::NonNegative => "must be >= 0".into(),
                Range::OpenUnit => "must be in (0, 1)".into(),
                Range::Closed(lo, hi) => format!("must be in [{}, {}]", units::show::num(lo), units::show::num(hi)),
                Range::PositiveOrInfinite => "must be > 0 (or \"inf\")".into(),
                Range::GasTemperature => format!("must lie between {TEMPERATURE_MIN} K and {TEMPERATURE_MAX} K (absolute)"),
                Range::AbsolutePressure => format!("must be > 0 and at most {} bar (absolute)", PRESSURE_MAX / 1e5),
            })
        }
    }
}

/// Declaration of one parameter of a block type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub kind: ParamKind,
    /// Default in SI (or choice index); `None` makes the parameter required.
    pub default: Option<f64>,
    pub range: Range,
    /// Unit used when showing the value to people ("bar", "L/min/bar").
    pub display_unit: &'static str,
    pub doc: &'static str,
}

impl ParamSpec {
    pub const fn quantity(
        name: &'static str,
        dim: Dimension,
        default: Option<f64>,
        range: Range,
        display_unit: &'static str,
        doc: &'static str,
    ) -> Self {
        Self { name, kind: ParamKind::Quantity(dim), default, range, display_unit, doc }
    }
    pub const fn choice(name: &'static str, options: &'static [&'static str], default: usize, doc: &'static str) -> Self {
        Self { name, kind: ParamKind::Choice(options), default: Some(default as f64), range: Range::Any, display_unit: "", doc }
    }
    pub const fn list(name: &'static str, dim: Dimension, range: Range, display_unit: &'static str, doc: &'static str) -> Self {
        Self { name, kind: ParamKind::List(dim), default: Some(0.0), range, display_unit, doc }
    }
    pub const fn count(name: &'static str, default: Option<f64>, doc: &'static str) -> Self {
        Self { name, kind: ParamKind::Count, default, range: Range::NonNegative, display_unit: "", doc }
    }
    /// Check an SI value against the parameter's range (a value set while the
    /// circuit runs, e.g. a live parameter driven by an interface input).
    pub fn check(&self, si: f64) -> Result<(), ParamError> {
        self.range.check(si).map_err(|reason| ParamError::OutOfRange { name: self.name.into(), value: units::show::num(si), reason })
    }
    /// Free text (one string or a list of strings); `required` makes it mandatory.
    pub const fn words(name: &'static str, required: bool, doc: &'static str) -> Self {
        Self { name, kind: ParamKind::Words, default: if required { None } else { Some(0.0) }, range: Range::Any, display_unit: "", doc }
    }
}

/// Total number of parameters in a list of parameter sets (for [`param_set!`]).
pub const fn total_len(parts: &[&[ParamSpec]]) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < parts.len() {
        n += parts[i].len();
        i += 1;
    }
    n
}

/// The parameter sets one after the other (for [`param_set!`]); `N` must be their total length.
pub const fn concat<const N: usize>(parts: &[&[ParamSpec]]) -> [ParamSpec; N] {
    const BLANK: ParamSpec = ParamSpec::count("", None, "");
    let mut out = [BLANK; N];
    let (mut k, mut i) = (0, 0);
    while i < parts.len() {
        let mut j = 0;
        while j < parts[i].len() {
            out[k] = parts[i][j];
            k += 1;
            j += 1;
        }
        i += 1;
    }
    assert!(k == N, "concat: N is not the total length");
    out
}

/// A block's parameter list made of shared sets and its own declarations,
/// evaluated at compile time: `param_set!(iso6358::PARAMS, &[ParamSpec::quantity(...)])`.
/// Shared sets (the ISO 6358 characteristic, the thermal wall) are declared
/// once and reused this way.
#[macro_export]
macro_rules! param_set {
    ($($part:expr),+ $(,)?) => {{
        const PARTS: &[&[$crate::params::ParamSpec]] = &[$($part),+];
        const N: usize = $crate::params::total_len(PARTS);
        const OUT: [$crate::params::ParamSpec; N] = $crate::params::concat::<N>(PARTS);
        &OUT
    }};
}

/// Why a parameter could not be accepted. The component id is added by the caller.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("unknown parameter \"{name}\"{hint} (accepted: {accepted})")]
    Unknown { name: String, hint: String, accepted: String },
    #[error("missing required parameter \"{name}\" ({doc})")]
    Missing { name: String, doc: String },
    #[error("parameter \"{name}\" = {value}: {source}")]
    Unit { name: String, value: String, source: units::UnitError },
    #[error("parameter \"{name}\" = {value} {reason}")]
    OutOfRange { name: String, value: String, reason: String },
    #[error("parameter \"{name}\" = {value}: expected one of {options}")]
    BadChoice { name: String, value: String, options: String },
    #[error("parameter \"{name}\": {reason}")]
    Invalid { name: String, reason: String },
}

/// Parsed, validated parameters of one component, in SI.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params {
    values: BTreeMap<&'static str, f64>,
    lists: BTreeMap<&'static str, Vec<f64>>,
    words: BTreeMap<&'static str, Vec<String>>,
    given: Vec<&'static str>,
}

impl Params {
    /// Parse raw values against the specs: converts units, applies defaults,
    /// checks ranges, and rejects unknown names.
    pub fn from_raw<'a>(specs: &'static [ParamSpec], raw: impl IntoIterator<Item = (&'a str, &'a RawValue)>) -> Result<Params, ParamError> {
        let mut values = BTreeMap::new();
        let mut lists = BTreeMap::new();
        let mut words = BTreeMap::new();
        let mut given = Vec::new();
        for (name, value) in raw {
            let spec = specs.iter().find(|s| s.name == name).ok_or_else(|| ParamError::Unknown {
                name: name.to_string(),
                hint: crate::suggest::did_you_mean(name, specs.iter().map(|s| s.name)),
                accepted: specs.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
            })?;
            match spec.kind {
                ParamKind::List(_) => {
                    lists.insert(spec.name, parse_list(spec, value)?);
                }
                ParamKind::Words => {
                    words.insert(spec.name, parse_words(spec, value)?);
                }
                _ => {
                    values.insert(spec.name, parse_value(spec, value)?);
                }
            }
            given.push(spec.name);
        }
        for spec in specs {
            if let ParamKind::List(_) = spec.kind {
                lists.entry(spec.name).or_default();
                continue;
            }
            if let ParamKind::Words = spec.kind {
                if spec.default.is_none() && !words.contains_key(spec.name) {
                    return Err(ParamError::Missing { name: spec.name.into(), doc: spec.doc.into() });
                }
                words.entry(spec.name).or_default();
                continue;
            }
            if !values.contains_key(spec.name) {
                match spec.default {
                    Some(d) => {
                        values.insert(spec.name, d);
                    }
                    None => return Err(ParamError::Missing { name: spec.name.into(), doc: spec.doc.into() }),
                }
            }
        }
        Ok(Params { values, lists, words, given })
    }

    /// Lines of a text parameter (empty if not given).
    pub fn words(&self, name: &str) -> &[String] {
        self.words.get(name).map(|v| v.as_slice()).unwrap_or(&[])
    }

    /// Values of a list parameter (empty if not given).
    pub fn list(&self, name: &str) -> &[f64] {
        self.lists.get(name).map(|v| v.as_slice()).unwrap_or(&[])
    }

    /// SI value of a declared parameter (0 if undeclared: a programming error caught by tests).
    pub fn get(&self, name: &str) -> f64 {
        debug_assert!(self.values.contains_key(name), "undeclared parameter {name}");
        self.values.get(name).copied().unwrap_or(0.0)
    }

    /// Index of a choice parameter.
    pub fn choice(&self, name: &str) -> usize {
        self.get(name) as usize
    }

    /// Whether the user gave this parameter explicitly (rather than its default).
    pub fn was_given(&self, name: &str) -> bool {
        self.given.contains(&name)
    }
}

/// Convert a list parameter: a JSON array or a comma-separated text.
pub fn parse_list(spec: &ParamSpec, value: &RawValue) -> Result<Vec<f64>, ParamError> {
    let ParamKind::List(dim) = spec.kind else {
        return Err(ParamError::Invalid { name: spec.name.into(), reason: "is not a list parameter".into() });
    };
    let items: Vec<RawValue> = match value {
        RawValue::List(items) => items.clone(),
        RawValue::Number(x) => vec![RawValue::Number(*x)],
        RawValue::Text(s) => s.split(',').map(|p| RawValue::Text(p.trim().to_string())).collect(),
    };
    let scalar = ParamSpec { kind: ParamKind::Quantity(dim), ..*spec };
    items.iter().map(|item| parse_value(&scalar, item)).collect()
}

/// Lines of a text parameter: a JSON array of strings, or one string.
pub fn parse_words(spec: &ParamSpec, value: &RawValue) -> Result<Vec<String>, ParamError> {
    let bad = || ParamError::Invalid { name: spec.name.into(), reason: format!("expected text or a list of texts, got {value}") };
    match value {
        RawValue::Text(s) => Ok(vec![s.clone()]),
        RawValue::List(items) => items.iter().map(|v| if let RawValue::Text(s) = v { Ok(s.clone()) } else { Err(bad()) }).collect(),
        RawValue::Number(_) => Err(bad()),
    }
}

/// Convert one raw value according to its spec.
pub fn parse_value(spec: &ParamSpec, value: &RawValue) -> Result<f64, ParamError> {
    let shown = value.to_string();
    let x = match (spec.kind, value) {
        (ParamKind::Quantity(_), RawValue::Number(x)) => *x,
        (_, RawValue::List(_)) => {
            return Err(ParamError::Invalid { name: spec.name.into(), reason: format!("expected a single value, got the list {shown}") })
        }
        (ParamKind::List(_), _) => return Err(ParamError::Invalid { name: spec.name.into(), reason: "is a list".into() }),
        (ParamKind::Words, _) => return Err(ParamError::Invalid { name: spec.name.into(), reason: "is text, not a number".into() }),
        (ParamKind::Quantity(dim), RawValue::Text(s)) => {
            if spec.range == Range::PositiveOrInfinite && matches!(s.trim(), "inf" | "infinity" | "∞") {
                f64::INFINITY
            } else {
                parse_quantity(s, dim).map_err(|source| match source {
                    // the message quotes the input itself, briefly: not twice
                    units::UnitError::NonFinite { .. } => ParamError::Invalid { name: spec.name.into(), reason: source.to_string() },
                    _ => ParamError::Unit { name: spec.name.into(), value: shown.clone(), source },
                })?
            }
        }
        (ParamKind::Choice(options), RawValue::Text(s)) => match options.iter().position(|o| o.eq_ignore_ascii_case(s.trim())) {
            Some(i) => return Ok(i as f64),
            None => return Err(ParamError::BadChoice { name: spec.name.into(), value: shown, options: options.join(", ") }),
        },
        (ParamKind::Choice(options), RawValue::Number(_)) => {
            return Err(ParamError::BadChoice { name: spec.name.into(), value: shown, options: options.join(", ") })
        }
        (ParamKind::Count, RawValue::Number(x)) if *x >= 0.0 && x.fract() == 0.0 => *x,
        (ParamKind::Count, RawValue::Text(s)) => match s.trim().parse::<u64>() {
            Ok(n) => n as f64,
            Err(_) => {
                return Err(ParamError::OutOfRange { name: spec.name.into(), value: shown, reason: "must be a whole number >= 0".into() })
            }
        },
        (ParamKind::Count, RawValue::Number(_)) => {
            return Err(ParamError::OutOfRange { name: spec.name.into(), value: shown, reason: "must be a whole number >= 0".into() })
        }
    };
    spec.range.check(x).map_err(|reason| ParamError::OutOfRange { name: spec.name.into(), value: shown, reason })?;
    Ok(x)
}
