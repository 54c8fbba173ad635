//! `pneumo report` pages opened in a real browser: headless Chromium
//! (Debian's package; `scripts/install-browser` installs it) loads the page
//! from a file with no network, runs its scripts, and the DOM it leaves
//! must say that every panel was drawn with data and that no script error
//! or Content-Security-Policy violation happened (the page's script records
//! both on `<body>`). A screenshot is saved beside the page (and copied to
//! `$PNEUMO_SCREENSHOT_DIR` when set, for the docs).
//!
//! Skipped, saying so, when no Chromium is found (`$PNEUMO_CHROMIUM`,
//! `chromium`, `chromium-browser` on PATH); `PNEUMO_REQUIRE_BROWSER=1`
//! (set by `scripts/browser-test`) makes a missing browser a failure.

mod common;
use common::{pneumo_within, repo, Scratch};
use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("PNEUMO_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    for dir in std::env::split_paths(&path) {
        for name in ["chromium", "chromium-browser"] {
            let p = dir.join(name);
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// Chromium's flags for a closed machine: no sandbox (root), no GPU, no
/// background traffic, a fresh profile; scripts get 10 s of virtual time.
fn run_chromium(browser: &Path, profile: &Path, extra: &[String], page: &Path) -> std::process::Output {
    let mut cmd = Command::new(browser);
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        "--virtual-time-budget=10000",
    ]);
    cmd.arg(format!("--user-data-dir={}", profile.display()));
    cmd.args(extra);
    cmd.arg(format!("file://{}", page.display()));
    cmd.output().expect("start chromium")
}

/// The value of attribute `name` on the `<body>` tag of a dumped DOM.
fn body_attr(dom: &str, name: &str) -> Option<String> {
    let start = dom.find("<body")?;
    let tag = &dom[start..start + dom[start..].find('>')?];
    let key = format!("{name}=\"");
    let i = tag.find(&key)? + key.len();
    Some(tag[i..i + tag[i..].find('"')?].to_string())
}

fn check_page(model: &str, cycles: &str) {
    check_page_with(model, cycles, None);
}

/// `experiments`: a manifest for `--experiments`; the page must then also
/// draw the measurements as markers in its before/after panels.
fn check_page_with(model: &str, cycles: &str, experiments: Option<&Path>) {
    let Some(browser) = chromium() else {
        assert!(std::env::var_os("PNEUMO_REQUIRE_BROWSER").is_none(), "PNEUMO_REQUIRE_BROWSER is set but no Chromium was found");
        eprintln!("skipped: no Chromium found (install it with scripts/install-browser, or set PNEUMO_CHROMIUM)");
        return;
    };
    let dir = Scratch::new("browser");
    let page = dir.path("report.html");
    let model_path = repo().join(model);
    let mut args = vec!["report", model_path.to_str().unwrap(), "--cycles", cycles, "--out", page.to_str().unwrap()];
    if let Some(e) = experiments {
        args.extend(["--experiments", e.to_str().unwrap()]);
    }
    // the discrepancy analysis takes minutes on a loaded 2-core machine
    let out = pneumo_within(&dir.0, &args, if experiments.is_some() { 1200 } else { 60 });
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let profile = dir.path("profile");
    let dump = run_chromium(&browser, &profile, &["--dump-dom".into()], &page);
    assert!(dump.status.success(), "chromium: {}", String::from_utf8_lossy(&dump.stderr));
    let dom = String::from_utf8_lossy(&dump.stdout);
    let plots: usize = body_attr(&dom, "data-plots").expect("the page's script ran").parse().unwrap();
    let points: usize = body_attr(&dom, "data-points").unwrap().parse().unwrap();
    let errors = body_attr(&dom, "data-errors").unwrap();
    assert_eq!(errors, "", "script errors or policy violations in {model}");
    assert!(plots >= 4, "{model}: {plots} panels drawn");
    assert!(points > 1000, "{model}: {points} values plotted");
    assert_eq!(dom.matches("class=\"uplot").count(), plots, "every panel is a uPlot chart");
    let markers: usize = body_attr(&dom, "data-markers").unwrap().parse().unwrap();
    if experiments.is_some() {
        // 4 experiments × 3 channels (head.p, rod.p, piston.x) before/after panels
        let fit_panels = dom.split("id=\"fit-plots\"").nth(1).map_or(0, |rest| rest.matches("class=\"uplot").count());
        assert_eq!(fit_panels, 12, "one before/after panel per experiment and measured channel");
        assert!(markers > 12 * 100, "{model}: {markers} measured values drawn as markers");
        assert!(dom.contains("Verdict (named):") && dom.contains("piston_seal_leak"), "the verdict is on the page");
    } else {
        assert_eq!(markers, 0, "no measurements without --experiments");
    }
    let stem = Path::new(model).file_stem().unwrap().to_string_lossy().into_owned();
    let stem = if experiments.is_some() { format!("{stem}_experiments") } else { stem };
    let shot = dir.path(&format!("report_{stem}.png"));
    let height = if experiments.is_some() { 6000 } else { 1800 };
    let shot_run =
        run_chromium(&browser, &profile, &[format!("--window-size=1200,{height}"), format!("--screenshot={}", shot.display())], &page);
    assert!(shot_run.status.success(), "chromium: {}", String::from_utf8_lossy(&shot_run.stderr));
    let png = std::fs::read(&shot).expect("a screenshot");
    assert!(png.starts_with(common::PNG_MAGIC) && png.len() > 20_000, "a screenshot with something on it");
    if let Some(keep) = std::env::var_os("PNEUMO_SCREENSHOT_DIR") {
        std::fs::copy(&shot, Path::new(&keep).join(format!("report_{stem}.png"))).unwrap();
    }
    eprintln!("{model}: {plots} panels, {points} values, no errors in {}", browser.display());
}

#[test]
fn meter_out_report_renders_in_chromium() {
    check_page("models/meter_out.json", "3");
}

#[test]
fn sequence_report_renders_in_chromium() {
    check_page("models/sequence_ab.json", "2");
}

/// The discrepancy example's experiments (models/examples/discrepancy) on
/// the meter-out model. The full workflow tries the whole catalogue and
/// takes minutes (docs/discrepancy.md), too slow for CI: this test's copy
/// of the manifest restricts the candidates to `piston_seal_leak` (the
/// effect the example hides; the manifest's `effects` option), which is
/// what the full run names too. Records, channels and the rest of the
/// workflow are the example's own.
#[test]
fn meter_out_report_with_experiments_renders_in_chromium() {
    if chromium().is_none() {
        check_page("models/meter_out.json", "3"); // says it skips (or fails under PNEUMO_REQUIRE_BROWSER)
        return;
    }
    let example = repo().join("models/examples/discrepancy");
    let text = std::fs::read_to_string(example.join("experiments.json")).unwrap();
    let mut manifest: serde_json::Value = serde_json::from_str(&text).unwrap();
    for e in manifest["experiments"].as_array_mut().unwrap() {
        let data = example.join(e["data"].as_str().unwrap());
        e["data"] = serde_json::Value::String(data.display().to_string());
    }
    manifest["effects"] = serde_json::json!(["piston_seal_leak"]);
    let dir = Scratch::new("browser_experiments");
    let path = dir.path("experiments.json");
    std::fs::write(&path, serde_json::to_string_pretty(&manifest).unwrap()).unwrap();
    check_page_with("models/meter_out.json", "3", Some(&path));
}
