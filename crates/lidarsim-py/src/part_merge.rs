//! Merges of a split run's parts from Python: of part directories given
//! at once ([`merge`]), and as the parts arrive ([`PartMerge`], the one
//! `lidarsim.distributed.run` makes while its parts run).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use lidarsim::Flight;
use lidarsim::run::merge::{Merge, Parts, merge_over};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::errors::to_py;
use crate::run::{DirOptions, check_threads, watched};
use crate::survey::SurveyCore;

/// `take_parts` as the library's [`Parts`].
fn taken(take_parts: bool) -> Parts {
    if take_parts { Parts::Take } else { Parts::Keep }
}

/// The flight of `core`, if its world is built already.
fn built(core: Option<&SurveyCore>) -> Option<Arc<Flight>> {
    core.and_then(SurveyCore::built_flight)
}

/// Merges the parts in `part_dirs` into `out_dir` and returns the summary;
/// `take_parts`: [`Parts::Take`]; `survey`: a survey whose world, if built
/// already, the merge uses when it is the parts' ([`merge_over`]).
pub fn merge<'py>(
    py: Python<'py>,
    part_dirs: Vec<PathBuf>,
    out_dir: &Path,
    threads: usize,
    (overwrite, take_parts): (bool, bool),
    survey: Option<&SurveyCore>,
) -> PyResult<Bound<'py, PyAny>> {
    check_threads(threads)?;
    let o = DirOptions {
        overwrite,
        ..DirOptions::default()
    };
    let built = built(survey);
    watched(py, (threads, None, 0), &o, |options| {
        merge_over(
            &part_dirs,
            out_dir,
            options,
            taken(take_parts),
            built.as_deref(),
        )
    })
}

/// A merge made as the parts of a split run arrive ([`Merge`]): `add`
/// each part's directory once it is done, then `finish`.
#[pyclass(module = "lidarsim._lidarsim", frozen)]
pub struct PartMerge {
    merge: Mutex<Option<Merge>>,
}

#[pymethods]
impl PartMerge {
    /// Begins a merge into `out_dir`, claimed as a run claims its output.
    #[new]
    #[pyo3(signature = (out_dir, overwrite=false, take_parts=false))]
    fn new(py: Python<'_>, out_dir: PathBuf, overwrite: bool, take_parts: bool) -> PyResult<Self> {
        let merge = py
            .detach(|| Merge::begin(&out_dir, overwrite, taken(take_parts)))
            .map_err(|e| to_py(py, &e, false))?;
        Ok(Self {
            merge: Mutex::new(Some(merge)),
        })
    }

    /// Adds the part in `part_dir` (checked against the parts before it)
    /// and joins what can be joined of the parts so far.
    fn add(&self, py: Python<'_>, part_dir: PathBuf) -> PyResult<()> {
        // The lock is taken and given back with the GIL released: a thread
        // that waits for it holding the GIL would keep this one from
        // returning.
        py.detach(|| {
            let mut guard = self.merge.lock().unwrap_or_else(|e| e.into_inner());
            let merge = guard.as_mut().ok_or(Added::Finished)?;
            merge.add(&part_dir).map_err(Added::Refused)
        })
        .map_err(|e| match e {
            Added::Finished => finished(),
            Added::Refused(e) => to_py(py, &e, false),
        })
    }

    /// Finishes the merge on `threads` threads, over the world of `survey`
    /// if it is built and is the parts' survey, and returns the summary.
    #[pyo3(signature = (threads, survey=None))]
    fn finish<'py>(
        &self,
        py: Python<'py>,
        threads: usize,
        survey: Option<PyRef<'py, SurveyCore>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        check_threads(threads)?;
        let merge = py
            .detach(|| self.merge.lock().unwrap_or_else(|e| e.into_inner()).take())
            .ok_or_else(finished)?;
        let built = built(survey.as_deref());
        watched(py, (threads, None, 0), &DirOptions::default(), |options| {
            merge.finish(options, built.as_deref())
        })
    }
}

/// Why a part was not added.
enum Added {
    /// The merge is finished.
    Finished,
    /// The merge refused it.
    Refused(lidarsim::Error),
}

/// The error of a merge used after `finish`.
fn finished() -> PyErr {
    PyValueError::new_err("this merge is finished: begin another")
}
