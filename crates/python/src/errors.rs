//! Errors as Python exceptions. Every failure of the use-case layer is a
//! `AppError`; it reaches Python as the exception class of its kind, defined
//! in `pneumo/_errors.py` (so that classes can have two bases, such as
//! `UsageError(PneumoError, ValueError)`), with the one-line message the
//! command line prints after "error: ".

use pneumo_app::AppError;
use pyo3::prelude::*;

/// The Python exception for `e`.
pub fn to_py(py: Python<'_>, e: &AppError) -> PyErr {
    let class = match e {
        AppError::Graph(_) => "NetlistError",
        AppError::Solve(_) | AppError::Incomplete(_) => "SimulationError",
        AppError::Io { .. } => "FileError",
        AppError::Usage(_) => "UsageError",
        AppError::Data(_) => "DataError",
    };
    exception(py, class, &pneumo_app::error::one_line(&e.to_string()))
}

/// An instance of `pneumo._errors.<class>` with `message`.
pub fn exception(py: Python<'_>, class: &str, message: &str) -> PyErr {
    match py.import("pneumo._errors").and_then(|m| m.getattr(class)).and_then(|c| c.call1((message,))) {
        Ok(value) => PyErr::from_value(value),
        Err(e) => e,
    }
}

/// `Result<T, AppError>` as `PyResult<T>`.
pub trait IntoPy<T> {
    fn py_err(self, py: Python<'_>) -> PyResult<T>;
}

impl<T> IntoPy<T> for Result<T, AppError> {
    fn py_err(self, py: Python<'_>) -> PyResult<T> {
        self.map_err(|e| to_py(py, &e))
    }
}
