//! Scratch: finite-difference noise of the residual function vs rtol and step.
use identify::problem::*;
use identify::synth::*;
use std::path::Path;
struct Fs;
impl graph::Loader for Fs {
    fn read(&self, p: &Path) -> Result<String, String> {
        std::fs::read_to_string(p).map_err(|e| e.to_string())
    }
}
fn main() {
    let mut base = graph::load(&Fs, Path::new("models/meter_out.json")).unwrap();
    graph::apply_set(&mut base, "controller.dwell_extended=0.2").unwrap();
    graph::apply_set(&mut base, "controller.dwell_retracted=0.2").unwrap();
    let mut settings = TruthSettings::default();
    settings.cycles = Some(2);
    settings.duration = 60.0;
    let sc = Scenario { hidden: None, operating_points: standard_operating_points(), perturb: vec![], truth_only: vec![], settings, seed: 1 };
    let (model, exps) = sc.generate(&base).unwrap();
    let calib = default_calibration(&model);
    let params = calibration_params(&model, &exps, &calib).unwrap();
    let v0: Vec<f64> = params.iter().map(|p| p.start).collect();
    for rtol in [1e-4, 1e-5, 1e-6] {
        for fi in [4e-3, 8e-3] {
            let pr = Problem::new(&model, &exps, vec![], params.clone(), SimSettings { rtol, atol: rtol, max_step: 0.05 }, fi);
            let t0 = std::time::Instant::now();
            let r0 = pr.residuals(&v0).unwrap();
            let el = t0.elapsed().as_secs_f64();
            let chi0: f64 = r0.iter().map(|x| x * x).sum();
            print!("rtol {rtol:e} fi {fi}: {:.1} ms chi2/N {:.3};", el * 1e3, chi0 / r0.len() as f64);
            let u0: Vec<f64> = params.iter().zip(&v0).map(|(p, v)| p.to_u(*v)).collect();
            for j in [0usize, 4] {
                let mut col = vec![];
                for h in [1e-4, 1e-3, 1e-2] {
                    let mut up = u0.clone();
                    up[j] += h;
                    let mut um = u0.clone();
                    um[j] -= h;
                    let rp = pr.residuals(&pr.values_of(&up)).unwrap();
                    let rm = pr.residuals(&pr.values_of(&um)).unwrap();
                    let d: Vec<f64> = rp.iter().zip(&rm).map(|(a, b)| (a - b) / (2.0 * h)).collect();
                    col.push(d);
                }
                let nrm = |v: &Vec<f64>| v.iter().map(|x| x * x).sum::<f64>().sqrt();
                let diff = |a: &Vec<f64>, b: &Vec<f64>| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt();
                print!("  p{j}: |J|={:.3e} rel(1e-4 vs 1e-3)={:.2e} rel(1e-3 vs 1e-2)={:.2e}", nrm(&col[1]), diff(&col[0], &col[1]) / nrm(&col[1]), diff(&col[1], &col[2]) / nrm(&col[1]));
            }
            println!();
        }
    }
}
