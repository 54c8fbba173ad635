//! Synthetic measurements: statistics of the sensor errors, timing,
//! determinism, and the CSV format.

use rig::sensors::{acquire, measure, sample_instants, write_csv, Channel, SensorSpec};
use rig::{Effects, ModelForm, Rig, RunSpec};

fn experiment(spec: &SensorSpec, seed: u64) -> (rig::Trace, rig::sensors::Measurements) {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let run = RunSpec { t_end: 3.0, ..RunSpec::cycles(1, 1e-3) };
    acquire(&rig, &ModelForm::default(), &Effects::default(), &run, spec, seed).unwrap()
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt())
}

#[test]
fn noise_offsets_and_quantisation_have_the_specified_statistics() {
    let spec = SensorSpec { temperatures: true, velocity_column: true, ..SensorSpec::default() };
    let (tr, m) = experiment(&spec, 11);
    let names: Vec<&str> = m.columns.iter().map(|c| c.0.as_str()).collect();
    assert_eq!(names, ["head.p", "rod.p", "piston.x", "head.T", "rod.T", "piston.v"]);
    assert_eq!(m.t.len(), tr.t.len());
    // ~2.98 s at 1 kHz (the run ends at the end of the cycle)
    assert!(m.t.len() > 2900, "{}", m.t.len());
    for (k, truth, sigma, offset_sd) in [(0, &tr.p1, 500.0, 1000.0), (1, &tr.p2, 500.0, 1000.0), (3, &tr.temp1, 0.2, 0.3)] {
        let r: Vec<f64> = m.columns[k].1.iter().zip(truth.iter()).map(|(y, s)| y - s).collect();
        let (mean, sd) = mean_sd(&r);
        assert!((mean - m.draws.offset[k]).abs() < 4.0 * sigma / (r.len() as f64).sqrt(), "{k}: {mean} {}", m.draws.offset[k]);
        assert!((sd / sigma - 1.0).abs() < 0.05, "{k}: {sd}");
        assert!(m.draws.offset[k].abs() < 5.0 * offset_sd);
        assert!(m.draws.offset[k] != 0.0);
    }
    // position: quantised to 10 µm, noise 20 µm
    let q = 10e-6;
    let x = &m.columns[2].1;
    assert!(x.iter().all(|v| ((v / q) - (v / q).round()).abs() < 1e-6));
    let r: Vec<f64> = x.iter().zip(&tr.x).map(|(y, s)| y - s).collect();
    let (_, sd) = mean_sd(&r);
    // quantisation adds q²/12 to the variance
    let expect = (20e-6f64.powi(2) + q * q / 12.0).sqrt();
    assert!((sd / expect - 1.0).abs() < 0.06, "{sd} {expect}");
}

#[test]
fn timing_jitter_dropouts_and_skew() {
    let spec = SensorSpec { jitter_sd: 50e-6, dropout: 0.05, time_skew: 0.25, ..SensorSpec::ideal() };
    let (tr, m) = experiment(&spec, 3);
    // the logger's clock is the simulation time plus the skew
    for (tl, ts) in m.t.iter().zip(&tr.t) {
        assert!((tl - ts - 0.25).abs() < 1e-12);
    }
    // jittered around the 1 ms grid, ordered, some samples lost
    let dt: Vec<f64> = tr.t.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(dt.iter().all(|&d| d > 0.0));
    let off_grid: Vec<f64> = tr.t.iter().map(|t| t - (t / 1e-3).round() * 1e-3).collect();
    let (_, sd) = mean_sd(&off_grid);
    assert!((sd / 50e-6 - 1.0).abs() < 0.1, "{sd}");
    let expected = tr.t_final / 1e-3;
    let lost = 1.0 - tr.t.len() as f64 / expected;
    assert!(lost > 0.03 && lost < 0.07, "{lost}");
    // the ideal logger reproduces the trace exactly
    assert_eq!(m.columns[0].1, tr.p1);
    assert_eq!(m.columns[2].1, tr.x);
}

#[test]
fn gain_error_scales_the_signal() {
    let z = Channel { noise: 0.0, offset_sd: 0.0, gain_sd: 0.0, quantum: 0.0 };
    let spec = SensorSpec { pressure: Channel { gain_sd: 0.01, ..z }, ..SensorSpec::ideal() };
    let (tr, m) = experiment(&spec, 5);
    let g = m.draws.gain[0];
    assert!(g != 0.0 && g.abs() < 0.05);
    for (y, s) in m.columns[0].1.iter().zip(&tr.p1) {
        assert!((y - (1.0 + g) * s).abs() < 1e-9 * s);
    }
}

#[test]
fn deterministic_in_the_seed() {
    let spec = SensorSpec::default();
    let (_, a) = experiment(&spec, 42);
    let (_, b) = experiment(&spec, 42);
    let (_, c) = experiment(&spec, 43);
    assert_eq!(a, b);
    assert_ne!(a.columns[0].1, c.columns[0].1);
    // the sampling instants depend on the clock stream only: a noise-free
    // logger with the same seed samples at the same instants
    let quiet = SensorSpec { pressure: Channel { noise: 0.0, ..spec.pressure }, ..spec.clone() };
    assert_eq!(sample_instants(&quiet, 3.0, 42).unwrap(), sample_instants(&spec, 3.0, 42).unwrap());
}

#[test]
fn csv_has_the_expected_header_and_round_trips() {
    let (tr, m) = experiment(&SensorSpec::default(), 9);
    let mut buf = Vec::new();
    write_csv(&m, &mut buf).unwrap();
    let text = String::from_utf8(buf).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "t,head.p,rod.p,piston.x");
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), tr.t.len());
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 4);
        assert_eq!(r[0], m.t[i]);
        assert_eq!(r[1], m.columns[0].1[i]);
        assert_eq!(r[3], m.columns[2].1[i]);
    }
    // and measuring an existing trace gives the same as acquire did
    let again = measure(&tr, &SensorSpec::default(), 9).unwrap();
    assert_eq!(again, m);
}
