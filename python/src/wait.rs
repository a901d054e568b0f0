//! Running library work off the Python thread: the work runs on a thread of its own with the
//! GIL released, while the calling thread wakes every 50 ms to deliver progress to a Python
//! callback and to check for Ctrl-C (Python runs its signal handlers only on the thread that
//! holds the GIL). On Ctrl-C, or when the callback raises, the work's cancel flag is set, the
//! work is joined (a render stops within a row of pixels) and the error is raised.

use pyo3::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::Duration;

/// How often the waiting thread checks for Ctrl-C.
const POLL: Duration = Duration::from_millis(50);

/// Run `work` (given the cancel flag and a progress sender) on its own thread; pass each
/// progress message to `on_progress` on the calling thread, with the GIL.
pub fn run<T: Send, M: Send>(
    py: Python<'_>,
    work: impl FnOnce(Arc<AtomicBool>, Sender<M>) -> T + Send,
    mut on_progress: impl FnMut(Python<'_>, M) -> PyResult<()>,
) -> PyResult<T> {
    let cancel = Arc::new(AtomicBool::new(false));
    let (tx, rx) = channel::<M>();
    std::thread::scope(|sc| {
        let c = cancel.clone();
        let handle = sc.spawn(move || work(c, tx));
        let rx = std::sync::Mutex::new(rx);
        let waited = wait(py, &rx, &mut on_progress);
        if waited.is_err() {
            cancel.store(true, Ordering::Relaxed);
        }
        // joined without the GIL: the work may be finishing its last row
        let out = py.detach(|| handle.join());
        waited?;
        out.map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("the work thread panicked"))
    })
}

fn wait<M: Send>(
    py: Python<'_>,
    rx: &std::sync::Mutex<Receiver<M>>,
    on_progress: &mut impl FnMut(Python<'_>, M) -> PyResult<()>,
) -> PyResult<()> {
    loop {
        // (a Mutex only to share the receiver with the GIL-free closure; it is never contended)
        match py.detach(|| rx.lock().expect("not poisoned").recv_timeout(POLL)) {
            Ok(m) => on_progress(py, m)?,
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return Ok(()),
        }
        py.check_signals()?;
    }
}
