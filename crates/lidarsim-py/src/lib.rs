//! `lidarsim._lidarsim`, the compiled half of the `lidarsim` Python
//! package: surveys checked by the library, runs with the GIL released and
//! Ctrl-C honoured between blocks, points packed into the bytes of a NumPy
//! structured array. The pure-Python half (`python/lidarsim`) wraps it in
//! the documented API.

mod convert;
mod errors;
mod hold;
mod part_merge;
mod points;
mod real;
mod run;
mod scene_data;
mod stream;
mod survey;
mod waveform;

use pyo3::exceptions::PyImportError;
use pyo3::prelude::*;

/// Merges the parts of a split run (directories of `run_part`) into
/// `out_dir`: the files of the unsplit run; returns its summary. With
/// `take_parts` the parts are taken (moved from, then removed); `survey`:
/// the parts' survey, whose world the merge uses if it is built.
#[pyfunction]
#[pyo3(signature = (part_dirs, out_dir, threads, overwrite=false, take_parts=false, survey=None))]
fn merge<'py>(
    py: Python<'py>,
    part_dirs: Vec<std::path::PathBuf>,
    out_dir: std::path::PathBuf,
    threads: usize,
    overwrite: bool,
    take_parts: bool,
    survey: Option<PyRef<'py, survey::SurveyCore>>,
) -> PyResult<Bound<'py, PyAny>> {
    part_merge::merge(
        py,
        part_dirs,
        &out_dir,
        threads,
        (overwrite, take_parts),
        survey.as_deref(),
    )
}

/// The module: refuses to load on a processor without the instructions the
/// build targets, as the command line does.
#[pymodule]
fn _lidarsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    if let Some(feature) = lidarsim::kernels::cpu::missing() {
        return Err(PyImportError::new_err(format!(
            "this build of lidarsim needs a processor with {feature} (x86-64-v3); rebuild it \
             for this one with RUSTFLAGS=\"-C target-cpu=native\" pip install \
             ./crates/lidarsim-py"
        )));
    }
    errors::add_classes(m)?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    m.add("POINT_FIELDS", points::FIELDS.to_vec())?;
    m.add("POINT_RECORD_BYTES", points::RECORD_BYTES)?;
    m.add("TRAJECTORY_FIELDS", points::TRAJECTORY_FIELDS.to_vec())?;
    m.add_class::<survey::SurveyCore>()?;
    m.add_class::<stream::PointStream>()?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add_class::<part_merge::PartMerge>()?;
    m.add_function(wrap_pyfunction!(real::twin, m)?)?;
    m.add_function(wrap_pyfunction!(real::compare, m)?)?;
    Ok(())
}
