//! `RawLinearization`: the linear model of a netlist about an operating
//! point (`pneumo_app::linearize`), held in Rust; Python's
//! `pneumo.Linearization` turns it into numpy matrices, modes and a
//! `control.StateSpace`.

use crate::errors::IntoPy;
use pneumo_app::linearize::Linearized;
use pyo3::prelude::*;

/// Real and imaginary parts of a frequency response, one list per frequency.
type Response = (Vec<Vec<f64>>, Vec<Vec<f64>>);

#[pyclass(module = "pneumo._pneumo", frozen)]
pub struct RawLinearization {
    lin: Linearized,
}

impl RawLinearization {
    pub fn new(lin: Linearized) -> Self {
        RawLinearization { lin }
    }
}

#[pymethods]
impl RawLinearization {
    /// Everything as JSON text: what `pneumo linearize --json` prints
    /// (operating point, named states, inputs, outputs with SI units, A, B,
    /// C, D row by row, modes, mechanical modes, states left out).
    fn json(&self) -> String {
        serde_json::to_string(&self.lin.json).unwrap_or_default()
    }

    /// What `pneumo linearize` prints.
    fn text(&self) -> String {
        pneumo_app::linearize::text(&self.lin)
    }

    /// The Bode CSV `pneumo linearize --out` writes (bode.csv).
    fn bode_csv(&self, py: Python<'_>) -> PyResult<String> {
        self.lin.bode_csv().py_err(py)
    }

    /// The default Bode frequencies [Hz] (those of bode.csv).
    fn bode_frequencies(&self) -> Vec<f64> {
        self.lin.bode_frequencies()
    }

    /// `(re, im)`: H(j 2π f) at every frequency [Hz], each a list of p·m
    /// values per frequency, row-major (output i, input j at i·m + j).
    fn frequency_response(&self, py: Python<'_>, f_hz: Vec<f64>) -> PyResult<Response> {
        let h = self.lin.frequency_response(&f_hz).py_err(py)?;
        Ok((h.iter().map(|hk| hk.iter().map(|v| v.re).collect()).collect(), h.iter().map(|hk| hk.iter().map(|v| v.im).collect()).collect()))
    }
}
