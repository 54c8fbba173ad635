//! Errors of unit parsing: one-line messages that say what was wrong and what
//! would have been accepted, so they can be shown to users unchanged.

use crate::Dimension;

/// Why a quantity or unit could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UnitError {
    /// Nothing but whitespace was given.
    #[error("empty value")]
    Empty,
    /// The text does not start with a number.
    #[error("cannot read a number in \"{}\"", crate::show::text(.text))]
    BadNumber { text: String },
    /// A unit symbol that is not known (with or without a prefix).
    #[error("unknown unit \"{}\" ({accepted})", crate::show::text(.unit))]
    UnknownUnit { unit: String, accepted: String },
    /// The unit is valid but measures something else than was asked for.
    #[error(
        "unit \"{}\" is {}, expected {} (accepted: {})",
        crate::show::text(.unit),
        .found.with_article(),
        .expected.with_article(),
        .expected.accepted_list()
    )]
    WrongDimension { unit: String, found: Dimension, expected: Dimension },
    /// An affine unit (degC, degF) or gauge unit (barg, psig) inside a larger
    /// expression, where its offset would have no meaning.
    #[error(
        "unit \"{}\" has an offset and may only stand alone, not inside \"{}\" \
         (write {instead} there)",
        crate::show::text(.unit),
        crate::show::text(.expression)
    )]
    OffsetInExpression { unit: String, expression: String, instead: &'static str },
    /// A malformed unit expression (parentheses, operators, exponents).
    #[error("cannot read unit \"{}\": {}", crate::show::text(.expression), crate::show::text(.reason))]
    Syntax { expression: String, reason: String },
    /// The number or its SI value is infinite or NaN (a run of digits beyond
    /// 1.8e308, "1e300 GPa"); the input is quoted, escaped and shortened.
    #[error("\"{}\" is not a finite number (beyond 1.8e308 in SI)", crate::show::brief(.text))]
    NonFinite { text: String },
}
