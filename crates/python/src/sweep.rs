//! `SweepPlan`: a `pneumo_app::sweep::Plan` for Python. Runs its cases on
//! local threads (`run`, Ctrl-C honoured) or one at a time (`run_case`, for
//! Dask workers), and turns outcomes into the sweep table: columns for a
//! DataFrame, or the exact CSV/JSON bytes of `pneumo sweep --out`.
//!
//! An outcome crosses to Python (and between processes, pickled) as a tuple
//! `(index, [(extend, retract, total), ...], [(T_min, T_max), ...],
//! [parameter value, ...], error)` of floats, strings and None, which
//! carries every f64 bit for bit.

use crate::errors::IntoPy;
use crate::model::Netlist;
use pneumo_app::sweep::{Cell, Outcome, Plan, Study, Table};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// A parameter value or table cell: a float, a word, or None.
#[derive(FromPyObject, IntoPyObject, Clone)]
pub enum Value {
    Num(f64),
    Text(String),
}

type PyCell = Option<Value>;

fn to_py_cell(c: &Cell) -> PyCell {
    match c {
        Cell::Empty => None,
        Cell::Num(x) => Some(Value::Num(*x)),
        Cell::Text(s) => Some(Value::Text(s.clone())),
    }
}

fn from_py_cell(c: PyCell) -> Cell {
    match c {
        None => Cell::Empty,
        Some(Value::Num(x)) => Cell::Num(x),
        Some(Value::Text(s)) => Cell::Text(s),
    }
}

/// An outcome as Python sees it (see the module documentation).
pub type PyOutcome = (usize, Vec<(f64, f64, f64)>, Vec<(Option<f64>, Option<f64>)>, Vec<PyCell>, Option<String>);

fn to_py_outcome(o: Outcome) -> PyOutcome {
    (o.index, o.cycles, o.temps, o.params.iter().map(to_py_cell).collect(), o.error)
}

fn from_py_outcome(o: PyOutcome) -> Outcome {
    Outcome { index: o.0, cycles: o.1, temps: o.2, params: o.3.into_iter().map(from_py_cell).collect(), error: o.4 }
}

#[pyclass(module = "pneumo._pneumo", frozen)]
pub struct SweepPlan {
    plan: Plan,
}

impl SweepPlan {
    fn table(&self, outcomes: Vec<PyOutcome>) -> Table {
        let outcomes: Vec<Outcome> = outcomes.into_iter().map(from_py_outcome).collect();
        self.plan.table(&outcomes)
    }
}

#[pymethods]
impl SweepPlan {
    /// Check a study of `netlist` (its overrides are the fixed `--set`s):
    /// `axes` is `[(ID.PARAM, [value, ...]), ...]`, slowest first.
    #[new]
    #[pyo3(signature = (netlist, axes, cycles = None, t_end = None, shard = None, max_cases = pneumo_app::sweep::DEFAULT_MAX_CASES))]
    fn new(
        py: Python<'_>,
        netlist: &Netlist,
        axes: Vec<(String, Vec<String>)>,
        cycles: Option<u64>,
        t_end: Option<f64>,
        shard: Option<(usize, usize)>,
        max_cases: usize,
    ) -> PyResult<Self> {
        let study = Study { axes, sets: netlist.sets.clone(), cycles, t_end, shard, max_cases };
        let plan = Plan::new(netlist.base.clone(), &netlist.source, &study).py_err(py)?;
        Ok(SweepPlan { plan })
    }

    /// Number of cases in the whole sweep.
    #[getter]
    fn n_cases(&self) -> usize {
        self.plan.n_cases()
    }

    /// Indices of the cases this plan runs (all, or its shard's).
    fn selected(&self) -> Vec<usize> {
        self.plan.selected().to_vec()
    }

    #[getter]
    fn parameter_columns(&self) -> Vec<String> {
        self.plan.parameter_columns().to_vec()
    }

    #[getter]
    fn temperature_columns(&self) -> Vec<String> {
        self.plan.temperature_columns().to_vec()
    }

    /// The `ID.PARAM=VALUE` assignments of a case.
    fn case_assignments(&self, index: usize) -> Vec<String> {
        self.plan.case_assignments(index)
    }

    /// Run these cases on `jobs` threads (default: the available
    /// parallelism, as `pneumo sweep`), GIL released; Ctrl-C stops them and
    /// raises KeyboardInterrupt.
    #[pyo3(signature = (indices, jobs = None))]
    fn run(&self, py: Python<'_>, indices: Vec<usize>, jobs: Option<usize>) -> PyResult<Vec<PyOutcome>> {
        let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1));
        let cancel = solve::Cancel::new();
        let outcomes = crate::interrupt::run(py, &cancel, || self.plan.run_cases(&indices, jobs, Some(&cancel), &|| {}))?.py_err(py)?;
        Ok(outcomes.into_iter().map(to_py_outcome).collect())
    }

    /// Run one case on this thread with the GIL released (for Dask workers).
    fn run_case(&self, py: Python<'_>, index: usize) -> PyResult<PyOutcome> {
        crate::interrupt::detached(py, || to_py_outcome(self.plan.run_case(index, None)))
    }

    /// `(header, columns)`: the sweep table of these outcomes, column by column.
    fn columns(&self, outcomes: Vec<PyOutcome>) -> (Vec<String>, Vec<Vec<PyCell>>) {
        let t = self.table(outcomes);
        let columns = (0..t.header.len()).map(|c| t.rows.iter().map(|r| to_py_cell(&r[c])).collect()).collect();
        (t.header, columns)
    }

    /// The bytes `pneumo sweep --out FILE.csv` writes for these outcomes.
    fn csv<'py>(&self, py: Python<'py>, outcomes: Vec<PyOutcome>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = pneumo_app::sweep::to_csv(&self.table(outcomes)).py_err(py)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// The bytes `pneumo sweep --out FILE.json` writes for these outcomes.
    fn json<'py>(&self, py: Python<'py>, outcomes: Vec<PyOutcome>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &pneumo_app::sweep::to_json(&self.table(outcomes)))
    }

    /// The table `pneumo sweep` prints: values as written, cycle time, status.
    fn summary_table(&self, outcomes: Vec<PyOutcome>) -> String {
        let outcomes: Vec<Outcome> = outcomes.into_iter().map(from_py_outcome).collect();
        self.plan.summary_table(&outcomes)
    }
}
