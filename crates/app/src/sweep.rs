//! Sweeps (`pneumo sweep`, `pneumo merge`, Python's `pneumo.sweep`):
//! full-factorial parameter studies run in parallel, split into shards for
//! clusters, and joined back together.
//!
//! No physics here: every case is one ordinary run (`crate::run::prepare`
//! and `execute`, the same path as `pneumo simulate`) of the netlist with the fixed `--set`
//! overrides followed by the case's varied assignments. What this module adds:
//!
//! - Case numbering. With axes `A` (values a0..), `B` (b0..), ... given in that
//!   order on the command line, case `i` (0-based) is the odometer reading of
//!   `i` with the LAST axis turning fastest: i = ((iA·nB + iB)·nC + iC)...
//!   `--shard K/N` (1-based K) keeps the cases with `i mod N = K-1`.
//! - Determinism. Cases run on a local rayon pool of at most `--jobs` threads
//!   (never more than the cases, nor than a few per core: [`worker_threads`]), but the
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
//! - Provenance, so that a file alone says what produced it: `model` (the
//!   netlist path as given), `model_sha256` (of the bytes of every netlist
//!   file read, see [`Source::sha256`]), `set` (the fixed `--set`s as a JSON
//!   list), `pneumo_version`, and one `param:NAME` column per parameter the
//!   case ran with: every named parameter and every block parameter and
//!   initial value (written, derived or default; initial values chosen by the
//!   rest state as chosen), `gas.model`, `gas.species` and the effective
//!   `simulation.*` settings (method included).
//! - Numbers are written in Rust's shortest round-trip form (plain decimal for
//!   1e-4 ≤ |x| < 1e15, scientific otherwise), so reading a cell back and
//!   writing it again reproduces the same bytes; `merge` relies on this. JSON
//!   is read by a small order- and digit-preserving parser for the same reason
//!   (serde_json's default float parsing may differ from the text by an ulp).
//! - Every row also carries `n_cases`, the size of the whole sweep, so that
//!   `merge` can name missing cases even when a whole shard is absent.
//!
//! The same [`Plan`] serves the Python package: `pneumo.sweep` runs its cases
//! on local threads or as tasks on Dask workers ([`Plan::run_case`]) and
//! builds the same [`Table`] from the outcomes.
//!
//! Assumption: the circuit's structure (and so its temperature and parameter
//! columns) does not depend on the varied values.

use crate::error::AppError;
use crate::load::Source;
use crate::run::{execute, prepare, RunSpec};
use blocks::params::{ParamKind, Range};
use graph::FlatNetlist;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A sweep as `pneumo sweep` takes it: the netlist file, the axes as
/// written (`ID.PARAM=V1,V2,...`), and where to write the table.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Parameters and their values, `ID.PARAM=V1,V2,...` (e.g. "supply.p=4 bar,7 bar"),
    /// a full factorial with the last one changing fastest.
    pub vary: Vec<String>,
    /// Overrides `ID.PARAM=VALUE` applied in every case.
    pub sets: Vec<String>,
    /// Number of actuator cycles per case.
    pub cycles: Option<u64>,
    /// End time of each case [s].
    pub t_end: Option<f64>,
    /// Worker threads (None: the available parallelism).
    pub jobs: Option<usize>,
    /// Run only shard "K/N" (1-based K): the cases whose index mod N is K-1.
    pub shard: Option<String>,
    /// Write one row per case (CSV, or JSON if the name ends in .json).
    pub out: Option<PathBuf>,
    /// Most cases this process runs (the whole sweep, or its shard).
    pub max_cases: usize,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            model: PathBuf::new(),
            vary: Vec::new(),
            sets: Vec::new(),
            cycles: None,
            t_end: None,
            jobs: None,
            shard: None,
            out: None,
            max_cases: DEFAULT_MAX_CASES,
        }
    }
}

/// Sweep tables to join (`pneumo merge`).
#[derive(Debug, Clone)]
pub struct MergeOptions {
    /// Shard outputs (CSV or JSON, as written by `pneumo sweep`).
    pub inputs: Vec<PathBuf>,
    /// Merged file (CSV, or JSON if the name ends in .json).
    pub out: PathBuf,
    /// Most cases the merged sweep may hold.
    pub max_cases: usize,
}

/// One output cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    Empty,
    Num(f64),
    Text(String),
}

/// A header and rows of cells, as written to or read from a file.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<Cell>>,
}

/// One varied parameter.
#[derive(Debug, Clone)]
struct Axis {
    target: String,
    /// The values as the user wrote them (trimmed).
    texts: Vec<String>,
    /// The same values in SI (or option words).
    values: Vec<Cell>,
}

/// What one case produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Case index in the whole sweep (0-based).
    pub index: usize,
    /// (extend, retract, total) per completed cycle [s].
    pub cycles: Vec<(f64, f64, f64)>,
    /// (min, max) of each temperature column, aligned with [`Plan::temperature_columns`].
    pub temps: Vec<(Option<f64>, Option<f64>)>,
    /// The case's parameters, aligned with [`Plan::parameter_columns`].
    pub params: Vec<Cell>,
    /// The one-line error of a failed (or incomplete) case.
    pub error: Option<String>,
}

/// A study: everything `pneumo sweep` takes besides the netlist file, the
/// output file and the number of threads.
#[derive(Debug, Clone)]
pub struct Study {
    /// `(ID.PARAM, values as written)`, slowest first.
    pub axes: Vec<(String, Vec<String>)>,
    /// Fixed overrides `ID.PARAM=VALUE`, applied before the varied values.
    pub sets: Vec<String>,
    pub cycles: Option<u64>,
    pub t_end: Option<f64>,
    /// `(K, N)`, 1-based K: only the cases with index mod N = K - 1.
    pub shard: Option<(usize, usize)>,
    /// Most cases this process may run.
    pub max_cases: usize,
}

impl Default for Study {
    fn default() -> Self {
        Study { axes: Vec::new(), sets: Vec::new(), cycles: None, t_end: None, shard: None, max_cases: DEFAULT_MAX_CASES }
    }
}

/// Prefix of the columns that hold every parameter of a case.
pub const PARAM_PREFIX: &str = "param:";

/// Columns that hold words or paths, never numbers, whatever they look like.
const TEXT_COLUMNS: [&str; 5] = ["error", "model", "model_sha256", "set", "pneumo_version"];

/// Simulation settings recorded for every case (after `--cycles`/`--t-end`).
const SIMULATION_COLUMNS: [&str; 8] = [
    "simulation.t_end",
    "simulation.cycles",
    "simulation.rtol",
    "simulation.atol",
    "simulation.sample_interval",
    "simulation.max_step",
    "simulation.initial",
    "simulation.method",
];

/// A sweep ready to run: the netlist read once, every `--vary` value
/// checked and converted, the cases numbered and the columns fixed.
#[derive(Debug, Clone)]
pub struct Plan {
    base: FlatNetlist,
    sets: Vec<String>,
    axes: Vec<Axis>,
    total: usize,
    selected: Vec<usize>,
    temps: Vec<String>,
    /// Names (without [`PARAM_PREFIX`]) of the parameter columns.
    params: Vec<String>,
    /// Cycles every case is asked for, if known before running (sizes the cycle columns).
    requested: Option<u64>,
    cycles: Option<u64>,
    t_end: Option<f64>,
    model: String,
    model_sha256: String,
}

/// Check one axis as `--vary` gives it: an `ID.PARAM` target and non-empty values.
fn check_axis(shown: &str, target: &str, texts: &[String]) -> Result<(), AppError> {
    let bad = |why: &str| AppError::Usage(format!("--vary \"{shown}\": {why}"));
    if graph::netlist::split_ref(target).is_none() {
        return Err(bad("expected ID.PARAM=V1,V2,... (the target needs an id and a parameter, e.g. supply.p)"));
    }
    if texts.is_empty() || texts.iter().any(|t| t.is_empty()) {
        return Err(bad("empty value in the list (values are separated by single commas)"));
    }
    Ok(())
}

/// Split "ID.PARAM=V1, V2, ..." into the target and the trimmed values.
fn parse_vary(s: &str) -> Result<(String, Vec<String>), AppError> {
    let (target, list) = s.split_once('=').ok_or_else(|| AppError::Usage(format!("--vary \"{s}\": expected ID.PARAM=V1,V2,...")))?;
    let target = target.trim();
    let texts: Vec<String> = list.split(',').map(|v| v.trim().to_string()).collect();
    check_axis(s, target, &texts)?;
    Ok((target.to_string(), texts))
}

/// Parse "K/N" with 1 ≤ K ≤ N into (K, N).
pub fn parse_shard(s: &str) -> Result<(usize, usize), AppError> {
    let bad = || AppError::Usage(format!("--shard \"{s}\": expected K/N with 1 <= K <= N (e.g. 3/16)"));
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

/// Every parameter of a netlist after its overrides, by name: named
/// parameters and every block parameter and initial value (written or
/// default) in SI from `graph::resolve`, choices as their word, lists as
/// "[a, b]", and the gas. Empty if the values do not resolve (the run then
/// fails and says why).
pub fn netlist_parameters(flat: &FlatNetlist) -> Vec<(String, Cell)> {
    let Ok(resolved) = graph::resolve(flat) else { return Vec::new() };
    let mut out: Vec<(String, Cell)> = resolved.values.iter().map(|(name, v)| (name.clone(), Cell::Num(v.si))).collect();
    for c in &flat.components {
        let Ok(ty) = blocks::registry::block_type(&c.kind) else { continue };
        for spec in ty.params {
            let written = c.value(spec.name);
            let cell = match spec.kind {
                ParamKind::Choice(options) => {
                    let index = match written {
                        Some(v) => blocks::params::parse_value(spec, &v.to_raw()).ok(),
                        None => spec.default,
                    };
                    index.and_then(|i| options.get(i as usize)).map_or(Cell::Empty, |w| Cell::Text(w.to_string()))
                }
                ParamKind::List(_) => {
                    let shown = written.map(|v| v.to_raw().to_string()).unwrap_or_default();
                    let inner = shown.trim().trim_start_matches('[').trim_end_matches(']').trim().to_string();
                    Cell::Text(format!("[{inner}]"))
                }
                _ => continue,
            };
            out.push((format!("{}.{}", c.id, spec.name), cell));
        }
    }
    let word = |v: serde_json::Result<serde_json::Value>| match v {
        Ok(serde_json::Value::String(s)) => Cell::Text(s),
        _ => Cell::Empty,
    };
    out.push(("gas.model".into(), word(serde_json::to_value(flat.gas.model))));
    out.push(("gas.species".into(), word(serde_json::to_value(flat.gas.species))));
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The settings a case runs with (aligned with [`SIMULATION_COLUMNS`]).
fn simulation_parameters(opts: &solve::SimOptions, simulation: &graph::netlist::Simulation) -> Vec<(String, Cell)> {
    let word = |v: serde_json::Result<serde_json::Value>| match v {
        Ok(serde_json::Value::String(s)) => Cell::Text(s),
        _ => Cell::Empty,
    };
    let values = [
        Cell::Num(opts.t_end),
        opts.cycles.map_or(Cell::Empty, |n| Cell::Num(n as f64)),
        Cell::Num(opts.rtol),
        Cell::Num(opts.atol),
        Cell::Num(opts.sample_interval),
        Cell::Num(opts.max_step),
        word(serde_json::to_value(simulation.initial)),
        word(serde_json::to_value(simulation.method)),
    ];
    SIMULATION_COLUMNS.iter().map(|s| s.to_string()).zip(values).collect()
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

/// A message as one line (whitespace runs, newlines included, become one space).
fn one_line(e: &AppError) -> String {
    e.to_string().split_whitespace().collect::<Vec<_>>().join(" ")
}

impl Plan {
    /// Check the study against the netlist `base` (read from `source`):
    /// every `--vary` target and value, `--set`, the shard and the number of
    /// cases. Nothing is simulated.
    pub fn new(base: FlatNetlist, source: &Source, study: &Study) -> Result<Plan, AppError> {
        let mut axes: Vec<Axis> = Vec::with_capacity(study.axes.len());
        for (target, texts) in &study.axes {
            let target = target.trim();
            let texts: Vec<String> = texts.iter().map(|t| t.trim().to_string()).collect();
            check_axis(&format!("{target}={}", texts.join(",")), target, &texts)?;
            if axes.iter().any(|x| x.target == target) {
                return Err(AppError::Usage(format!("--vary {target} is given twice (put all its values in one list)")));
            }
            axes.push(Axis { target: target.to_string(), texts, values: Vec::new() });
        }
        if axes.is_empty() {
            return Err(AppError::Usage("nothing to vary (give at least one --vary ID.PARAM=V1,V2,...)".into()));
        }
        if let Some((k, n)) = study.shard {
            if k == 0 || n == 0 || k > n {
                return Err(AppError::Usage(format!("--shard \"{k}/{n}\": expected K/N with 1 <= K <= N (e.g. 3/16)")));
            }
        }
        if let Some(t) = study.t_end {
            if !(t > 0.0 && t.is_finite()) {
                return Err(AppError::Usage(format!("--t-end must be > 0 s, got {t}")));
            }
        }
        // --set errors stop the sweep before any case runs
        let mut with_sets = base.clone();
        for s in &study.sets {
            graph::apply_set(&mut with_sets, s)?;
        }
        for axis in &mut axes {
            let target = resolve(&with_sets, &axis.target).map_err(|why| AppError::Usage(format!("--vary {}: {why}", axis.target)))?;
            for text in &axis.texts {
                let value = si_value(&target, text).map_err(|why| AppError::Usage(format!("--vary {}={text}: {why}", axis.target)))?;
                axis.values.push(value);
            }
        }
        let total = axes
            .iter()
            .try_fold(1usize, |n, x| n.checked_mul(x.texts.len()))
            .filter(|&n| n as u64 <= MAX_INDEX)
            .ok_or_else(|| AppError::Usage(format!("the sweep has more than {MAX_INDEX} cases")))?;
        let mine = match study.shard {
            Some((k, n)) => total / n + usize::from(k - 1 < total % n),
            None => total,
        };
        if mine > study.max_cases {
            return Err(AppError::Usage(format!(
                "this sweep would run {mine} cases, more than --max-cases {} (raise it, or split the sweep with --shard K/N)",
                study.max_cases
            )));
        }
        let selected: Vec<usize> = match study.shard {
            Some((k, n)) => (k - 1..total).step_by(n).collect(),
            None => (0..total).collect(),
        };
        let (temps, params) = Self::columns(&with_sets, &axes, total);
        let requested = study.cycles.or_else(|| {
            let varied = axes.iter().find(|x| x.target == "simulation.cycles");
            match varied {
                Some(x) => x.values.iter().filter_map(|v| if let Cell::Num(n) = v { Some(*n as u64) } else { None }).max(),
                None => with_sets.simulation.cycles,
            }
        });
        Ok(Plan {
            base,
            sets: study.sets.clone(),
            axes,
            total,
            selected,
            temps,
            params,
            requested,
            cycles: study.cycles,
            t_end: study.t_end,
            model: source.name(),
            model_sha256: source.sha256(),
        })
    }

    /// Temperature columns ("<id>.T") and parameter names of the circuit,
    /// taken from the first case whose netlist builds (building is cheap;
    /// nothing is simulated), so that every shard finds the same.
    fn columns(with_sets: &FlatNetlist, axes: &[Axis], total: usize) -> (Vec<String>, Vec<String>) {
        for i in 0..total {
            let mut flat = with_sets.clone();
            if case_sets(axes, i).iter().any(|s| graph::apply_set(&mut flat, s).is_err()) {
                continue;
            }
            if let Ok(circuit) = graph::build(&flat) {
                let names = solve::Model::new(circuit).output_names();
                let temps = names.into_iter().filter(|n| n.ends_with(".T") && n.len() > 2).collect();
                let mut params: Vec<String> = netlist_parameters(&flat).into_iter().map(|(n, _)| n).collect();
                params.extend(SIMULATION_COLUMNS.iter().map(|s| s.to_string()));
                return (temps, params);
            }
        }
        (Vec::new(), Vec::new())
    }

    /// Number of cases in the whole sweep (all shards).
    pub fn n_cases(&self) -> usize {
        self.total
    }

    /// Indices of the cases this plan runs (all, or its shard's).
    pub fn selected(&self) -> &[usize] {
        &self.selected
    }

    /// The temperature columns ("head.T") whose range every case records.
    pub fn temperature_columns(&self) -> &[String] {
        &self.temps
    }

    /// Names of the parameter columns (without [`PARAM_PREFIX`]).
    pub fn parameter_columns(&self) -> &[String] {
        &self.params
    }

    /// `(ID.PARAM, values as written)` of every axis.
    pub fn axes(&self) -> Vec<(String, Vec<String>)> {
        self.axes.iter().map(|a| (a.target.clone(), a.texts.clone())).collect()
    }

    /// The `ID.PARAM=VALUE` assignments of case `index` (fixed ones first).
    pub fn case_assignments(&self, index: usize) -> Vec<String> {
        let mut all = self.sets.clone();
        all.extend(case_sets(&self.axes, index));
        all
    }

    /// Run one case (the same path as `pneumo simulate`). Never fails: an
    /// error becomes the outcome's one-line message.
    pub fn run_case(&self, index: usize, cancel: Option<&solve::Cancel>) -> Outcome {
        let mut params = vec![Cell::Empty; self.params.len()];
        let no_temps = vec![(None, None); self.temps.len()];
        let failed = |e: AppError, params: Vec<Cell>| Outcome {
            index,
            cycles: Vec::new(),
            temps: no_temps.clone(),
            params,
            error: Some(one_line(&e)),
        };
        if index >= self.total {
            return failed(AppError::Usage(format!("case {index} is out of range (n_cases = {})", self.total)), params);
        }
        let mut flat = self.base.clone();
        for s in self.case_assignments(index) {
            if let Err(e) = graph::apply_set(&mut flat, &s) {
                return failed(e.into(), params);
            }
        }
        let mut put = |found: Vec<(String, Cell)>| {
            for (name, cell) in found {
                if let Some(k) = self.params.iter().position(|p| *p == name) {
                    params[k] = cell;
                }
            }
        };
        put(netlist_parameters(&flat));
        let simulation = flat.simulation.clone();
        let spec = RunSpec { sets: Vec::new(), cycles: self.cycles, t_end: self.t_end, cancel: cancel.cloned() };
        let prepared = match prepare(flat, &spec) {
            Ok(p) => p,
            Err(e) => return failed(e, params),
        };
        put(simulation_parameters(&prepared.opts, &simulation));
        match execute(prepared) {
            Ok(run) => {
                let r = &run.result;
                let cycles = r.cycles.iter().map(|c| (c.extend, c.retract, c.total)).collect();
                let temps = self
                    .temps
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
                // the initial values the rest state chose are the ones the case ran with
                put(r.rest.values.iter().map(|v| (format!("{}.{}", v.id, v.param), Cell::Num(v.value))).collect());
                Outcome { index, cycles, temps, params, error: run.incomplete.clone() }
            }
            Err(e) => failed(e, params),
        }
    }

    /// Run `indices` on a pool of `jobs` threads, results in the order
    /// given; `tick` is called after each case. A raised `cancel` makes the
    /// remaining cases end at once with the message "cancelled".
    pub fn run_cases(
        &self,
        indices: &[usize],
        jobs: usize,
        cancel: Option<&solve::Cancel>,
        tick: &(dyn Fn() + Sync),
    ) -> Result<Vec<Outcome>, AppError> {
        if jobs == 0 {
            return Err(AppError::Usage("--jobs must be at least 1".into()));
        }
        let threads = worker_threads(jobs, indices.len());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| AppError::Data(format!("cannot start {threads} worker threads: {e}")))?;
        Ok(pool.install(|| {
            indices
                .par_iter()
                .map(|&i| {
                    let o = self.run_case(i, cancel);
                    tick();
                    o
                })
                .collect()
        }))
    }

    /// The output table of these outcomes (sorted by case): one row per case.
    pub fn table(&self, outcomes: &[Outcome]) -> Table {
        let mut sorted: Vec<&Outcome> = outcomes.iter().collect();
        sorted.sort_by_key(|o| o.index);
        let observed = sorted.iter().map(|o| o.cycles.len()).max().unwrap_or(0);
        let ncyc = observed.max(self.requested.map_or(0, |n| usize::try_from(n).unwrap_or(usize::MAX).min(100_000)));
        let mut header = vec!["case".to_string(), "n_cases".to_string()];
        header.extend(self.axes.iter().map(|a| a.target.clone()));
        for k in 1..=ncyc {
            header.extend(cycle_columns(k));
        }
        header.push("cycle_time_s".into());
        for t in &self.temps {
            header.push(format!("{t}_min_K"));
            header.push(format!("{t}_max_K"));
        }
        header.push("error".into());
        header.extend(["model", "model_sha256", "set", "pneumo_version"].map(String::from));
        header.extend(self.params.iter().map(|p| format!("{PARAM_PREFIX}{p}")));
        let sets = serde_json::to_string(&self.sets).unwrap_or_else(|_| "[]".into());
        let num = |x: Option<f64>| x.map_or(Cell::Empty, Cell::Num);
        let rows = sorted
            .iter()
            .map(|o| {
                let mut row = vec![Cell::Num(o.index as f64), Cell::Num(self.total as f64)];
                row.extend(case_indices(&self.axes, o.index).iter().zip(&self.axes).map(|(&j, a)| a.values[j].clone()));
                for k in 0..ncyc {
                    let c = o.cycles.get(k);
                    row.extend([num(c.map(|c| c.0)), num(c.map(|c| c.1)), num(c.map(|c| c.2))]);
                }
                // A case that stopped early keeps the cycles it completed, but
                // has no cycle time and no temperature range (they would
                // describe a shorter run than the other rows).
                let failed = o.error.is_some();
                row.push(if failed { Cell::Empty } else { num(o.cycles.last().map(|c| c.2)) });
                for k in 0..self.temps.len() {
                    let (lo, hi) = if failed { (None, None) } else { o.temps.get(k).copied().unwrap_or((None, None)) };
                    row.push(num(lo));
                    row.push(num(hi));
                }
                row.push(o.error.clone().map_or(Cell::Empty, Cell::Text));
                row.push(Cell::Text(self.model.clone()));
                row.push(Cell::Text(self.model_sha256.clone()));
                row.push(Cell::Text(sets.clone()));
                row.push(Cell::Text(env!("CARGO_PKG_VERSION").into()));
                row.extend((0..self.params.len()).map(|k| o.params.get(k).cloned().unwrap_or(Cell::Empty)));
                row
            })
            .collect();
        Table { header, rows }
    }

    /// The human-readable table printed to stdout: values as written, cycle time, status.
    pub fn summary_table(&self, outcomes: &[Outcome]) -> String {
        let mut header = vec!["case".to_string()];
        header.extend(self.axes.iter().map(|a| a.target.clone()));
        header.push("cycle_time_s".into());
        header.push("status".into());
        let mut lines = vec![header];
        for o in outcomes {
            let mut line = vec![o.index.to_string()];
            line.extend(case_indices(&self.axes, o.index).iter().zip(&self.axes).map(|(&j, a)| a.texts[j].clone()));
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
}

/// Worker threads per available core at most: cases are CPU-bound, so more
/// threads only add memory (each holds a model and its traces).
pub const MAX_THREADS_PER_CORE: usize = 4;

/// Threads of the pool that runs `cases` cases when `jobs` are asked for:
/// `jobs` is an upper bound, like make's and cargo's `-j` — never more
/// threads than cases, nor than [`MAX_THREADS_PER_CORE`] per available core.
pub fn worker_threads(jobs: usize, cases: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    jobs.min(cases).min(MAX_THREADS_PER_CORE.saturating_mul(cores)).max(1)
}

/// A sweep ready to run (`pneumo sweep`): its options checked, the netlist
/// read once, the output target checked against the inputs.
pub struct Sweep {
    plan: Plan,
    jobs: usize,
    shard: Option<(usize, usize)>,
    out: Option<PathBuf>,
    outputs: crate::output::Transaction,
}

/// A finished sweep: the outcomes of its cases (its table was written).
pub struct SweepDone {
    pub plan: Plan,
    pub outcomes: Vec<Outcome>,
    pub shard: Option<(usize, usize)>,
}

impl Sweep {
    /// Check the options of `o`, read its netlist and build the [`Plan`].
    pub fn new(o: &SweepOptions) -> Result<Sweep, AppError> {
        let mut axes = Vec::with_capacity(o.vary.len());
        for v in &o.vary {
            let (target, texts) = parse_vary(v)?;
            if axes.iter().any(|(t, _): &(String, Vec<String>)| *t == target) {
                return Err(AppError::Usage(format!("--vary {target} is given twice (put all its values in one list)")));
            }
            axes.push((target, texts));
        }
        let shard = o.shard.as_deref().map(parse_shard).transpose()?;
        let jobs = match o.jobs {
            Some(0) => return Err(AppError::Usage("--jobs must be at least 1".into())),
            Some(n) => n,
            None => std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        };
        if let Some(t) = o.t_end {
            if !(t > 0.0 && t.is_finite()) {
                return Err(AppError::Usage(format!("--t-end must be > 0 s, got {t}")));
            }
        }
        // The file is read once.
        let (base, source) = Source::read(&o.model)?;
        let inputs: Vec<&std::path::Path> = source.files.iter().map(|(p, _)| p.as_path()).collect();
        let outputs = crate::output::Transaction::new(&inputs);
        if let Some(out) = &o.out {
            outputs.check_targets(&[out])?;
        }
        let study = Study { axes, sets: o.sets.clone(), cycles: o.cycles, t_end: o.t_end, shard, max_cases: o.max_cases };
        let plan = Plan::new(base, &source, &study)?;
        Ok(Sweep { plan, jobs, shard, out: o.out.clone(), outputs })
    }

    /// The plan: its cases, the ones this process runs, its columns.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Run the selected cases (`tick` is called after each) and write the table.
    pub fn run(mut self, tick: &(dyn Fn() + Sync)) -> Result<SweepDone, AppError> {
        let outcomes = self.plan.run_cases(self.plan.selected(), self.jobs, None, tick)?;
        let table = self.plan.table(&outcomes);
        if let Some(path) = &self.out {
            let bytes = if is_json(path) { to_json(&table) } else { to_csv(&table)? };
            self.outputs.add(path, &bytes)?;
            self.outputs.commit()?;
        }
        Ok(SweepDone { plan: self.plan, outcomes, shard: self.shard })
    }
}

impl SweepDone {
    /// What `pneumo sweep` prints: the table of cases and the count of failures.
    pub fn text(&self) -> String {
        let mut text = self.plan.summary_table(&self.outcomes);
        let failed = self.outcomes.iter().filter(|o| o.error.is_some()).count();
        let of = match self.shard {
            Some((k, n)) => format!(" (shard {k}/{n} of {})", self.plan.n_cases()),
            None => String::new(),
        };
        text.push_str(&format!("{} cases{of}, {} ok, {failed} failed\n", self.outcomes.len(), self.outcomes.len() - failed));
        text
    }
}

/// Whether an output path asks for JSON (by its extension).
pub fn is_json(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Shortest round-trip text of a number: plain for 1e-4 ≤ |x| < 1e15, else scientific.
pub fn fmt_num(x: f64) -> String {
    let a = x.abs();
    if !x.is_finite() || a == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The table as CSV (the bytes `pneumo sweep --out f.csv` writes).
pub fn to_csv(t: &Table) -> Result<Vec<u8>, AppError> {
    let err = |e: csv::Error| AppError::Data(format!("cannot format CSV: {e}"));
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
    w.into_inner().map_err(|e| AppError::Data(format!("cannot format CSV: {e}")))
}

/// `{"columns": [...], "cases": [{...}, ...]}`, one case per line, keys in column order.
pub fn to_json(t: &Table) -> Vec<u8> {
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

/// A cell read back from a file: a number where the text is one written
/// the way this module writes numbers (so that writing it again gives the
/// same bytes), text otherwise, and always text in the columns of words.
fn cell_from_text(column: &str, text: &str) -> Cell {
    if text.is_empty() {
        return Cell::Empty;
    }
    if TEXT_COLUMNS.contains(&column) {
        return Cell::Text(text.to_string());
    }
    match text.parse::<f64>() {
        Ok(x) if fmt_num(x) == text => Cell::Num(x),
        _ => Cell::Text(text.to_string()),
    }
}

fn read_csv(path: &Path, text: &str) -> Result<Table, AppError> {
    let mut r = csv::ReaderBuilder::new().has_headers(true).from_reader(text.as_bytes());
    let header: Vec<String> = r.headers().map_err(|e| AppError::io(path, e))?.iter().map(str::to_string).collect();
    let mut rows = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| AppError::io(path, e))?;
        rows.push(header.iter().zip(rec.iter()).map(|(h, v)| cell_from_text(h, v)).collect());
    }
    Ok(Table { header, rows })
}

fn read_json(path: &Path, text: &str) -> Result<Table, AppError> {
    let bad = |why: String| AppError::io(path, why);
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

/// Join sweep shards into one table and write it (`pneumo merge`);
/// returns the number of cases merged.
pub fn merge(o: &MergeOptions) -> Result<usize, AppError> {
    let inputs: Vec<&std::path::Path> = o.inputs.iter().map(|p| p.as_path()).collect();
    let mut outputs = crate::output::Transaction::new(&inputs);
    outputs.check_targets(&[&o.out])?;
    let mut tables = Vec::with_capacity(o.inputs.len());
    for path in &o.inputs {
        let text = crate::load::read_input_text(path, "sweep result").map_err(|e| AppError::io(path, e))?;
        let t = if is_json(path) { read_json(path, &text)? } else { read_csv(path, &text)? };
        if t.header.len() < 2 || t.header[0] != "case" || t.header[1] != "n_cases" {
            return Err(AppError::io(path, "the first columns are not \"case,n_cases\" (not written by pneumo sweep?)"));
        }
        tables.push(t);
    }
    let merged = merge_tables(&o.inputs, &tables, o.max_cases)?;
    let bytes = if is_json(&o.out) { to_json(&merged) } else { to_csv(&merged)? };
    outputs.add(&o.out, &bytes)?;
    outputs.commit()?;
    Ok(merged.rows.len())
}

/// Join tables whose headers agree (up to the number of cycle columns) and
/// sort their rows by case; every case 0..n_cases must appear exactly once.
fn merge_tables(paths: &[PathBuf], tables: &[Table], max_cases: usize) -> Result<Table, AppError> {
    let fixed = |t: &Table| t.header.iter().filter(|h| !is_cycle_column(h)).cloned().collect::<Vec<_>>();
    // the header with the most cycle columns is the merged header
    let widest = (0..tables.len()).max_by_key(|&i| (tables[i].header.len(), std::cmp::Reverse(i))).unwrap_or(0);
    let Some(widest_table) = tables.get(widest) else { return Err(AppError::Usage("nothing to merge".into())) };
    let header = widest_table.header.clone();
    let reference = fixed(widest_table);
    for (t, p) in tables.iter().zip(paths) {
        if fixed(t) != reference || t.header.iter().any(|h| !header.contains(h)) {
            return Err(AppError::Usage(format!(
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
                return Err(AppError::io(p, "a row has no valid case index or n_cases"));
            };
            if n > max_cases as u64 {
                return Err(AppError::Data(format!(
                    "{}: n_cases = {n} is more than --max-cases {max_cases} (a corrupt file, or raise the limit)",
                    crate::error::shown_path(p)
                )));
            }
            match total {
                None => total = Some((n, f)),
                Some((m, g)) if m != n => {
                    return Err(AppError::Data(format!(
                        "{} has {n} cases in all but {} has {m}: shards of different sweeps?",
                        p.display(),
                        paths[g].display()
                    )))
                }
                Some(_) => {}
            }
            if case >= n {
                return Err(AppError::io(p, format!("case {case} is out of range (n_cases = {n})")));
            }
            let cells = position.iter().map(|pos| pos.and_then(|i| row.get(i).cloned()).unwrap_or(Cell::Empty)).collect();
            if let Some((g, _)) = by_case.insert(case, (f, cells)) {
                return Err(AppError::Data(format!("case {case} appears twice ({} and {})", paths[g].display(), p.display())));
            }
        }
    }
    let Some((total, _)) = total else { return Err(AppError::Usage("the inputs hold no cases".into())) };
    let n_missing = total - by_case.len() as u64;
    if n_missing > 0 {
        let first: Vec<String> = (0..total).filter(|i| !by_case.contains_key(i)).take(20).map(|i| i.to_string()).collect();
        let more = if n_missing > 20 { ", ..." } else { "" };
        return Err(AppError::Data(format!("{n_missing} of {total} cases missing: {}{more}", first.join(", "))));
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
    fn jobs_100000_with_one_case_starts_one_worker() {
        assert_eq!(worker_threads(100_000, 1), 1);
        assert_eq!(worker_threads(usize::MAX, 0), 1);
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(worker_threads(100_000, 1_000_000), MAX_THREADS_PER_CORE * cores);
        assert_eq!(worker_threads(2, 1_000_000), 2.min(MAX_THREADS_PER_CORE * cores));
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
    fn cells_read_back_keep_their_text_unless_it_is_a_number_as_written() {
        assert_eq!(cell_from_text("a.x", "0.30000000000000004"), Cell::Num(0.1 + 0.2));
        assert_eq!(cell_from_text("a.x", "2.2e-9"), Cell::Num(2.2e-9));
        assert_eq!(cell_from_text("a.x", "inf"), Cell::Num(f64::INFINITY));
        // not the shortest form: kept as text so that it is written back unchanged
        assert_eq!(cell_from_text("a.x", "1.50"), Cell::Text("1.50".into()));
        assert_eq!(cell_from_text("a.x", "1e3"), Cell::Text("1e3".into()));
        // words and paths stay text, whatever they look like
        for column in TEXT_COLUMNS {
            assert_eq!(cell_from_text(column, "12"), Cell::Text("12".into()), "{column}");
        }
        assert_eq!(cell_from_text("param:head.orientation", "extend"), Cell::Text("extend".into()));
        assert_eq!(cell_from_text("a.x", ""), Cell::Empty);
    }

    fn meter_out() -> (FlatNetlist, Source) {
        Source::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/meter_out.json")).unwrap()
    }

    #[test]
    fn a_plan_checks_its_axes_like_the_command_line() {
        let (flat, source) = meter_out();
        let study = |axes: Vec<(&str, Vec<&str>)>| Study {
            axes: axes.into_iter().map(|(t, v)| (t.to_string(), v.into_iter().map(String::from).collect())).collect(),
            ..Study::default()
        };
        let err = |s: Study| Plan::new(flat.clone(), &source, &s).unwrap_err().to_string();
        assert!(err(study(vec![("supply", vec!["4 bar"])])).contains("expected ID.PARAM"));
        assert!(err(study(vec![("supply.p", vec![])])).contains("empty value"));
        assert!(err(study(vec![("supply.p", vec!["4 bar", " "])])).contains("empty value"));
        assert!(err(study(vec![("supply.p", vec!["4 bar"]), ("supply.p", vec!["5 bar"])])).contains("given twice"));
        assert!(err(study(vec![("supply.p", vec!["7 m"])])).contains("7 m"));
        assert!(err(study(vec![])).contains("nothing to vary"));
        let mut sharded = study(vec![("supply.p", vec!["4 bar"])]);
        sharded.shard = Some((3, 2));
        assert!(err(sharded).contains("--shard"));
        let plan = Plan::new(
            flat.clone(),
            &source,
            &study(vec![("supply.p", vec!["4 bar", "5 bar", "6 bar"]), ("piston.mass", vec!["1 kg", "2 kg"])]),
        )
        .unwrap();
        assert_eq!(plan.n_cases(), 6);
        assert_eq!(plan.case_assignments(3), vec!["supply.p=5 bar", "piston.mass=2 kg"]);
        assert_eq!(plan.temperature_columns(), ["head.T", "rod.T"]);
        for name in ["bore", "supply.p", "head.orientation", "gas.model", "simulation.t_end"] {
            assert!(plan.parameter_columns().iter().any(|p| p == name), "no parameter column {name}");
        }
    }

    #[test]
    fn every_case_records_the_parameters_it_ran_with() {
        let (flat, source) = meter_out();
        let study = Study {
            axes: vec![("supply.p".into(), vec!["5 bar".into(), "0.5 bar".into()])],
            sets: vec!["piston.mass=2 kg".into()],
            cycles: Some(1),
            ..Study::default()
        };
        let plan = Plan::new(flat, &source, &study).unwrap();
        let outcomes = plan.run_cases(plan.selected(), 2, None, &|| {}).unwrap();
        let t = plan.table(&outcomes);
        let col = |name: &str| t.header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name}"));
        let ok = &t.rows[0];
        assert_eq!(ok[col("error")], Cell::Empty);
        assert_eq!(ok[col("param:supply.p")], Cell::Num(5e5));
        assert_eq!(ok[col("param:piston.mass")], Cell::Num(2.0));
        // derived, default and rest-state values
        assert_eq!(ok[col("param:bore")], Cell::Num(0.045));
        assert_eq!(ok[col("param:head.bore")], Cell::Num(0.045));
        assert_eq!(ok[col("param:rod.p0")], Cell::Num(5e5), "the rod chamber rests at the supply pressure");
        assert_eq!(ok[col("param:head.orientation")], Cell::Text("extend".into()));
        assert_eq!(ok[col("param:gas.model")], Cell::Text("ideal".into()));
        assert_eq!(ok[col("param:simulation.cycles")], Cell::Num(1.0));
        assert_eq!(ok[col("param:simulation.t_end")], Cell::Num(60.0));
        assert_eq!(ok[col("param:simulation.method")], Cell::Text("rodas4".into()));
        assert_eq!(ok[col("set")], Cell::Text("[\"piston.mass=2 kg\"]".into()));
        assert_eq!(ok[col("model_sha256")], Cell::Text(source.sha256()));
        assert_eq!(ok[col("model")], Cell::Text(source.name()));
        // a case whose supply is below the exhaust fails, and still says what it ran with
        let failed = &t.rows[1];
        assert!(matches!(&failed[col("error")], Cell::Text(_)), "{:?}", failed[col("error")]);
        assert_eq!(failed[col("param:supply.p")], Cell::Num(0.5e5));
        // the table does not depend on the order outcomes arrive in
        let mut reversed = outcomes.clone();
        reversed.reverse();
        assert_eq!(plan.table(&reversed), t);
        // a raised flag ends the remaining cases at once
        let cancel = solve::Cancel::new();
        cancel.cancel();
        let stopped = plan.run_case(0, Some(&cancel));
        assert!(stopped.error.as_deref().is_some_and(|e| e.starts_with("cancelled")), "{:?}", stopped.error);
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
