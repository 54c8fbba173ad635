//! Tests of expression parsing and evaluation: hand-computed values, every
//! error with its column, and property tests against a direct evaluator.

use super::*;
use crate::{parse_quantity, parse_unit};
use proptest::prelude::*;

/// Parameters known to the hand-written tests.
fn params(name: &str) -> Option<Quantity> {
    Some(match name {
        "supply.p" => Quantity::new(6e5, dim::PRESSURE),
        "bore" => Quantity::new(0.045, dim::LENGTH),
        "stroke" => Quantity::new(0.45, dim::LENGTH),
        "V_port" => Quantity::new(2e-6, dim::VOLUME),
        "cyl.head.p0" => Quantity::new(1e5, dim::PRESSURE),
        "T" => Quantity::new(293.15, dim::TEMPERATURE),
        "n" => Quantity::dimensionless(3.0),
        "zero" => Quantity::dimensionless(0.0),
        "big" => Quantity::dimensionless(1e308),
        "bad" => Quantity::dimensionless(f64::NAN),
        "odd" => Quantity::new(1.0, Dimension { mass: 100, length: 0, time: 0, temperature: 0 }),
        _ => return None,
    })
}

fn eval_text(text: &str) -> Result<Quantity, ExprError> {
    parse_expr(text)?.eval(&mut params)
}

fn value(text: &str) -> Quantity {
    eval_text(text).unwrap_or_else(|e| panic!("{text:?}: {e}"))
}

/// Dimensionless value.
fn number(text: &str) -> f64 {
    let q = value(text);
    assert_eq!(q.dim, dim::DIMENSIONLESS, "{text:?}");
    q.value
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

#[test]
fn operators_precedence_and_associativity() {
    let cases: &[(&str, f64)] = &[
        ("2 + 3", 5.0),
        ("7 - 2", 5.0),
        ("6 * 7", 42.0),
        ("1 / 4", 0.25),
        ("2^10", 1024.0),
        ("-3", -3.0),
        ("+3", 3.0),
        ("--2", 2.0),
        ("2 - -3", 5.0),
        ("2 * -3", -6.0),
        ("2 + 3 * 4", 14.0),
        ("2 * 3 + 4", 10.0),
        ("(2 + 3) * 4", 20.0),
        ("2^3^2", 512.0),
        ("(2^3)^2", 64.0),
        ("-2^2", -4.0),
        ("(-2)^2", 4.0),
        ("-2 * 3^2", -18.0),
        ("2^3 * 2", 16.0),
        ("2 * 3^2", 18.0),
        ("1 - 2 - 3", -4.0),
        ("1 - (2 - 3)", 2.0),
        ("8/4/2", 1.0),
        ("8/(4/2)", 4.0),
        ("12 / 2 * 3", 18.0),
        ("2^-1", 0.5),
        ("-2^-2", -0.25),
        ("2^-1^2", 0.5),
        ("(-8)^3", -512.0),
        ("4^0.5", 2.0),
        ("0^0", 1.0),
        ("1e-5", 1e-5),
        ("2.5E+3", 2500.0),
        (".5", 0.5),
        ("5.", 5.0),
        ("= 1+2", 3.0),
        ("  =\t2*3 ", 6.0),
        ("((((7))))", 7.0),
        ("pi", std::f64::consts::PI),
        ("n * 2", 6.0),
    ];
    for &(text, want) in cases {
        assert_eq!(number(text), want, "{text:?}");
    }
}

#[test]
fn functions() {
    let cases: &[(&str, f64)] = &[
        ("sqrt(16)", 4.0),
        ("abs(-3)", 3.0),
        ("abs(3)", 3.0),
        ("min(3, 1, 2)", 1.0),
        ("max(3, 1, 2)", 3.0),
        ("min(-1, 1)", -1.0),
        ("hypot(3, 4)", 5.0),
        ("hypot(-3, 4)", 5.0),
        ("exp(0)", 1.0),
        ("ln(1)", 0.0),
        ("exp(1)", std::f64::consts::E),
        ("log10(1000)", 3.0),
        ("sin(0)", 0.0),
        ("cos(0)", 1.0),
        ("tan(0)", 0.0),
        ("sqrt(2)^2 - 2", 2f64.sqrt().powf(2.0) - 2.0),
        ("2 * max(1, n)", 6.0),
    ];
    for &(text, want) in cases {
        assert_eq!(number(text), want, "{text:?}");
    }
    assert!(close(number("sin(pi/2)"), 1.0, 1e-15));
    assert!(close(number("ln(exp(2.5))"), 2.5, 1e-15));
    // Dimensions pass through sqrt (halved), abs, min, max, hypot.
    assert_eq!(value("sqrt(9 m2)"), Quantity::new(3.0, dim::LENGTH));
    assert_eq!(value("sqrt(bore^2)"), Quantity::new(0.045, dim::LENGTH));
    assert_eq!(value("abs(-2 bar)"), Quantity::new(2e5, dim::PRESSURE));
    assert_eq!(value("min(supply.p, 3 bar)"), Quantity::new(3e5, dim::PRESSURE));
    assert_eq!(value("max(supply.p, 3 bar)"), Quantity::new(6e5, dim::PRESSURE));
    assert_eq!(value("hypot(3 mm, 4 mm)").dim, dim::LENGTH);
    assert!(close(value("hypot(3 mm, 4 mm)").value, 0.005, 1e-15));
    assert_eq!(value("sqrt(16 [m^4 s^-2])"), Quantity::new(4.0, dim::VELOCITY.mul(dim::LENGTH).unwrap()));
    // A parameter may share a function's name when it is not called.
    let e = parse_expr("min + 1").unwrap();
    assert_eq!(e.names(), ["min"]);
    assert_eq!(e.eval(&mut |_| Some(Quantity::dimensionless(1.0))), Ok(Quantity::dimensionless(2.0)));
}

#[test]
fn units_in_literals() {
    use dim::*;
    let area = value("pi/4 * (45 mm)^2");
    assert_eq!(area, Quantity::new(1.5904312808798327e-3, AREA));
    let volume = value("= pi/4 * (45 mm)^2 * 450 mm");
    assert!(close(volume.value, 1.5904312808798327e-3 * 0.45, 1e-15));
    assert_eq!(volume.dim, VOLUME);
    assert_eq!(value("4 bar - 0.98 bar"), Quantity::new(302_000.0, PRESSURE));
    assert_eq!(value("19 degC"), Quantity::new(292.15, TEMPERATURE));
    assert_eq!(value("19 °C"), Quantity::new(292.15, TEMPERATURE));
    assert_eq!(value("19 [degC]"), Quantity::new(292.15, TEMPERATURE));
    let c = value("13.2 L/min/bar");
    assert_eq!(c.dim, CONDUCTANCE);
    assert!(close(c.value, 13.2e-3 / 60.0 / 1e5, 1e-15));
    assert_eq!(value("20 cm3"), Quantity::new(2e-5, VOLUME));
    assert_eq!(value("3 barg"), Quantity::new(401_325.0, PRESSURE));
    assert_eq!(value("2e-4 [N s/(m Pa)]"), Quantity::new(2e-4, DAMPING_PER_PRESSURE));
    assert_eq!(value("2e-4[N s/(m Pa)]"), Quantity::new(2e-4, DAMPING_PER_PRESSURE));
    assert_eq!(value("5 [ /s ]"), Quantity::new(5.0, FREQUENCY));
    assert_eq!(value("0.98bar"), Quantity::new(98_000.0, PRESSURE));
    assert_eq!(value("25 µm"), Quantity::new(25e-6, LENGTH));
    assert_eq!(value("2 m^-1"), Quantity::new(2.0, LENGTH.pow(-1).unwrap()));
    assert_eq!(value("3 m/s^2"), Quantity::new(3.0, ACCELERATION));
    assert_eq!(value("10 N·m"), Quantity::new(10.0, ENERGY));
    // A literal with a unit is one value; the unit word stops before "/2" and "^x".
    assert_eq!(value("45 mm^2"), Quantity::new(45e-6, AREA));
    assert_eq!(value("(45 mm)^2").dim, AREA);
    assert!(close(value("(45 mm)^2").value, 0.045 * 0.045, 1e-15));
    assert_eq!(value("4 bar/2"), Quantity::new(2e5, PRESSURE));
    assert_eq!(value("2 m^n"), Quantity::new(8.0, VOLUME));
    assert_eq!(value("stroke / 2 mm"), Quantity::dimensionless(225.0));
    assert_eq!(value("4 bar * 2 mm").dim, FORCE.mul(LENGTH.pow(-1).unwrap()).unwrap());
    // Offset units: the sign written on the number belongs to it.
    assert_eq!(value("-10 degC"), Quantity::new(263.15, TEMPERATURE));
    assert_eq!(value("- 10 degC"), Quantity::new(263.15, TEMPERATURE));
    assert_eq!(value("-(10 degC)"), Quantity::new(-283.15, TEMPERATURE));
    assert_eq!(value("-0.5 barg"), Quantity::new(101_325.0 - 5e4, PRESSURE));
    assert_eq!(value("2 * -10 degC"), Quantity::new(2.0 * 263.15, TEMPERATURE));
    assert!(close(value("20 degC - 10 degC").value, 10.0, 1e-12));
    // Without an offset a folded sign and a negation are the same value.
    assert_eq!(value("-2 bar"), Quantity::new(-2e5, PRESSURE));
}

#[test]
fn lookups_and_names() {
    use dim::*;
    assert_eq!(value("= supply.p"), Quantity::new(6e5, PRESSURE));
    assert_eq!(value("= supply.p - 0.5 bar"), Quantity::new(5.5e5, PRESSURE));
    assert_eq!(value("= 2 * V_port"), Quantity::new(4e-6, VOLUME));
    assert_eq!(value("cyl.head.p0 * 2"), Quantity::new(2e5, PRESSURE));
    let area = parse_expr("= pi/4 * bore^2").unwrap().eval_as(AREA, &mut params).unwrap();
    assert_eq!(area, std::f64::consts::PI / 4.0 * 0.045f64.powf(2.0));
    assert_eq!(value("supply.p-cyl.head.p0"), Quantity::new(5e5, PRESSURE)); // '-' is minus, not part of a name
    assert_eq!(value("T - 10 K"), Quantity::new(283.15, TEMPERATURE));

    let e = parse_expr("= a + b.c * a - sqrt(d) + pi + e.pi + min(d, f_2)").unwrap();
    assert_eq!(e.names(), ["a", "b.c", "d", "e.pi", "f_2"]);
    assert!(parse_expr("2 bar * pi").unwrap().names().is_empty());
    // The lookup is asked for each occurrence, in order.
    let mut asked = Vec::new();
    let q = parse_expr("x * y + x").unwrap().eval(&mut |name: &str| {
        asked.push(name.to_string());
        Some(Quantity::dimensionless(2.0))
    });
    assert_eq!(q, Ok(Quantity::dimensionless(6.0)));
    assert_eq!(asked, ["x", "y", "x"]);
}

#[test]
fn is_expression_and_eval_as() {
    for (text, want) in [("= 2", true), ("  =x", true), ("=", true), ("2", false), ("", false), ("4 bar", false), ("x=", false)] {
        assert_eq!(is_expression(text), want, "{text:?}");
    }
    let e = parse_expr("  = 2 mm").unwrap();
    assert_eq!(e.eval_as(dim::LENGTH, &mut params), Ok(0.002));
    let err = e.eval_as(dim::PRESSURE, &mut params).unwrap_err();
    assert_eq!(err.column, 5);
    assert_eq!(err.kind, ExprErrorKind::WrongDimension { found: dim::LENGTH, expected: dim::PRESSURE });
    let msg = err.to_string();
    assert!(msg.starts_with("column 5: the expression gives a length, expected a pressure (units: Pa, kPa"), "{msg}");
}

/// (column, message) of the error of parsing or evaluating `text`.
fn failure(text: &str) -> (usize, String) {
    match eval_text(text) {
        Ok(q) => panic!("{text:?} gave {q:?}, expected an error"),
        Err(e) => {
            let prefix = format!("column {}: ", e.column);
            let msg = e.to_string();
            assert!(msg.starts_with(&prefix), "{msg}");
            (e.column, msg[prefix.len()..].to_string())
        }
    }
}

fn kind(text: &str) -> ExprErrorKind {
    eval_text(text).expect_err(text).kind
}

#[test]
fn syntax_errors_with_columns() {
    let cases: &[(&str, usize, &str)] = &[
        ("", 1, "empty expression"),
        ("=", 2, "empty expression"),
        ("  =  ", 6, "empty expression"),
        ("1 +", 4, "expected a value after \"+\""),
        ("= supply.p +", 13, "expected a value after \"+\""),
        ("1 + )", 5, "expected a value after \"+\", found \")\""),
        ("* 2", 1, "expected a value, found \"*\""),
        ("2 * * 3", 5, "expected a value after \"*\", found \"*\""),
        ("(1 + 2", 7, "missing \")\" for the \"(\" at column 1"),
        ("1 + 2)", 6, "unmatched \")\""),
        ("(1 2)", 4, "expected an operator or \")\" after \"1\", found number \"2\""),
        ("2 3", 3, "expected an operator after \"2\", found number \"3\""),
        ("2 (3)", 3, "expected an operator after \"2\", found \"(\""),
        ("x y", 3, "expected an operator after \"x\", found name \"y\""),
        ("2 $", 3, "unexpected character \"$\""),
        ("a = b", 3, "unexpected character \"=\" (only one \"=\" is allowed, at the start)"),
        ("2 × 3", 3, "unexpected character \"×\" (write * to multiply)"),
        ("x²", 2, "unexpected character \"²\" (write ^2 or ^3)"),
        ("a.", 3, "expected a name after \"a.\""),
        ("a.2", 3, "expected a name after \"a.\""),
        ("1.2.3", 1, "number \"1.2.\" is malformed"),
        ("2_000", 1, "number \"2_\" is malformed"),
        ("1e400", 1, "number \"1e400\" is out of range"),
        ("1e300 GPa", 1, "number \"1e300 GPa\" is out of range"),
        ("2 [mm", 3, "missing \"]\" after the unit"),
        ("2 [ ]", 3, "empty unit \"[]\""),
        ("[mm]", 1, "unexpected character \"[\" (a unit in brackets must follow a number, e.g. 2 [N s/m])"),
        ("sqrt(2", 7, "missing \")\" for the \"(\" of sqrt at column 5"),
        ("min(1 2)", 7, "expected an operator, \",\" or \")\" after \"1\", found number \"2\""),
        ("min(1,)", 7, "expected a value after \",\", found \")\""),
        ("sqrt(1, 2)", 1, "sqrt takes 1 argument, found 2"),
        ("sqrt()", 1, "sqrt takes 1 argument, found 0"),
        ("= 2 * min(1)", 7, "min takes 2 or more arguments, found 1"),
        ("foo(1)", 1, "unknown function \"foo\" (known: sqrt, abs, min, max, hypot, exp, ln, log10, sin, cos, tan)"),
        ("pi(2)", 1, "unknown function \"pi\" (known: sqrt, abs, min, max, hypot, exp, ln, log10, sin, cos, tan)"),
    ];
    for &(text, column, message) in cases {
        assert_eq!(failure(text), (column, message.to_string()), "{text:?}");
    }
    // The first problem from the left is reported.
    assert_eq!(failure("1 + * 2 $").0, 5);
    assert_eq!(failure("1 + + 2 $").0, 9);
}

#[test]
fn unit_errors_with_columns() {
    let (column, msg) = failure("= 2 V_port");
    assert_eq!(column, 5);
    assert_eq!(msg, "unknown unit \"V_port\" after 2 (write 2 * V_port to multiply by a parameter)");
    let (column, msg) = failure("2 supply.p");
    assert_eq!(column, 3);
    assert!(msg.contains("write 2 * supply.p to multiply by a parameter"), "{msg}");
    let (column, msg) = failure("= 2 bor");
    assert_eq!(column, 5);
    assert!(msg.starts_with("unknown unit \"bor\" after 2 (write 2 * bor to multiply by a parameter; known: m, g, s"), "{msg}");
    let (column, msg) = failure("2x");
    assert_eq!(column, 2);
    assert!(msg.contains("write 2 * x"), "{msg}");
    let (column, msg) = failure("4 bar/x");
    assert_eq!(column, 7);
    assert!(msg.starts_with("unknown unit \"x\" in \"bar/x\" (write (4 bar)/x to divide by a parameter; known:"), "{msg}");
    let (column, msg) = failure("2 [N x]");
    assert_eq!(column, 6);
    assert!(msg.starts_with("unknown unit \"x\" in \"N x\" (known:"), "{msg}");
    let (column, msg) = failure("2 degC/s");
    assert_eq!(column, 3);
    assert!(msg.contains("\"degC\" has an offset") && msg.contains("write K there"), "{msg}");
    assert!(matches!(kind("2 [J/kg K]"), ExprErrorKind::Unit(UnitError::Syntax { .. })));
    let (column, msg) = failure("2 bar/x_1");
    assert_eq!(column, 7);
    assert_eq!(msg, "unknown unit \"x_1\" in \"bar/x_1\" (write (2 bar)/x_1 to divide by a parameter)");
    let (column, msg) = failure("2 bar/supply.p");
    assert_eq!(column, 7);
    assert!(msg.contains("write (2 bar)/supply.p"), "{msg}");
    // A unit with parentheses needs brackets; "/(" after a unit word that
    // does not make a unit divides.
    let (column, msg) = failure("= 2 L/(min bar)");
    assert_eq!(column, 6);
    assert_eq!(msg, "a unit with parentheses must be in brackets: write 2 [L/(min bar)] (or (2 L)/(...) to divide by an expression)");
    assert_eq!(value("2 [L/(min bar)]"), value("2 L/min/bar"));
    assert_eq!(value("4 bar/(n + 1)"), Quantity::new(1e5, dim::PRESSURE));
    assert_eq!(value("4 bar/(2 s)").dim, dim::PRESSURE.mul(dim::FREQUENCY).unwrap());
    // Several unit words need brackets.
    let (column, msg) = failure("2 N s/m");
    assert_eq!(column, 5);
    assert_eq!(
        msg,
        "expected an operator after \"2 N\", found name \"s\" (write a unit of several words in brackets, \
         e.g. 2 [N s], or an operator, e.g. 2 N * s)"
    );
}

#[test]
fn evaluation_errors_with_columns() {
    let cases: &[(&str, usize, &str)] = &[
        ("= bor", 3, "unknown name \"bor\""),
        ("2 * cyl.head.p1", 5, "unknown name \"cyl.head.p1\""),
        ("1 + bad", 5, "the value of \"bad\" is NaN"),
        ("= 2 bar + 3 mm", 9, "cannot add a length to a pressure"),
        ("2 mm - 1 bar", 6, "cannot subtract a pressure from a length"),
        ("supply.p + 0", 10, "cannot add a dimensionless number to a pressure"),
        ("1 + 1 + 2 s", 7, "cannot add a time to a dimensionless number"),
        ("2^(1 m)", 2, "the exponent must be a dimensionless number, not a length"),
        ("(2 m)^0.5", 6, "a length can only be raised to an integer power, not 0.5"),
        ("(2 m)^200", 6, "a length to the power 200 is out of the range of dimensions"),
        ("bore^(1/3)", 5, "a length can only be raised to an integer power, not 0.3333333333333333"),
        (
            "odd * odd",
            5,
            "the product of a quantity of dimension kg^100 and a quantity of dimension kg^100 is out of the range of dimensions",
        ),
        ("odd^2", 4, "a quantity of dimension kg^100 to the power 2 is out of the range of dimensions"),
        ("sqrt(2 m)", 1, "sqrt of a length has no dimension (the powers of kg, m, s, K must be even)"),
        ("1 + exp(2 m)", 5, "exp needs a dimensionless argument, not a length"),
        ("sin(T)", 1, "sin needs a dimensionless argument, not a temperature"),
        ("min(1 m, 1 s)", 1, "min needs arguments of one dimension, but argument 2 is a time and argument 1 is a length"),
        (
            "hypot(1 m, 1 m, 1)",
            1,
            "hypot needs arguments of one dimension, but argument 3 is a dimensionless number and argument 1 is a length",
        ),
        ("1 / 0", 3, "division by zero"),
        ("2 bar / (1 - 1)", 7, "division by zero"),
        ("n / zero", 3, "division by zero"),
        ("0^-1", 2, "division by zero"),
        ("1e300 * 1e300", 7, "the result of \"*\" overflows"),
        ("1 / 1e-300 / 1e-300", 12, "the result of \"/\" overflows"),
        ("big + big", 5, "the result of \"+\" overflows"),
        ("-big - big", 6, "the result of \"-\" overflows"),
        ("10^400", 3, "10^400 overflows"),
        ("sqrt(-4)", 1, "sqrt of a negative number (-4)"),
        ("2 * ln(0)", 5, "ln of a number that is not positive (0)"),
        ("log10(-1)", 1, "log10 of a number that is not positive (-1)"),
        ("(-8)^(1/3)", 5, "(-8)^0.3333333333333333 is not a real number"),
        ("exp(1000)", 1, "exp overflows"),
    ];
    for &(text, column, message) in cases {
        assert_eq!(failure(text), (column, message.to_string()), "{text:?}");
    }
    // Within 1e-9 of an integer counts as the integer.
    assert_eq!(value("(2 m)^2.0000000001"), Quantity::new(4.0, dim::AREA));
    assert_eq!(value("(2 m)^(3 * (1/3))"), Quantity::new(2.0, dim::LENGTH));
    assert_eq!(value("(2 m)^0"), Quantity::dimensionless(1.0));
    // Errors are one kind per problem.
    assert_eq!(kind("1/0"), ExprErrorKind::DivisionByZero);
    assert!(matches!(kind("x"), ExprErrorKind::UnknownName(n) if n == "x"));
    assert!(matches!(kind("1 m + 1 s"), ExprErrorKind::DimensionMismatch { subtract: false, .. }));
}

#[test]
fn nesting_is_limited_not_a_stack_overflow() {
    let nested = |n: usize| format!("{}1{}", "(".repeat(n), ")".repeat(n));
    assert_eq!(number(&nested(60)), 1.0);
    for deep in [nested(70), nested(100_000), "-".repeat(100_000) + "1", "2^".repeat(100_000) + "1", "sqrt(".repeat(10_000)] {
        let e = parse_expr(&deep).unwrap_err();
        assert_eq!(e.kind, ExprErrorKind::TooDeep);
    }
    // Long flat sums and products are not nested.
    let sum = vec!["1"; 100_000].join(" + ");
    assert_eq!(number(&sum), 100_000.0);
    let product = vec!["1 m / 1 m"; 10_000].join(" * ");
    assert_eq!(number(&product), 1.0);
    // Look-ahead for "unit/(...)" is bounded, so this is fast, and an error.
    let slashes = "1 m/(".repeat(50_000);
    assert!(matches!(parse_expr(&slashes).unwrap_err().kind, ExprErrorKind::TooDeep));
}

#[test]
fn control_characters_are_escaped() {
    for (text, shown) in [
        ("2 [m\nx]", "\\u{a}"),
        ("1 + \u{7}", "\\u{7}"),
        ("\u{202e}x", "\\u{202e}"),
        ("2 [m\rx]", "\\u{d}"),
        ("2 [\u{1b}[31m]", "\\u{1b}"),
        ("2 [x\u{2028}y]", "\\u{2028}"),
    ] {
        let msg = parse_expr(text).unwrap_err().to_string();
        assert!(msg.contains(shown), "{text:?}: {msg}");
        assert!(!msg.chars().any(|c| c.is_control() || c == '\u{202e}' || c == '\u{2028}'), "{msg:?}");
    }
    // Columns count characters, not bytes.
    assert_eq!(failure("= µ + 1").0, 3);
    assert_eq!(failure("°° + )").0, 1);
    assert_eq!(failure("19 °C + )").0, 9);
}

#[test]
fn display_is_normalized_and_parses_back() {
    let cases = [
        ("=1+2*3", "1 + 2 * 3"),
        ("(1+2)*3", "(1 + 2) * 3"),
        ("1-(2-3)", "1 - (2 - 3)"),
        ("(1-2)-3", "1 - 2 - 3"),
        ("8/(4/2)", "8 / (4 / 2)"),
        ("(2^3)^2", "(2^3)^2"),
        ("2^3^2", "2^3^2"),
        ("-2^2", "-2^2"),
        ("(-2)^2", "(-2)^2"),
        ("2^-x", "2^-x"),
        ("(45 mm)^2", "(45 mm)^2"),
        ("45 [mm]^2", "45 [mm]^2"),
        ("-10 degC", "-10 degC"),
        ("-(10 degC)", "-(10 degC)"),
        ("-+10 degC", "-(10 degC)"),
        ("(-10 degC)^2", "(-10 degC)^2"),
        ("min( a,b.c ,2e3 bar)", "min(a, b.c, 2e3 bar)"),
        ("+pi", "pi"),
    ];
    for (text, shown) in cases {
        let e = parse_expr(text).unwrap();
        assert_eq!(e.to_string(), shown, "{text:?}");
        let back = parse_expr(shown).unwrap();
        let mut any = |_: &str| Some(Quantity::dimensionless(1.5));
        assert_eq!(e.eval(&mut any), back.eval(&mut any), "{text:?}");
    }
}

// ---------------------------------------------------------------------------
// Property tests

/// Names known to the generated expressions.
const NAMES: &[(&str, Quantity)] = &[
    ("a", Quantity::new(0.2, dim::LENGTH)),
    ("b.c", Quantity::new(3e5, dim::PRESSURE)),
    ("x_1", Quantity::dimensionless(2.5)),
    ("y", Quantity::dimensionless(-1.5)),
    ("z", Quantity::dimensionless(0.0)),
    ("len.L2", Quantity::new(0.03, dim::LENGTH)),
];

const UNITS: &[&str] = &["mm", "bar", "s", "L/min", "kPa", "m2"];

fn lookup_names(name: &str) -> Option<Quantity> {
    NAMES.iter().find(|(n, _)| *n == name).map(|&(_, q)| q)
}

/// A generated expression tree, printed independently of `Expr`'s Display.
#[derive(Clone, Debug)]
enum T {
    /// Non-negative number, its unit (index into UNITS, bracketed), scientific notation.
    Num(f64, Option<(usize, bool)>, bool),
    Name(usize),
    Pi,
    Neg(Box<T>),
    Bin(char, Box<T>, Box<T>),
    Pow(Box<T>, Box<T>),
    Call(&'static str, Vec<T>),
}

fn tree() -> impl Strategy<Value = T> {
    let num = prop_oneof![Just(0.0), Just(0.5), Just(1.0), Just(2.0), Just(3.0), (0u8..5).prop_map(f64::from), 0.0..100.0f64];
    let unit = prop_oneof![3 => Just(None), 1 => (0..UNITS.len(), any::<bool>()).prop_map(Some)];
    let leaf = prop_oneof![
        4 => (num, unit, any::<bool>()).prop_map(|(x, u, sci)| T::Num(x, u, sci)),
        3 => (0..NAMES.len()).prop_map(T::Name),
        1 => Just(T::Pi),
    ];
    leaf.prop_recursive(5, 48, 3, |inner| {
        let small = (0u8..4).prop_map(|k| T::Num(f64::from(k), None, false));
        prop_oneof![
            1 => inner.clone().prop_map(|x| T::Neg(Box::new(x))),
            3 => (prop::sample::select(vec!['+', '-', '*', '/']), inner.clone(), inner.clone())
                .prop_map(|(op, a, b)| T::Bin(op, Box::new(a), Box::new(b))),
            1 => (inner.clone(), prop_oneof![small, inner.clone()]).prop_map(|(a, b)| T::Pow(Box::new(a), Box::new(b))),
            1 => (prop::sample::select(vec!["sqrt", "abs"]), inner.clone()).prop_map(|(f, x)| T::Call(f, vec![x])),
            1 => (prop::sample::select(vec!["min", "max", "hypot"]), prop::collection::vec(inner, 2..4)).prop_map(|(f, xs)| T::Call(f, xs)),
        ]
    })
}

fn number_text(x: f64, sci: bool) -> String {
    if sci {
        format!("{x:e}")
    } else {
        format!("{x:?}")
    }
}

/// Text of `t` with the fewest parentheses the documented precedence allows:
/// sum 1, product 2, sign 3, power 4, atom 5.
fn print(t: &T, min: u8) -> String {
    let (level, s) = match t {
        T::Num(x, unit, sci) => {
            let n = number_text(*x, *sci);
            match unit {
                None => (5, n),
                Some((u, true)) => (5, format!("{n} [{}]", UNITS[*u])),
                // "2 mm^2" would be 2 mm²: a unit word before '^' needs parentheses.
                Some((u, false)) => (4, format!("{n} {}", UNITS[*u])),
            }
        }
        T::Name(k) => (5, NAMES[*k].0.to_string()),
        T::Pi => (5, "pi".to_string()),
        T::Neg(x) => (3, format!("-{}", print(x, 3))),
        T::Bin(op, a, b) => {
            let level = if matches!(op, '+' | '-') { 1 } else { 2 };
            (level, format!("{} {op} {}", print(a, level), print(b, level + 1)))
        }
        T::Pow(a, b) => (4, format!("{}^{}", print(a, 5), print(b, 3))),
        T::Call(f, args) => (5, format!("{f}({})", args.iter().map(|a| print(a, 0)).collect::<Vec<_>>().join(", "))),
    };
    if level < min {
        format!("({s})")
    } else {
        s
    }
}

fn combine(a: Dimension, b: Dimension, sign: i8) -> Option<Dimension> {
    let f = |x: i8, y: i8| x.checked_add(y.checked_mul(sign)?);
    Some(Dimension {
        mass: f(a.mass, b.mass)?,
        length: f(a.length, b.length)?,
        time: f(a.time, b.time)?,
        temperature: f(a.temperature, b.temperature)?,
    })
}

fn finite(x: f64, d: Dimension) -> Option<(f64, Dimension)> {
    x.is_finite().then_some((x, d))
}

/// The value of `t` by the documented rules, computed directly on the tree;
/// `None` where evaluation must fail.
fn direct(t: &T) -> Option<(f64, Dimension)> {
    const ONE: Dimension = dim::DIMENSIONLESS;
    match t {
        T::Num(x, None, _) => Some((*x, ONE)),
        T::Num(x, Some((u, _)), sci) => {
            let d = parse_unit(UNITS[*u]).ok()?.dimension;
            let v = parse_quantity(&format!("{} {}", number_text(*x, *sci), UNITS[*u]), d).ok()?;
            Some((v, d))
        }
        T::Name(k) => Some((NAMES[*k].1.value, NAMES[*k].1.dim)),
        T::Pi => Some((std::f64::consts::PI, ONE)),
        T::Neg(x) => direct(x).map(|(v, d)| (-v, d)),
        T::Bin(op, a, b) => {
            let ((x, dx), (y, dy)) = (direct(a)?, direct(b)?);
            match op {
                '+' if dx == dy => finite(x + y, dx),
                '-' if dx == dy => finite(x - y, dx),
                '*' => finite(x * y, combine(dx, dy, 1)?),
                '/' if y != 0.0 => finite(x / y, combine(dx, dy, -1)?),
                _ => None,
            }
        }
        T::Pow(a, b) => {
            let ((x, dx), (e, de)) = (direct(a)?, direct(b)?);
            if de != ONE {
                return None;
            }
            let (e, d) = if dx == ONE {
                (e, ONE)
            } else {
                let n = e.round();
                if (e - n).abs() > 1e-9 || n.abs() > 127.0 {
                    return None;
                }
                let k = n as i8;
                let m = |v: i8| v.checked_mul(k);
                (n, Dimension { mass: m(dx.mass)?, length: m(dx.length)?, time: m(dx.time)?, temperature: m(dx.temperature)? })
            };
            if x == 0.0 && e < 0.0 {
                return None;
            }
            finite(x.powf(e), d)
        }
        T::Call(f, args) => {
            let vals: Vec<(f64, Dimension)> = args.iter().map(direct).collect::<Option<_>>()?;
            let (x, d) = vals[0];
            match *f {
                "sqrt" => {
                    let even = [d.mass, d.length, d.time, d.temperature].iter().all(|e| e % 2 == 0);
                    let half = Dimension { mass: d.mass / 2, length: d.length / 2, time: d.time / 2, temperature: d.temperature / 2 };
                    (even && x >= 0.0).then(|| (x.sqrt(), half))
                }
                "abs" => Some((x.abs(), d)),
                _ => {
                    if vals.iter().any(|v| v.1 != d) {
                        return None;
                    }
                    let fold: fn(f64, f64) -> f64 = match *f {
                        "min" => f64::min,
                        "max" => f64::max,
                        _ => f64::hypot,
                    };
                    finite(vals[1..].iter().fold(x, |acc, v| fold(acc, v.0)), d)
                }
            }
        }
    }
}

/// Names of `t` left to right, first appearance only.
fn tree_names(t: &T, out: &mut Vec<String>) {
    match t {
        T::Name(k) => {
            let n = NAMES[*k].0.to_string();
            if !out.contains(&n) {
                out.push(n);
            }
        }
        T::Num(..) | T::Pi => {}
        T::Neg(x) => tree_names(x, out),
        T::Bin(_, a, b) | T::Pow(a, b) => {
            tree_names(a, out);
            tree_names(b, out);
        }
        T::Call(_, args) => args.iter().for_each(|a| tree_names(a, out)),
    }
}

/// Checks that hold for every error: a column inside the text (or just
/// after it), the "column N: " prefix, one line without control characters.
fn check_error(text: &str, e: &ExprError) -> Result<(), TestCaseError> {
    let msg = e.to_string();
    prop_assert!(e.column >= 1 && e.column <= text.chars().count() + 1, "{:?}: {}", text, msg);
    let prefix = format!("column {}: ", e.column);
    prop_assert!(msg.starts_with(&prefix), "{}", msg);
    prop_assert!(!msg.chars().any(|c| c.is_control() || matches!(c, '\u{2028}' | '\u{2029}' | '\u{202a}'..='\u{202e}')), "{:?}", msg);
    Ok(())
}

/// A lookup that knows every name starting with a–m, with a dimension chosen by its length.
fn total_lookup(name: &str) -> Option<Quantity> {
    let first = name.chars().next()?;
    let dims = [dim::DIMENSIONLESS, dim::LENGTH, dim::PRESSURE, dim::TIME];
    ('a'..='m').contains(&first).then(|| Quantity::new(name.len() as f64 - 2.0, dims[name.len() % dims.len()]))
}

/// Pieces of expressions, valid and invalid, glued at random.
const PIECES: &[&str] = &[
    "1",
    "2.5",
    "0",
    "1e3",
    ".5",
    "3e",
    "x",
    "a.b",
    "pi",
    "sqrt",
    "min",
    "ln",
    "(",
    ")",
    ",",
    "+",
    "-",
    "*",
    "/",
    "^",
    " ",
    " ",
    "mm",
    "bar",
    "degC",
    "barg",
    "[N s/m]",
    "[",
    "]",
    "=",
    ".",
    "_",
    "é",
    "µm",
    "°C",
    "\n",
    "\u{0}",
    "\u{202e}",
    "\t",
    "1e400",
    "e",
    "2 m",
    "/s",
    "^-1",
    "²",
    "L/min/bar",
    "big",
    "kPa",
];

fn check_any_text(text: &str) -> Result<(), TestCaseError> {
    match parse_expr(text) {
        Err(e) => check_error(text, &e)?,
        Ok(expr) => {
            let names = expr.names();
            let result = expr.eval(&mut total_lookup);
            if let Err(e) = &result {
                check_error(text, e)?;
            }
            // What Display writes parses back to the same names and value.
            let shown = expr.to_string();
            let back = parse_expr(&shown);
            prop_assert!(back.is_ok(), "{:?} -> {:?}: {:?}", text, shown, back);
            if let Ok(back) = back {
                prop_assert_eq!(back.names(), names);
                let again = back.eval(&mut total_lookup);
                match (&result, &again) {
                    (Ok(a), Ok(b)) => prop_assert!(a.value.to_bits() == b.value.to_bits() && a.dim == b.dim, "{:?} vs {:?}", a, b),
                    (Err(_), Err(_)) => {}
                    _ => prop_assert!(false, "{:?} -> {:?}: {:?} vs {:?}", text, shown, result, again),
                }
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// Printed with minimal parentheses, parsed and evaluated, a generated
    /// tree gives exactly the direct evaluation (or an error where it fails).
    #[test]
    fn prop_matches_direct_evaluation(t in tree(), eq in any::<bool>()) {
        let text = format!("{}{}", if eq { "= " } else { "" }, print(&t, 0));
        let expr = parse_expr(&text).map_err(|e| TestCaseError::fail(format!("{text:?}: {e}")))?;
        let mut want_names = Vec::new();
        tree_names(&t, &mut want_names);
        prop_assert_eq!(expr.names(), want_names);
        let got = expr.eval(&mut lookup_names);
        match (direct(&t), &got) {
            (Some((v, d)), Ok(q)) => prop_assert!(q.value.to_bits() == v.to_bits() && q.dim == d, "{:?}: {:?} vs {} {:?}", text, q, v, d),
            (None, Err(e)) => check_error(&text, e)?,
            (want, _) => prop_assert!(false, "{:?}: direct {:?}, eval {:?}", text, want, got),
        }
    }

    /// Display of a generated expression reparses to the same value.
    #[test]
    fn prop_display_round_trip(t in tree()) {
        check_any_text(&print(&t, 0))?;
    }

    /// Glued pieces of expressions: never a panic, errors well-formed, Display round trip.
    #[test]
    fn prop_token_soup_never_panics(pieces in prop::collection::vec(prop::sample::select(PIECES), 0..16)) {
        check_any_text(&pieces.concat())?;
    }

    /// Arbitrary Unicode, control characters included: never a panic.
    #[test]
    fn prop_arbitrary_text_never_panics(text in any::<String>(), prefix in prop::sample::select(vec!["", "=", "1 + ", "2 ", "2 [", "x."])) {
        check_any_text(&format!("{prefix}{text}"))?;
    }

    /// a + b - b ≈ a for quantities of one dimension.
    #[test]
    fn prop_add_subtract(a in -1e6f64..1e6, b in -1e6f64..1e6, d in 0usize..4) {
        let dims = [dim::DIMENSIONLESS, dim::PRESSURE, dim::LENGTH, dim::CONDUCTANCE];
        let mut lookup = |n: &str| match n { "a" => Some(Quantity::new(a, dims[d])), "b" => Some(Quantity::new(b, dims[d])), _ => None };
        let q = parse_expr("a + b - b").unwrap().eval(&mut lookup).unwrap();
        prop_assert_eq!(q.dim, dims[d]);
        prop_assert!((q.value - a).abs() <= 2.0 * f64::EPSILON * (a.abs() + b.abs()), "{} {} {}", a, b, q.value);
    }

    /// x * y / y has the dimension of x and (nearly) its value.
    #[test]
    fn prop_product_quotient(x in -1e3f64..1e3, y in prop_oneof![-1e3f64..-1e-3, 1e-3f64..1e3],
                             dx in prop::array::uniform4(-4i8..=4), dy in prop::array::uniform4(-4i8..=4)) {
        let d = |e: [i8; 4]| Dimension { mass: e[0], length: e[1], time: e[2], temperature: e[3] };
        let mut lookup = |n: &str| match n { "x" => Some(Quantity::new(x, d(dx))), "y" => Some(Quantity::new(y, d(dy))), _ => None };
        let q = parse_expr("x * y / y").unwrap().eval(&mut lookup).unwrap();
        prop_assert_eq!(q.dim, d(dx));
        prop_assert!((q.value - x).abs() <= 2.0 * f64::EPSILON * x.abs(), "{} {} {}", x, y, q.value);
        // A sum of x and the quotient needs no conversion: same dimension.
        let s = parse_expr("x + x * y / y").unwrap().eval(&mut lookup).unwrap();
        prop_assert_eq!(s.dim, d(dx));
    }
}
