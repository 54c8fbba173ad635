//! `pneumo sweep` and `pneumo merge`: full-factorial parameter studies run in
//! parallel, split into shards for clusters, and joined back together.
//!
//! No physics here: every case is one ordinary run (`crate::run::run_flat`,
//! the same path as `pneumo simulate`) of the netlist with the fixed `--set`
//! overrides followed by the case's varied assignments. What this module adds:
//!
//! - Case numbering. With axes `A` (values a0..), `B` (b0..), ... given in that
//!   order on the command line, case `i` (0-based) is the odometer reading of
//!   `i` with the LAST axis turning fastest: i = ((iA·nB + iB)·nC + iC)...
//!   `--shard K/N` (1-based K) keeps the cases with `i mod N = K-1`.
//! - Determinism. Cases run on a local rayon pool of `--jobs` threads, but the
//!   results are collected in case order and formatted without any
//!   thread-dependent state, so the output file is byte-identical for any
//!   `--jobs`, and merged shards are byte-identical to the unsharded file.
//! - Output columns, all SI: `case`, `n_cases`, one column per varied
//!   `ID.PARAM` (the value converted to SI with the parameter's declared
//!   dimension, or the option word for choice parameters), `cycleK_extend_s`, `cycleK_retract_s`,
//!   `cycleK_total_s` for K = 1..(most cycles), `cycle_time_s` (total time of
//!   the last completed cycle: the periodic cycle time), `<id>.T_min_K` and
//!   `<id>.T_max_K` for every temperature column `<id>.T` of the result (min
//!   and max over the recorded samples), and `error` (empty on success). A
//!   failed case is a row with its one-line error and empty numbers.
//! - Numbers are written in Rust's shortest round-trip form (plain decimal for
//!   1e-4 ≤ |x| < 1e15, scientific otherwise), so reading a cell back and
//!   writing it again reproduces the same bytes; `merge` relies on this. JSON
//!   is read by a small order- and digit-preserving parser for the same reason
//!   (serde_json's default float parsing may differ from the text by an ulp).
//! - Every row also carries `n_cases`, the size of the whole sweep, so that
//!   `merge` can name missing cases even when a whole shard is absent.
//!
//! Assumption: the circuit's structure (and so its temperature columns) does
//! not depend on the varied values.

use crate::error::CliError;
use crate::run::{run_flat, RunSpec};
use blocks::params::{ParamKind, Range};
use graph::FlatNetlist;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct SweepArgs {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// A parameter and its values: ID.PARAM=V1,V2,... (e.g. "supply.p=4 bar,7 bar").
    /// Repeat for a full factorial; the last --vary changes fastest.
    #[arg(long = "vary", value_name = "ID.PARAM=V1,V2,...", required = true)]
    pub vary: Vec<String>,
    /// Override a parameter in every case: ID.PARAM=VALUE.
    #[arg(long = "set", value_name = "ID.PARAM=VALUE")]
    pub sets: Vec<String>,
    /// Number of actuator cycles per case.
    #[arg(long)]
    pub cycles: Option<u64>,
    /// End time of each case [s].
    #[arg(long = "t-end", value_name = "SECONDS")]
    pub t_end: Option<f64>,
    /// Worker threads (default: the available parallelism).
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Run only shard K of N (1-based K): the cases whose index mod N is K-1.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Write one row per case (CSV, or JSON if the name ends in .json).
    #[arg(long, value_name = "FILE.csv|FILE.json")]
    pub out: Option<PathBuf>,
    /// Most cases this process runs (the whole sweep, or its shard); raise it, or split the sweep with --shard.
    #[arg(long = "max-cases", value_name = "N", default_value_t = DEFAULT_MAX_CASES)]
    pub max_cases: usize,
}

#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Shard outputs to join (CSV or JSON, as written by `pneumo sweep`).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Merged file (CSV, or JSON if the name ends in .json).
    #[arg(long, value_name = "FILE.csv|FILE.json")]
    pub out: PathBuf,
    /// Most cases the merged sweep may hold.
    #[arg(long = "max-cases", value_name = "N", default_value_t = DEFAULT_MAX_CASES)]
    pub max_cases: usize,
}

/// One output cell.
#[derive(Debug, Clone, PartialEq)]
enum Cell {
    Empty,
    Num(f64),
    Text(String),
}

/// A header and rows of cells, as written to or read from a file.
#[derive(Debug, Clone, PartialEq)]
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<Cell>>,
}

/// One `--vary` axis.
#[derive(Debug, Clone)]
struct Axis {
    target: String,
    /// The values as the user wrote them (trimmed).
    texts: Vec<String>,
    /// The same values in SI (or option words).
    values: Vec<Cell>,
}

/// What one case produced.
struct Outcome {
    index: usize,
    /// (extend, retract, total) per completed cycle [s].
    cycles: Vec<(f64, f64, f64)>,
    /// (min, max) of each temperature column, aligned with the sweep's list.
    temps: Vec<(Option<f64>, Option<f64>)>,
    error: Option<String>,
}

/// Split "ID.PARAM=V1, V2, ..." into the target and the trimmed values.
fn parse_vary(s: &str) -> Result<(String, Vec<String>), CliError> {
    let bad = |why: &str| CliError::Usage(format!("--vary \"{s}\": {why}"));
    let (target, list) = s.split_once('=').ok_or_else(|| bad("expected ID.PARAM=V1,V2,..."))?;
    let target = target.trim();
    if graph::netlist::split_ref(target).is_none() {
        return Err(bad("expected ID.PARAM=V1,V2,... (the target needs an id and a parameter, e.g. supply.p)"));
    }
    let texts: Vec<String> = list.split(',').map(|v| v.trim().to_string()).collect();
    if texts.iter().any(|t| t.is_empty()) {
        return Err(bad("empty value in the list (values are separated by single commas)"));
    }
    Ok((target.to_string(), texts))
}

/// Parse "K/N" with 1 ≤ K ≤ N into (K, N).
fn parse_shard(s: &str) -> Result<(usize, usize), CliError> {
    let bad = || CliError::Usage(format!("--shard \"{s}\": expected K/N with 1 <= K <= N (e.g. 3/16)"));
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let k: usize = k.trim().parse().map_err(|_| bad())?;
    let n: usize = n.trim().parse().map_err(|_| bad())?;
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok((k, n))
}

/// What a `--vary` target refers to.
enum Target {
    /// A `simulation.<setting>`.
    Simulation(String),
    /// A declared block parameter.
    Param(&'static blocks::params::ParamSpec),
    /// `gas.model` or `gas.species`, with the accepted words.
    Gas(&'static [&'static str]),
}

/// Resolve `ID.PARAM` against the flat netlist and the block declarations.
fn resolve(flat: &FlatNetlist, target: &str) -> Result<Target, String> {
    let (id, param) = graph::netlist::split_ref(target).ok_or("expected ID.PARAM")?;
    if id == "simulation" {
        return match param {
            "t_end" | "sample_interval" | "max_step" | "rtol" | "atol" | "cycles" => Ok(Target::Simulation(param.into())),
            _ => Err(format!("unknown simulation setting \"{param}\" (rtol, atol, t_end, cycles, sample_interval, max_step)")),
        };
    }
    if let Some(words) = graph::expand::gas_setting_words(flat, id, param) {
        return words.map(Target::Gas);
    }
    let comp = flat.components.iter().find(|c| c.id == id).ok_or_else(|| {
        let ids: Vec<&str> = flat.components.iter().map(|c| c.id.as_str()).collect();
        format!("no component \"{id}\" in the netlist (components: {})", ids.join(", "))
    })?;
    let ty = blocks::registry::block_type(&comp.kind).map_err(|e| e.to_string())?;
    let spec = ty.params.iter().find(|p| p.name == param).ok_or_else(|| {
        let names: Vec<&str> = ty.params.iter().map(|p| p.name).collect();
        format!("{} \"{id}\" has no parameter \"{param}\" (accepted: {})", comp.kind, names.join(", "))
    })?;
    if let ParamKind::List(_) = spec.kind {
        return Err(format!("\"{param}\" is a list parameter and cannot be varied (sweep values are separated by commas)"));
    }
    Ok(Target::Param(spec))
}

/// The SI value of `text` (or the option word of a choice), checked for its
/// dimension. Range checks are left to the run, so an out-of-range value
/// fails its cases rather than the whole sweep.
fn si_value(target: &Target, text: &str) -> Result<Cell, String> {
    let number = text.parse::<f64>().ok();
    let whole = || match number {
        Some(x) if x >= 0.0 && x.fract() == 0.0 => Ok(Cell::Num(x)),
        _ => Err(format!("\"{text}\" is not a whole number")),
    };
    let spec = match target {
        Target::Simulation(setting) => {
            return match setting.as_str() {
                "rtol" | "atol" => number.map(Cell::Num).ok_or_else(|| format!("\"{text}\" is not a number")),
                "cycles" => whole(),
                _ => units::parse_quantity(text, units::dim::TIME).map(Cell::Num).map_err(|e| e.to_string()),
            }
        }
        Target::Param(spec) => spec,
        Target::Gas(words) => {
            return words
                .iter()
                .find(|w| w.eq_ignore_ascii_case(text))
                .map(|w| Cell::Text(w.to_string()))
                .ok_or_else(|| format!("\"{text}\": expected one of {}", words.join(", ")))
        }
    };
    match spec.kind {
        ParamKind::Quantity(dim) => {
            if let Some(x) = number {
                Ok(Cell::Num(x))
            } else if spec.range == Range::PositiveOrInfinite && matches!(text, "inf" | "infinity" | "∞") {
                Ok(Cell::Num(f64::INFINITY))
            } else {
                units::parse_quantity(text, dim).map(Cell::Num).map_err(|e| e.to_string())
            }
        }
        ParamKind::Count => whole(),
        ParamKind::Choice(options) => options
            .iter()
            .find(|o| o.eq_ignore_ascii_case(text))
            .map(|o| Cell::Text(o.to_string()))
            .ok_or_else(|| format!("\"{text}\": expected one of {}", options.join(", "))),
        ParamKind::List(_) => Err("a list parameter cannot be varied".into()),
        ParamKind::Words => Err("a text parameter cannot be varied".into()),
    }
}

/// Axis value indices of case `i` (last axis fastest).
fn case_indices(axes: &[Axis], mut i: usize) -> Vec<usize> {
    let mut idx = vec![0; axes.len()];
    for (k, axis) in axes.iter().enumerate().rev() {
        let n = axis.texts.len();
        idx[k] = i % n;
        i /= n;
    }
    idx
}

/// The `ID.PARAM=VALUE` assignments of case `i`.
fn case_sets(axes: &[Axis], i: usize) -> Vec<String> {
    case_indices(axes, i).iter().zip(axes).map(|(&j, a)| format!("{}={}", a.target, a.texts[j])).collect()
}

/// Temperature columns ("<id>.T") of the circuit, taken from the first case
/// whose netlist builds (building is cheap; nothing is simulated).
fn temperature_columns(base: &FlatNetlist, axes: &[Axis], total: usize) -> Vec<String> {
    for i in 0..total {
        let mut flat = base.clone();
        if case_sets(axes, i).iter().any(|s| graph::apply_set(&mut flat, s).is_err()) {
            continue;
        }
        if let Ok(circuit) = graph::build(&flat) {
            let names = solve::Model::new(circuit).output_names();
            return names.into_iter().filter(|n| n.ends_with(".T") && n.len() > 2).collect();
        }
    }
    Vec::new()
}

fn run_case(base: &FlatNetlist, sets: &[String], axes: &[Axis], spec: &RunSpec, temps: &[String], index: usize) -> Outcome {
    let mut all_sets = sets.to_vec();
    all_sets.extend(case_sets(axes, index));
    let spec = RunSpec { sets: all_sets, cycles: spec.cycles, t_end: spec.t_end };
    match run_flat(base.clone(), &spec) {
        Ok(run) => {
            let r = &run.result;
            let cycles = r.cycles.iter().map(|c| (c.extend, c.retract, c.total)).collect();
            let temps = temps
                .iter()
                .map(|name| {
                    let Some(c) = r.column(name) else { return (None, None) };
                    let mut range: Option<(f64, f64)> = None;
                    for v in r.rows.iter().filter_map(|row| row[c]) {
                        range = Some(range.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))));
                    }
                    (range.map(|r| r.0), range.map(|r| r.1))
                })
                .collect();
            Outcome { index, cycles, temps, error: run.incomplete.clone() }
        }
        Err(e) => {
            let msg = e.to_string().split_whitespace().collect::<Vec<_>>().join(" ");
            Outcome { index, cycles: Vec::new(), temps: vec![(None, None); temps.len()], error: Some(msg) }
        }
    }
}

/// Default of `--max-cases`: a sweep larger than this runs as shards.
pub const DEFAULT_MAX_CASES: usize = 100_000;
/// Largest case index a sweep may number.
const MAX_INDEX: u64 = 1 << 40;

fn cycle_columns(k: usize) -> [String; 3] {
    [format!("cycle{k}_extend_s"), format!("cycle{k}_retract_s"), format!("cycle{k}_total_s")]
}

/// Whether a column is one of the per-cycle columns.
fn is_cycle_column(name: &str) -> bool {
    let Some(rest) = name.strip_prefix("cycle") else { return false };
    let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
    digits > 0 && matches!(&rest[digits..], "_extend_s" | "_retract_s" | "_total_s")
}

fn build_table(axes: &[Axis], temps: &[String], ncyc: usize, total: usize, outcomes: &[Outcome]) -> Table {
    let mut header = vec!["case".to_string(), "n_cases".to_string()];
    header.extend(axes.iter().map(|a| a.target.clone()));
    for k in 1..=ncyc {
        header.extend(cycle_columns(k));
    }
    header.push("cycle_time_s".into());
    for t in temps {
        header.push(format!("{t}_min_K"));
        header.push(format!("{t}_max_K"));
    }
    header.push("error".into());
    let num = |x: Option<f64>| x.map_or(Cell::Empty, Cell::Num);
    let rows = outcomes
        .iter()
        .map(|o| {
            let mut row = vec![Cell::Num(o.index as f64), Cell::Num(total as f64)];
            row.extend(case_indices(axes, o.index).iter().zip(axes).map(|(&j, a)| a.values[j].clone()));
            for k in 0..ncyc {
                let c = o.cycles.get(k);
                row.extend([num(c.map(|c| c.0)), num(c.map(|c| c.1)), num(c.map(|c| c.2))]);
            }
            row.push(num(o.cycles.last().map(|c| c.2)));
            for &(lo, hi) in &o.temps {
                row.push(num(lo));
                row.push(num(hi));
            }
            row.push(o.error.clone().map_or(Cell::Empty, Cell::Text));
            row
        })
        .collect();
    Table { header, rows }
}

pub fn run(a: &SweepArgs) -> Result<(), CliError> {
    let mut axes = Vec::with_capacity(a.vary.len());
    for v in &a.vary {
        let (target, texts) = parse_vary(v)?;
        if axes.iter().any(|x: &Axis| x.target == target) {
            return Err(CliError::Usage(format!("--vary {target} is given twice (put all its values in one list)")));
        }
        axes.push(Axis { target, texts, values: Vec::new() });
    }
    let shard = a.shard.as_deref().map(parse_shard).transpose()?;
    let jobs = match a.jobs {
        Some(0) => return Err(CliError::Usage("--jobs must be at least 1".into())),
        Some(n) => n,
        None => std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
    };
    if let Some(t) = a.t_end {
        if !(t > 0.0 && t.is_finite()) {
            return Err(CliError::Usage(format!("--t-end must be > 0 s, got {t}")));
        }
    }
    // The file is read once; --set errors stop the sweep before any case runs.
    let (base, inputs) = crate::load::netlist_with_files(&a.model, &[])?;
    let inputs: Vec<&std::path::Path> = inputs.iter().map(|p| p.as_path()).collect();
    let mut outputs = crate::output::Transaction::new(&inputs);
    if let Some(out) = &a.out {
        outputs.check_targets(&[out])?;
    }
    let mut with_sets = base.clone();
    for s in &a.sets {
        graph::apply_set(&mut with_sets, s)?;
    }
    for axis in &mut axes {
        let target = resolve(&with_sets, &axis.target).map_err(|why| CliError::Usage(format!("--vary {}: {why}", axis.target)))?;
        for text in &axis.texts {
            let value = si_value(&target, text).map_err(|why| CliError::Usage(format!("--vary {}={text}: {why}", axis.target)))?;
            axis.values.push(value);
        }
    }
    let total = axes
        .iter()
        .try_fold(1usize, |n, x| n.checked_mul(x.texts.len()))
        .filter(|&n| n as u64 <= MAX_INDEX)
        .ok_or_else(|| CliError::Usage(format!("the sweep has more than {MAX_INDEX} cases")))?;
    let mine = match shard {
        Some((k, n)) => total / n + usize::from(k - 1 < total % n),
        None => total,
    };
    if mine > a.max_cases {
        return Err(CliError::Usage(format!(
            "this sweep would run {mine} cases, more than --max-cases {} (raise it, or split the sweep with --shard K/N)",
            a.max_cases
        )));
    }
    let selected: Vec<usize> = match shard {
        Some((k, n)) => (k - 1..total).step_by(n).collect(),
        None => (0..total).collect(),
    };
    let temps = temperature_columns(&with_sets, &axes, total);
    let requested = a.cycles.or_else(|| {
        let varied = axes.iter().find(|x| x.target == "simulation.cycles");
        match varied {
            Some(x) => x.values.iter().filter_map(|v| if let Cell::Num(n) = v { Some(*n as u64) } else { None }).max(),
            None => with_sets.simulation.cycles,
        }
    });
    let spec = RunSpec { sets: Vec::new(), cycles: a.cycles, t_end: a.t_end };

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| CliError::Data(format!("cannot start {jobs} worker threads: {e}")))?;
    let bar = progress_bar(selected.len());
    let outcomes: Vec<Outcome> = pool.install(|| {
        selected
            .par_iter()
            .map(|&i| {
                let o = run_case(&base, &a.sets, &axes, &spec, &temps, i);
                bar.inc(1);
                o
            })
            .collect()
    });
    bar.finish_and_clear();

    let observed = outcomes.iter().map(|o| o.cycles.len()).max().unwrap_or(0);
    let ncyc = observed.max(requested.map_or(0, |n| usize::try_from(n).unwrap_or(usize::MAX).min(100_000)));
    let table = build_table(&axes, &temps, ncyc, total, &outcomes);
    if let Some(path) = &a.out {
        let bytes = if is_json(path) { to_json(&table) } else { to_csv(&table)? };
        outputs.add(path, &bytes)?;
        outputs.commit()?;
    }
    print!("{}", summary_table(&axes, &outcomes));
    let failed = outcomes.iter().filter(|o| o.error.is_some()).count();
    let of = match shard {
        Some((k, n)) => format!(" (shard {k}/{n} of {total})"),
        None => String::new(),
    };
    println!("{} cases{of}, {} ok, {failed} failed", outcomes.len(), outcomes.len() - failed);
    Ok(())
}

fn progress_bar(n: usize) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(n as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} cases  {elapsed} elapsed, ETA {eta}") {
        bar.set_style(style);
    }
    bar
}

/// The human-readable table printed to stdout: values as written, cycle time, status.
fn summary_table(axes: &[Axis], outcomes: &[Outcome]) -> String {
    let mut header = vec!["case".to_string()];
    header.extend(axes.iter().map(|a| a.target.clone()));
    header.push("cycle_time_s".into());
    header.push("status".into());
    let mut lines = vec![header];
    for o in outcomes {
        let mut line = vec![o.index.to_string()];
        line.extend(case_indices(axes, o.index).iter().zip(axes).map(|(&j, a)| a.texts[j].clone()));
        line.push(o.cycles.last().map_or("-".into(), |c| format!("{:.4}", c.2)));
        line.push(o.error.as_ref().map_or("ok".into(), |e| format!("error: {e}")));
        lines.push(line);
    }
    let ncol = lines[0].len();
    let widths: Vec<usize> = (0..ncol - 1).map(|c| lines.iter().map(|l| l[c].chars().count()).max().unwrap_or(0)).collect();
    let mut s = String::new();
    for l in &lines {
        for (c, w) in widths.iter().enumerate() {
            s.push_str(&format!("{:<w$}  ", l[c], w = *w));
        }
        s.push_str(&l[ncol - 1]);
        s.push('\n');
    }
    s
}

fn is_json(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Shortest round-trip text of a number: plain for 1e-4 ≤ |x| < 1e15, else scientific.
fn fmt_num(x: f64) -> String {
    let a = x.abs();
    if !x.is_finite() || a == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

fn to_csv(t: &Table) -> Result<Vec<u8>, CliError> {
    let err = |e: csv::Error| CliError::Data(format!("cannot format CSV: {e}"));
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    w.write_record(&t.header).map_err(err)?;
    for row in &t.rows {
        w.write_record(row.iter().map(|c| match c {
            Cell::Empty => String::new(),
            Cell::Num(x) => fmt_num(*x),
            Cell::Text(s) => s.clone(),
        }))
        .map_err(err)?;
    }
    w.into_inner().map_err(|e| CliError::Data(format!("cannot format CSV: {e}")))
}

/// `{"columns": [...], "cases": [{...}, ...]}`, one case per line, keys in column order.
fn to_json(t: &Table) -> Vec<u8> {
    let q = |s: &str| serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into());
    let mut s = String::from("{\n  \"columns\": [");
    s.push_str(&t.header.iter().map(|h| q(h)).collect::<Vec<_>>().join(", "));
    s.push_str("],\n  \"cases\": [");
    for (r, row) in t.rows.iter().enumerate() {
        s.push_str(if r == 0 { "\n    {" } else { ",\n    {" });
        for (c, (name, cell)) in t.header.iter().zip(row).enumerate() {
            if c > 0 {
                s.push_str(", ");
            }
            s.push_str(&q(name));
            s.push_str(": ");
            match cell {
                Cell::Empty => s.push_str("null"),
                Cell::Num(x) if x.is_finite() => s.push_str(&fmt_num(*x)),
                Cell::Num(x) => s.push_str(&q(&fmt_num(*x))),
                Cell::Text(t) => s.push_str(&q(t)),
            }
        }
        s.push('}');
    }
    s.push_str(if t.rows.is_empty() { "]\n}\n" } else { "\n  ]\n}\n" });
    s.into_bytes()
}

/// A cell read back from a file: numbers where the text is one (except in `error`).
fn cell_from_text(column: &str, text: &str) -> Cell {
    if text.is_empty() {
        Cell::Empty
    } else if column != "error" {
        text.parse::<f64>().map_or_else(|_| Cell::Text(text.to_string()), Cell::Num)
    } else {
        Cell::Text(text.to_string())
    }
}

fn read_csv(path: &Path, text: &str) -> Result<Table, CliError> {
    let mut r = csv::ReaderBuilder::new().has_headers(true).from_reader(text.as_bytes());
    let header: Vec<String> = r.headers().map_err(|e| CliError::io(path, e))?.iter().map(str::to_string).collect();
    let mut rows = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| CliError::io(path, e))?;
        rows.push(header.iter().zip(rec.iter()).map(|(h, v)| cell_from_text(h, v)).collect());
    }
    Ok(Table { header, rows })
}

fn read_json(path: &Path, text: &str) -> Result<Table, CliError> {
    let bad = |why: String| CliError::io(path, why);
    let doc = json::parse(text).map_err(bad)?;
    let json::Value::Object(top) = doc else { return Err(bad("expected a JSON object {\"cases\": [...]}".into())) };
    let field = |name: &str| top.iter().find(|(k, _)| k == name).map(|(_, v)| v);
    let Some(json::Value::Array(cases)) = field("cases") else {
        return Err(bad("no \"cases\" array".into()));
    };
    let header: Vec<String> = match field("columns") {
        Some(json::Value::Array(cols)) => cols
            .iter()
            .map(|c| match c {
                json::Value::String(s) => Ok(s.clone()),
                _ => Err(bad("\"columns\" must hold strings".into())),
            })
            .collect::<Result<_, _>>()?,
        _ => match cases.first() {
            Some(json::Value::Object(first)) => first.iter().map(|(k, _)| k.clone()).collect(),
            _ => Vec::new(),
        },
    };
    let mut rows = Vec::with_capacity(cases.len());
    for (n, case) in cases.iter().enumerate() {
        let json::Value::Object(fields) = case else { return Err(bad(format!("case entry {} is not an object", n + 1))) };
        let row = header
            .iter()
            .map(|h| match fields.iter().find(|(k, _)| k == h).map(|(_, v)| v) {
                None | Some(json::Value::Null) => Ok(Cell::Empty),
                Some(json::Value::Number(raw)) => raw.parse::<f64>().map(Cell::Num).map_err(|_| bad(format!("bad number {raw}"))),
                Some(json::Value::String(s)) => Ok(cell_from_text(h, s)),
                Some(json::Value::Bool(b)) => Ok(Cell::Text(b.to_string())),
                Some(_) => Err(bad(format!("case entry {}: \"{h}\" is not a number or text", n + 1))),
            })
            .collect::<Result<Vec<_>, _>>()?;
        if fields.len() != header.len() || fields.iter().any(|(k, _)| !header.contains(k)) {
            return Err(bad(format!("case entry {} does not have the listed columns", n + 1)));
        }
        rows.push(row);
    }
    Ok(Table { header, rows })
}

pub fn merge(a: &MergeArgs) -> Result<(), CliError> {
    let inputs: Vec<&std::path::Path> = a.inputs.iter().map(|p| p.as_path()).collect();
    let mut outputs = crate::output::Transaction::new(&inputs);
    outputs.check_targets(&[&a.out])?;
    let mut tables = Vec::with_capacity(a.inputs.len());
    for path in &a.inputs {
        let text = std::fs::read_to_string(path).map_err(|e| CliError::io(path, e))?;
        let t = if is_json(path) { read_json(path, &text)? } else { read_csv(path, &text)? };
        if t.header.len() < 2 || t.header[0] != "case" || t.header[1] != "n_cases" {
            return Err(CliError::io(path, "the first columns are not \"case,n_cases\" (not written by pneumo sweep?)"));
        }
        tables.push(t);
    }
    let merged = merge_tables(&a.inputs, &tables, a.max_cases)?;
    let bytes = if is_json(&a.out) { to_json(&merged) } else { to_csv(&merged)? };
    outputs.add(&a.out, &bytes)?;
    outputs.commit()?;
    println!("merged {} cases from {} files into {}", merged.rows.len(), tables.len(), a.out.display());
    Ok(())
}

/// Join tables whose headers agree (up to the number of cycle columns) and
/// sort their rows by case; every case 0..n_cases must appear exactly once.
fn merge_tables(paths: &[PathBuf], tables: &[Table], max_cases: usize) -> Result<Table, CliError> {
    let fixed = |t: &Table| t.header.iter().filter(|h| !is_cycle_column(h)).cloned().collect::<Vec<_>>();
    // the header with the most cycle columns is the merged header
    let widest = (0..tables.len()).max_by_key(|&i| (tables[i].header.len(), std::cmp::Reverse(i))).unwrap_or(0);
    let Some(widest_table) = tables.get(widest) else { return Err(CliError::Usage("nothing to merge".into())) };
    let header = widest_table.header.clone();
    let reference = fixed(widest_table);
    for (t, p) in tables.iter().zip(paths) {
        if fixed(t) != reference || t.header.iter().any(|h| !header.contains(h)) {
            return Err(CliError::Usage(format!(
                "{}: columns differ from {} ({} vs {})",
                p.display(),
                paths[widest].display(),
                t.header.join(","),
                header.join(",")
            )));
        }
    }
    let index = |c: Option<&Cell>| match c {
        Some(Cell::Num(x)) if *x >= 0.0 && x.fract() == 0.0 && *x < 1e15 => Some(*x as u64),
        _ => None,
    };
    let mut by_case: BTreeMap<u64, (usize, Vec<Cell>)> = BTreeMap::new();
    // number of cases of the whole sweep, and the file it was first read from
    let mut total: Option<(u64, usize)> = None;
    for (f, (t, p)) in tables.iter().zip(paths).enumerate() {
        let position: Vec<Option<usize>> = header.iter().map(|h| t.header.iter().position(|x| x == h)).collect();
        for row in &t.rows {
            let (Some(case), Some(n)) = (index(row.first()), index(row.get(1))) else {
                return Err(CliError::io(p, "a row has no valid case index or n_cases"));
            };
            if n > max_cases as u64 {
                return Err(CliError::Data(format!(
                    "{}: n_cases = {n} is more than --max-cases {max_cases} (a corrupt file, or raise the limit)",
                    crate::error::shown_path(p)
                )));
            }
            match total {
                None => total = Some((n, f)),
                Some((m, g)) if m != n => {
                    return Err(CliError::Data(format!(
                        "{} has {n} cases in all but {} has {m}: shards of different sweeps?",
                        p.display(),
                        paths[g].display()
                    )))
                }
                Some(_) => {}
            }
            if case >= n {
                return Err(CliError::io(p, format!("case {case} is out of range (n_cases = {n})")));
            }
            let cells = position.iter().map(|pos| pos.and_then(|i| row.get(i).cloned()).unwrap_or(Cell::Empty)).collect();
            if let Some((g, _)) = by_case.insert(case, (f, cells)) {
                return Err(CliError::Data(format!("case {case} appears twice ({} and {})", paths[g].display(), p.display())));
            }
        }
    }
    let Some((total, _)) = total else { return Err(CliError::Usage("the inputs hold no cases".into())) };
    let n_missing = total - by_case.len() as u64;
    if n_missing > 0 {
        let first: Vec<String> = (0..total).filter(|i| !by_case.contains_key(i)).take(20).map(|i| i.to_string()).collect();
        let more = if n_missing > 20 { ", ..." } else { "" };
        return Err(CliError::Data(format!("{n_missing} of {total} cases missing: {}{more}", first.join(", "))));
    }
    Ok(Table { header, rows: by_case.into_values().map(|(_, r)| r).collect() })
}

/// A minimal JSON reader that keeps object keys in order and numbers as
/// their text, so `merge` reproduces the digits it read.
mod json {
    #[derive(Debug, Clone, PartialEq)]
    pub enum Value {
        Null,
        Bool(bool),
        Number(String),
        String(String),
        Array(Vec<Value>),
        Object(Vec<(String, Value)>),
    }

    pub fn parse(text: &str) -> Result<Value, String> {
        let mut p = Parser { s: text.as_bytes(), i: 0, text };
        let v = p.value(0)?;
        p.ws();
        if p.i != p.s.len() {
            return Err(p.err("trailing characters"));
        }
        Ok(v)
    }

    struct Parser<'a> {
        s: &'a [u8],
        i: usize,
        text: &'a str,
    }

    impl Parser<'_> {
        fn err(&self, what: &str) -> String {
            let line = self.text.as_bytes()[..self.i.min(self.s.len())].iter().filter(|&&b| b == b'\n').count() + 1;
            format!("invalid JSON at line {line}: {what}")
        }
        fn ws(&mut self) {
            while self.i < self.s.len() && matches!(self.s[self.i], b' ' | b'\t' | b'\n' | b'\r') {
                self.i += 1;
            }
        }
        fn eat(&mut self, b: u8) -> bool {
            self.ws();
            if self.s.get(self.i) == Some(&b) {
                self.i += 1;
                true
            } else {
                false
            }
        }
        fn value(&mut self, depth: usize) -> Result<Value, String> {
            if depth > 64 {
                return Err(self.err("nested too deeply"));
            }
            self.ws();
            match self.s.get(self.i) {
                Some(b'{') => {
                    self.i += 1;
                    let mut fields = Vec::new();
                    if self.eat(b'}') {
                        return Ok(Value::Object(fields));
                    }
                    loop {
                        self.ws();
                        let key = self.string()?;
                        if !self.eat(b':') {
                            return Err(self.err("expected ':'"));
                        }
                        fields.push((key, self.value(depth + 1)?));
                        if self.eat(b'}') {
                            return Ok(Value::Object(fields));
                        }
                        if !self.eat(b',') {
                            return Err(self.err("expected ',' or '}'"));
                        }
                    }
                }
                Some(b'[') => {
                    self.i += 1;
                    let mut items = Vec::new();
                    if self.eat(b']') {
                        return Ok(Value::Array(items));
                    }
                    loop {
                        items.push(self.value(depth + 1)?);
                        if self.eat(b']') {
                            return Ok(Value::Array(items));
                        }
                        if !self.eat(b',') {
                            return Err(self.err("expected ',' or ']'"));
                        }
                    }
                }
                Some(b'"') => Ok(Value::String(self.string()?)),
                Some(b'-' | b'0'..=b'9') => {
                    let start = self.i;
                    while self.i < self.s.len() && matches!(self.s[self.i], b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9') {
                        self.i += 1;
                    }
                    Ok(Value::Number(self.text[start..self.i].to_string()))
                }
                _ => {
                    for (word, v) in [("null", Value::Null), ("true", Value::Bool(true)), ("false", Value::Bool(false))] {
                        if self.s[self.i..].starts_with(word.as_bytes()) {
                            self.i += word.len();
                            return Ok(v);
                        }
                    }
                    Err(self.err("expected a value"))
                }
            }
        }
        /// A string token, decoded by serde_json (escapes, \u sequences).
        fn string(&mut self) -> Result<String, String> {
            if self.s.get(self.i) != Some(&b'"') {
                return Err(self.err("expected a string"));
            }
            let start = self.i;
            self.i += 1;
            while self.i < self.s.len() {
                match self.s[self.i] {
                    b'\\' => self.i += 2,
                    b'"' => {
                        self.i += 1;
                        return serde_json::from_str(&self.text[start..self.i]).map_err(|e| self.err(&e.to_string()));
                    }
                    _ => self.i += 1,
                }
            }
            Err(self.err("unterminated string"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(target: &str, n: usize) -> Axis {
        Axis {
            target: target.into(),
            texts: (0..n).map(|i| i.to_string()).collect(),
            values: (0..n).map(|i| Cell::Num(i as f64)).collect(),
        }
    }

    #[test]
    fn case_numbering_is_an_odometer_with_the_last_axis_fastest() {
        let axes = [axis("a.x", 4), axis("b.y", 2), axis("c.z", 3)];
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..24 {
            let idx = case_indices(&axes, i);
            assert_eq!(idx[0] * 6 + idx[1] * 3 + idx[2], i);
            seen.insert(idx);
        }
        assert_eq!(seen.len(), 24, "every combination exactly once");
        assert_eq!(case_sets(&axes, 5), vec!["a.x=0", "b.y=1", "c.z=2"]);
    }

    #[test]
    fn vary_and_shard_parsing() {
        let (t, v) = parse_vary(" flow_control.C = 1.41 L/min/bar, 2.68 L/min/bar ,13.2 L/min/bar").unwrap();
        assert_eq!(t, "flow_control.C");
        assert_eq!(v, vec!["1.41 L/min/bar", "2.68 L/min/bar", "13.2 L/min/bar"]);
        for bad in ["supply.p", "supply=4 bar", "supply.p=4 bar,,7 bar", "supply.p=", ".p=1"] {
            assert!(parse_vary(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_shard("3/16").unwrap(), (3, 16));
        for bad in ["0/4", "5/4", "1/0", "2", "a/b", "-1/2"] {
            assert!(parse_shard(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn numbers_round_trip_through_their_text() {
        for x in [0.0, 1.0, 0.1 + 0.2, 2.2e-9, 1.0 / 3.0, 123456.789, 1e-4, 9.99e-5, 1e15, -4.2e-300, f64::INFINITY] {
            let s = fmt_num(x);
            assert_eq!(s.parse::<f64>().unwrap(), x, "{s}");
            assert_eq!(fmt_num(s.parse().unwrap()), s);
        }
        assert_eq!(fmt_num(2.2e-9), "2.2e-9");
        assert_eq!(fmt_num(400000.0), "400000");
    }

    #[test]
    fn cycle_column_names_are_recognised() {
        for k in [1, 9, 12] {
            for c in cycle_columns(k) {
                assert!(is_cycle_column(&c), "{c}");
            }
        }
        for c in ["cycle_time_s", "cycle1_total", "cyclex_total_s", "head.T_min_K", "case"] {
            assert!(!is_cycle_column(c), "{c}");
        }
    }

    fn sample_table() -> Table {
        Table {
            header: vec!["case".into(), "n_cases".into(), "a.x".into(), "cycle_time_s".into(), "error".into()],
            rows: vec![
                vec![Cell::Num(0.0), Cell::Num(3.0), Cell::Num(0.1 + 0.2), Cell::Num(1.0 / 3.0), Cell::Empty],
                vec![Cell::Num(1.0), Cell::Num(3.0), Cell::Text("extend".into()), Cell::Empty, Cell::Text("bad, \"x\"\n2".into())],
                vec![Cell::Num(2.0), Cell::Num(3.0), Cell::Num(f64::INFINITY), Cell::Num(7.1e-12), Cell::Text("12".into())],
            ],
        }
    }

    #[test]
    fn csv_and_json_read_back_to_the_same_table() {
        let t = sample_table();
        let csv_bytes = to_csv(&t).unwrap();
        let back = read_csv(Path::new("t.csv"), std::str::from_utf8(&csv_bytes).unwrap()).unwrap();
        assert_eq!(back, t);
        let json_bytes = to_json(&t);
        let text = std::str::from_utf8(&json_bytes).unwrap();
        // valid JSON for other tools too
        let v: serde_json::Value = serde_json::from_str(text).unwrap();
        assert_eq!(v["cases"].as_array().unwrap().len(), 3);
        assert_eq!(v["cases"][1]["a.x"], "extend");
        let back = read_json(Path::new("t.json"), text).unwrap();
        assert_eq!(back, t);
        assert_eq!(to_json(&back), json_bytes);
    }

    #[test]
    fn merge_sorts_cases_and_reports_duplicates_and_gaps() {
        let t = sample_table();
        let part = |keep: &[usize]| Table { header: t.header.clone(), rows: keep.iter().map(|&i| t.rows[i].clone()).collect() };
        let paths = [PathBuf::from("s1"), PathBuf::from("s2")];
        assert_eq!(merge_tables(&paths, &[part(&[1]), part(&[0, 2])], DEFAULT_MAX_CASES).unwrap(), t);
        let dup = merge_tables(&paths, &[part(&[1, 2]), part(&[0, 2])], DEFAULT_MAX_CASES).unwrap_err().to_string();
        assert!(dup.contains("case 2 appears twice") && dup.contains("s1") && dup.contains("s2"), "{dup}");
        let gap = merge_tables(&paths, &[part(&[0]), part(&[2])], DEFAULT_MAX_CASES).unwrap_err().to_string();
        assert!(gap.contains("1 of 3 cases missing: 1"), "{gap}");
        // the last case missing is noticed through n_cases
        let tail = merge_tables(&paths, &[part(&[0]), part(&[1])], DEFAULT_MAX_CASES).unwrap_err().to_string();
        assert!(tail.contains("1 of 3 cases missing: 2"), "{tail}");
        let mut other = part(&[2]);
        other.header[2] = "b.y".into();
        let e = merge_tables(&paths, &[part(&[0, 1]), other], DEFAULT_MAX_CASES).unwrap_err().to_string();
        assert!(e.contains("columns differ"), "{e}");
        let mut foreign = part(&[2]);
        foreign.rows[0][1] = Cell::Num(4.0);
        let e = merge_tables(&paths, &[part(&[0, 1]), foreign], DEFAULT_MAX_CASES).unwrap_err().to_string();
        assert!(e.contains("different sweeps"), "{e}");
    }

    #[test]
    fn merge_pads_shards_that_recorded_fewer_cycles() {
        let [e1, r1, t1] = cycle_columns(1);
        let [e2, r2, t2] = cycle_columns(2);
        let short = Table {
            header: vec!["case".into(), "n_cases".into(), e1.clone(), r1.clone(), t1.clone(), "error".into()],
            rows: vec![vec![Cell::Num(0.0), Cell::Num(2.0), Cell::Num(1.0), Cell::Num(2.0), Cell::Num(3.0), Cell::Empty]],
        };
        let long = Table {
            header: vec!["case".into(), "n_cases".into(), e1, r1, t1, e2, r2, t2, "error".into()],
            rows: vec![vec![
                Cell::Num(1.0),
                Cell::Num(2.0),
                Cell::Num(4.0),
                Cell::Num(5.0),
                Cell::Num(6.0),
                Cell::Num(7.0),
                Cell::Num(8.0),
                Cell::Num(9.0),
                Cell::Empty,
            ]],
        };
        let m = merge_tables(&[PathBuf::from("a"), PathBuf::from("b")], &[short, long.clone()], DEFAULT_MAX_CASES).unwrap();
        assert_eq!(m.header, long.header);
        let e = Cell::Empty;
        assert_eq!(
            m.rows[0],
            vec![Cell::Num(0.0), Cell::Num(2.0), Cell::Num(1.0), Cell::Num(2.0), Cell::Num(3.0), e.clone(), e.clone(), e.clone(), e]
        );
        assert_eq!(m.rows[1], long.rows[0]);
    }
}
