//! `Netlist`: a model as Python holds it. Immutable: the files it was read
//! from ([`Source`]), the overrides applied to it, and the flat netlist with
//! and without them. `with_sets` makes a new one; `state`/`from_state` carry
//! it to another process (a Dask worker) without the file system.

use crate::errors::IntoPy;
use crate::linearize::RawLinearization;
use crate::result::RawResult;
use graph::FlatNetlist;
use pneumo_app::load::Source;
use pneumo_app::run::{execute, prepare, RunSpec};
use pneumo_app::sweep::Cell;
use pneumo_app::AppError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// `(path, [(file, text), ...], sets, si_numbers)`: a netlist, to rebuild anywhere.
type State = (PathBuf, Vec<(PathBuf, String)>, Vec<String>, Vec<String>);

/// `(name, value, SI unit, how it came about)` of one parameter.
type ParameterRow = (String, Py<PyAny>, String, String);

#[pyclass(module = "pneumo._pneumo", frozen)]
pub struct Netlist {
    pub source: Source,
    /// Flat netlist as read, without `sets`.
    pub base: FlatNetlist,
    /// `ID.PARAM=VALUE` overrides, in the order given.
    pub sets: Vec<String>,
    /// `base` with `sets` applied.
    pub flat: FlatNetlist,
    /// Names set from Python numbers, which are SI by definition: the
    /// command line's warning about plain numbers is not given for them
    /// ("*": for every value, in a netlist pneumo wrote in SI).
    pub si_numbers: Vec<String>,
}

impl Netlist {
    fn new(base: FlatNetlist, source: Source, sets: Vec<String>, si_numbers: Vec<String>) -> Result<Self, AppError> {
        let mut flat = base.clone();
        for s in &sets {
            graph::apply_set(&mut flat, s)?;
        }
        if !sets.is_empty() {
            // a wrong value is reported where it is set, with the message a run would give
            graph::resolve(&flat)?;
        }
        Ok(Netlist { source, base, sets, flat, si_numbers })
    }

    /// The warnings worth showing: all but those about numbers given in SI on purpose.
    pub fn shown_warnings(&self, warnings: &[graph::Warning]) -> Vec<String> {
        warnings
            .iter()
            .filter(|w| {
                let plain_si = w.message.contains(" (SI)");
                !(plain_si && self.si_numbers.iter().any(|n| n == "*" || w.message.starts_with(&format!("{n} = "))))
            })
            .map(|w| pneumo_app::error::one_line(&w.to_string()))
            .collect()
    }
}

/// A parameter value for Python: a float (SI), a word, or None.
fn cell_value(py: Python<'_>, cell: &Cell) -> Py<PyAny> {
    match cell {
        Cell::Num(x) => x.into_pyobject(py).map(|v| v.into_any().unbind()).unwrap_or_else(|_| py.None()),
        Cell::Text(s) => s.into_pyobject(py).map(|v| v.into_any().unbind()).unwrap_or_else(|_| py.None()),
        Cell::Empty => py.None(),
    }
}

#[pymethods]
impl Netlist {
    /// Read the netlist at `path` and its subsystem files.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let (flat, source) = Source::read(&path).py_err(py)?;
        Netlist::new(flat, source, Vec::new(), Vec::new()).py_err(py)
    }

    /// A netlist given as JSON text, named `name` in messages; subsystem
    /// files are read relative to `name`'s folder. `written_in_si`: a
    /// netlist pneumo wrote with plain SI numbers (no warnings about them).
    #[staticmethod]
    #[pyo3(signature = (text, name = PathBuf::from("<string>.json"), written_in_si = false))]
    fn from_text(py: Python<'_>, text: &str, name: PathBuf, written_in_si: bool) -> PyResult<Self> {
        let (flat, source) = Source::from_text(text, &name).py_err(py)?;
        let si = if written_in_si { vec!["*".to_string()] } else { Vec::new() };
        Netlist::new(flat, source, Vec::new(), si).py_err(py)
    }

    /// Rebuild from [`Netlist::state`] (reads no file).
    #[staticmethod]
    #[pyo3(signature = (path, files, sets, si_numbers = Vec::new()))]
    fn from_state(
        py: Python<'_>,
        path: PathBuf,
        files: Vec<(PathBuf, String)>,
        sets: Vec<String>,
        si_numbers: Vec<String>,
    ) -> PyResult<Self> {
        let source = Source { path, files };
        let flat = source.load().py_err(py)?;
        Netlist::new(flat, source, sets, si_numbers).py_err(py)
    }

    /// `(path, [(file, text), ...], sets, si_numbers)`: everything needed to rebuild it.
    fn state(&self) -> State {
        (self.source.path.clone(), self.source.files.clone(), self.sets.clone(), self.si_numbers.clone())
    }

    /// A new netlist with these overrides added after the present ones;
    /// `si_numbers` names those given as Python numbers.
    #[pyo3(signature = (sets, si_numbers = Vec::new()))]
    fn with_sets(&self, py: Python<'_>, sets: Vec<String>, si_numbers: Vec<String>) -> PyResult<Self> {
        let mut all = self.sets.clone();
        all.extend(sets);
        let mut si = self.si_numbers.clone();
        si.extend(si_numbers);
        Netlist::new(self.base.clone(), self.source.clone(), all, si).py_err(py)
    }

    /// The netlist's own name (its "name" field, or the file name).
    #[getter]
    fn name(&self) -> String {
        self.flat.name.clone()
    }

    /// The path it was read from, as given.
    #[getter]
    fn path(&self) -> PathBuf {
        self.source.path.clone()
    }

    #[getter]
    fn sets(&self) -> Vec<String> {
        self.sets.clone()
    }

    /// SHA-256 of the bytes of every netlist file read (see docs/sweeps.md).
    #[getter]
    fn sha256(&self) -> String {
        self.source.sha256()
    }

    /// Every file read for it (the netlist, then its subsystems).
    #[getter]
    fn files(&self) -> Vec<PathBuf> {
        self.source.files.iter().map(|(p, _)| p.clone()).collect()
    }

    /// `[(name, value, unit, how), ...]`: every parameter after the
    /// overrides: named parameters, block parameters and initial values in SI
    /// (unit its SI symbol), choices and lists as text, the gas. `how` is
    /// "parameter", "written", "derived" or "default".
    fn parameters(&self, py: Python<'_>) -> PyResult<Vec<ParameterRow>> {
        let resolved = graph::resolve(&self.flat).map_err(|e| crate::errors::to_py(py, &e.into()))?;
        let cells = pneumo_app::sweep::netlist_parameters(&self.flat);
        Ok(cells
            .iter()
            .map(|(name, cell)| {
                let (unit, how) = match resolved.get(name) {
                    Some(v) => {
                        let how = match (&v.kind, v.derived()) {
                            (graph::params::SlotKind::Parameter { .. }, _) => "parameter",
                            (_, true) => "derived",
                            (graph::params::SlotKind::Written, false) => "written",
                            (graph::params::SlotKind::Default, false) => "default",
                        };
                        (graph::params::si_unit(v.dim), how)
                    }
                    None => (String::new(), if name.starts_with("gas.") { "written" } else { "choice" }),
                };
                (name.clone(), cell_value(py, cell), unit, how.to_string())
            })
            .collect())
    }

    /// `[(signal, SI unit), ...]` that a run records.
    fn signals(&self, py: Python<'_>) -> PyResult<Vec<(String, String)>> {
        let circuit = graph::build(&self.flat).map_err(|e| crate::errors::to_py(py, &e.into()))?;
        let model = solve::Model::new(circuit);
        Ok(model.output_names().into_iter().zip(model.output_units()).collect())
    }

    /// `(report, warnings)`: what `pneumo check` prints (causality table,
    /// parameters, rest state) and the warnings it gives.
    fn check(&self, py: Python<'_>) -> PyResult<(String, Vec<String>)> {
        let mut warnings = Vec::new();
        let checked = pneumo_app::check::check(&self.flat, &mut |w| warnings.extend(self.shown_warnings(w))).py_err(py)?;
        Ok((checked.text, warnings))
    }

    /// The circuit as Graphviz text.
    fn dot(&self, py: Python<'_>) -> PyResult<String> {
        let circuit = graph::build(&self.flat).map_err(|e| crate::errors::to_py(py, &e.into()))?;
        Ok(graph::report::dot(&circuit))
    }

    /// The netlist with its overrides written in, as one runnable JSON file
    /// (subsystems expanded).
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        let description =
            format!("{} with {}", self.source.name(), if self.sets.is_empty() { "no overrides".into() } else { self.sets.join("; ") });
        pneumo_app::discrepancy::netlist_json(&self.flat, description).py_err(py)
    }

    /// Simulate (GIL released, Ctrl-C honoured). `cycles`/`t_end` as in
    /// `pneumo simulate`; with `sensitivities` (netlist parameters
    /// "ID.PARAM") also their forward sensitivities.
    #[pyo3(signature = (cycles = None, t_end = None, sensitivities = None))]
    fn simulate(&self, py: Python<'_>, cycles: Option<u64>, t_end: Option<f64>, sensitivities: Option<Vec<String>>) -> PyResult<RawResult> {
        let cancel = solve::Cancel::new();
        let spec = RunSpec { sets: Vec::new(), cycles, t_end, cancel: Some(cancel.clone()) };
        let flat = self.flat.clone();
        let outcome = crate::interrupt::run(py, &cancel, move || -> Result<_, AppError> {
            let prepared = prepare(flat.clone(), &spec)?;
            let warnings = self.shown_warnings(&prepared.warnings);
            match sensitivities.filter(|s| !s.is_empty()) {
                None => Ok((execute(prepared)?, None, warnings)),
                Some(params) => {
                    drop(prepared);
                    let (run, sens) = pneumo_app::sensitivity::run_with_sensitivities(flat, &spec, &params)?;
                    Ok((run, Some(sens), warnings))
                }
            }
        })?;
        let (run, sens, warnings) = outcome.py_err(py)?;
        Ok(RawResult::new(run, warnings).with_sensitivities(sens))
    }

    /// The linear model about the operating point `at` ("rest" or
    /// "t=1.2 s"), inputs and outputs from the netlist's interface section
    /// (GIL released, panics caught).
    #[pyo3(signature = (at, keep_all_states = false))]
    fn linearize(&self, py: Python<'_>, at: String, keep_all_states: bool) -> PyResult<RawLinearization> {
        let flat = self.flat.clone();
        let lin = crate::interrupt::detached(py, move || pneumo_app::linearize::linearize_netlist(&flat, &at, keep_all_states))?;
        Ok(RawLinearization::new(lin.py_err(py)?))
    }

    /// Export as an FMI 2.0 Co-Simulation FMU at `out`, with the runtime
    /// library at `runtime`. The FMU carries the netlist files as read:
    /// overrides are refused (save the model with them and load that).
    fn export_fmu(&self, py: Python<'_>, out: PathBuf, runtime: PathBuf) -> PyResult<()> {
        if !self.sets.is_empty() {
            return Err(crate::errors::exception(
                py,
                "UsageError",
                &format!(
                    "export_fmu: the model has overrides ({}); an FMU carries the netlist files as written: save the model (Model.save) and export the saved file, or set top-level parameters in the FMU",
                    pneumo_app::error::one_line(&self.sets.join("; "))
                ),
            ));
        }
        let (flat, source) = (self.base.clone(), self.source.clone());
        crate::interrupt::detached(py, move || pneumo_app::fmu::export_source(&flat, &source, &out, &runtime))?.py_err(py)
    }

    fn __repr__(&self) -> String {
        let sets = if self.sets.is_empty() { String::new() } else { format!(", sets={:?}", self.sets) };
        format!("Netlist({:?}{sets})", self.source.path.display().to_string())
    }
}
