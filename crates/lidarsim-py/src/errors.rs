//! The library's errors as Python exceptions, one class per kind: a survey
//! with problems is a `SurveyError` (a `ValueError` with the problems as
//! dicts in `diagnostics`); a file that cannot be read, written, joined or
//! continued is an `OSError` of its kind — `InputError`, `OutputError`,
//! `PartError`, `ResumeError`, `BudgetError` — whose message names the
//! file and whose `path` attribute holds it.

use lidarsim::Error;
use lidarsim::output::{WriteCause, WriteError};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

pyo3::create_exception!(
    _lidarsim,
    SurveyError,
    PyValueError,
    "A survey with problems: `str(e)` lists every one with its key, \
     `e.diagnostics` holds them as dicts (file, line, column, key, message, help)."
);

pyo3::create_exception!(
    _lidarsim,
    InputError,
    PyOSError,
    "A file a run reads cannot be read, or is one the run would write over \
     or remove: `e.path` is the file."
);

pyo3::create_exception!(
    _lidarsim,
    OutputError,
    PyOSError,
    "An output file could not be written, or the output directory is not one \
     a run may write into: `e.path` is the file or directory."
);

pyo3::create_exception!(
    _lidarsim,
    PartError,
    PyOSError,
    "A part given to a merge does not make one run with the others, or a part \
     number is out of range: `e.path` is the part's file or directory."
);

pyo3::create_exception!(
    _lidarsim,
    ResumeError,
    PyOSError,
    "The interrupted run in a directory cannot be resumed: `e.path` is the \
     file that says why."
);

pyo3::create_exception!(
    _lidarsim,
    BudgetError,
    PyOSError,
    "A run whose output or memory would not fit the machine, refused before \
     it starts (pass no_space_check=True to run anyway): `e.path` is the \
     output directory."
);

/// Adds the exception classes to the module.
pub fn add_classes(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SurveyError", py.get_type::<SurveyError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    m.add("PartError", py.get_type::<PartError>())?;
    m.add("ResumeError", py.get_type::<ResumeError>())?;
    m.add("BudgetError", py.get_type::<BudgetError>())?;
    Ok(())
}

/// The library's survey error as `SurveyError`: the message lists every
/// problem; `diagnostics` holds them as dicts. `keys_only` leaves out the
/// file, line and source text (for surveys given as dicts).
pub fn survey_error(py: Python<'_>, e: &lidarsim::survey::SurveyError, keys_only: bool) -> PyErr {
    let message = if keys_only {
        e.diagnostics
            .iter()
            .map(|d| match &d.help {
                Some(h) => format!("key `{}`: {} (help: {h})", d.key, d.message),
                None => format!("key `{}`: {}", d.key, d.message),
            })
            .collect::<Vec<_>>()
            .join("\n")
    } else {
        e.to_string()
    };
    let err = SurveyError::new_err(message);
    let list = PyList::empty(py);
    for d in &e.diagnostics {
        let item = PyDict::new(py);
        let _ = item.set_item("file", (!keys_only).then_some(&d.file));
        let _ = item.set_item("line", (!keys_only && d.line > 0).then_some(d.line));
        let _ = item.set_item("column", (!keys_only && d.column > 0).then_some(d.column));
        let _ = item.set_item("key", &d.key);
        let _ = item.set_item("message", &d.message);
        let _ = item.set_item("help", d.help.as_deref());
        let _ = list.append(item);
    }
    let _ = err.value(py).setattr("diagnostics", list);
    err
}

/// The library's error as the exception of its kind (`keys_only`: the
/// survey was given as a dict, see [`survey_error`]).
pub fn to_py(py: Python<'_>, e: &Error, keys_only: bool) -> PyErr {
    let message = e.to_string();
    let err = match e {
        Error::Survey(s) => return survey_error(py, s, keys_only),
        Error::Input(_) => InputError::new_err(message),
        Error::Part(_) => PartError::new_err(message),
        Error::Resume(_) => ResumeError::new_err(message),
        Error::Budget(_) => BudgetError::new_err(message),
        // Output, Directory and kinds added later.
        _ => OutputError::new_err(message),
    };
    set_path(py, &err, e.path());
    err
}

/// An output file's error as `OutputError` with its `path` (takes the
/// interpreter's lock for the attribute, so it may be called without it).
pub fn write_error(e: &WriteError) -> PyErr {
    Python::attach(|py| {
        let err = OutputError::new_err(e.to_string());
        set_path(py, &err, Some(&e.path));
        err
    })
}

/// A point that cannot be stored with the survey's LAS scale and offset,
/// as `OutputError` (the points are the LAS file's, even in memory).
pub fn point_error(cause: &WriteCause) -> PyErr {
    OutputError::new_err(cause.to_string())
}

/// Sets `path` of an exception to the file, as a string. (Not
/// `OSError`'s `filename`, which would make the message "[Errno None]
/// None: path" instead of the library's.)
fn set_path(py: Python<'_>, err: &PyErr, path: Option<&std::path::Path>) {
    let path = path.map(|p| p.display().to_string());
    let _ = err.value(py).setattr("path", path.as_deref());
}
