//! Arithmetic expressions on quantities with units, checked for dimensions.
//!
//! Netlist parameters may be written as expressions instead of single
//! quantities, e.g. `"= supply.p - 0.5 bar"` or `"= pi/4 * (45 mm)^2 * 450 mm"`.
//! This module parses one such expression into an [`Expr`] and evaluates it
//! to a [`Quantity`]: an SI `f64` (absolute: kelvin, absolute pascal)
//! together with its [`Dimension`]. Names (`supply.p`, `bore`) are resolved
//! through a callback, so whoever evaluates decides what a name means and in
//! which order parameters are computed; [`Expr::names`] lists the names an
//! expression needs.
//!
//! ```
//! use units::{dim, parse_expr, Quantity};
//! let e = parse_expr("= pi/4 * bore^2").unwrap();
//! assert_eq!(e.names(), ["bore"]);
//! let mut lookup = |name: &str| (name == "bore").then_some(Quantity::new(0.045, dim::LENGTH));
//! let area = e.eval_as(dim::AREA, &mut lookup).unwrap();
//! assert!((area - std::f64::consts::PI / 4.0 * 0.045 * 0.045).abs() < 1e-18);
//!
//! // Literals carry units; the result is SI.
//! let v = parse_expr("4 bar - 0.98 bar").unwrap().eval_as(dim::PRESSURE, &mut |_| None).unwrap();
//! assert_eq!(v, 302_000.0);
//!
//! // Errors are one line and give the 1-based character column in the text as written.
//! let err = parse_expr("= 2 bar + 3 mm").unwrap().eval(&mut |_| None).unwrap_err();
//! assert_eq!(err.to_string(), "column 9: cannot add a length to a pressure");
//! ```
//!
//! # Grammar
//!
//! ```text
//! input   := [whitespace] ['=' ] sum            (a leading '=' is skipped)
//! sum     := product (('+' | '-') product)*     left-associative
//! product := unary (('*' | '/') unary)*         left-associative
//! unary   := ('-' | '+') unary | power
//! power   := primary ['^' unary]                right-associative
//! primary := literal | name | FUNCTION '(' sum (',' sum)* ')' | '(' sum ')'
//! literal := NUMBER [unit]
//! unit    := [whitespace] '[' UNIT ']' | [whitespace] UNIT_WORD
//! name    := IDENT ('.' IDENT)*                 IDENT = [A-Za-z_][A-Za-z0-9_]*
//! ```
//!
//! * NUMBER is Rust/JSON float syntax without a sign: `4`, `0.5`, `.5`,
//!   `1e-5`, `2.5E+3`. A bare number is dimensionless.
//! * A number may be followed by a unit, which makes the literal a quantity
//!   converted to SI at parse time: either any unit the unit parser accepts
//!   in brackets, `2e-4 [N s/(m Pa)]`, or one unit word, `4 bar`, `45 mm`,
//!   `13.2 L/min/bar`, `20 cm3`, `19 degC`, `3 barg`, `2 m^-1`. A unit word
//!   is letters (including `°` and `µ`) and digits, joined by `/` before a
//!   letter and by `^` before an optional sign and digits; it stops at
//!   anything else, so `4 bar/2` is (4 bar)/2 and `4 m^x` is (4 m)^x. A unit
//!   of several words or with parentheses needs brackets: `2 [N s/m]`,
//!   `13.2 [L/(min bar)]`. Where a unit word and a following `/(...)` would
//!   read as one unit, as in `13.2 L/(min bar)`, that is an error asking for
//!   brackets; otherwise `/(...)` divides: `4 bar/(x + 1)`. A word after a
//!   number that is not a unit is an error (`2 V_port`: write `2 * V_port`).
//! * A literal with a unit is one value: `x / 2 mm` is x/(2 mm), and
//!   `(45 mm)^2` squares the quantity while `45 mm^2` is 45 square millimetres.
//! * Affine and gauge units (`degC`, `degF`, `barg`, `psig`, ...) convert to
//!   absolute SI values, as [`crate::parse_quantity`] does: `19 degC` is
//!   292.15 K and `3 barg` is 401 325 Pa. A minus sign written directly before
//!   such a literal belongs to the number (`-10 degC` is 263.15 K, whereas
//!   `-(10 degC)` is -283.15 K). Sums mix absolute values: `20 degC - 10 degC`
//!   is 10 K, but `T + 5 degC` adds 278.15 K; write differences in K or bar.
//! * Names are identifiers joined by dots: `supply.p`, `cyl.head.p0`,
//!   `V_port`. A hyphen is always minus (`a-b` is a - b). A name followed by
//!   `(` is a function call, so a parameter may share a function's name.
//! * `pi` (without dots) is always π = 3.14159...; a parameter cannot be
//!   named `pi` (but `cyl.pi` is an ordinary name).
//! * Operators, loosest first: `+ -`, then `* /`, then unary `-`/`+`, then
//!   `^`. So `-x^2` = -(x²), `2^3^2` = 2^9 = 512, `1 - 2 - 3` = -4, `8/4/2` = 1,
//!   and `2^-1` = 0.5 (the exponent may carry a sign).
//! * Functions: `sqrt(x)`, `abs(x)`; `min`, `max` and `hypot` of two or more
//!   arguments of one dimension; `exp`, `ln`, `log10`, `sin`, `cos`, `tan`
//!   (radians) of one dimensionless number.
//! * Nesting (parentheses, signs, powers, calls) is limited to 64 levels.
//!
//! # Dimension rules
//!
//! * `+` and `-` need equal dimensions; a dimensionless 0 is not special, so
//!   `p + 0` is an error when p is a pressure.
//! * `*` and `/` multiply and divide dimensions.
//! * In `a ^ b`, b must be dimensionless. If a has a dimension, b must be an
//!   integer (within 1e-9) and the powers of kg, m, s, K must stay within the
//!   range of [`Dimension`] (i8).
//! * `sqrt` needs even powers (m² gives m; m³ is an error), `abs` keeps the
//!   dimension, `min`/`max`/`hypot` need all arguments alike, and
//!   `exp`/`ln`/`log10`/trigonometric functions need dimensionless arguments.
//! * Every intermediate result must be finite: division by zero, overflow
//!   and results that are not real (`sqrt` of a negative number, `ln` of a
//!   non-positive one, a negative number to a fractional power) are errors
//!   at the column of the operator or function.
//!
//! Errors ([`ExprError`]) are one line, `column N: message`, where N is the
//! 1-based character column in the text as given (including any leading `=`
//! and whitespace). Control and other invisible characters from the input are
//! shown escaped as `\u{..}`, so that input cannot forge lines in a log.

use std::f64::consts::PI;
use std::fmt::{self, Write as _};

use crate::dimension::dim;
use crate::parse::{parse_unit_expr, Parsed};
use crate::{number_end, Dimension, UnitError};

/// Deepest nesting of parentheses, signs, powers and calls.
const MAX_DEPTH: usize = 64;

/// Largest distance of a dimensioned base's exponent from an integer.
const INTEGER_TOLERANCE: f64 = 1e-9;

/// A value in SI units (absolute temperature and pressure) with its dimension.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantity {
    pub value: f64,
    pub dim: Dimension,
}

impl Quantity {
    pub const fn new(value: f64, dim: Dimension) -> Quantity {
        Quantity { value, dim }
    }

    /// A pure number.
    pub const fn dimensionless(value: f64) -> Quantity {
        Quantity { value, dim: dim::DIMENSIONLESS }
    }
}

/// Whether a parameter's text is an expression: it starts with '=' after
/// optional whitespace.
pub fn is_expression(text: &str) -> bool {
    text.trim_start().starts_with('=')
}

// ---------------------------------------------------------------------------
// Errors

/// Why an expression could not be parsed or evaluated, and where: `column`
/// is the 1-based character column in the text given to [`parse_expr`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("column {column}: {kind}")]
pub struct ExprError {
    pub column: usize,
    pub kind: ExprErrorKind,
}

/// What went wrong; its `Display` is the message after "column N: ".
/// Strings from the input are escaped when displayed.
#[derive(Debug, Clone, PartialEq)]
pub enum ExprErrorKind {
    /// Nothing after the optional '='.
    Empty,
    /// Malformed text: a missing value, operator or parenthesis, an unexpected character.
    Syntax(String),
    /// A number that cannot be read, or is out of the range of f64.
    BadNumber { number: String, reason: &'static str },
    /// A unit symbol after a number that is not known (often a name written without '*').
    UnknownUnit { unit: String, hint: String },
    /// Any other error of the unit after a number.
    Unit(UnitError),
    /// The lookup did not know this name.
    UnknownName(String),
    /// A call of something that is not one of the functions.
    UnknownFunction(String),
    /// A function called with the wrong number of arguments.
    ArgumentCount { function: &'static str, expected: &'static str, found: usize },
    /// `+` or `-` of different dimensions.
    DimensionMismatch { subtract: bool, left: Dimension, right: Dimension },
    /// An exponent that is not dimensionless, not an integer for a dimensioned base, or too large.
    BadExponent(String),
    /// A function argument of a dimension the function does not accept.
    ArgumentDimension(String),
    /// A product or quotient whose dimension exponents do not fit.
    DimensionOutOfRange(String),
    /// Division by zero (also zero to a negative power).
    DivisionByZero,
    /// An infinite or NaN result: overflow, sqrt of a negative number, ln of zero, ...
    NonFinite(String),
    /// The result has another dimension than [`Expr::eval_as`] asked for.
    WrongDimension { found: Dimension, expected: Dimension },
    /// More than 64 levels of nesting.
    TooDeep,
}

impl fmt::Display for ExprErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExprErrorKind::Empty => f.write_str("empty expression"),
            ExprErrorKind::Syntax(m)
            | ExprErrorKind::BadExponent(m)
            | ExprErrorKind::ArgumentDimension(m)
            | ExprErrorKind::DimensionOutOfRange(m)
            | ExprErrorKind::NonFinite(m) => write!(f, "{}", Escaped(m)),
            ExprErrorKind::BadNumber { number, reason } => write!(f, "number \"{}\" {reason}", shown(number)),
            ExprErrorKind::UnknownUnit { unit, hint } => write!(f, "unknown unit \"{}\" {}", shown(unit), Escaped(hint)),
            ExprErrorKind::Unit(e) => write!(f, "{}", Escaped(&e.to_string())),
            ExprErrorKind::UnknownName(name) => write!(f, "unknown name \"{}\"", shown(name)),
            ExprErrorKind::UnknownFunction(name) => {
                let known: Vec<&str> = FUNCTIONS.iter().map(|(n, _)| *n).collect();
                write!(f, "unknown function \"{}\" (known: {})", shown(name), known.join(", "))
            }
            ExprErrorKind::ArgumentCount { function, expected, found } => {
                write!(f, "{function} takes {expected}, found {found}")
            }
            ExprErrorKind::DimensionMismatch { subtract: false, left, right } => {
                write!(f, "cannot add {} to {}", right.with_article(), left.with_article())
            }
            ExprErrorKind::DimensionMismatch { subtract: true, left, right } => {
                write!(f, "cannot subtract {} from {}", right.with_article(), left.with_article())
            }
            ExprErrorKind::DivisionByZero => f.write_str("division by zero"),
            ExprErrorKind::WrongDimension { found, expected } => write!(
                f,
                "the expression gives {}, expected {} (units: {})",
                found.with_article(),
                expected.with_article(),
                expected.accepted_list()
            ),
            ExprErrorKind::TooDeep => write!(f, "expression nested too deeply (more than {MAX_DEPTH} levels)"),
        }
    }
}

impl std::error::Error for ExprErrorKind {}

fn error(column: usize, kind: ExprErrorKind) -> ExprError {
    ExprError { column, kind }
}

fn syntax(column: usize, message: String) -> ExprError {
    error(column, ExprErrorKind::Syntax(message))
}

/// Displays a whole message with hidden characters
/// ([`crate::show::is_hidden`]) as `\u{..}`; the input it quotes is
/// already shortened by [`crate::show::text`].
struct Escaped<'a>(&'a str);

impl fmt::Display for Escaped<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            if crate::show::is_hidden(c) {
                write!(f, "\\u{{{:x}}}", u32::from(c))?;
            } else {
                f.write_char(c)?;
            }
        }
        Ok(())
    }
}

use crate::show::{num as show, text as shown};

// ---------------------------------------------------------------------------
// Syntax tree

/// A parsed expression; evaluate it with [`Expr::eval`] or [`Expr::eval_as`].
/// `Display` writes it back in a normalized form that parses to the same value.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    node: Node,
    /// Column where the expression proper starts (after '=' and whitespace).
    column: usize,
}

#[derive(Clone, Debug, PartialEq)]
enum Node {
    Literal(Box<Literal>),
    Pi,
    Name {
        name: String,
        column: usize,
    },
    Neg(Box<Node>),
    /// first (+|- operand)*, evaluated left to right.
    Sum {
        first: Box<Node>,
        rest: Vec<Operand>,
    },
    /// first (*|/ operand)*, evaluated left to right.
    Product {
        first: Box<Node>,
        rest: Vec<Operand>,
    },
    Pow {
        base: Box<Node>,
        exponent: Box<Node>,
        column: usize,
    },
    Call {
        func: Func,
        column: usize,
        args: Vec<Node>,
    },
}

#[derive(Clone, Debug, PartialEq)]
struct Operand {
    op: char,
    /// Column of the operator.
    column: usize,
    node: Node,
}

/// A number with an optional unit, already converted to SI.
#[derive(Clone, Debug, PartialEq)]
struct Literal {
    /// The number as written (with a '-' when a sign was folded into it).
    text: String,
    number: f64,
    unit: Option<LiteralUnit>,
    value: Quantity,
}

#[derive(Clone, Debug, PartialEq)]
struct LiteralUnit {
    text: String,
    bracketed: bool,
    parsed: Parsed,
}

impl Literal {
    fn has_offset(&self) -> bool {
        self.unit.as_ref().is_some_and(|u| u.parsed.offset != 0.0)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Func {
    Sqrt,
    Abs,
    Min,
    Max,
    Hypot,
    Exp,
    Ln,
    Log10,
    Sin,
    Cos,
    Tan,
}

const FUNCTIONS: &[(&str, Func)] = &[
    ("sqrt", Func::Sqrt),
    ("abs", Func::Abs),
    ("min", Func::Min),
    ("max", Func::Max),
    ("hypot", Func::Hypot),
    ("exp", Func::Exp),
    ("ln", Func::Ln),
    ("log10", Func::Log10),
    ("sin", Func::Sin),
    ("cos", Func::Cos),
    ("tan", Func::Tan),
];

impl Func {
    fn from_name(name: &str) -> Option<Func> {
        FUNCTIONS.iter().find(|(n, _)| *n == name).map(|&(_, f)| f)
    }

    fn name(self) -> &'static str {
        FUNCTIONS.iter().find(|(_, f)| *f == self).map_or("?", |&(n, _)| n)
    }

    /// min, max and hypot take two or more arguments, the others one.
    fn variadic(self) -> bool {
        matches!(self, Func::Min | Func::Max | Func::Hypot)
    }
}

// ---------------------------------------------------------------------------
// Lexer

#[derive(Clone, Debug)]
enum TokKind {
    Number(Box<Literal>),
    Name(String),
    /// One of + - * / ^ ( ) ,
    Sym(char),
    End,
}

#[derive(Clone, Debug)]
struct Tok {
    kind: TokKind,
    column: usize,
    /// Source text of the token, for messages.
    text: String,
}

impl Tok {
    fn describe(&self) -> String {
        match &self.kind {
            TokKind::Number(_) => format!("number \"{}\"", shown(&self.text)),
            TokKind::Name(_) => format!("name \"{}\"", shown(&self.text)),
            TokKind::Sym(c) => format!("\"{c}\""),
            TokKind::End => "the end".to_string(),
        }
    }
}

struct Lexer<'a> {
    text: &'a str,
    /// (byte offset, char); the column of chars[i] is i + 1.
    chars: Vec<(usize, char)>,
    i: usize,
    toks: Vec<Tok>,
}

fn is_ident_start(c: Option<char>) -> bool {
    c.is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
}

fn is_unit_letter(c: Option<char>) -> bool {
    c.is_some_and(|c| c.is_alphabetic() || c == '°')
}

impl Lexer<'_> {
    fn at(&self, i: usize) -> Option<char> {
        self.chars.get(i).map(|&(_, c)| c)
    }

    fn slice(&self, from: usize, to: usize) -> String {
        self.chars.get(from..to).unwrap_or_default().iter().map(|&(_, c)| c).collect()
    }

    fn skip_whitespace(&mut self) {
        while self.at(self.i).is_some_and(char::is_whitespace) {
            self.i += 1;
        }
    }

    /// Tokens up to and including End, or up to the first error.
    fn run(&mut self) -> Result<(), ExprError> {
        loop {
            self.skip_whitespace();
            let start = self.i;
            let Some(c) = self.at(start) else {
                self.toks.push(Tok { kind: TokKind::End, column: start + 1, text: String::new() });
                return Ok(());
            };
            let kind = if c.is_ascii_digit() || (c == '.' && self.at(start + 1).is_some_and(|d| d.is_ascii_digit())) {
                TokKind::Number(Box::new(self.literal()?))
            } else if is_ident_start(Some(c)) {
                TokKind::Name(self.name()?)
            } else if "+-*/^(),".contains(c) {
                self.i += 1;
                TokKind::Sym(c)
            } else {
                return Err(syntax(start + 1, unexpected_character(c)));
            };
            let text = self.slice(start, self.i);
            self.toks.push(Tok { kind, column: start + 1, text });
        }
    }

    fn name(&mut self) -> Result<String, ExprError> {
        let start = self.i;
        loop {
            while self.at(self.i).is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
                self.i += 1;
            }
            if self.at(self.i) != Some('.') {
                return Ok(self.slice(start, self.i));
            }
            if !is_ident_start(self.at(self.i + 1)) {
                let so_far = self.slice(start, self.i + 1);
                return Err(syntax(self.i + 2, format!("expected a name after \"{}\"", shown(&so_far))));
            }
            self.i += 1;
        }
    }

    /// A number and its optional unit.
    fn literal(&mut self) -> Result<Literal, ExprError> {
        let start = self.i;
        let column = start + 1;
        let byte = self.chars.get(start).map_or(self.text.len(), |&(b, _)| b);
        let rest = self.text.get(byte..).unwrap_or_default();
        // The caller saw a digit or ".digit"; number_end counts ASCII bytes, i.e. chars.
        let len = number_end(rest).unwrap_or(0).max(1);
        let text = rest.get(..len).unwrap_or_default().to_string();
        self.i = start + len;
        if let Some(c) = self.at(self.i).filter(|&c| c == '.' || c == '_' || c.is_ascii_digit()) {
            return Err(error(column, ExprErrorKind::BadNumber { number: format!("{text}{c}"), reason: "is malformed" }));
        }
        let number: f64 =
            text.parse().map_err(|_| error(column, ExprErrorKind::BadNumber { number: text.clone(), reason: "is malformed" }))?;
        if !number.is_finite() {
            return Err(error(column, ExprErrorKind::BadNumber { number: text, reason: "is out of range" }));
        }
        let after_number = self.i;
        self.skip_whitespace();
        let unit = match self.at(self.i) {
            Some('[') => Some(self.bracketed_unit(&text)?),
            c if is_unit_letter(c) => Some(self.unit_word(&text)?),
            _ => {
                self.i = after_number;
                None
            }
        };
        let value = match &unit {
            None => Quantity::dimensionless(number),
            Some(u) => Quantity::new(u.parsed.to_si(number), u.parsed.dim),
        };
        if !value.value.is_finite() {
            let number = self.slice(start, self.i);
            return Err(error(column, ExprErrorKind::BadNumber { number, reason: "is out of range" }));
        }
        Ok(Literal { text, number, unit, value })
    }

    fn unit_word(&mut self, number: &str) -> Result<LiteralUnit, ExprError> {
        let start = self.i;
        loop {
            let c = self.at(self.i);
            let next = self.at(self.i + 1);
            match c {
                Some(c) if c.is_alphabetic() || c.is_ascii_digit() || matches!(c, '°' | '²' | '³' | '_') => self.i += 1,
                // Let a dotted name through, to say "write 2 * supply.p".
                Some('.') if is_ident_start(next) => self.i += 1,
                Some('/' | '·' | '⋅') if is_unit_letter(next) => self.i += 1,
                Some('^') => {
                    let digits_at = if matches!(next, Some('+' | '-')) { self.i + 2 } else { self.i + 1 };
                    if !self.at(digits_at).is_some_and(|d| d.is_ascii_digit()) {
                        break;
                    }
                    self.i = digits_at;
                }
                _ => break,
            }
        }
        let word = self.slice(start, self.i);
        // "2 L/(min bar)": a unit word stops before '(', so this would divide
        // by a parenthesized expression. When the whole reads as a unit, the
        // text is ambiguous: ask for brackets (or explicit parentheses).
        if self.at(self.i) == Some('/') && self.at(self.i + 1) == Some('(') {
            if let Some(close) = self.matching_parenthesis(self.i + 1) {
                let whole = format!("{word}{}", self.slice(self.i, close + 1));
                if parse_unit_expr(&whole).is_ok() {
                    let number = shown(number);
                    let message = format!(
                        "a unit with parentheses must be in brackets: write {number} [{whole}] \
                         (or ({number} {word})/(...) to divide by an expression)"
                    );
                    return Err(syntax(self.i + 1, message));
                }
            }
        }
        unit_of(&word, start + 1, number, false)
    }

    /// Index of the ')' closing the '(' at `open`, if within a unit's length.
    fn matching_parenthesis(&self, open: usize) -> Option<usize> {
        const LONGEST_UNIT: usize = 100;
        let mut depth = 0usize;
        for j in open..self.chars.len().min(open + LONGEST_UNIT) {
            match self.at(j) {
                Some('(') => depth += 1,
                Some(')') => {
                    depth = depth.checked_sub(1)?;
                    if depth == 0 {
                        return Some(j);
                    }
                }
                _ => {}
            }
        }
        None
    }

    fn bracketed_unit(&mut self, number: &str) -> Result<LiteralUnit, ExprError> {
        let open = self.i;
        let Some(close) = (open + 1..self.chars.len()).find(|&j| self.at(j) == Some(']')) else {
            return Err(syntax(open + 1, "missing \"]\" after the unit".to_string()));
        };
        let first = (open + 1..close).find(|&j| !self.at(j).is_some_and(char::is_whitespace)).unwrap_or(close);
        let inner = self.slice(open + 1, close);
        self.i = close + 1;
        let inner = inner.trim();
        if inner.is_empty() {
            return Err(syntax(open + 1, "empty unit \"[]\"".to_string()));
        }
        unit_of(inner, first + 1, number, true)
    }
}

fn unexpected_character(c: char) -> String {
    let hint = match c {
        '[' => " (a unit in brackets must follow a number, e.g. 2 [N s/m])",
        '·' | '⋅' | '×' => " (write * to multiply)",
        '²' | '³' => " (write ^2 or ^3)",
        '−' | '–' => " (write - for minus)",
        '=' => " (only one \"=\" is allowed, at the start)",
        _ => "",
    };
    format!("unexpected character \"{c}\"{hint}")
}

/// The unit of a literal, from a word (`bar`, `L/min/bar`) or bracket contents.
fn unit_of(text: &str, column: usize, number: &str, bracketed: bool) -> Result<LiteralUnit, ExprError> {
    // Names have '_' or '.', units never: "2 V_port", "4 bar/supply.p".
    let name_like = |t: &str| t.contains(['_', '.']);
    // what the hints quote, shortened
    let (number_s, text_s) = (shown(number), shown(text));
    if !bracketed && name_like(text) {
        let (head, tail) = text.rsplit_once('/').unwrap_or(("", text));
        if head.is_empty() && !text.contains('^') {
            let hint = format!("after {number_s} (write {number_s} * {text_s} to multiply by a parameter)");
            return Err(error(column, ExprErrorKind::UnknownUnit { unit: text.to_string(), hint }));
        }
        if !head.is_empty() && !name_like(head) && !tail.contains('^') {
            let hint = format!("in \"{text_s}\" (write ({number_s} {})/{} to divide by a parameter)", shown(head), shown(tail));
            let offset = head.chars().count() + 1;
            return Err(error(column + offset, ExprErrorKind::UnknownUnit { unit: tail.to_string(), hint }));
        }
    }
    // "[/s]" reads as "1/s", as in parse_quantity.
    let source = if text.starts_with('/') { format!("1{text}") } else { text.to_string() };
    match parse_unit_expr(&source) {
        Ok(parsed) => Ok(LiteralUnit { text: text.to_string(), bracketed, parsed }),
        Err(UnitError::UnknownUnit { unit, accepted }) => {
            let hint = if !bracketed && unit == text {
                format!("after {number_s} (write {number_s} * {text_s} to multiply by a parameter; {accepted})")
            } else if let Some(before) = text.strip_suffix(unit.as_str()).and_then(|t| t.strip_suffix('/')).filter(|_| !bracketed) {
                format!("in \"{text_s}\" (write ({number_s} {})/{} to divide by a parameter; {accepted})", shown(before), shown(&unit))
            } else {
                format!("in \"{text_s}\" ({accepted})")
            };
            let offset = text.find(unit.as_str()).map_or(0, |b| text.get(..b).unwrap_or_default().chars().count());
            Err(error(column + offset, ExprErrorKind::UnknownUnit { unit, hint }))
        }
        Err(e) => Err(error(column, ExprErrorKind::Unit(e))),
    }
}

// ---------------------------------------------------------------------------
// Parser

/// Parse an expression such as `"= supply.p - 0.5 bar"` or `"pi/4 * bore^2"`.
/// Leading whitespace and one leading '=' are skipped; error columns count
/// characters of `text` as given, from 1.
pub fn parse_expr(text: &str) -> Result<Expr, ExprError> {
    let chars: Vec<(usize, char)> = text.char_indices().collect();
    let mut lexer = Lexer { text, chars, i: 0, toks: Vec::new() };
    lexer.skip_whitespace();
    if lexer.at(lexer.i) == Some('=') {
        lexer.i += 1;
    }
    let lex_error = lexer.run().err();
    let end_column = lexer.chars.len() + 1;
    let mut p = Parser { toks: lexer.toks, lex_error, pos: 0, depth: 0, end_column };
    let first = p.peek()?;
    if matches!(first.kind, TokKind::End) {
        return Err(error(first.column, ExprErrorKind::Empty));
    }
    let column = first.column;
    let node = p.sum()?;
    let tok = p.peek()?;
    if matches!(tok.kind, TokKind::End) {
        Ok(Expr { node, column })
    } else {
        Err(p.unexpected(tok, "an operator"))
    }
}

struct Parser {
    toks: Vec<Tok>,
    /// The lexer's error, met when the parser reaches its position.
    lex_error: Option<ExprError>,
    pos: usize,
    depth: usize,
    end_column: usize,
}

impl Parser {
    fn peek(&self) -> Result<&Tok, ExprError> {
        match self.toks.get(self.pos) {
            Some(t) => Ok(t),
            None => Err(self.lex_error.clone().unwrap_or_else(|| syntax(self.end_column, "unexpected end".to_string()))),
        }
    }

    /// Step past the current token (never past End).
    fn bump(&mut self) {
        if self.toks.get(self.pos).is_some_and(|t| !matches!(t.kind, TokKind::End)) {
            self.pos += 1;
        }
    }

    fn previous(&self) -> Option<&Tok> {
        self.pos.checked_sub(1).and_then(|p| self.toks.get(p))
    }

    fn peek_sym(&self) -> Result<Option<(char, usize)>, ExprError> {
        let tok = self.peek()?;
        Ok(match tok.kind {
            TokKind::Sym(c) => Some((c, tok.column)),
            _ => None,
        })
    }

    /// `tok` where `wanted` (e.g. "an operator") should follow a complete value.
    fn unexpected(&self, tok: &Tok, wanted: &str) -> ExprError {
        let prev = self.previous();
        let after = prev.map(|p| format!(" after \"{}\"", shown(&p.text))).unwrap_or_default();
        let message = match (&tok.kind, prev.map(|p| &p.kind)) {
            (TokKind::Sym(')'), _) => "unmatched \")\"".to_string(),
            (TokKind::End, _) => format!("expected {wanted}{after}"),
            (TokKind::Name(name), Some(TokKind::Number(lit))) if lit.unit.as_ref().is_some_and(|u| !u.bracketed) => {
                let (number, unit) = (shown(&lit.text), shown(lit.unit.as_ref().map_or("", |u| u.text.as_str())));
                let name = shown(name);
                format!(
                    "expected {wanted}{after}, found name \"{name}\" (write a unit of several words in brackets, \
                     e.g. {number} [{unit} {name}], or an operator, e.g. {number} {unit} * {name})"
                )
            }
            _ => format!("expected {wanted}{after}, found {}", tok.describe()),
        };
        syntax(tok.column, message)
    }

    fn expected_value(&self, tok: &Tok) -> ExprError {
        let after = self.previous().map(|p| format!(" after \"{}\"", shown(&p.text))).unwrap_or_default();
        let found = match tok.kind {
            TokKind::End => String::new(),
            _ => format!(", found {}", tok.describe()),
        };
        syntax(tok.column, format!("expected a value{after}{found}"))
    }

    fn sum(&mut self) -> Result<Node, ExprError> {
        let first = self.product()?;
        let mut rest = Vec::new();
        while let Some((op @ ('+' | '-'), column)) = self.peek_sym()? {
            self.bump();
            rest.push(Operand { op, column, node: self.product()? });
        }
        Ok(if rest.is_empty() { first } else { Node::Sum { first: Box::new(first), rest } })
    }

    fn product(&mut self) -> Result<Node, ExprError> {
        let first = self.unary()?;
        let mut rest = Vec::new();
        while let Some((op @ ('*' | '/'), column)) = self.peek_sym()? {
            self.bump();
            rest.push(Operand { op, column, node: self.unary()? });
        }
        Ok(if rest.is_empty() { first } else { Node::Product { first: Box::new(first), rest } })
    }

    fn unary(&mut self) -> Result<Node, ExprError> {
        let column = self.peek()?.column;
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(error(column, ExprErrorKind::TooDeep));
        }
        let node = match self.peek_sym()? {
            Some(('-', _)) => {
                self.bump();
                let before_number = matches!(self.peek()?.kind, TokKind::Number(_));
                let operand = self.unary()?;
                match operand {
                    // "-10 degC" is (-10) degC, not -(283.15 K).
                    Node::Literal(lit) if before_number && lit.has_offset() => Node::Literal(Box::new(negated(*lit, column)?)),
                    other => Node::Neg(Box::new(other)),
                }
            }
            Some(('+', _)) => {
                self.bump();
                self.unary()?
            }
            _ => self.power()?,
        };
        self.depth -= 1;
        Ok(node)
    }

    fn power(&mut self) -> Result<Node, ExprError> {
        let base = self.primary()?;
        match self.peek_sym()? {
            Some(('^', column)) => {
                self.bump();
                let exponent = self.unary()?;
                Ok(Node::Pow { base: Box::new(base), exponent: Box::new(exponent), column })
            }
            _ => Ok(base),
        }
    }

    fn primary(&mut self) -> Result<Node, ExprError> {
        let tok = self.peek()?.clone();
        match tok.kind {
            TokKind::Number(lit) => {
                self.bump();
                Ok(Node::Literal(lit))
            }
            TokKind::Name(name) => {
                self.bump();
                if let Some(('(', _)) = self.peek_sym()? {
                    self.call(&name, tok.column)
                } else if name == "pi" {
                    Ok(Node::Pi)
                } else {
                    Ok(Node::Name { name, column: tok.column })
                }
            }
            TokKind::Sym('(') => {
                self.bump();
                let inner = self.sum()?;
                let close = self.peek()?;
                match close.kind {
                    TokKind::Sym(')') => {
                        self.bump();
                        Ok(inner)
                    }
                    TokKind::End => Err(syntax(close.column, format!("missing \")\" for the \"(\" at column {}", tok.column))),
                    _ => Err(self.unexpected(close, "an operator or \")\"")),
                }
            }
            _ => Err(self.expected_value(&tok)),
        }
    }

    /// A call; the current token is the '(' after the function name.
    fn call(&mut self, name: &str, column: usize) -> Result<Node, ExprError> {
        let func = Func::from_name(name).ok_or_else(|| error(column, ExprErrorKind::UnknownFunction(name.to_string())))?;
        let open = self.peek()?.column;
        self.bump();
        let mut args = Vec::new();
        if let Some((')', _)) = self.peek_sym()? {
            self.bump();
        } else {
            loop {
                args.push(self.sum()?);
                let tok = self.peek()?;
                match tok.kind {
                    TokKind::Sym(',') => self.bump(),
                    TokKind::Sym(')') => {
                        self.bump();
                        break;
                    }
                    TokKind::End => {
                        return Err(syntax(tok.column, format!("missing \")\" for the \"(\" of {name} at column {open}")));
                    }
                    _ => return Err(self.unexpected(tok, "an operator, \",\" or \")\"")),
                }
            }
        }
        let (fits, expected) = if func.variadic() { (args.len() >= 2, "2 or more arguments") } else { (args.len() == 1, "1 argument") };
        if !fits {
            return Err(error(column, ExprErrorKind::ArgumentCount { function: func.name(), expected, found: args.len() }));
        }
        Ok(Node::Call { func, column, args })
    }
}

/// The literal with its number negated (for "-10 degC").
fn negated(lit: Literal, column: usize) -> Result<Literal, ExprError> {
    let number = -lit.number;
    let value = match &lit.unit {
        Some(u) => Quantity::new(u.parsed.to_si(number), u.parsed.dim),
        None => Quantity::dimensionless(number),
    };
    if !value.value.is_finite() {
        return Err(error(column, ExprErrorKind::BadNumber { number: format!("-{}", lit.text), reason: "is out of range" }));
    }
    Ok(Literal { text: format!("-{}", lit.text), number, unit: lit.unit, value })
}

// ---------------------------------------------------------------------------
// Evaluation

impl Expr {
    /// Names referenced (e.g. "supply.p", "bore"), in order of first
    /// appearance, without duplicates; `pi` is not a name.
    pub fn names(&self) -> Vec<String> {
        let mut names = Vec::new();
        collect_names(&self.node, &mut names);
        names
    }

    /// Evaluate; `lookup` gives the value of a name, or `None` if it is unknown.
    pub fn eval(&self, lookup: &mut dyn FnMut(&str) -> Option<Quantity>) -> Result<Quantity, ExprError> {
        eval(&self.node, lookup)
    }

    /// Evaluate and require the result to have dimension `expected`; returns the SI value.
    pub fn eval_as(&self, expected: Dimension, lookup: &mut dyn FnMut(&str) -> Option<Quantity>) -> Result<f64, ExprError> {
        let q = self.eval(lookup)?;
        if q.dim == expected {
            Ok(q.value)
        } else {
            Err(error(self.column, ExprErrorKind::WrongDimension { found: q.dim, expected }))
        }
    }
}

fn collect_names(node: &Node, names: &mut Vec<String>) {
    match node {
        Node::Literal(_) | Node::Pi => {}
        Node::Name { name, .. } => {
            if !names.contains(name) {
                names.push(name.clone());
            }
        }
        Node::Neg(x) => collect_names(x, names),
        Node::Sum { first, rest } | Node::Product { first, rest } => {
            collect_names(first, names);
            rest.iter().for_each(|o| collect_names(&o.node, names));
        }
        Node::Pow { base, exponent, .. } => {
            collect_names(base, names);
            collect_names(exponent, names);
        }
        Node::Call { args, .. } => args.iter().for_each(|a| collect_names(a, names)),
    }
}

fn non_finite(column: usize, message: String) -> ExprError {
    error(column, ExprErrorKind::NonFinite(message))
}

fn eval(node: &Node, lookup: &mut dyn FnMut(&str) -> Option<Quantity>) -> Result<Quantity, ExprError> {
    match node {
        Node::Literal(lit) => Ok(lit.value),
        Node::Pi => Ok(Quantity::dimensionless(PI)),
        Node::Name { name, column } => match lookup(name) {
            None => Err(error(*column, ExprErrorKind::UnknownName(name.clone()))),
            Some(q) if !q.value.is_finite() => Err(non_finite(*column, format!("the value of \"{}\" is {}", shown(name), show(q.value)))),
            Some(q) => Ok(q),
        },
        Node::Neg(x) => {
            let q = eval(x, lookup)?;
            Ok(Quantity::new(-q.value, q.dim))
        }
        Node::Sum { first, rest } => {
            let mut acc = eval(first, lookup)?;
            for Operand { op, column, node } in rest {
                let q = eval(node, lookup)?;
                let subtract = *op == '-';
                if q.dim != acc.dim {
                    return Err(error(*column, ExprErrorKind::DimensionMismatch { subtract, left: acc.dim, right: q.dim }));
                }
                acc.value = if subtract { acc.value - q.value } else { acc.value + q.value };
                if !acc.value.is_finite() {
                    return Err(non_finite(*column, format!("the result of \"{op}\" overflows")));
                }
            }
            Ok(acc)
        }
        Node::Product { first, rest } => {
            let mut acc = eval(first, lookup)?;
            for Operand { op, column, node } in rest {
                let q = eval(node, lookup)?;
                let divide = *op == '/';
                if divide && q.value == 0.0 {
                    return Err(error(*column, ExprErrorKind::DivisionByZero));
                }
                let dim = if divide { q.dim.pow(-1).and_then(|inv| acc.dim.mul(inv)) } else { acc.dim.mul(q.dim) };
                let Some(dim) = dim else {
                    let message = format!(
                        "the {} of {} and {} is out of the range of dimensions",
                        if divide { "quotient" } else { "product" },
                        acc.dim.with_article(),
                        q.dim.with_article()
                    );
                    return Err(error(*column, ExprErrorKind::DimensionOutOfRange(message)));
                };
                acc = Quantity::new(if divide { acc.value / q.value } else { acc.value * q.value }, dim);
                if !acc.value.is_finite() {
                    return Err(non_finite(*column, format!("the result of \"{op}\" overflows")));
                }
            }
            Ok(acc)
        }
        Node::Pow { base, exponent, column } => {
            let b = eval(base, lookup)?;
            let e = eval(exponent, lookup)?;
            power(b, e, *column)
        }
        Node::Call { func, column, args } => {
            let mut values = Vec::with_capacity(args.len());
            for a in args {
                values.push(eval(a, lookup)?);
            }
            call(*func, &values, *column)
        }
    }
}

fn power(b: Quantity, e: Quantity, column: usize) -> Result<Quantity, ExprError> {
    if e.dim != dim::DIMENSIONLESS {
        let message = format!("the exponent must be a dimensionless number, not {}", e.dim.with_article());
        return Err(error(column, ExprErrorKind::BadExponent(message)));
    }
    let (exponent, dim) = if b.dim == dim::DIMENSIONLESS {
        (e.value, b.dim)
    } else {
        let n = e.value.round();
        if (e.value - n).abs() > INTEGER_TOLERANCE {
            let message = format!("{} can only be raised to an integer power, not {}", b.dim.with_article(), show(e.value));
            return Err(error(column, ExprErrorKind::BadExponent(message)));
        }
        // |n| <= 127 makes the cast exact; Dimension::pow checks the products.
        let dim = if n.abs() <= 127.0 { b.dim.pow(n as i8) } else { None };
        let Some(dim) = dim else {
            let message = format!("{} to the power {} is out of the range of dimensions", b.dim.with_article(), show(n));
            return Err(error(column, ExprErrorKind::BadExponent(message)));
        };
        (n, dim)
    };
    if b.value == 0.0 && exponent < 0.0 {
        return Err(error(column, ExprErrorKind::DivisionByZero));
    }
    let value = b.value.powf(exponent);
    if !value.is_finite() {
        let base = if b.value < 0.0 { format!("({})", show(b.value)) } else { show(b.value) };
        let what = if value.is_nan() { "is not a real number" } else { "overflows" };
        return Err(non_finite(column, format!("{base}^{} {what}", show(exponent))));
    }
    Ok(Quantity::new(value, dim))
}

fn call(func: Func, args: &[Quantity], column: usize) -> Result<Quantity, ExprError> {
    let name = func.name();
    let Some((&first, others)) = args.split_first() else {
        let expected = if func.variadic() { "2 or more arguments" } else { "1 argument" };
        return Err(error(column, ExprErrorKind::ArgumentCount { function: name, expected, found: 0 }));
    };
    let argument_error = |message: String| Err(error(column, ExprErrorKind::ArgumentDimension(message)));
    let needs_number = || argument_error(format!("{name} needs a dimensionless argument, not {}", first.dim.with_article()));
    let result = match func {
        Func::Sqrt => {
            let d = first.dim;
            if [d.mass, d.length, d.time, d.temperature].iter().any(|e| e % 2 != 0) {
                return argument_error(format!("sqrt of {} has no dimension (the powers of kg, m, s, K must be even)", d.with_article()));
            }
            if first.value < 0.0 {
                return Err(non_finite(column, format!("sqrt of a negative number ({})", show(first.value))));
            }
            let half = Dimension { mass: d.mass / 2, length: d.length / 2, time: d.time / 2, temperature: d.temperature / 2 };
            Quantity::new(first.value.sqrt(), half)
        }
        Func::Abs => Quantity::new(first.value.abs(), first.dim),
        Func::Min | Func::Max | Func::Hypot => {
            if let Some((k, q)) = others.iter().enumerate().find(|(_, q)| q.dim != first.dim) {
                return argument_error(format!(
                    "{name} needs arguments of one dimension, but argument {} is {} and argument 1 is {}",
                    k + 2,
                    q.dim.with_article(),
                    first.dim.with_article()
                ));
            }
            let fold: fn(f64, f64) -> f64 = match func {
                Func::Min => f64::min,
                Func::Max => f64::max,
                _ => f64::hypot,
            };
            let start = if func == Func::Hypot { first.value.abs() } else { first.value };
            Quantity::new(others.iter().fold(start, |acc, q| fold(acc, q.value)), first.dim)
        }
        Func::Exp | Func::Ln | Func::Log10 | Func::Sin | Func::Cos | Func::Tan => {
            if first.dim != dim::DIMENSIONLESS {
                return needs_number();
            }
            let x = first.value;
            if matches!(func, Func::Ln | Func::Log10) && x <= 0.0 {
                return Err(non_finite(column, format!("{name} of a number that is not positive ({})", show(x))));
            }
            let value = match func {
                Func::Exp => x.exp(),
                Func::Ln => x.ln(),
                Func::Log10 => x.log10(),
                Func::Sin => x.sin(),
                Func::Cos => x.cos(),
                _ => x.tan(),
            };
            Quantity::dimensionless(value)
        }
    };
    if result.value.is_finite() {
        Ok(result)
    } else {
        Err(non_finite(column, format!("{name} overflows")))
    }
}

// ---------------------------------------------------------------------------
// Printing

/// Binding strength for printing: sum 1, product 2, sign 3, power 4, atom 5.
fn level(node: &Node) -> u8 {
    match node {
        Node::Sum { .. } => 1,
        Node::Product { .. } => 2,
        Node::Neg(_) => 3,
        Node::Pow { .. } => 4,
        Node::Literal(lit) if lit.text.starts_with('-') => 3,
        // "4 bar" before "^2" would read as 4 bar^2.
        Node::Literal(lit) if lit.unit.as_ref().is_some_and(|u| !u.bracketed) => 4,
        _ => 5,
    }
}

fn write_node(f: &mut fmt::Formatter<'_>, node: &Node, min_level: u8) -> fmt::Result {
    if level(node) < min_level {
        f.write_char('(')?;
        write_node(f, node, 0)?;
        return f.write_char(')');
    }
    match node {
        Node::Literal(lit) => {
            f.write_str(&lit.text)?;
            match &lit.unit {
                Some(LiteralUnit { text, bracketed: true, .. }) => write!(f, " [{text}]"),
                Some(LiteralUnit { text, .. }) => write!(f, " {text}"),
                None => Ok(()),
            }
        }
        Node::Pi => f.write_str("pi"),
        Node::Name { name, .. } => f.write_str(name),
        Node::Neg(x) => {
            f.write_char('-')?;
            // "-(10 degC)" must not become "-10 degC", which is another value.
            let keep_apart = matches!(&**x, Node::Literal(lit) if lit.has_offset() && !lit.text.starts_with('-'));
            write_node(f, x, if keep_apart { 6 } else { 3 })
        }
        Node::Sum { first, rest } | Node::Product { first, rest } => {
            let own = level(node);
            write_node(f, first, own)?;
            for Operand { op, node, .. } in rest {
                write!(f, " {op} ")?;
                write_node(f, node, own + 1)?;
            }
            Ok(())
        }
        Node::Pow { base, exponent, .. } => {
            write_node(f, base, 5)?;
            f.write_char('^')?;
            write_node(f, exponent, 3)
        }
        Node::Call { func, args, .. } => {
            write!(f, "{}(", func.name())?;
            for (k, a) in args.iter().enumerate() {
                if k > 0 {
                    f.write_str(", ")?;
                }
                write_node(f, a, 0)?;
            }
            f.write_char(')')
        }
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_node(f, &self.node, 0)
    }
}

#[cfg(test)]
mod tests;
