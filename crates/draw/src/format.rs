//! Numbers for labels, in engineering units: SI values converted to the
//! unit a reader expects (the block's display unit: bar, mm, L/min/bar),
//! three significant digits, no exponent between 0.001 and 10⁶.

/// `x` with `digits` significant digits, trailing zeros removed
/// (12.0 → "12", 0.30000001 → "0.3", 1.5e-7 → "1.5e-7").
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "?".into()
        } else if x > 0.0 {
            "∞".into()
        } else {
            "-∞".into()
        };
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-3..6).contains(&mag) {
        let s = format!("{:.*e}", digits.saturating_sub(1), x);
        // 1.50e-7 → 1.5e-7
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = if m.contains('.') { m.trim_end_matches('0').trim_end_matches('.') } else { m };
        return format!("{m}e{e}");
    }
    let decimals = (digits as i32 - 1 - mag).max(0) as usize;
    let s = format!("{x:.decimals$}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

/// A unit as printed: superscripts for powers, a degree sign for angles.
pub fn pretty_unit(unit: &str) -> String {
    match unit {
        "cm3" => "cm³".into(),
        "dm3" => "dm³".into(),
        "m3" => "m³".into(),
        "mm2" => "mm²".into(),
        "cm2" => "cm²".into(),
        "m2" => "m²".into(),
        "deg" => "°".into(),
        "m/s^2" => "m/s²".into(),
        "kg/m3" => "kg/m³".into(),
        "degC" => "°C".into(),
        other => other.to_string(),
    }
}

/// An SI value shown in `unit` ("13.2 L/min/bar"); plain when `unit` is empty.
pub fn quantity(si: f64, unit: &str) -> String {
    if unit.is_empty() {
        return sig(si, 3);
    }
    let v = units::to_unit(si, unit).unwrap_or(si);
    let u = pretty_unit(unit);
    if u == "°" {
        format!("{}°", sig(v, 3))
    } else {
        format!("{} {u}", sig(v, 3))
    }
}

/// Standard atmosphere [Pa], the reference of gauge pressures ("barg").
pub const P_STANDARD: f64 = 101_325.0;

/// An absolute pressure with its gauge value: "7.01 bar (6 barg)".
pub fn pressure(p: f64) -> String {
    let abs = quantity(p, "bar");
    if p > P_STANDARD * 1.05 {
        format!("{abs} ({} barg)", sig((p - P_STANDARD) / 1e5, 3))
    } else {
        abs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(sig(13.2, 3), "13.2");
        assert_eq!(sig(490.0, 3), "490");
        assert_eq!(sig(0.3, 3), "0.3");
        assert_eq!(sig(0.30000000000000004, 3), "0.3");
        assert_eq!(sig(7.01325, 3), "7.01");
        assert_eq!(sig(1234567.0, 3), "1.23e6");
        assert_eq!(sig(1.5e-7, 3), "1.5e-7");
        assert_eq!(sig(2e-5, 3), "2e-5");
        assert_eq!(sig(-0.0001, 3), "-1e-4");
        assert_eq!(sig(0.0, 3), "0");
        assert_eq!(sig(f64::INFINITY, 3), "∞");
        assert_eq!(sig(99.96, 3), "100");
    }

    #[test]
    fn quantities_in_engineering_units() {
        assert_eq!(quantity(13.2 / 60.0 * 1e-3 / 1e5, "L/min/bar"), "13.2 L/min/bar");
        assert_eq!(quantity(0.045, "mm"), "45 mm");
        assert_eq!(quantity(20e-6, "cm3"), "20 cm³");
        assert_eq!(quantity(std::f64::consts::FRAC_PI_2, "deg"), "90°");
        assert_eq!(pressure(4e5), "4 bar (2.99 barg)");
        assert_eq!(pressure(P_STANDARD + 6e5), "7.01 bar (6 barg)");
        assert_eq!(pressure(0.98e5), "0.98 bar");
    }
}
