//! Long work with the GIL released and Ctrl-C honoured.
//!
//! The work runs on a scoped thread; the calling thread waits for it in
//! slices of 50 ms without the GIL and between slices asks Python whether a
//! signal arrived (`check_signals`, which raises `KeyboardInterrupt` for
//! Ctrl-C in the main thread). On a signal it raises the work's [`Cancel`]
//! flag, which every simulation looks at while it integrates, waits for the
//! work to end (promptly) and returns the signal's exception. A panic in the
//! work becomes `pneumo.PneumoError`: nothing unwinds into Python.

use pyo3::prelude::*;
use solve::Cancel;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// Run `work` (see the module documentation).
pub fn run<T: Send>(py: Python<'_>, cancel: &Cancel, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    let done = (Mutex::new(false), Condvar::new());
    let outcome = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let r = catch_unwind(AssertUnwindSafe(work));
            let (flag, wake) = &done;
            *flag.lock().unwrap_or_else(|p| p.into_inner()) = true;
            wake.notify_all();
            r
        });
        let mut signal: Option<PyErr> = None;
        loop {
            let finished = py.detach(|| {
                let (flag, wake) = &done;
                let guard = flag.lock().unwrap_or_else(|p| p.into_inner());
                let (guard, _) = wake.wait_timeout_while(guard, Duration::from_millis(50), |f| !*f).unwrap_or_else(|p| p.into_inner());
                *guard
            });
            if finished {
                break;
            }
            if signal.is_none() {
                if let Err(e) = py.check_signals() {
                    cancel.cancel();
                    signal = Some(e);
                }
            }
        }
        let joined = py.detach(|| worker.join());
        (signal, joined)
    });
    match outcome {
        (Some(signal), _) => Err(signal),
        (None, Ok(Ok(value))) => Ok(value),
        (None, Ok(Err(panic)) | Err(panic)) => {
            Err(crate::errors::exception(py, "PneumoError", &format!("internal error: {}", panic_text(&panic))))
        }
    }
}

/// The message of a panic payload.
pub fn panic_text(payload: &Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".into())
}

/// Run `work` with the GIL released on this thread (no Ctrl-C polling: for
/// Dask worker threads, where signals do not arrive), panics caught.
pub fn detached<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    py.detach(|| catch_unwind(AssertUnwindSafe(work)))
        .map_err(|panic| crate::errors::exception(py, "PneumoError", &format!("internal error: {}", panic_text(&panic))))
}
