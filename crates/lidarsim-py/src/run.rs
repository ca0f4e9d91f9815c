//! Runs from Python: the simulation with the GIL released, Ctrl-C and the
//! progress callback served between blocks of pulses on the calling thread
//! (the thread that hands blocks to the sinks), points packed for NumPy.

use std::io;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use lidarsim::output::PointSink;
use lidarsim::run::{RunOptions, run_world_to_dir};
use lidarsim::sim::{RunControl, Simulator};
use lidarsim::summary::{Measured, Summary};
use numpy::PyArray1;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::json_to_py;
use crate::points::{PackSink, pack_trajectory};
use crate::survey::SurveyCore;

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
        }
    }

    fn fail(&self, e: PyErr) {
        self.error.lock().expect("error lock").get_or_insert(e);
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Called with the pulses simulated so far, after blocks were handed
    /// over, on the thread that called the run.
    fn tick(&self, done: u64) {
        if self.stop.load(Ordering::SeqCst) || (!self.main_thread && self.progress.is_none()) {
            return;
        }
        {
            let mut last = self.last_look.lock().expect("look lock");
            if last.is_some_and(|t| t.elapsed() < LOOK_EVERY) && done < self.total {
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
            if last.is_some_and(|t| t.elapsed() < PROGRESS_EVERY) && done < self.total {
                return;
            }
            *last = Some(Instant::now());
            if let Err(e) = callback.call1(py, (done, self.total)) {
                self.fail(e);
            }
        });
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

/// A message of the library in Python's words: the command line's flags
/// named as the keyword arguments that set them (issue 49: a run into a
/// non-empty folder said "pass --overwrite" to a Python user).
pub(crate) fn in_python_words(message: &str) -> String {
    message
        .replace("--overwrite (overwrite=True in Python)", "overwrite=True")
        .replace("--no-space-check (no_space_check)", "no_space_check=True")
        .replace("--overwrite", "overwrite=True")
        .replace("--no-space-check", "no_space_check=True")
}

/// An `OSError` with the library's message in Python's words.
pub(crate) fn os_error(e: impl std::fmt::Display) -> PyErr {
    PyOSError::new_err(in_python_words(&e.to_string()))
}

fn bytes_array(py: Python<'_>, bytes: Vec<u8>) -> Bound<'_, PyArray1<u8>> {
    PyArray1::from_vec(py, bytes)
}

/// Simulates the whole survey into memory. Returns a dict: `points` and
/// `trajectory_true` / `trajectory_observed` as `uint8` arrays of packed
/// records, `summary` (as in `summary.json`) and `las` (the LAS file's
/// scale, offset, CRS and extra-byte groups).
pub fn run<'py>(
    py: Python<'py>,
    core: &SurveyCore,
    threads: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    check_threads(threads)?;
    let world = core.world(py)?;
    let survey = &*core.survey;
    let total = world.lines.iter().map(|l| survey.pulses_of(l)).sum();
    let watch = Watch::new(progress, total);
    let settings = lidarsim::files::las_settings(survey, &world);
    let result = py.detach(|| {
        let sim = Simulator::new(survey, &world);
        let mut sink = PackSink {
            settings: settings.clone(),
            bytes: Vec::new(),
        };
        let started = Instant::now();
        let control = RunControl {
            start: Default::default(),
            stop: Some(&watch.stop),
            pulse_budget: None,
            only: None,
        };
        let outcome = {
            let mut sinks: [&mut (dyn PointSink + 'static); 1] = [&mut sink];
            sim.run_from(threads, &mut sinks, &|n| watch.tick(n), &control)?
        };
        Ok::<_, io::Error>((sink.bytes, outcome, started.elapsed().as_secs_f64()))
    });
    if let Some(e) = watch.take_error() {
        return Err(e);
    }
    let (bytes, outcome, wall_time_s) = result.map_err(os_error)?;
    let plan = lidarsim::plan::plan(survey, &world);
    let warnings = lidarsim::plan::warnings(survey, &world, &plan);
    let measured = Measured {
        counts: outcome.counts,
        threads,
        wall_time_s,
        index_time_s: world.index_time_s,
        scene_primitives: world.scene().primitives.len(),
        estimate: lidarsim::budget::estimate(survey, &world, threads),
    };
    let summary = Summary::of(survey, &world, plan, &measured, Vec::new(), &warnings);
    let out = PyDict::new(py);
    out.set_item("points", bytes_array(py, bytes))?;
    for (name, observed) in [("trajectory_true", false), ("trajectory_observed", true)] {
        let rows = lidarsim::files::trajectory_rows(survey, &world.lines, observed);
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
/// of the watch (Ctrl-C, the callback's) comes first; the job's is an
/// `OSError`. Callers check `threads` before loading the world.
pub(crate) fn watched<'py, T, E>(
    py: Python<'py>,
    (threads, progress, total): (usize, Option<Py<PyAny>>, u64),
    o: &DirOptions,
    job: impl FnOnce(&RunOptions) -> Result<T, E> + Send,
) -> PyResult<Bound<'py, PyAny>>
where
    T: serde::Serialize + Send,
    E: std::fmt::Display + Send,
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
    let value = result.map_err(os_error)?;
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
    core: &SurveyCore,
    out_dir: &Path,
    threads: usize,
    progress: Option<Py<PyAny>>,
    o: DirOptions,
) -> PyResult<Bound<'py, PyAny>> {
    check_threads(threads)?;
    let world = core.world(py)?;
    let survey = &*core.survey;
    let total = world.lines.iter().map(|l| survey.pulses_of(l)).sum();
    watched(py, (threads, progress, total), &o, |options| {
        run_world_to_dir(survey, &world, out_dir, options)
    })
}

/// Simulates part `k` of `n` of the survey into `out_dir` (its points,
/// part.json, survey.toml) and returns its record as a dict.
pub fn run_part<'py>(
    py: Python<'py>,
    core: &SurveyCore,
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
    let world = core.world(py)?;
    let survey = &*core.survey;
    let o = DirOptions {
        overwrite,
        ..DirOptions::default()
    };
    watched(py, (threads, None, 0), &o, |options| {
        lidarsim::run::part::run_part(survey, &world, (k, n), out_dir, options)
    })
}
