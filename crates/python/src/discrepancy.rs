//! `discrepancy`: the workflow of `pneumo discrepancy` for Python. The
//! analysis runs on a rayon pool made for it, whose threads carry the call's
//! cancellation flag (`solve::settings::set_thread_cancel`), so that Ctrl-C
//! stops every simulation of the analysis; its parallel steps stay inside
//! that pool.

use crate::errors::IntoPy;
use crate::model::Netlist;
use pneumo_app::discrepancy::{model_file, netlist_json, run_workflow, text_summary};
use pneumo_app::AppError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// What the analysis produced, for `pneumo.DiscrepancyResult`.
#[derive(IntoPyObject)]
pub struct Found {
    /// The `--json` summary.
    summary_json: String,
    /// The verdict and candidates as `pneumo discrepancy` prints them.
    text: String,
    /// `(label, file name, netlist JSON)` of the final model and of each
    /// ambiguous alternative ("baseline": the calibrated model).
    models: Vec<(String, String, String)>,
    /// Files written into the report directory.
    written: Vec<PathBuf>,
}

/// Calibrate `netlist` against the experiments of the manifest at
/// `experiments`, find the missing effect and return the models; with
/// `report`, also write the report directory `pneumo discrepancy --report`
/// writes.
#[pyfunction]
#[pyo3(signature = (netlist, experiments, report = None))]
pub fn discrepancy(py: Python<'_>, netlist: &Netlist, experiments: PathBuf, report: Option<PathBuf>) -> PyResult<Found> {
    let cancel = solve::Cancel::new();
    let flag = cancel.clone();
    let pool = rayon::ThreadPoolBuilder::new()
        .start_handler(move |_| solve::settings::set_thread_cancel(Some(flag.clone())))
        .build()
        .map_err(|e| crate::errors::to_py(py, &AppError::Data(format!("cannot start worker threads: {e}"))))?;
    let work = || -> Result<Found, AppError> {
        let files: Vec<PathBuf> = netlist.source.files.iter().map(|(p, _)| p.clone()).collect();
        let found = run_workflow(&netlist.flat, &files, &netlist.source.path, &experiments, report.as_deref())?;
        let mut models = Vec::new();
        for (label, augmented) in &found.outcome.augmented {
            let description = format!(
                "{} with the discrepancy workflow's result: {}.",
                netlist.source.name(),
                if label == "baseline" { "no missing effect".to_string() } else { format!("added {label}") }
            );
            models.push((label.clone(), model_file(label), netlist_json(augmented, description)?));
        }
        Ok(Found { text: text_summary(&found.outcome), summary_json: found.summary_json, models, written: found.written })
    };
    crate::interrupt::run(py, &cancel, || pool.install(work))?.py_err(py)
}
