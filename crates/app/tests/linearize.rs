//! `pneumo linearize --at` with trim conditions (issue 25): the conditions
//! are read in their units against the model's names, the linear model is
//! about the trimmed point, and a condition that names nothing, has the
//! wrong dimension or cannot be met is one clear error naming it.

use pneumo_app::linearize::{linearize, LinearizeOptions};
use std::path::{Path, PathBuf};

fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/examples/linearize/paper_cylinder_mid_stroke.json")
}

fn at(text: &str) -> Result<pneumo_app::linearize::Linearized, String> {
    linearize(&LinearizeOptions { model: model(), at: text.to_string(), ..Default::default() }).map_err(|e| e.to_string())
}

#[test]
fn trim_conditions_in_units_give_the_linear_model_about_the_trimmed_point() {
    let r = at("piston.x=200 mm; F=0 N; head.p=4 bar").unwrap_or_else(|e| panic!("{e}"));
    let op = &r.json["operating_point"];
    assert_eq!(op["kind"], "trim");
    let k = r.model.outputs.iter().position(|o| o.name == "x").expect("output x");
    assert!((r.model.y0[k] - 0.2).abs() < 1e-12, "x = {} m", r.model.y0[k]);
    // at an equilibrium every kept state's rate is zero
    for (s, dx) in r.model.states.iter().zip(&r.model.dx0) {
        assert!(dx.abs() < 1e-6, "d{}/dt = {dx:e}", s.name);
    }
    let held = r.json["trim"]["held"].as_array().expect("trim.held");
    let names: Vec<&str> = held.iter().map(|h| h["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["piston.x", "F", "head.p"]);
    assert_eq!(held[2]["value"], 4e5);
    assert!(r.json["trim"]["residual"].as_f64().unwrap() < 1e-10);
    let text = pneumo_app::linearize::text(&r);
    assert!(text.contains("held piston.x = 0.2 m, F = 0 N, head.p = 400000 Pa"), "{text}");
    // commas separate conditions too
    let again = at("piston.x = 200 mm, F = 0 N, head.p = 4 bar").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(again.model.a.to_rows(), r.model.a.to_rows());
}

#[test]
fn a_bad_trim_condition_is_one_error_naming_it() {
    let cases: [(&str, &[&str]); 5] = [
        ("piston.y=200 mm; F=0 N; head.p=4 bar", &["piston.y", "no state, interface input or recorded value"]),
        ("piston.x=200 bar; F=0 N; head.p=4 bar", &["piston.x=200 bar", "bar"]),
        ("piston.x=200 mm; F; head.p=4 bar", &["\"F\" is not NAME=VALUE"]),
        ("piston.x=200 mm", &["under-determined", "head.m", "rod.m", "F"]),
        ("piston.x=600 mm; F=0 N; head.p=4 bar", &["piston.x = 0.6 m", "cannot be evaluated"]),
    ];
    for (text, wanted) in cases {
        let e = at(text).err().unwrap_or_else(|| panic!("{text}: accepted"));
        assert_eq!(e.lines().count(), 1, "{text}: {e}");
        for w in wanted {
            assert!(e.contains(w), "{text}: {e} (wanted {w})");
        }
    }
}

/// H(s) = C (sI − A)⁻¹ B + D of the whole (not minimal) linear model at one
/// complex s, by Gaussian elimination with partial pivoting: independent of
/// `linear`'s balancing and of the minimal realisations behind the poles and
/// zeros.
fn transfer(lm: &solve::linearize::LinearModel, s: linear::Complex) -> Vec<linear::Complex> {
    use linear::Complex;
    let (n, m, p) = (lm.states.len(), lm.inputs.len(), lm.outputs.len());
    let mut a: Vec<Vec<Complex>> = (0..n)
        .map(|i| {
            let mut row: Vec<Complex> =
                (0..n).map(|j| Complex::new(-lm.a[(i, j)], 0.0) + if i == j { s } else { Complex::new(0.0, 0.0) }).collect();
            row.extend((0..m).map(|j| Complex::new(lm.b[(i, j)], 0.0)));
            row
        })
        .collect();
    for k in 0..n {
        let pivot = (k..n).max_by(|&x, &y| a[x][k].norm().total_cmp(&a[y][k].norm())).unwrap();
        a.swap(k, pivot);
        let (upper, lower) = a.split_at_mut(k + 1);
        let pivot_row = &upper[k];
        for row in lower.iter_mut() {
            let factor = row[k] / pivot_row[k];
            for (target, v) in row.iter_mut().zip(pivot_row).skip(k) {
                *target -= factor * v;
            }
        }
    }
    let mut x = vec![vec![Complex::new(0.0, 0.0); m]; n];
    for k in (0..n).rev() {
        for j in 0..m {
            let mut v = a[k][n + j];
            for l in k + 1..n {
                v -= a[k][l] * x[l][j];
            }
            x[k][j] = v / a[k][k];
        }
    }
    let mut h = Vec::with_capacity(p * m);
    for i in 0..p {
        for j in 0..m {
            h.push(x.iter().enumerate().map(|(k, xk)| xk[j] * lm.c[(i, k)]).sum::<Complex>() + lm.d[(i, j)]);
        }
    }
    h
}

#[test]
fn poles_zeros_and_gain_of_each_pair_factor_its_transfer_function() {
    use linear::Complex;
    let r = at("rest").unwrap_or_else(|e| panic!("{e}"));
    let (p, m) = (r.model.outputs.len(), r.model.inputs.len());
    assert_eq!(r.pairs.len(), p * m);
    let mut zeros_seen = 0;
    for (k, pair) in r.pairs.iter().enumerate() {
        let (i, j) = (k / m, k % m);
        assert_eq!((pair.output.as_str(), pair.input.as_str()), (r.model.outputs[i].name.as_str(), r.model.inputs[j].name.as_str()));
        let pz = &pair.pole_zero;
        assert_eq!(pz.poles.len(), pz.order);
        // G(s) = k Π(s − z)/Π(s − p) against H(s) of the whole model, on and off the imaginary axis
        for s in [Complex::new(0.0, 2.0), Complex::new(0.0, 85.0), Complex::new(-3.0, 400.0), Complex::new(7.0, -20.0)] {
            let h = transfer(&r.model, s)[k];
            let g = pz.zeros.iter().map(|z| s - z).product::<Complex>() / pz.poles.iter().map(|q| s - q).product::<Complex>() * pz.gain;
            assert!(
                (g - h).norm() <= 1e-7 * h.norm(),
                "{}/{} at s = {s}: {g} from poles and zeros, {h} from A, B, C, D",
                pair.output,
                pair.input
            );
        }
        // each zero is where the whole model's H vanishes (relative to H nearby)
        for z in &pz.zeros {
            let scale = transfer(&r.model, z + Complex::new(0.0, 0.1 * z.norm().max(1.0)))[k].norm();
            assert!(transfer(&r.model, *z)[k].norm() <= 1e-6 * scale, "{}/{}: H({z}) is not 0", pair.output, pair.input);
            zeros_seen += 1;
        }
        if let Some(dc) = pz.dc_gain {
            // (at s = 0 itself sI − A is singular: the conserved gas masses are λ = 0 modes F cannot reach)
            let h0 = transfer(&r.model, Complex::new(0.0, 1e-7))[k];
            assert!((h0 - dc).norm() <= 1e-4 * dc.abs(), "{dc} vs {h0}");
        }
    }
    assert!(zeros_seen >= 1, "no zero checked");
    // the oscillating mode of the gas springs (13.7 Hz) is a pole of x/F, whose DC gain is the springs' compliance
    let x = &r.pairs[r.model.outputs.iter().position(|o| o.name == "x").unwrap() * m].pole_zero;
    assert!(x.poles.iter().any(|q| (q.norm() / (2.0 * std::f64::consts::PI) - 13.667).abs() < 0.01), "{:?}", x.poles);
    assert!(x.dc_gain.is_some_and(|g| g > 0.0));
    // in linear.json and the text output
    let pairs = r.json["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), p * m);
    assert_eq!(pairs[0]["output"], r.model.outputs[0].name.as_str());
    assert_eq!(pairs[0]["poles"].as_array().unwrap().len(), r.pairs[0].pole_zero.order);
    let text = pneumo_app::linearize::text(&r);
    assert!(text.contains("x/F: order"), "{text}");
    assert!(text.contains("DC gain") && text.contains(" m/N"), "{text}");
}

/// The x and y pixel coordinates of every polyline of an SVG (plotters
/// draws each line series as one `<polyline points="x,y x,y ...">`).
fn polylines(svg: &str) -> Vec<Vec<(f64, f64)>> {
    svg.split("<polyline")
        .skip(1)
        .filter_map(|tag| {
            let points = tag.split("points=\"").nth(1)?.split('"').next()?;
            Some(
                points
                    .split_whitespace()
                    .map(|xy| {
                        let (x, y) = xy.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect(),
            )
        })
        .collect()
}

/// The least-squares line y ≈ a + b·x and its largest residual.
fn affine(points: &[(f64, f64)]) -> (f64, f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    let a = my - b * mx;
    (a, b, points.iter().map(|p| (p.1 - a - b * p.0).abs()).fold(0.0, f64::max))
}

#[test]
fn the_bode_picture_draws_each_pairs_magnitude_and_phase() {
    let dir = std::env::temp_dir().join(format!("pneumo-bode-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (svg_path, png_path) = (dir.join("bode.svg"), dir.join("bode.png"));
    let options =
        |bode: &Path| LinearizeOptions { model: model(), at: "rest".into(), bode: Some(bode.to_path_buf()), ..Default::default() };
    let r = linearize(&options(&svg_path)).unwrap_or_else(|e| panic!("{e}"));
    linearize(&options(&png_path)).unwrap_or_else(|e| panic!("{e}"));
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    let png = std::fs::read(&png_path).unwrap();
    let e = linearize(&options(&dir.join("bode.txt"))).err().map(|e| e.to_string()).unwrap_or_default();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(png.starts_with(b"\x89PNG"), "not a PNG");
    assert!(e.contains(".png or .svg"), "{e}");
    let (f, pairs) = r.bode_data().unwrap();
    // one polyline per pair and panel with a point per frequency: magnitudes first, then phases
    let lines: Vec<Vec<(f64, f64)>> = polylines(&svg).into_iter().filter(|l| l.len() == f.len()).collect();
    assert_eq!(lines.len(), 2 * pairs.len(), "{} polylines of {} points", lines.len(), f.len());
    for text in ["magnitude [dB]", "phase [deg]", "frequency [Hz]"] {
        assert!(svg.contains(text), "no {text}");
    }
    for (label, _, _) in &pairs {
        assert!(svg.contains(label.as_str()), "no legend entry {label}");
    }
    // the picture's pixels are affine in log10 f and in the drawn values, within the 1 px rounding
    let m = r.model.inputs.len();
    let mut checked = 0;
    for (panel, pick) in [(0, 1), (1, 2)] {
        let drawn = &lines[panel * pairs.len()..(panel + 1) * pairs.len()];
        let horizontal: Vec<(f64, f64)> = drawn[0].iter().zip(&f).map(|(px, fk)| (fk.log10(), px.0)).collect();
        assert!(affine(&horizontal).2 <= 1.0, "frequency axis");
        let vertical: Vec<(f64, f64)> = drawn
            .iter()
            .zip(&pairs)
            .flat_map(|(line, pair)| {
                let values = if pick == 1 { &pair.1 } else { &pair.2 };
                line.iter().zip(values).map(|(px, v)| (*v, px.1))
            })
            .collect();
        let (a, b, worst) = affine(&vertical);
        assert!(worst <= 1.0, "panel {panel}: {worst} px off the axis line");
        // and the drawn points are the model's response C (jωI − A)⁻¹ B + D at a few frequencies
        for k in [0, f.len() / 3, f.len() / 2, f.len() - 1] {
            let h = transfer(&r.model, linear::Complex::new(0.0, 2.0 * std::f64::consts::PI * f[k]));
            for (q, line) in drawn.iter().enumerate() {
                let hq = h[(q / m) * m + q % m];
                let value = if pick == 1 { 20.0 * hq.norm().log10() } else { hq.arg().to_degrees() };
                let y = line[k].1;
                // the phase is unwrapped: compare modulo 360°
                let expected = if pick == 1 {
                    a + b * value
                } else {
                    let drawn_value = (y - a) / b;
                    a + b * (value + 360.0 * ((drawn_value - value) / 360.0).round())
                };
                assert!(
                    (y - expected).abs() <= 1.0,
                    "panel {panel}, {} at {} Hz: drawn at {y} px, expected {expected} px",
                    pairs[q].0,
                    f[k]
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 24, "{checked}");
}

#[test]
fn position_is_the_integral_of_velocity_in_the_factored_pairs() {
    // position_control trimmed at mid-stroke (docs/position_control_tuning.md):
    // x = ∫ v, so x/u = (v/u)/s — the same gain k and the same zeros. Before
    // the zero count was bounded by the relative degree, x/u came out with
    // k = −1.3e-21 and five spurious zeros near 1e5 1/s (the pencil's multiple
    // infinite eigenvalue split by rounding), v/u with k = 7.2e-18.
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/position_control.json");
    let r = linearize(&LinearizeOptions {
        model,
        at: "cyl.piston.x=100 mm; F_load=0 N".to_string(),
        sets: vec!["cyl.x0=100 mm".to_string()],
        ..Default::default()
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let m = r.model.inputs.len();
    let pair = |out: &str, inp: &str| {
        let i = r.model.outputs.iter().position(|o| o.name == out).unwrap();
        let j = r.model.inputs.iter().position(|o| o.name == inp).unwrap();
        &r.pairs[i * m + j].pole_zero
    };
    let (x, v) = (pair("x", "u"), pair("v", "u"));
    assert!((x.gain - v.gain).abs() <= 1e-6 * v.gain.abs(), "k of x/u {:e}, of v/u {:e}", x.gain, v.gain);
    assert_eq!(x.zeros.len(), v.zeros.len(), "x/u zeros {:?}, v/u zeros {:?}", x.zeros, v.zeros);
    for (a, b) in x.zeros.iter().zip(&v.zeros) {
        assert!((a - b).norm() <= 1e-6 * b.norm().max(1.0), "x/u zeros {:?}, v/u zeros {:?}", x.zeros, v.zeros);
    }
    // no zero far beyond the model's fastest mode (the 1 ms sensor lag, 1000 1/s)
    assert!(x.zeros.iter().all(|z| z.norm() < 1e4), "{:?}", x.zeros);
}
