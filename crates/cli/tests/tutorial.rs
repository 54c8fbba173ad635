//! docs/tutorial.md and the commands other pages mark as checked cannot go
//! stale. In docs/tutorial.md every ```sh block is run; in the other pages
//! listed in [`CHECKED_PAGES`] only the blocks marked ```sh checked. Blocks
//! run in order, in an empty folder that holds only a link to the
//! repository's `models/`, with the `pneumo` this test was built with first
//! on the PATH; each must exit 0. A ```text block right after a run block is
//! that block's standard output: lines compared one by one, text exactly,
//! numbers to the digits shown within 0.5 % (a solver change may move the
//! last digit), and a line ending in `…` only up to the `…` (`…` alone: any
//! line). Every `scratch/…` file the tutorial's commands name must exist
//! afterwards. Blocks marked `slow` (the tutorial's discrepancy step,
//! minutes) run only in the ignored test.

mod common;

use common::numbers::mismatch;
use common::{repo, Scratch};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One fenced block of the page: its info string and its text.
struct Block {
    info: String,
    text: String,
}

fn blocks(page: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut current: Option<Block> = None;
    for line in page.lines() {
        match (&mut current, line.trim_start().strip_prefix("```")) {
            (None, Some(info)) => current = Some(Block { info: info.trim().to_string(), text: String::new() }),
            (Some(_), Some(_)) => out.extend(current.take()),
            (Some(b), None) => {
                b.text.push_str(line);
                b.text.push('\n');
            }
            (None, None) => {
                // prose between blocks separates a command from a later output block
                if !line.trim().is_empty() {
                    out.push(Block { info: "prose".into(), text: String::new() });
                }
            }
        }
    }
    out
}

/// Run one block as a shell script in `dir`; its standard output.
fn run_block(page: &str, dir: &Path, script: &str) -> String {
    let bin = Path::new(env!("CARGO_BIN_EXE_pneumo")).parent().expect("bin dir").to_path_buf();
    let path = std::env::join_paths(std::iter::once(bin).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())))
        .expect("PATH");
    let mut child = Command::new("sh")
        .arg("-e")
        .arg("-c")
        .arg(script)
        .current_dir(dir)
        .env("PATH", path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start sh");
    let start = Instant::now();
    // the discrepancy step fits four runs; allow it minutes on a busy CI machine
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > Duration::from_secs(600) {
            let _ = child.kill();
            panic!("a block of {page} did not finish within 600 s:\n{script}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("output");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{page} block failed ({:?}):\n{script}\nstderr:\n{stderr}", out.status.code());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Pages besides the tutorial whose ```sh checked blocks are run, with the
/// least number of outputs each must show (so a page cannot lose its checks
/// silently).
const CHECKED_PAGES: &[(&str, usize)] = &[
    ("docs/validation.md", 1),
    ("docs/sweeps.md", 1),
    ("docs/conductance.md", 1),
    ("docs/performance.md", 2),
    ("docs/report.md", 1),
    ("docs/position_control_tuning.md", 2),
    ("docs/circuits.md", 4),
    ("docs/linearize.md", 2),
    ("docs/draw.md", 1),
    ("docs/netlist.md", 1),
];

/// Run a page's blocks — every ```sh block when `every_sh` (the tutorial),
/// else the ```sh checked ones — the slow ones too when `slow`, and compare
/// the outputs it shows. Returns the folder it ran in, the commands run and
/// the number of outputs checked.
fn run_page(page_name: &str, every_sh: bool, slow: bool) -> (Scratch, String, usize) {
    let page = std::fs::read_to_string(repo().join(page_name)).unwrap_or_else(|e| panic!("{page_name}: {e}"));
    let dir = Scratch::new("docs-page");
    std::os::unix::fs::symlink(repo().join("models").canonicalize().expect("models"), dir.path("models")).expect("link models");
    let mut commands = String::new();
    let mut checked_outputs = 0;
    let mut last_stdout: Option<String> = None;
    let mut skipping = false;
    for block in &blocks(&page) {
        let words: Vec<&str> = block.info.split_whitespace().collect();
        let is_sh = words.first() == Some(&"sh");
        let runs = is_sh && (every_sh || words.contains(&"checked"));
        let is_slow = words.contains(&"slow");
        match block.info.as_str() {
            _ if is_sh => {
                skipping = !runs || (is_slow && !slow);
                if skipping {
                    continue;
                }
                commands.push_str(&block.text);
                last_stdout = Some(run_block(page_name, &dir.0, &block.text));
            }
            "text" if skipping => skipping = false,
            "text" => {
                let Some(stdout) = last_stdout.take() else {
                    continue; // an illustration, not the output of a run block
                };
                let actual: Vec<&str> = stdout.lines().collect();
                let expected: Vec<&str> = block.text.lines().collect();
                assert_eq!(expected.len(), actual.len(), "{page_name} shows\n{}\nthe run printed\n{stdout}", block.text);
                for (e, a) in expected.iter().zip(&actual) {
                    if let Some(why) = mismatch(e, a) {
                        panic!("{page_name} is stale: {why}\n page: {e}\n  run: {a}\nthe run printed:\n{stdout}");
                    }
                }
                checked_outputs += 1;
            }
            _ => {
                last_stdout = None;
                skipping = false;
            }
        }
    }
    (dir, commands, checked_outputs)
}

/// Run the tutorial and check what it must contain.
fn run_tutorial(slow: bool) {
    let (dir, commands, checked_outputs) = run_page("docs/tutorial.md", true, slow);
    assert!(commands.lines().filter(|l| l.starts_with("pneumo ")).count() >= 7, "too few commands found:\n{commands}");
    assert!(checked_outputs >= 4, "{checked_outputs} outputs checked");
    // every file the commands write into scratch/ is there
    for word in commands.split_whitespace() {
        if let Some(name) = word.strip_prefix("scratch/") {
            let p = dir.path("scratch").join(name);
            assert!(p.exists(), "the tutorial's command should have written scratch/{name}");
        }
    }
}

#[test]
fn the_tutorial_runs_as_written_and_prints_what_it_shows() {
    run_tutorial(false);
}

/// The comparison with measurements takes minutes: `-- --ignored`.
#[test]
#[ignore]
fn the_tutorial_s_slow_step_runs_too() {
    run_tutorial(true);
}

#[test]
fn the_checked_commands_of_other_pages_print_what_they_show() {
    for &(page, least) in CHECKED_PAGES {
        let (_dir, _commands, checked) = run_page(page, false, false);
        assert!(checked >= least, "{page}: {checked} outputs checked, expected at least {least}");
    }
}

#[test]
fn the_comparison_reads_numbers_to_the_digits_shown() {
    assert_eq!(mismatch("total 2.9760 s", "total 2.9760 s"), None);
    assert_eq!(mismatch("total 2.9760 s", "total 2.9761 s"), None);
    assert!(mismatch("total 2.9760 s", "total 3.0100 s").is_some());
    assert!(mismatch("total 2.9760 s", "extend 2.9760 s").is_some());
    assert!(mismatch("n 1.5", "n 1.5 more").is_some());
    assert_eq!(mismatch("t = 7.7350 s, …", "t = 7.7350 s, 194 steps"), None);
    assert_eq!(mismatch("…", "4026 simulations in 417.3 s"), None);
    assert_eq!(mismatch("residual 3.3e-7", "residual 3.3e-7"), None);
    assert!(mismatch("residual 3.3e-7", "residual 4.3e-7").is_some());
    assert_eq!(mismatch("head.p 4 bar", "head.p 4 bar"), None);
    assert!(mismatch("case 0  4 bar", "case 0  5 bar").is_some());
}
