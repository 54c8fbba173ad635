//! `pneumo._pneumo`: the native half of the Python package `pneumo`.
//!
//! Owns: the conversion between Python values and the use-case layer
//! (`pneumo_app`: loading, `run::prepare`/`execute`, the summary,
//! `sweep::Plan`, discrepancy), running it with the GIL released and
//! Ctrl-C honoured ([`interrupt`]), and errors as Python exceptions
//! ([`errors`]). The friendly API (numpy arrays, DataFrames, Dask, plots) is
//! Python code in `python/pneumo/`.
//! Never knows: physics, numpy, pandas, Dask (they are Python's business).

mod discrepancy;
mod errors;
mod interrupt;
mod linearize;
mod model;
mod result;
mod sweep;

use pyo3::prelude::*;

/// Run the `pneumo` command line with `argv` (argv[0] is the program name);
/// returns its exit status. `python -m pneumo` calls this.
#[pyfunction]
fn main(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| pneumo_cli::command::run(argv))
}

/// The block types with their ports and parameters (`pneumo blocks`).
#[pyfunction]
fn blocks() -> String {
    pneumo_app::check::block_listing()
}

/// The JSON Schema of the netlist format (`pneumo schema`), as JSON text.
#[pyfunction]
fn schema_json() -> String {
    serde_json::to_string_pretty(&graph::netlist::schema()).unwrap_or_default()
}

#[pymodule]
fn _pneumo(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<model::Netlist>()?;
    m.add_class::<result::RawResult>()?;
    m.add_class::<linearize::RawLinearization>()?;
    m.add_class::<sweep::SweepPlan>()?;
    m.add_function(wrap_pyfunction!(discrepancy::discrepancy, m)?)?;
    m.add_function(wrap_pyfunction!(main, m)?)?;
    m.add_function(wrap_pyfunction!(blocks, m)?)?;
    m.add_function(wrap_pyfunction!(schema_json, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DEFAULT_MAX_CASES", pneumo_app::sweep::DEFAULT_MAX_CASES)?;
    Ok(())
}
