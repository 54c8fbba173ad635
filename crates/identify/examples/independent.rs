//! One case of the independent-truth matrix through the workflow, or its
//! dataset written for `pneumo discrepancy`.
//!
//! ```text
//! cargo run --release -p pneumo-identify --example independent -- CASE SEED [nominal|varied] [--write DIR] [--cycles N]
//! ```
//!
//! CASE is `none`, a catalogue effect, or `piston_seal_leak+valve_delay`
//! (see `tests/truth/mod.rs`). With `--write DIR` it writes `DIR/<op>.csv`,
//! `DIR/E.json` and `DIR/model.json` (the model to hand to the workflow)
//! and does not run the workflow.

#[path = "../tests/truth/mod.rs"]
mod truth;

use truth::{Case, Variation};

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let case = args.first().and_then(|c| Case::by_name(c)).ok_or("first argument: a case name")?;
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).ok_or("second argument: a seed")?;
    let variation = match args.get(2).map(String::as_str) {
        Some("varied") => Variation::Varied,
        _ => Variation::Nominal,
    };
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let cycles: usize = flag("--cycles").and_then(|c| c.parse().ok()).unwrap_or(3);
    let mut t = truth::draw(case, seed, variation);
    // development knob: FORM="index=0.49,laminar=1e-3,check=2000,tol=1e-4,lat=2e-4,crack=2e4,skew=1e-3,gain=1e-3,jitter=1e-4,xoff=5e-5"
    if let Ok(spec) = std::env::var("FORM") {
        for kv in spec.split(',').filter(|s| !s.is_empty()) {
            let (k, v) = kv.split_once('=').ok_or("FORM: key=value")?;
            let v: f64 = v.parse().map_err(|_| format!("FORM: {kv}"))?;
            match k {
                "index" => t.form.subsonic.index = v,
                "laminar" => t.form.subsonic.laminar_width = Some(v),
                "check" => t.form.check = rig::CheckLaw::Linear { opening: v },
                "crack" => t.check_cracking = v,
                "tol" => t.form.switches.tolerance = v,
                "lat" => t.form.switches.latency = v,
                "skew" => t.sensors.time_skew = v,
                "gain" => t.sensors.pressure.gain_sd = v,
                "jitter" => t.sensors.jitter_sd = v,
                "xoff" => t.sensors.position.offset_sd = v,
                "drop" => t.sensors.dropout = v,
                _ => return Err(format!("FORM: unknown key {k}")),
            }
        }
        t.description += &format!("; FORM {spec}");
    }
    eprintln!("{}: {}", case.name(), t.description);
    let clock = std::time::Instant::now();
    let records = truth::records(&t, seed, cycles)?;
    eprintln!("generated in {:.1} s", clock.elapsed().as_secs_f64());
    if let Some(dir) = flag("--write") {
        let dir = std::path::PathBuf::from(dir);
        std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
        for r in &records {
            let f = std::fs::File::create(dir.join(format!("{}.csv", r.name))).map_err(|e| e.to_string())?;
            rig::sensors::write_csv(&r.measured, std::io::BufWriter::new(f)).map_err(|e| e.to_string())?;
        }
        let desc = format!("pneumo-rig truth, case {}, seed {seed}: {}", case.name(), t.description);
        std::fs::write(dir.join("E.json"), truth::manifest_text(&records, &desc)).map_err(|e| e.to_string())?;
        std::fs::write(dir.join("model.json"), truth::model_text(case)).map_err(|e| e.to_string())?;
        eprintln!("wrote {}", dir.display());
        return Ok(());
    }
    let experiments = truth::experiments(&records)?;
    let model = truth::model(case);
    let mut calibrate = identify::params::default_calibration(&model);
    // debugging knob: DROP=id.param,... removes calibration targets
    if let Ok(drop) = std::env::var("DROP") {
        calibrate.retain(|c| !drop.split(',').any(|d| d == c.target));
    }
    // debugging knob: EXTRA=id.param:lo:hi,... adds calibration targets
    if let Ok(extra) = std::env::var("EXTRA") {
        for item in extra.split(',').filter(|s| !s.is_empty()) {
            let parts: Vec<&str> = item.split(':').collect();
            let bound = |i: usize| parts.get(i).and_then(|v| v.parse::<f64>().ok());
            let bounds = bound(1).zip(bound(2));
            calibrate.push(identify::params::CalibSpec { target: parts[0].to_string(), bounds, prior: None });
        }
    }
    let mut options = identify::Options { report: true, ..identify::Options::default() };
    if std::env::var("VERBOSE").is_ok() {
        options.progress = identify::options::Progress::to(|m| eprintln!("{m}"));
    }
    if std::env::var("BASEONLY").is_ok() {
        options.effects = Some(vec![]);
    }
    // debugging knobs: ONLY=a,b restricts the catalogue, STARTS=n the starts per shaped effect
    if let Ok(only) = std::env::var("ONLY") {
        options.effects = Some(only.split(',').map(str::to_string).collect());
    }
    // PREPARE=n: candidates prepared after the projected scan (0: the scan only)
    if let Some(n) = std::env::var("PREPARE").ok().and_then(|s| s.parse().ok()) {
        options.screen_prepare = n;
    }
    if let Some(n) = std::env::var("STARTS").ok().and_then(|s| s.parse().ok()) {
        options.starts = n;
    }
    // SKEW=σ [s] sets the skew prior (0: none), NOGAIN=1 fits no gains, NOFORM=1 drops the form parameters
    if let Some(x) = std::env::var("SKEW").ok().and_then(|s| s.parse().ok()) {
        options.sensors.skew = x;
    }
    // RECENTRE=0 turns the recentred starts off, RECENTRE=1 on (Options::recentre)
    if let Ok(v) = std::env::var("RECENTRE") {
        options.recentre = v != "0";
    }
    // FRESH=0 turns the fresh starts of the full-record fits off (Options::fresh_start)
    if std::env::var("FRESH").is_ok_and(|v| v == "0") {
        options.fresh_start = false;
    }
    // PSTART=0 turns the projected starts of the screens off (Options::projected_start)
    if std::env::var("PSTART").is_ok_and(|v| v == "0") {
        options.projected_start = false;
    }
    // SCREEN_ITER=n: step attempts per short-record stage of a candidate (Options::screen_iter)
    if let Some(n) = std::env::var("SCREEN_ITER").ok().and_then(|s| s.parse().ok()) {
        options.screen_iter = n;
    }
    if std::env::var("NOGAIN").is_ok() {
        options.sensors.gain = false;
    }
    if std::env::var("NOFORM").is_ok() {
        calibrate.retain(|c| c.prior.is_none());
    }
    let o = identify::run(&model, &experiments, &calibrate, &options).map_err(|e| e.to_string())?;
    let s = &o.summary;
    println!("verdict: {}", s.verdict);
    println!("baseline rmse_n {:?} held-out {:.3}", s.baseline.rmse_normalized, s.baseline.heldout_rmse);
    for c in &s.candidates {
        println!(
            "  r{} {:<18} [{} sims] dIC {:>10.1} chi2 {:>10.1} held {:>7.3} {} {:?} {} [{}]",
            c.round,
            c.evaluations,
            c.effect,
            c.delta_ic,
            c.chi2,
            c.heldout_rmse,
            if c.accepted { "PASS" } else { "fail" },
            c.params,
            c.reasons.join("; "),
            c.notes.join("; ")
        );
    }
    println!("after rmse_n {:?}", s.after.rmse_normalized);
    for p in &s.after.params {
        println!("  {} = {:?} {} (ci {:?})", p.name, p.shown, p.unit, p.shown_ci95);
    }
    for x in s.after.sensors.iter().filter(|x| x.symptom.is_some() || std::env::var("SENSORS").is_ok()) {
        println!(
            "  {} {}: offset {:.4e} (z {:.2}) gain {:.2e} (z {:.2}) skew {:.3} ms {:?}",
            x.experiment,
            x.signal,
            x.offset,
            x.offset_z,
            x.gain,
            x.gain_z,
            x.time_skew * 1e3,
            x.symptom
        );
    }
    println!("grade {:?}", s.grade);
    println!("{} simulations, {:.1} s, {:?}", s.evaluations, s.seconds, s.timing);
    let (runs, busy, _) = identify::problem::simulation_count();
    println!("{runs} experiment simulations, {busy:.1} s of them summed over threads");
    Ok(())
}
