//! Progress and Ctrl-C for Python: the core's [`Progress`] reported as a
//! tqdm-like line on `sys.stderr` or to a callable `(phase, done, total)`,
//! and the work run on a thread of its own while the Python thread, the
//! only one that can run signal handlers, watches for Ctrl-C.
//!
//! The first Ctrl-C asks the work to stop ([`Progress::interrupted`]): a
//! solve stops refining and sweeping and is finished from what is done
//! (its `stats["stopped"]` says `"interrupted"`), with a `SolveWarning`. A
//! second one, or an exception a callable raises (which stops the work the
//! same way), is raised once the work has returned. Work with nothing to
//! finish (a render, [`PyProgress::raising_interrupts`]) stops at the first
//! Ctrl-C, and `KeyboardInterrupt` is raised once it has.
//!
//! What the work tells the user as it goes on ([`Progress::warn`]) becomes
//! a `wavrad.SolveWarning` on the Python thread, at its next look at the
//! signals and once the work has returned, so that `warnings` filters and
//! `pytest.warns` see it where the call was made.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::PyBool;
use wavrad_core::progress::Progress;

use crate::error::{Error, Result, SolveWarning};

/// How often the Python thread runs signal handlers while work is under way.
const SIGNAL_POLL: Duration = Duration::from_millis(50);
/// How often, at most, a phase's progress is shown on a terminal or passed
/// to a callable (besides its start and end).
const SHOW_INTERVAL: Duration = Duration::from_millis(100);
/// How often, at most, a phase's progress is printed as a line of its own
/// where `sys.stderr` is not a terminal.
const LINE_INTERVAL: Duration = Duration::from_secs(10);

/// Where progress goes.
enum Report {
    Nothing,
    /// A line on `sys.stderr`: redrawn in place on a terminal, else printed
    /// every [`LINE_INTERVAL`] and at the end of each phase.
    Stderr {
        terminal: bool,
    },
    /// `callable(phase, done, total)`.
    Call(PyObject),
}

/// One phase under way.
struct Phase {
    name: String,
    total: u64,
    done: u64,
    started: Instant,
    shown: Instant,
}

/// The `progress=` of a Python call, as the core's [`Progress`].
pub struct PyProgress {
    report: Report,
    /// Whether the first Ctrl-C is raised too, not only the second.
    raise_first: bool,
    phase: Mutex<Option<Phase>>,
    stop: AtomicBool,
    raised: Mutex<Option<PyErr>>,
    /// What the work told ([`Progress::warn`]), not yet warned in Python.
    warnings: Warnings,
}

impl PyProgress {
    /// From `progress`: `True` (a line on `sys.stderr`), `False`, a callable
    /// `(phase, done, total)`, or `None`: `True` where `sys.stderr` is a
    /// terminal, else `False`.
    pub fn new(py: Python<'_>, progress: Option<&Bound<'_, PyAny>>) -> Result<PyProgress> {
        let terminal = || -> PyResult<bool> {
            py.import("sys")?
                .getattr("stderr")?
                .call_method0("isatty")?
                .extract()
        };
        let report = match progress {
            None => match terminal()? {
                true => Report::Stderr { terminal: true },
                false => Report::Nothing,
            },
            Some(p) if p.is_instance_of::<PyBool>() => match p.extract::<bool>()? {
                true => Report::Stderr {
                    terminal: terminal()?,
                },
                false => Report::Nothing,
            },
            Some(p) if p.is_callable() => Report::Call(p.clone().unbind()),
            Some(p) => {
                return Err(Error::Argument(format!(
                    "progress: expected True, False or a callable (phase, done, total), got {p}"
                )))
            }
        };
        Ok(PyProgress {
            report,
            raise_first: false,
            phase: Mutex::new(None),
            stop: AtomicBool::new(false),
            raised: Mutex::new(None),
            warnings: Warnings::default(),
        })
    }

    /// The same, but for work that a stop leaves with nothing to return:
    /// the first Ctrl-C stops it and is raised once it has stopped.
    pub fn raising_interrupts(self) -> PyProgress {
        PyProgress {
            raise_first: true,
            ..self
        }
    }

    /// Run `work` without the GIL on a thread of its own, while this
    /// thread runs Python's signal handlers every [`SIGNAL_POLL`]; then
    /// raise what a callable or a second Ctrl-C raised meanwhile.
    pub fn watch<T: Send>(&self, py: Python<'_>, work: impl FnOnce() -> T + Send) -> Result<T> {
        let done = py.allow_threads(|| {
            std::thread::scope(|scope| {
                let (sender, receiver) = mpsc::channel();
                scope.spawn(move || sender.send(work()));
                loop {
                    match receiver.recv_timeout(SIGNAL_POLL) {
                        Ok(done) => return Some(done),
                        Err(RecvTimeoutError::Timeout) => self.poll_signals(),
                        // The work panicked: the scope raises its panic.
                        Err(RecvTimeoutError::Disconnected) => return None,
                    }
                }
            })
        });
        let done = done.expect("a scope whose thread panicked panics itself");
        if let Err(e) = self.warnings.raise(py) {
            self.keep(e);
        }
        self.raise_kept().map(|()| done)
    }

    /// What a callable (or a second Ctrl-C) raised, as an error.
    pub fn raise_kept(&self) -> Result<()> {
        match self.raised.lock().expect("progress lock").take() {
            Some(e) => Err(Error::Python(e)),
            None => Ok(()),
        }
    }

    /// Run pending signal handlers: the first KeyboardInterrupt asks the
    /// work to stop and warns; anything else raised is kept for later.
    fn poll_signals(&self) {
        Python::with_gil(|py| {
            if let Err(e) = self.warnings.raise(py) {
                self.keep(e);
            }
            let Err(e) = py.check_signals() else {
                return;
            };
            let first = e.is_instance_of::<PyKeyboardInterrupt>(py)
                && !self.stop.swap(true, Ordering::SeqCst);
            if !first || self.raise_first {
                return self.keep(e);
            }
            let warned = warn(
                py,
                "wavrad: interrupted: the solve stops refining and finishes from what is done \
                 (Ctrl-C again raises KeyboardInterrupt once it has)",
            );
            if let Err(e) = warned {
                self.keep(e);
            }
        });
    }

    /// Keep `e` (the first one) to raise once the work is over, and ask the
    /// work to stop.
    fn keep(&self, e: PyErr) {
        self.stop.store(true, Ordering::SeqCst);
        self.raised.lock().expect("progress lock").get_or_insert(e);
    }

    /// Show `phase` at `done` of `total`; `end` for its last report.
    fn show(&self, phase: &str, done: u64, total: u64, elapsed: Duration, end: bool) {
        match &self.report {
            Report::Nothing => {}
            Report::Call(callable) => Python::with_gil(|py| {
                if let Err(e) = callable.call1(py, (phase, done, total)) {
                    self.keep(e);
                }
            }),
            // Not on a terminal, a phase's start is not worth a line.
            Report::Stderr { terminal: false } if done == 0 && !end => {}
            Report::Stderr { terminal } => {
                let line = progress_line(phase, done, total, elapsed);
                let text = match (terminal, end) {
                    (true, false) => format!("\r{line}"),
                    (true, true) => format!("\r{line}\n"),
                    (false, _) => format!("{line}\n"),
                };
                Python::with_gil(|py| {
                    let written = py
                        .import("sys")
                        .and_then(|sys| sys.getattr("stderr"))
                        .and_then(|err| err.call_method1("write", (text,)));
                    if let Err(e) = written {
                        self.keep(e);
                    }
                });
            }
        }
    }
}

/// `phase: 45%|█████▍      | 450/1000 [3.1 s < 3.8 s, 145/s]`, as tqdm shows.
fn progress_line(phase: &str, done: u64, total: u64, elapsed: Duration) -> String {
    const WIDTH: usize = 20;
    let share = if total == 0 {
        1.0
    } else {
        (done as f64 / total as f64).min(1.0)
    };
    let full = (share * WIDTH as f64).round() as usize;
    let bar = format!("{}{}", "█".repeat(full), " ".repeat(WIDTH - full));
    let seconds = elapsed.as_secs_f64();
    let rate = done as f64 / seconds.max(1e-9);
    let left = if share > 0.0 {
        format!("{:.1} s", seconds * (1.0 - share) / share)
    } else {
        "?".into()
    };
    format!(
        "{phase}: {:3.0}%|{bar}| {done}/{total} [{seconds:.1} s < {left}, {rate:.0}/s]",
        100.0 * share
    )
}

impl Progress for PyProgress {
    fn start(&self, phase: &str, total: u64) {
        let now = Instant::now();
        *self.phase.lock().expect("progress lock") = Some(Phase {
            name: phase.to_string(),
            total,
            done: 0,
            started: now,
            shown: now,
        });
        self.show(phase, 0, total, Duration::ZERO, false);
    }

    fn advance(&self, steps: u64) {
        let due = {
            let mut phase = self.phase.lock().expect("progress lock");
            let Some(phase) = phase.as_mut() else {
                return;
            };
            phase.done += steps;
            let interval = match self.report {
                Report::Stderr { terminal: false } => LINE_INTERVAL,
                _ => SHOW_INTERVAL,
            };
            let due = phase.shown.elapsed() >= interval;
            if due {
                phase.shown = Instant::now();
            }
            due.then(|| {
                (
                    phase.name.clone(),
                    phase.done,
                    phase.total,
                    phase.started.elapsed(),
                )
            })
        };
        if let Some((name, done, total, elapsed)) = due {
            self.show(&name, done, total, elapsed, false);
        }
    }

    fn finish(&self) {
        let Some(phase) = self.phase.lock().expect("progress lock").take() else {
            return;
        };
        self.show(
            &phase.name,
            phase.done,
            phase.total,
            phase.started.elapsed(),
            true,
        );
    }

    fn interrupted(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    fn warn(&self, message: &str) {
        self.warnings.warn(message)
    }
}

/// What work that reports no progress told ([`Progress::warn`]), kept to
/// be warned in Python once it has returned ([`Warnings::raise`]).
#[derive(Debug, Default)]
pub struct Warnings(Mutex<Vec<String>>);

impl Warnings {
    /// Each message kept, as a `wavrad.SolveWarning`, in the order told;
    /// then none is kept. Raises what `warnings.warn` raises (a filter that
    /// turns warnings into errors).
    pub fn raise(&self, py: Python<'_>) -> PyResult<()> {
        let told = std::mem::take(&mut *self.0.lock().expect("warnings lock"));
        told.iter().try_for_each(|message| warn(py, message))
    }
}

impl Progress for Warnings {
    fn warn(&self, message: &str) {
        self.0
            .lock()
            .expect("warnings lock")
            .push(message.to_string())
    }
}

/// Warn `message` as a `wavrad.SolveWarning`, attributed to the line that
/// called wavrad (under the thin wrapper `wavrad._docs` puts around each
/// native function).
pub fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let category = py.get_type::<SolveWarning>();
    py.import("warnings")?
        .call_method1("warn", (message, category, 2))
        .map(drop)
}
