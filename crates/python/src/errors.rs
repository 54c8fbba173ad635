//! Errors as Python exceptions. Every failure of the use-case layer is a
//! `CliError`; it reaches Python as the exception class of its kind, defined
//! in `pneumo/_errors.py` (so that classes can have two bases, such as
//! `UsageError(PneumoError, ValueError)`), with the one-line message the
//! command line prints after "error: ".

use pneumo_cli::CliError;
use pyo3::prelude::*;

/// The Python exception for `e`.
pub fn to_py(py: Python<'_>, e: &CliError) -> PyErr {
    let class = match e {
        CliError::Graph(_) => "NetlistError",
        CliError::Solve(_) | CliError::Incomplete(_) => "SimulationError",
        CliError::Io { .. } => "FileError",
        CliError::Usage(_) => "UsageError",
        CliError::Data(_) => "DataError",
    };
    exception(py, class, &pneumo_cli::command::one_line(&e.to_string()))
}

/// An instance of `pneumo._errors.<class>` with `message`.
pub fn exception(py: Python<'_>, class: &str, message: &str) -> PyErr {
    match py.import("pneumo._errors").and_then(|m| m.getattr(class)).and_then(|c| c.call1((message,))) {
        Ok(value) => PyErr::from_value(value),
        Err(e) => e,
    }
}

/// `Result<T, CliError>` as `PyResult<T>`.
pub trait IntoPy<T> {
    fn py_err(self, py: Python<'_>) -> PyResult<T>;
}

impl<T> IntoPy<T> for Result<T, CliError> {
    fn py_err(self, py: Python<'_>) -> PyResult<T> {
        self.map_err(|e| to_py(py, &e))
    }
}
