//! Runs from Python: the simulation with the GIL released, Ctrl-C and the
//! progress callback served between blocks of pulses on the calling thread
//! (the thread that hands blocks to the sinks), points packed for NumPy.

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use lidarsim::output::{PointSink, WriteCause};
use lidarsim::run::RunOptions;
use lidarsim::sim::{RunControl, Simulator};
use lidarsim::summary::{Measured, Summary};
use lidarsim::{Error, Flight};
use numpy::PyArray1;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::json_to_py;
use crate::errors::{point_error, to_py};
use crate::hold::Hold;
use crate::points::{PackSink, pack_trajectory};

/// How often the progress callback is called at most.
const PROGRESS_EVERY: Duration = Duration::from_millis(100);

/// How often a run takes the GIL to look at Python's signals at most
/// (each time may wait for another thread to let the GIL go).
const LOOK_EVERY: Duration = Duration::from_millis(50);

/// What a run watches between blocks: Python's signals (Ctrl-C raises
/// `KeyboardInterrupt` in the main thread) and the progress callback. The
/// first error stops the run; it is raised once the run has returned.
struct Watch {
    stop: AtomicBool,
    error: Mutex<Option<PyErr>>,
    progress: Option<Py<PyAny>>,
    total: u64,
    last: Mutex<Option<Instant>>,
    last_look: Mutex<Option<Instant>>,
    /// Whether the run was called from Python's main thread, the only one
    /// that sees signals (a Dask worker runs tasks on other threads).
    main_thread: bool,
    /// A test's hold of the run at a set pulse ([`Hold`]).
    hold: Option<Hold>,
}

impl Watch {
    fn new(progress: Option<Py<PyAny>>, total: u64) -> Self {
        let main_thread = Python::attach(|py| {
            let threading = py.import("threading").ok()?;
            let main = threading.call_method0("main_thread").ok()?;
            let current = threading.call_method0("current_thread").ok()?;
            Some(main.is(&current))
        })
        .unwrap_or(true);
        Self {
            stop: AtomicBool::new(false),
            error: Mutex::new(None),
            progress,
            total,
            last: Mutex::new(None),
            last_look: Mutex::new(None),
            main_thread,
            hold: Hold::from_env(),
        }
    }

    fn fail(&self, e: PyErr) {
        self.error.lock().expect("error lock").get_or_insert(e);
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Called with the pulses simulated so far, after blocks were handed
    /// over, on the thread that called the run.
    fn tick(&self, done: u64) {
        self.look(done);
        if let Some(hold) = &self.hold {
            let held = hold.wait(
                done,
                || self.stop.load(Ordering::SeqCst),
                || self.look_at_signals(),
            );
            if let Err(e) = held {
                self.fail(PyRuntimeError::new_err(e.to_string()));
            }
        }
    }

    /// The progress callback and Python's signals, at most as often as
    /// [`LOOK_EVERY`] and [`PROGRESS_EVERY`] say (a hold is a new look).
    fn look(&self, done: u64) {
        if self.stop.load(Ordering::SeqCst) || (!self.main_thread && self.progress.is_none()) {
            return;
        }
        let holding = self.hold.as_ref().is_some_and(|h| h.due(done));
        {
            let mut last = self.last_look.lock().expect("look lock");
            if last.is_some_and(|t| t.elapsed() < LOOK_EVERY) && done < self.total && !holding {
                return;
            }
            *last = Some(Instant::now());
        }
        Python::attach(|py| {
            if let Err(e) = py.check_signals() {
                self.fail(e);
                return;
            }
            let Some(callback) = &self.progress else {
                return;
            };
            let mut last = self.last.lock().expect("progress lock");
            if last.is_some_and(|t| t.elapsed() < PROGRESS_EVERY) && done < self.total && !holding {
                return;
            }
            *last = Some(Instant::now());
            if let Err(e) = callback.call1(py, (done, self.total)) {
                self.fail(e);
            }
        });
    }

    /// Python's signals (Ctrl-C), on the main thread: the first stops the
    /// run.
    fn look_at_signals(&self) {
        if self.main_thread && !self.stop.load(Ordering::SeqCst) {
            Python::attach(|py| {
                if let Err(e) = py.check_signals() {
                    self.fail(e);
                }
            });
        }
    }

    fn take_error(&self) -> Option<PyErr> {
        self.error.lock().expect("error lock").take()
    }
}

pub fn check_threads(threads: usize) -> PyResult<()> {
    if threads == 0 {
        return Err(PyValueError::new_err(
            "threads must be at least 1 (None uses every core)",
        ));
    }
    Ok(())
}

fn bytes_array(py: Python<'_>, bytes: Vec<u8>) -> Bound<'_, PyArray1<u8>> {
    PyArray1::from_vec(py, bytes)
}

/// Simulates the whole flight into memory. Returns a dict: `points` and
/// `trajectory_true` / `trajectory_observed` as `uint8` arrays of packed
/// records, `summary` (as in `summary.json`) and `las` (the LAS file's
/// scale, offset, CRS and extra-byte groups).
pub fn run<'py>(
    py: Python<'py>,
    flight: &Flight,
    threads: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    check_threads(threads)?;
    let watch = Watch::new(progress, flight.pulses());
    let settings = flight.las_settings();
    let result = py.detach(|| {
        let sim = Simulator::new(flight.survey(), flight.world());
        let mut sink = PackSink {
            settings: settings.clone(),
            bytes: Vec::new(),
        };
        let started = Instant::now();
        let control = RunControl {
            stop: Some(&watch.stop),
            ..RunControl::default()
        };
        let outcome = {
            let mut sinks: [&mut (dyn PointSink<Error = WriteCause> + 'static); 1] = [&mut sink];
            sim.run_from(threads, &mut sinks, &|n| watch.tick(n), &control)?
        };
        Ok::<_, WriteCause>((sink.bytes, outcome, started.elapsed().as_secs_f64()))
    });
    if let Some(e) = watch.take_error() {
        return Err(e);
    }
    let (bytes, outcome, wall_time_s) = result.map_err(|e| point_error(&e))?;
    let measured = Measured {
        counts: outcome.counts,
        threads,
        wall_time_s,
        estimate: flight.estimate(threads),
    };
    let summary = Summary::of(flight, &measured, Vec::new());
    let out = PyDict::new(py);
    out.set_item("points", bytes_array(py, bytes))?;
    for (name, observed) in [("trajectory_true", false), ("trajectory_observed", true)] {
        let rows = lidarsim::files::trajectory_rows(flight.survey(), flight.lines(), observed);
        out.set_item(name, bytes_array(py, pack_trajectory(&rows)))?;
    }
    let text = serde_json::to_string(&summary)
        .map_err(|e| PyValueError::new_err(format!("cannot write the summary: {e}")))?;
    out.set_item("summary", json_to_py(py, &text)?)?;
    let las = PyDict::new(py);
    las.set_item("scale", settings.scale_m)?;
    las.set_item("offset", settings.offset_m.to_vec())?;
    las.set_item("crs_wkt", settings.crs_wkt.clone())?;
    las.set_item("extra_bytes", settings.attribute_extra_bytes)?;
    las.set_item("error_extra_bytes", settings.error_extra_bytes)?;
    out.set_item("las", las)?;
    Ok(out.into_any())
}

/// Options of a run into a directory, as the command line's.
#[derive(Default)]
pub struct DirOptions {
    pub overwrite: bool,
    pub resume: bool,
    pub no_space_check: bool,
}

/// Runs `job` with the GIL released under a [`Watch`] of `progress` over
/// `total` pulses, handing it the run options of `threads` and `o`, and
/// returns what it returns as Python data (a dict, as its JSON). An error
/// of the watch (Ctrl-C, the callback's) comes first; the job's is raised
/// as the exception of its kind ([`to_py`]). Callers check `threads`
/// before building the flight.
pub(crate) fn watched<'py, T>(
    py: Python<'py>,
    (threads, progress, total): (usize, Option<Py<PyAny>>, u64),
    o: &DirOptions,
    job: impl FnOnce(&RunOptions) -> Result<T, Error> + Send,
) -> PyResult<Bound<'py, PyAny>>
where
    T: serde::Serialize + Send,
{
    let watch = Watch::new(progress, total);
    let result = py.detach(|| {
        let tick = |n| watch.tick(n);
        let options = RunOptions {
            stop: Some(&watch.stop),
            resume: o.resume,
            overwrite: o.overwrite,
            no_space_check: o.no_space_check,
            ..RunOptions::new(threads, &tick)
        };
        job(&options)
    });
    if let Some(e) = watch.take_error() {
        return Err(e);
    }
    let value = result.map_err(|e| to_py(py, &e, false))?;
    let text = serde_json::to_string(&value)
        .map_err(|e| PyValueError::new_err(format!("cannot write the result: {e}")))?;
    json_to_py(py, &text)
}

/// Writes the same files as `lidarsim run` into `out_dir` and returns the
/// summary. Ctrl-C stops it at a block boundary with every file finished
/// under its `.partial` name and a record to resume, then raises
/// `KeyboardInterrupt`.
pub fn run_to<'py>(
    py: Python<'py>,
    flight: &Flight,
    out_dir: &Path,
    threads: usize,
    progress: Option<Py<PyAny>>,
    o: DirOptions,
) -> PyResult<Bound<'py, PyAny>> {
    check_threads(threads)?;
    watched(py, (threads, progress, flight.pulses()), &o, |options| {
        lidarsim::run::run(flight, out_dir, options)
    })
}

/// Simulates part `k` of `n` of the flight into `out_dir` (its points,
/// part.json, survey.toml) and returns its record as a dict.
pub fn run_part<'py>(
    py: Python<'py>,
    flight: &Flight,
    out_dir: &Path,
    (k, n): (usize, usize),
    threads: usize,
    overwrite: bool,
) -> PyResult<Bound<'py, PyAny>> {
    check_threads(threads)?;
    if n == 0 || !(1..=n).contains(&k) {
        return Err(PyValueError::new_err(format!(
            "part {k}/{n}: K must be from 1 to N, and N at least 1"
        )));
    }
    let o = DirOptions {
        overwrite,
        ..DirOptions::default()
    };
    watched(py, (threads, None, 0), &o, |options| {
        lidarsim::run::part::run_part(flight, (k, n), out_dir, options)
    })
}
