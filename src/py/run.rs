//! Running core work with the GIL released.
//!
//! [`cancellable`] runs a long computation on a worker thread while the
//! calling thread waits with the GIL released, waking every 50 ms to let
//! Python run its signal handlers: Ctrl-C sets the core's [`Cancel`] flag and
//! the call raises `KeyboardInterrupt` as soon as the core notices (within a
//! fraction of a second). Panics in the core become `RuntimeError`, never a
//! crash.

use crate::cancel::Cancel;
use crate::error::Result;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{mpsc, Mutex};
use std::time::Duration;

fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

fn internal_error(p: Box<dyn std::any::Any + Send>) -> PyErr {
    PyRuntimeError::new_err(format!(
        "fcol internal error (please report with the call that caused it): {}",
        panic_message(p)
    ))
}

/// Run a short core call with the GIL released (no cancellation).
pub fn detached<T, F>(py: Python<'_>, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> Result<T> + Send,
{
    match py.detach(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(r) => r.map_err(PyErr::from),
        Err(p) => Err(internal_error(p)),
    }
}

/// Run a long core call with the GIL released, honouring Ctrl-C.
pub fn cancellable<T, F>(py: Python<'_>, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Cancel) -> Result<T> + Send,
{
    cancellable_polled(py, |_| Ok(()), f)
}

/// Like [`cancellable`], and calls `abort` as soon as Ctrl-C is seen, before
/// waiting for the core to stop: renderers use it to make Python callables
/// behind a surface stop calling back into Python, so the core reaches its
/// next cancellation check quickly however slow the callable is.
pub fn cancellable_aborting<T, F, A>(py: Python<'_>, abort: A, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Cancel) -> Result<T> + Send,
    A: FnOnce(),
{
    run_cancellable(py, |_| Ok(()), abort, f)
}

/// Like [`cancellable`], and calls `poll` with the GIL held between the
/// 50 ms waits (e.g. to report progress to a Python callback). An error from
/// `poll` cancels the computation and is raised.
pub fn cancellable_polled<T, F, P>(py: Python<'_>, poll: P, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Cancel) -> Result<T> + Send,
    P: FnMut(Python<'_>) -> PyResult<()>,
{
    run_cancellable(py, poll, || {}, f)
}

fn run_cancellable<T, F, P, A>(py: Python<'_>, mut poll: P, abort: A, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Cancel) -> Result<T> + Send,
    P: FnMut(Python<'_>) -> PyResult<()>,
    A: FnOnce(),
{
    let cancel = Cancel::new();
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        // The receiver crosses into `detach`, which needs Sync.
        let rx = Mutex::new(rx);
        let recv = |timeout: Option<Duration>| {
            let rx = rx.lock().unwrap_or_else(|p| p.into_inner());
            match timeout {
                Some(t) => rx.recv_timeout(t),
                None => rx.recv().map_err(|_| mpsc::RecvTimeoutError::Disconnected),
            }
        };
        let cancel_ref = &cancel;
        s.spawn(move || {
            let r = catch_unwind(AssertUnwindSafe(|| f(cancel_ref)));
            let _ = tx.send(r);
        });
        loop {
            match py.detach(|| recv(Some(Duration::from_millis(50)))) {
                Ok(Ok(r)) => return r.map_err(PyErr::from),
                Ok(Err(p)) => return Err(internal_error(p)),
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals().and_then(|_| poll(py)) {
                        cancel.cancel();
                        abort();
                        // Wait for the worker to notice, then raise.
                        let _ = py.detach(|| recv(None));
                        return Err(e);
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err("fcol worker thread vanished"))
                }
            }
        }
    })
}
