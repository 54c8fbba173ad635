//! `RawResult`: one finished run, held in Rust; Python's `pneumo.Result`
//! turns it into numpy arrays, a DataFrame and a summary dict.

use pneumo_app::run::Run;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

#[pyclass(module = "pneumo._pneumo", frozen)]
pub struct RawResult {
    run: Run,
    warnings: Vec<String>,
    sensitivities: Option<solve::Sensitivities>,
}

impl RawResult {
    pub fn new(run: Run, warnings: Vec<String>) -> Self {
        RawResult { run, warnings, sensitivities: None }
    }

    pub fn with_sensitivities(self, sensitivities: Option<solve::Sensitivities>) -> Self {
        RawResult { sensitivities, ..self }
    }
}

#[pymethods]
impl RawResult {
    /// Parameters whose sensitivities the run integrated ("friction.k0").
    #[getter]
    fn sensitivity_params(&self) -> Vec<String> {
        self.sensitivities.as_ref().map(|s| s.params.clone()).unwrap_or_default()
    }

    /// ∂(channel)/∂(param) on the time grid as little-endian f64 (NaN where
    /// the channel is undefined), or None if either name is unknown.
    fn sensitivity_data<'py>(&self, py: Python<'py>, channel: &str, param: &str) -> Option<Bound<'py, PyBytes>> {
        let series = self.sensitivities.as_ref()?.series(channel, param)?;
        let bytes: Vec<u8> = series.iter().flat_map(|v| v.unwrap_or(f64::NAN).to_le_bytes()).collect();
        Some(PyBytes::new(py, &bytes))
    }

    /// Recorded signal names ("head.p"), without the time.
    #[getter]
    fn columns(&self) -> Vec<String> {
        self.run.result.columns.clone()
    }

    /// SI unit of each signal ("Pa"; "" for dimensionless).
    #[getter]
    fn units(&self) -> Vec<String> {
        self.run.result.units.clone()
    }

    #[getter]
    fn n_rows(&self) -> usize {
        self.run.result.times.len()
    }

    /// All samples as little-endian f64, row by row: the time, then every
    /// column (NaN where a signal is undefined).
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let r = &self.run.result;
        let mut bytes = Vec::with_capacity(r.times.len() * (r.columns.len() + 1) * 8);
        for (t, row) in r.times.iter().zip(&r.rows) {
            bytes.extend_from_slice(&t.to_le_bytes());
            for v in row {
                bytes.extend_from_slice(&v.unwrap_or(f64::NAN).to_le_bytes());
            }
        }
        PyBytes::new(py, &bytes)
    }

    /// The summary JSON that `pneumo simulate --summary` writes.
    fn summary_json(&self) -> String {
        serde_json::to_string_pretty(&pneumo_app::simulate::summary_of(&self.run)).unwrap_or_default()
    }

    /// Why the run did less than asked (cycles not completed), or None.
    #[getter]
    fn incomplete(&self) -> Option<String> {
        self.run.incomplete.clone()
    }

    /// Warnings about the netlist's values (one line each).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    #[getter]
    fn model_name(&self) -> String {
        self.run.name.clone()
    }

    #[getter]
    fn t_final(&self) -> f64 {
        self.run.result.t_final
    }

    /// `[(t, what), ...]`: every discrete event.
    fn events(&self) -> Vec<(f64, String)> {
        self.run.result.events.iter().map(|e| (e.t, e.what.clone())).collect()
    }

    /// The CSV text `pneumo simulate --out` writes, for these signals (all if
    /// None), with units in the header if asked.
    #[pyo3(signature = (signals = None, header_units = false))]
    fn csv(&self, py: Python<'_>, signals: Option<Vec<String>>, header_units: bool) -> PyResult<String> {
        use crate::errors::IntoPy;
        let columns = pneumo_app::output::select_columns(&self.run.result, &signals.unwrap_or_default()).py_err(py)?;
        Ok(pneumo_app::output::csv(&self.run.result, &columns, header_units))
    }
}
