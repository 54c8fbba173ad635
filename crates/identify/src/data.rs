//! Measured data: a CSV table with a time column `t` [s] and measured
//! channels in SI units, and an estimate of each channel's sensor noise.
//!
//! # Format
//! - First non-blank line: the header, comma-separated names, one of them `t`.
//! - Then one row per sample, the same number of fields as the header. Blank
//!   lines and lines starting with `#` are skipped.
//! - A cell is a number (Rust/JSON float syntax), or empty / `NaN` for a
//!   missing sample. Times must be finite and strictly increasing; uneven
//!   sampling and a first time other than 0 are accepted.
//! - Errors name the file, the line (1-based) and the column (name and
//!   1-based position).
//!
//! # Noise estimate (per channel)
//! Each interior sample is compared with the straight line through its two
//! neighbours in the same channel (rows where the channel is empty are
//! skipped): d_i = y_i − (w·y_{i−1} + (1 − w)·y_{i+1}), w = (t_{i+1} − t_i)/(t_{i+1} − t_{i−1}).
//! For white noise of standard deviation σ on a signal that is locally
//! linear, Var d_i = σ²·(1 + w² + (1 − w)²) (= 1.5 σ² for even sampling).
//! The estimate is robust to the few samples where the signal is not
//! locally linear (valve switching, impacts): σ̂ = 1.4826·median(|d_i|/√(1 + w² + (1 − w)²))
//! (the median absolute deviation of a normal law). Valid when the signal's
//! curvature over two sampling intervals is small against σ on most samples,
//! which holds at 1 kHz for cylinder pressures and positions. A constant
//! offset of the sensor is not seen by this estimate.

/// Why a data file could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DataError {
    #[error("{file}:{line}: {message}")]
    Line { file: String, line: usize, message: String },
    #[error("{file}:{line}: column {column} (\"{name}\"): {message}")]
    Cell { file: String, line: usize, column: usize, name: String, message: String },
    #[error("{file}: {message}")]
    File { file: String, message: String },
}

/// A measured table.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// File name, for messages.
    pub origin: String,
    /// Sample times [s], strictly increasing, as written in the file.
    pub times: Vec<f64>,
    /// Channel names (header, `t` excluded).
    pub names: Vec<String>,
    /// `values[c][i]`: channel c at sample i; `None` = missing.
    pub values: Vec<Vec<Option<f64>>>,
    /// Line (1-based) of each sample in the source file, for messages about
    /// a sample; empty for data not read from a file.
    pub lines: Vec<usize>,
}

impl Dataset {
    /// Index of a channel by name.
    pub fn channel(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
    /// Median sampling interval [s].
    pub fn median_interval(&self) -> f64 {
        let mut d: Vec<f64> = self.times.windows(2).map(|w| w[1] - w[0]).collect();
        median(&mut d).unwrap_or(0.0)
    }
    /// The table as CSV text (header `t,<names>`; missing samples as empty cells).
    pub fn to_csv(&self) -> String {
        let mut s = String::from("t");
        for n in &self.names {
            s.push(',');
            s.push_str(n);
        }
        s.push('\n');
        for (i, t) in self.times.iter().enumerate() {
            s.push_str(&format!("{t}"));
            for col in &self.values {
                s.push(',');
                if let Some(v) = col[i] {
                    s.push_str(&format!("{v}"));
                }
            }
            s.push('\n');
        }
        s
    }
}

/// Median of the finite values (sorts the slice); `None` when empty.
pub fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    Some(if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) })
}

/// Parse CSV text; `origin` names the file in errors.
pub fn parse_csv(text: &str, origin: &str) -> Result<Dataset, DataError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim_end_matches('\r'))).filter(|(_, l)| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('#')
    });
    let (header_line, header) = lines.next().ok_or_else(|| DataError::File {
        file: origin.to_string(),
        message: "is empty (expected a header line with a column \"t\")".into(),
    })?;
    // "p1 [bar]": a unit after the name converts the column to SI
    let mut scales: Vec<Option<units::Unit>> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (k, cell) in header.split(',').map(|s| s.trim().trim_matches('"')).enumerate() {
        match cell.strip_suffix(']').and_then(|c| c.rsplit_once(" [")) {
            Some((name, unit)) => {
                let u = units::parse_unit(unit.trim()).map_err(|e| DataError::Cell {
                    file: origin.into(),
                    line: header_line,
                    column: k + 1,
                    name: name.trim().to_string(),
                    message: format!("unit \"{}\": {e}", unit.trim()),
                })?;
                names.push(name.trim().to_string());
                scales.push(Some(u));
            }
            None => {
                names.push(cell.to_string());
                scales.push(None);
            }
        }
    }
    for (k, n) in names.iter().enumerate() {
        if n.is_empty() {
            return Err(DataError::Cell {
                file: origin.into(),
                line: header_line,
                column: k + 1,
                name: String::new(),
                message: "empty column name".into(),
            });
        }
        if names[..k].contains(n) {
            return Err(DataError::Cell {
                file: origin.into(),
                line: header_line,
                column: k + 1,
                name: n.clone(),
                message: "column name used twice".into(),
            });
        }
    }
    let t_col = names.iter().position(|n| n == "t").ok_or_else(|| DataError::Line {
        file: origin.into(),
        line: header_line,
        message: format!("no time column \"t\" in the header (columns: {})", names.join(", ")),
    })?;
    let channel_cols: Vec<usize> = (0..names.len()).filter(|&k| k != t_col).collect();
    let mut times = Vec::new();
    let mut sample_lines = Vec::new();
    let mut values: Vec<Vec<Option<f64>>> = vec![Vec::new(); channel_cols.len()];
    for (line, row) in lines {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != names.len() {
            return Err(DataError::Line {
                file: origin.into(),
                line,
                message: format!("{} fields, but the header has {} columns", fields.len(), names.len()),
            });
        }
        let cell = |k: usize| -> Result<Option<f64>, DataError> {
            let f = fields[k].trim_matches('"');
            if f.is_empty() || f.eq_ignore_ascii_case("nan") {
                return Ok(None);
            }
            match f.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(scales[k].map_or(v, |u| u.to_si(v)))),
                Ok(v) => Err(DataError::Cell {
                    file: origin.into(),
                    line,
                    column: k + 1,
                    name: names[k].clone(),
                    message: format!("{v} is not a finite number"),
                }),
                Err(_) => Err(DataError::Cell {
                    file: origin.into(),
                    line,
                    column: k + 1,
                    name: names[k].clone(),
                    message: format!("\"{f}\" is not a number"),
                }),
            }
        };
        let t = cell(t_col)?.ok_or_else(|| DataError::Cell {
            file: origin.into(),
            line,
            column: t_col + 1,
            name: "t".into(),
            message: "the time is missing".into(),
        })?;
        if let Some(&prev) = times.last() {
            if t <= prev {
                return Err(DataError::Cell {
                    file: origin.into(),
                    line,
                    column: t_col + 1,
                    name: "t".into(),
                    message: format!("time {} s does not increase (previous sample {} s)", units::show::num(t), units::show::num(prev)),
                });
            }
        }
        times.push(t);
        sample_lines.push(line);
        for (c, &k) in channel_cols.iter().enumerate() {
            values[c].push(cell(k)?);
        }
    }
    if times.len() < 3 {
        return Err(DataError::File { file: origin.into(), message: format!("has {} samples; at least 3 are needed", times.len()) });
    }
    Ok(Dataset {
        origin: origin.to_string(),
        times,
        names: channel_cols.iter().map(|&k| names[k].clone()).collect(),
        values,
        lines: sample_lines,
    })
}

/// Linear interpolation of (times, values) at `t`; values beyond the ends
/// are held; a missing value next to `t` gives its defined neighbour.
pub fn interpolate(times: &[f64], values: &[Option<f64>], t: f64) -> Option<f64> {
    let k = times.partition_point(|&u| u <= t);
    between(times, values, k, t, |_, _, a, b, x| a + (b - a) * x)
}

/// [`interpolate`] at many times `at`, in one pass when they increase (as
/// sample times do; any order is answered correctly).
pub fn interpolate_many(times: &[f64], values: &[Option<f64>], at: impl Iterator<Item = f64>) -> Vec<Option<f64>> {
    let mut k = 0;
    at.map(|t| {
        k = next_index(times, k, t);
        between(times, values, k, t, |_, _, a, b, x| a + (b - a) * x)
    })
    .collect()
}

/// Like [`interpolate_many`], but a cubic Hermite curve between grid points
/// with finite-difference slopes (Catmull–Rom on an uneven grid), so that
/// the value is continuously differentiable in the query time: a fit that
/// shifts the query times (the logger skew of [`crate::nuisance`]) then sees
/// a smooth cost. Linear where a neighbour needed for a slope is missing.
pub fn interpolate_many_smooth(times: &[f64], values: &[Option<f64>], at: impl Iterator<Item = f64>) -> Vec<Option<f64>> {
    let n = times.len();
    let slope = |k: usize| -> Option<f64> {
        let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
        let dt = times[b] - times[a];
        match (values[a], values[b]) {
            (Some(ya), Some(yb)) if dt > 0.0 => Some((yb - ya) / dt),
            _ => None,
        }
    };
    let mut k = 0;
    at.map(|t| {
        k = next_index(times, k, t);
        between(times, values, k, t, |k0, h, a, b, x| match (slope(k0), slope(k0 + 1)) {
            (Some(ma), Some(mb)) => {
                let (x2, x3) = (x * x, x * x * x);
                (2.0 * x3 - 3.0 * x2 + 1.0) * a + (x3 - 2.0 * x2 + x) * h * ma + (-2.0 * x3 + 3.0 * x2) * b + (x3 - x2) * h * mb
            }
            _ => a + (b - a) * x,
        })
    })
    .collect()
}

/// The number of grid times ≤ `t`, walking on from `k` (the answer for an
/// earlier query) when the queries increase, searching otherwise.
fn next_index(times: &[f64], mut k: usize, t: f64) -> usize {
    if k > 0 && times[k - 1] > t {
        k = times.partition_point(|&u| u <= t);
    }
    while k < times.len() && times[k] <= t {
        k += 1;
    }
    k
}

/// The value at `t` given k = the number of grid times ≤ `t`: held beyond
/// the ends, `curve(k − 1, h, y₀, y₁, x)` inside the segment [t₀, t₁] of
/// length h at the fraction x, a defined neighbour where one value is missing.
fn between(times: &[f64], values: &[Option<f64>], k: usize, t: f64, curve: impl Fn(usize, f64, f64, f64, f64) -> f64) -> Option<f64> {
    if times.is_empty() {
        return None;
    }
    if k == 0 {
        return values[0];
    }
    if k >= times.len() {
        return values[times.len() - 1];
    }
    let (t0, t1) = (times[k - 1], times[k]);
    match (values[k - 1], values[k]) {
        (Some(a), Some(b)) if t1 > t0 => Some(curve(k - 1, t1 - t0, a, b, (t - t0) / (t1 - t0))),
        (Some(a), _) => Some(a),
        (None, b) => b,
    }
}

/// Robust white-noise standard deviation of one channel (see the module
/// header); `None` if fewer than 10 usable triples. The triples are
/// consecutive samples *of this channel*: a row where it is missing (another
/// channel logged at its own instants, as in a file that merges a pressure
/// logger's and a thermocouple's records) is skipped, not a break.
pub fn noise_sigma(times: &[f64], values: &[Option<f64>]) -> Option<f64> {
    let (times, values): (Vec<f64>, Vec<f64>) = times.iter().zip(values).filter_map(|(&t, v)| v.map(|v| (t, v))).unzip();
    let mut d = Vec::with_capacity(values.len());
    for i in 1..values.len().saturating_sub(1) {
        let (a, b, c) = (values[i - 1], values[i], values[i + 1]);
        let span = times[i + 1] - times[i - 1];
        if span <= 0.0 {
            continue;
        }
        let w = (times[i + 1] - times[i]) / span;
        let dev = b - (w * a + (1.0 - w) * c);
        d.push(dev.abs() / (1.0 + w * w + (1.0 - w) * (1.0 - w)).sqrt());
    }
    if d.len() < 10 {
        return None;
    }
    median(&mut d).map(|m| 1.482_6 * m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn interpolating_many_times_agrees_with_one_at_a_time_in_any_order() {
        let times = [0.0, 1.0, 2.0, 2.0, 3.5, 5.0];
        let values = [Some(0.0), Some(2.0), None, Some(4.0), Some(1.0), Some(7.0)];
        let at = [-1.0, 0.0, 0.25, 1.0, 1.5, 2.0, 3.0, 5.0, 6.0, 0.5, 4.9, -0.5, 2.5];
        let many = interpolate_many(&times, &values, at.iter().copied());
        let one: Vec<Option<f64>> = at.iter().map(|&t| interpolate(&times, &values, t)).collect();
        assert_eq!(many, one);
        assert!(interpolate_many(&[], &[], [1.0].into_iter()).iter().all(Option::is_none));
    }

    #[test]
    fn the_smooth_interpolation_is_exact_for_a_parabola_and_has_no_kink_at_grid_points() {
        // central-difference slopes are exact for a quadratic, so the Hermite curve is the parabola itself
        let times: Vec<f64> = (0..8).map(|i| 0.5 * i as f64).collect();
        let values: Vec<Option<f64>> = times.iter().map(|t| Some(3.0 * t * t - t + 2.0)).collect();
        let at = [0.6, 1.25, 1.5, 2.2, 2.9];
        let smooth = interpolate_many_smooth(&times, &values, at.iter().copied());
        for (t, v) in at.iter().zip(&smooth) {
            assert!((v.unwrap() - (3.0 * t * t - t + 2.0)).abs() < 1e-12, "{t}: {v:?}");
        }
        // the linear one is not (that is the point of the smooth one)
        let linear = interpolate_many(&times, &values, [1.25].into_iter());
        assert!((linear[0].unwrap() - (3.0 * 1.5625 - 1.25 + 2.0)).abs() > 0.1);
        // one-sided slopes agree at a grid point (the curve is C¹)
        let values: Vec<Option<f64>> = times.iter().map(|t| Some((2.0 * t).sin())).collect();
        let h = 1e-6;
        let v = interpolate_many_smooth(&times, &values, [1.5 - h, 1.5, 1.5 + h].into_iter());
        let (left, right) = ((v[1].unwrap() - v[0].unwrap()) / h, (v[2].unwrap() - v[1].unwrap()) / h);
        assert!((left - right).abs() < 1e-4, "{left} {right}");
        // a missing neighbour falls back to linear, ends are held
        let gaps = [Some(0.0), Some(1.0), None, Some(3.0)];
        let v = interpolate_many_smooth(&[0.0, 1.0, 2.0, 3.0], &gaps, [0.5, -1.0, 4.0].into_iter());
        assert_eq!(v, vec![Some(0.5), Some(0.0), Some(3.0)]);
    }

    #[test]
    fn reads_uneven_offset_times_and_missing_cells() {
        let text = "# comment\nt, head.p ,piston.x\n10.0,1e5,0\n\n10.001,NaN,0.001\n10.0025,,0.002\n10.004,1.2e5,\n";
        let d = parse_csv(text, "run.csv").unwrap();
        assert_eq!(d.times, vec![10.0, 10.001, 10.0025, 10.004]);
        assert_eq!(d.names, vec!["head.p", "piston.x"]);
        assert_eq!(d.values[0], vec![Some(1e5), None, None, Some(1.2e5)]);
        assert_eq!(d.values[1][3], None);
        assert!((d.median_interval() - 0.0015).abs() < 1e-12);
        // round trip
        let again = parse_csv(&d.to_csv(), "again").unwrap();
        assert_eq!(again.values, d.values);
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse_csv("t,p\n0,1\n0.1,abc\n0.2,3\n", "a.csv").unwrap_err().to_string();
        assert!(e.contains("a.csv:3") && e.contains("column 2") && e.contains("\"p\"") && e.contains("abc"), "{e}");
        let e = parse_csv("t,p\n0,1\n0.1\n", "b.csv").unwrap_err().to_string();
        assert!(e.contains("b.csv:3") && e.contains("1 fields"), "{e}");
        let e = parse_csv("time,p\n0,1\n", "c.csv").unwrap_err().to_string();
        assert!(e.contains("c.csv:1") && e.contains("\"t\""), "{e}");
        let e = parse_csv("t,p\n0,1\n0.2,1\n0.1,1\n", "d.csv").unwrap_err().to_string();
        assert!(e.contains("d.csv:4") && e.contains("does not increase"), "{e}");
        // an extreme time prints as a number, not 309 digits
        let e = parse_csv("t,p\n0,1\n1e308,1\n30,1\n", "d.csv").unwrap_err().to_string();
        assert!(e.contains("time 30 s does not increase (previous sample 1e308 s)"), "{e}");
        let e = parse_csv("t,p\n0,1\n,2\n", "e.csv").unwrap_err().to_string();
        assert!(e.contains("e.csv:3") && e.contains("time is missing"), "{e}");
        assert!(parse_csv("", "f.csv").unwrap_err().to_string().contains("empty"));
        assert!(parse_csv("t,p,p\n", "g.csv").unwrap_err().to_string().contains("twice"));
        let e = parse_csv("t,p\n0,1\n1,inf\n2,3\n", "h.csv").unwrap_err().to_string();
        assert!(e.contains("h.csv:3") && e.contains("finite"), "{e}");
    }

    #[test]
    fn interpolation_is_exact_on_lines_and_holds_beyond_the_ends() {
        let t = [0.0, 1.0, 3.0];
        let v = [Some(1.0), Some(3.0), Some(7.0)];
        assert_eq!(interpolate(&t, &v, 0.5), Some(2.0));
        assert_eq!(interpolate(&t, &v, 2.0), Some(5.0));
        assert_eq!(interpolate(&t, &v, -1.0), Some(1.0));
        assert_eq!(interpolate(&t, &v, 9.0), Some(7.0));
        assert_eq!(interpolate(&t, &v, 1.0), Some(3.0));
    }

    #[test]
    fn noise_estimate_recovers_sigma_on_a_curved_signal_with_a_few_jumps() {
        let mut rng = Rng::new(7);
        for &sigma in &[5e2, 20e-6] {
            let n = 20_000;
            // uneven sampling around 1 kHz
            let mut times = Vec::with_capacity(n);
            let mut t = 0.0;
            for _ in 0..n {
                times.push(t);
                t += 1e-3 * (0.7 + 0.6 * rng.uniform());
            }
            let values: Vec<Option<f64>> = times
                .iter()
                .enumerate()
                .map(|(i, &t)| {
                    let smooth = 3e5 * (2.0 * t).sin() + if i % 2000 < 3 { 1e5 } else { 0.0 };
                    Some(smooth * sigma / 5e2 + sigma * rng.normal())
                })
                .collect();
            let s = noise_sigma(&times, &values).unwrap();
            assert!((s / sigma - 1.0).abs() < 0.05, "sigma {sigma}: estimated {s}");
        }
        assert_eq!(noise_sigma(&[0.0, 1.0, 2.0], &[Some(1.0), Some(2.0), Some(3.0)]), None);
    }
}
