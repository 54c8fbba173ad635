//! Tests of unit parsing against hand-computed SI values, error messages,
//! and round trips (including property tests with proptest).

use super::*;
use proptest::prelude::*;

/// Relative closeness: |a - b| <= rel · max(|a|, |b|).
fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

fn q(text: &str, d: Dimension) -> f64 {
    match parse_quantity(text, d) {
        Ok(x) => x,
        Err(e) => panic!("{text:?} as {}: {e}", d.name()),
    }
}

fn err(text: &str, d: Dimension) -> UnitError {
    match parse_quantity(text, d) {
        Ok(x) => panic!("{text:?} as {} gave {x}, expected an error", d.name()),
        Err(e) => e,
    }
}

#[test]
fn hand_computed_values() {
    use dim::*;
    // Hand-computed SI values; the factor is what each unit is defined as.
    let cases: &[(&str, Dimension, f64)] = &[
        ("450 mm", LENGTH, 0.45),
        ("4 bar", PRESSURE, 4e5),
        ("0.98 bar", PRESSURE, 98_000.0),
        ("13.2 L/min/bar", CONDUCTANCE, 13.2e-3 / 60.0 / 1e5),
        ("3.3 dm3/(s bar)", CONDUCTANCE, 3.3e-3 / 1e5),
        ("292 K", TEMPERATURE, 292.0),
        ("19 degC", TEMPERATURE, 292.15),
        ("19 °C", TEMPERATURE, 292.15),
        ("20 cm3", VOLUME, 2e-5),
        ("1 kg", MASS, 1.0),
        ("250 g", MASS, 0.25),
        ("50 N s/m", DAMPING, 50.0),
        ("2e-5 N/Pa", FORCE_PER_PRESSURE, 2e-5),
        ("2e-4 N s/(m Pa)", DAMPING_PER_PRESSURE, 2e-4),
        ("3 barg", PRESSURE, 3e5 + 101_325.0),
        ("500 mbarg", PRESSURE, 5e4 + 101_325.0),
        ("200 kPag", PRESSURE, 2e5 + 101_325.0),
        ("0.6 MPag", PRESSURE, 6e5 + 101_325.0),
        ("1 atm", PRESSURE, 101_325.0),
        ("5 ms", TIME, 5e-3),
        ("2 min", TIME, 120.0),
        ("1.5 h", TIME, 5400.0),
        ("10 L/min", VOLUME_FLOW, 10e-3 / 60.0),
        ("10 l/min", VOLUME_FLOW, 10e-3 / 60.0),
        ("3 mL", VOLUME, 3e-6),
        ("50 Hz", FREQUENCY, 50.0),
        ("2 kHz", FREQUENCY, 2000.0),
        ("0.5 MPa", PRESSURE, 5e5),
        ("25 µm", LENGTH, 25e-6),
        ("25 um", LENGTH, 25e-6),
        ("2 km", LENGTH, 2000.0),
        ("3 m/s^2", ACCELERATION, 3.0),
        ("1.2 kg/m3", DENSITY, 1.2),
        ("1 g/cm3", DENSITY, 1000.0),
        ("1005 J/(kg K)", SPECIFIC_HEAT, 1005.0),
        ("1.005 kJ/kg/K", SPECIFIC_HEAT, 1005.0),
        ("0.3 W/K", HEAT_CONDUCTANCE, 0.3),
        ("2 kW", POWER, 2000.0),
        ("1 kW h", ENERGY, 3.6e6),
        ("1e4 N/m", STIFFNESS, 1e4),
        ("10 N/mm", STIFFNESS, 1e4),
        ("3 kN", FORCE, 3000.0),
        ("1 kg m/s^2", FORCE, 1.0),
        ("4 mm2", AREA, 4e-6),
        ("0.1 nm", LENGTH, 1e-10),
        ("1 GPa", PRESSURE, 1e9),
        ("7 cm", LENGTH, 0.07),
        ("7 dm", LENGTH, 0.7),
    ];
    for &(text, d, want) in cases {
        let got = q(text, d);
        assert!(close(got, want, 1e-15), "{text}: got {got}, want {want}");
    }
}

#[test]
fn decimal_prefixes_are_exact() {
    // Powers of ten are applied exactly, so these are the nearest doubles.
    assert_eq!(q("450 mm", dim::LENGTH), 0.45);
    assert_eq!(q("0.98 bar", dim::PRESSURE), 98_000.0);
    assert_eq!(q("20 cm3", dim::VOLUME), 2e-5);
    assert_eq!(q("3 barg", dim::PRESSURE), 401_325.0);
}

#[test]
fn imperial_units() {
    // psi = lbf/in² = 0.45359237 kg · 9.80665 m/s² / (0.0254 m)²;
    // NIST SP 811 App. B gives 6.894 757 E+03 Pa.
    let psi = q("1 psi", dim::PRESSURE);
    assert!((psi - 6894.757).abs() < 5e-4, "{psi}");
    assert!(close(psi, 4.448_221_615_260_5 / 6.4516e-4, 1e-14), "{psi}");
    assert!(close(q("10 psig", dim::PRESSURE), 10.0 * psi + 101_325.0, 1e-15));
    // Freezing and boiling points of water.
    assert!(close(q("32 degF", dim::TEMPERATURE), 273.15, 1e-15));
    assert!(close(q("212 °F", dim::TEMPERATURE), 373.15, 1e-15));
    assert!(close(q("-40 degF", dim::TEMPERATURE), q("-40 degC", dim::TEMPERATURE), 1e-15));
}

#[test]
fn equivalent_spellings() {
    let same = |a: &str, b: &str, d: Dimension| {
        let (x, y) = (q(a, d), q(b, d));
        assert!(close(x, y, 1e-15), "{a} = {x} but {b} = {y}");
    };
    same("13.2 L/min/bar", "13.2 L/(min bar)", dim::CONDUCTANCE);
    same("13.2 L/min/bar", "13.2 L/(min*bar)", dim::CONDUCTANCE);
    same("13.2 L/min/bar", "13.2 L/(min·bar)", dim::CONDUCTANCE);
    same("13.2 L/min/bar", "13.2 dm^3 min^-1 bar^-1", dim::CONDUCTANCE);
    same("2 m2", "2 m^2", dim::AREA);
    same("2 m2", "2 m²", dim::AREA);
    same("2 cm3", "2 (cm)^3", dim::VOLUME);
    same("2 cm3", "2 mL", dim::VOLUME);
    same("2 cm3", "2 cm³", dim::VOLUME);
    same("5 Hz", "5 1/s", dim::FREQUENCY);
    same("5 Hz", "5 s^-1", dim::FREQUENCY);
    same("5 Hz", "5/s", dim::FREQUENCY);
    same("5 Hz", "5 /s", dim::FREQUENCY);
    same("3 m/s^2", "3 m/(s s)", dim::ACCELERATION);
    same("3 m/s^2", "3 m s^-2", dim::ACCELERATION);
    same("3 m/s^2", "3 (m/s)/s", dim::ACCELERATION);
    same("2e-4 N s/(m Pa)", "2e-4 N*s/m/Pa", dim::DAMPING_PER_PRESSURE);
    same("1 bar", "100 kPa", dim::PRESSURE);
    same("1 bar", "1000 mbar", dim::PRESSURE);
}

#[test]
fn whitespace_and_number_forms() {
    for text in ["4bar", " 4  bar ", "4 bar", "\t4\tbar\n", "4e0 bar", "4.0bar", "+4 bar", "0.4e1 bar", "40E-1 bar"] {
        assert_eq!(parse_quantity(text, dim::PRESSURE), Ok(4e5), "{text:?}");
    }
    assert_eq!(parse_quantity("0.98bar", dim::PRESSURE), Ok(98_000.0));
    assert_eq!(parse_quantity(".5 bar", dim::PRESSURE), Ok(5e4));
    assert!(close(q("-20 degC", dim::TEMPERATURE), 253.15, 1e-15));
    assert_eq!(parse_quantity("2e5Pa", dim::PRESSURE), Ok(2e5));
}

#[test]
fn bare_numbers_pass_through() {
    for (text, want) in [("1e-5", 1e-5), ("4", 4.0), ("-3.5", -3.5), (" 2.5E+3 ", 2500.0), ("0", 0.0)] {
        for d in [dim::PRESSURE, dim::CONDUCTANCE, dim::DIMENSIONLESS, dim::TEMPERATURE] {
            assert_eq!(parse_quantity(text, d), Ok(want), "{text:?}");
        }
    }
}

#[test]
fn wrong_dimension_names_both() {
    let e = err("450 mm", dim::PRESSURE);
    assert_eq!(e, UnitError::WrongDimension { unit: "mm".into(), found: dim::LENGTH, expected: dim::PRESSURE });
    let msg = e.to_string();
    assert!(msg.starts_with("unit \"mm\" is a length, expected a pressure (accepted: Pa, kPa,"), "{msg}");
    let msg = err("10 L/min", dim::CONDUCTANCE).to_string();
    assert!(msg.contains("a volume flow") && msg.contains("a sonic conductance"), "{msg}");
    assert!(msg.contains("L/min/bar"), "{msg}");
    // An unnamed dimension is spelled out in base units.
    let msg = err("1 bar/s", dim::PRESSURE).to_string();
    assert!(msg.contains("a quantity of dimension kg m^-1 s^-3"), "{msg}");
    // A number with a unit where a pure number is expected.
    let msg = err("3 bar", dim::DIMENSIONLESS).to_string();
    assert!(msg.contains("expected a dimensionless number (accepted: a plain number)"), "{msg}");
    // "K" is a temperature, not a pressure, even though "kPa" is one.
    assert!(matches!(err("1 K", dim::PRESSURE), UnitError::WrongDimension { .. }));
}

#[test]
fn unknown_units_list_accepted() {
    let e = err("4 bars", dim::PRESSURE);
    assert!(matches!(&e, UnitError::UnknownUnit { unit, .. } if unit == "bars"));
    let msg = e.to_string();
    assert!(msg.starts_with("unknown unit \"bars\" (accepted for pressure: Pa, kPa, MPa, bar"), "{msg}");
    // Case matters (except l/L); prefixes need a known symbol after them.
    for (text, bad) in [("4 Bar", "Bar"), ("4 PA", "PA"), ("1 kpsi", "kpsi"), ("1 mmin", "mmin")] {
        let d = if bad == "mmin" { dim::TIME } else { dim::PRESSURE };
        assert!(matches!(err(text, d), UnitError::UnknownUnit { unit, .. } if unit == bad), "{text}");
    }
    // Without an expected dimension, parse_unit lists the known symbols.
    let msg = parse_unit("L/mn").unwrap_err().to_string();
    assert!(msg.contains("\"mn\"") && msg.contains("min") && msg.contains("degC"), "{msg}");
}

#[test]
fn offset_units_only_alone() {
    for (unit, alone) in
        [("degC/s", "degC"), ("K/degC", "degC"), ("(degC)", "degC"), ("degF^2", "degF"), ("barg/s", "barg"), ("N/psig", "psig")]
    {
        match parse_unit(unit) {
            Err(UnitError::OffsetInExpression { unit: u, expression, .. }) => {
                assert_eq!((u.as_str(), expression.as_str()), (alone, unit));
            }
            other => panic!("{unit}: {other:?}"),
        }
    }
    let msg = err("2 degC/s", dim::TEMPERATURE).to_string();
    assert!(msg.contains("\"degC\"") && msg.contains("write K there"), "{msg}");
    // Alone they carry their offset; K and bar are absolute.
    assert_eq!(parse_unit("degC"), Ok(Unit { factor: 1.0, offset: 273.15, dimension: dim::TEMPERATURE }));
    assert_eq!(parse_unit(" barg "), Ok(Unit { factor: 1e5, offset: STANDARD_ATMOSPHERE, dimension: dim::PRESSURE }));
    assert_eq!(parse_unit("bar"), Ok(Unit { factor: 1e5, offset: 0.0, dimension: dim::PRESSURE }));
    assert_eq!(parse_unit("K").map(|u| u.offset), Ok(0.0));
}

#[test]
fn parse_unit_factors() {
    let u = parse_unit("L/min/bar").unwrap();
    assert!(close(u.factor, 1e-3 / 60.0 / 1e5, 1e-15));
    assert_eq!((u.offset, u.dimension), (0.0, dim::CONDUCTANCE));
    let u = parse_unit("N s/(m Pa)").unwrap();
    assert_eq!((u.factor, u.dimension), (1.0, dim::DAMPING_PER_PRESSURE));
    assert_eq!(parse_unit("J/(kg K)").map(|u| u.dimension), Ok(dim::SPECIFIC_HEAT));
    assert_eq!(parse_unit("min").map(|u| u.factor), Ok(60.0));
    assert_eq!(parse_unit("m").map(|u| (u.factor, u.dimension)), Ok((1.0, dim::LENGTH)));
    assert_eq!(parse_unit("l").map(|u| u.factor), parse_unit("L").map(|u| u.factor));
    let u = parse_unit("degF").unwrap();
    assert!(close(u.to_si(212.0), 373.15, 1e-15) && close(u.in_unit(273.15), 32.0, 1e-14));
}

#[test]
fn syntax_errors() {
    for unit in ["L/(min", "bar)", "J/kg K", "m/s kg", "m 2", "m^x", "m^", "m^300", "L/", "*m", "m//s", "()", "m-1", "2 m"] {
        assert!(matches!(parse_unit(unit), Err(UnitError::Syntax { .. })), "{unit}: {:?}", parse_unit(unit));
    }
    let msg = parse_unit("J/kg K").unwrap_err().to_string();
    assert!(msg.contains("J/(kg K)"), "{msg}");
    // Exponent overflow of the i8 dimension is an error, not a panic.
    assert!(matches!(parse_unit("(m^100)^100"), Err(UnitError::Syntax { .. })));
    assert!(matches!(parse_unit("m^100 m^100"), Err(UnitError::Syntax { .. })));
    // Powers of ten are fine while the factor is a finite double, an error beyond.
    assert!(close(parse_unit("(km/m)^100").unwrap().factor, 1e300, 1e-15));
    let huge = ["(km/m)^100 (km/m)^100", "((km/m)^100)^100", "((((km/m)^100)^100)^100)^100"];
    for unit in huge {
        assert!(matches!(parse_unit(unit), Err(UnitError::Syntax { .. })), "{unit}");
    }
    let deep = format!("{}m{}", "(".repeat(100), ")".repeat(100));
    assert!(matches!(parse_unit(&deep), Err(UnitError::Syntax { .. })));
    let ok = format!("{}m{}", "(".repeat(10), ")".repeat(10));
    assert_eq!(parse_unit(&ok).map(|u| u.dimension), Ok(dim::LENGTH));
}

#[test]
fn bad_numbers_and_empty() {
    assert_eq!(parse_quantity("", dim::PRESSURE), Err(UnitError::Empty));
    assert_eq!(parse_quantity("   ", dim::PRESSURE), Err(UnitError::Empty));
    assert_eq!(parse_unit(" "), Err(UnitError::Empty));
    assert_eq!(err("abc bar", dim::PRESSURE).to_string(), "cannot read a number in \"abc bar\"");
    for text in ["bar", "1.5.3 bar", "1,5 bar", "5-3 bar", "- 3 bar", ". bar", "inf", "NaN", "e5 bar"] {
        assert!(matches!(err(text, dim::PRESSURE), UnitError::BadNumber { .. }), "{text}");
    }
    assert_eq!(err("1e400", dim::PRESSURE), UnitError::NonFinite { text: "1e400".into() });
    assert_eq!(err("1e300 GPa", dim::PRESSURE), UnitError::NonFinite { text: "1e300 GPa".into() });
    // a 100 kB run of digits is refused with the input quoted, shortened
    let digits = "1".repeat(100_000);
    let message = err(&digits, dim::PRESSURE).to_string();
    assert!(
        message.len() < 300 && message.contains("1111") && message.contains("100000 characters") && !message.contains(&"1".repeat(30)),
        "{message}"
    );
    assert!(message.contains("not a finite number"), "{message}");
    assert_eq!(err("1e400", dim::PRESSURE).to_string(), "\"1e400\" is not a finite number (beyond 1.8e308 in SI)");
}

#[test]
fn dimension_names_and_examples() {
    assert_eq!(dim::PRESSURE.name(), "pressure");
    assert_eq!(dim::CONDUCTANCE.name(), "sonic conductance");
    assert_eq!(dim::DAMPING.name(), dim::MASS_FLOW.name());
    let odd = Dimension { mass: 1, length: -1, time: -3, temperature: 0 };
    assert_eq!(odd.name(), "kg m^-1 s^-3");
    assert_eq!(Dimension { mass: 0, length: 1, time: 0, temperature: -1 }.to_string(), "m K^-1");
    assert_eq!(odd.example_units(), &[] as &[&str]);
    assert_eq!(&dim::PRESSURE.example_units()[..3], &["Pa", "kPa", "MPa"]);
    // Every example unit parses, and to its own dimension.
    use dim::*;
    let all = [
        DIMENSIONLESS,
        PRESSURE,
        TEMPERATURE,
        LENGTH,
        AREA,
        VOLUME,
        MASS,
        TIME,
        FREQUENCY,
        FORCE,
        VELOCITY,
        ACCELERATION,
        MASS_FLOW,
        VOLUME_FLOW,
        CONDUCTANCE,
        DAMPING,
        STIFFNESS,
        FORCE_PER_PRESSURE,
        DAMPING_PER_PRESSURE,
        HEAT_CONDUCTANCE,
        DENSITY,
        SPECIFIC_HEAT,
        POWER,
        ENERGY,
    ];
    for d in all {
        assert!(!d.name().contains('^'), "{d:?} has no name");
        assert!(!d.example_units().is_empty() || d == DIMENSIONLESS);
        for u in d.example_units() {
            assert_eq!(parse_unit(u).map(|u| u.dimension), Ok(d), "{u}");
            assert!(parse_quantity(&format!("2 {u}"), d).is_ok(), "{u}");
        }
    }
}

#[test]
fn to_unit_round_trips() {
    let cases: &[(f64, &str, Dimension)] = &[
        (4e5, "bar", dim::PRESSURE),
        (4e5, "psi", dim::PRESSURE),
        (4e5, "barg", dim::PRESSURE),
        (293.15, "degC", dim::TEMPERATURE),
        (293.15, "degF", dim::TEMPERATURE),
        (2.2e-8, "L/min/bar", dim::CONDUCTANCE),
        (0.45, "mm", dim::LENGTH),
        (1.7e-4, "L/min", dim::VOLUME_FLOW),
    ];
    for &(si, unit, d) in cases {
        let shown = to_unit(si, unit).unwrap();
        let back = q(&format!("{shown} {unit}"), d);
        assert!(close(back, si, 1e-15), "{si} -> {shown} {unit} -> {back}");
    }
    assert_eq!(to_unit(4e5, "bar"), Ok(4.0));
    assert_eq!(to_unit(401_325.0, "barg"), Ok(3.0));
    assert!(close(to_unit(293.15, "degC").unwrap(), 20.0, 1e-13));
    assert_eq!(to_unit(0.45, "mm"), Ok(450.0));
    assert!(to_unit(1.0, "bars").is_err());
}

const ROUND_TRIP_UNITS: &[(&str, Dimension)] = &[
    ("bar", dim::PRESSURE),
    ("barg", dim::PRESSURE),
    ("psig", dim::PRESSURE),
    ("kPa", dim::PRESSURE),
    ("degC", dim::TEMPERATURE),
    ("degF", dim::TEMPERATURE),
    ("mm", dim::LENGTH),
    ("L/min/bar", dim::CONDUCTANCE),
    ("dm3/(s bar)", dim::CONDUCTANCE),
    ("N s/(m Pa)", dim::DAMPING_PER_PRESSURE),
    ("cm3", dim::VOLUME),
    ("ms", dim::TIME),
    ("L/min", dim::VOLUME_FLOW),
];

proptest! {
    /// parse(to_unit(x)) = x up to rounding (offset units lose digits relative to the offset).
    #[test]
    fn prop_round_trip(si in -1e9f64..1e9, i in 0..ROUND_TRIP_UNITS.len(), sci in any::<bool>()) {
        let (unit, d) = ROUND_TRIP_UNITS[i];
        let u = parse_unit(unit).unwrap();
        let shown = to_unit(si, unit).unwrap();
        let text = if sci { format!("{shown:e}{unit}") } else { format!("{shown} {unit}") };
        let back = parse_quantity(&text, d).unwrap();
        let tol = 1e-14 * (si.abs() + u.offset.abs());
        prop_assert!((back - si).abs() <= tol, "{} -> {} -> {}", si, text, back);
    }

    /// Every float formatted by Rust (plain or scientific) reads back exactly as a bare number.
    #[test]
    fn prop_bare_numbers_exact(x in any::<f64>().prop_filter("finite", |x| x.is_finite()), form in 0..3u8) {
        let text = match form { 0 => format!("{x}"), 1 => format!(" {x:e} "), _ => format!("{x:E}") };
        prop_assert_eq!(parse_quantity(&text, dim::PRESSURE), Ok(x));
    }

    /// The SI value is value · factor + offset, as parse_unit reports.
    #[test]
    fn prop_affine_in_number(v in -1e6f64..1e6, i in 0..ROUND_TRIP_UNITS.len()) {
        let (unit, d) = ROUND_TRIP_UNITS[i];
        let u = parse_unit(unit).unwrap();
        let got = parse_quantity(&format!("{v} {unit}"), d).unwrap();
        let want = v * u.factor + u.offset;
        prop_assert!((got - want).abs() <= 1e-14 * (want.abs() + u.offset.abs() + (v * u.factor).abs()));
    }
}
