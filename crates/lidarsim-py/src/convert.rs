//! Python values to TOML and back, so that a survey given as a dict is
//! checked by the same code, with the same messages, as a survey file.

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// `obj` (dicts, lists, tuples, str, bool, int, float, NumPy arrays and
/// scalars) as a TOML value; `at` names where it is, for errors. `None`
/// in a dict leaves the key out.
pub fn to_toml(obj: &Bound<'_, PyAny>, at: &str) -> PyResult<Option<toml::Value>> {
    if obj.is_none() {
        return Ok(None);
    }
    // NumPy arrays and scalars: their plain Python form.
    if obj.hasattr("tolist")? && !obj.is_instance_of::<PyList>() {
        let plain = obj.call_method0("tolist")?;
        if !plain.is(obj) {
            return to_toml(&plain, at);
        }
    }
    if obj.is_instance_of::<PyBool>() {
        return Ok(Some(toml::Value::Boolean(obj.extract()?)));
    }
    if obj.is_instance_of::<PyInt>() {
        return match obj.extract::<i64>() {
            Ok(v) => Ok(Some(toml::Value::Integer(v))),
            Err(_) => Err(PyValueError::new_err(format!(
                "key `{at}`: {obj} does not fit in a 64-bit integer"
            ))),
        };
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(Some(toml::Value::Float(obj.extract()?)));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(Some(toml::Value::String(obj.extract()?)));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!("key `{at}`: table keys must be strings, got {k}"))
            })?;
            let path = if at.is_empty() {
                key.clone()
            } else {
                format!("{at}.{key}")
            };
            if let Some(value) = to_toml(&v, &path)? {
                table.insert(key, value);
            }
        }
        return Ok(Some(toml::Value::Table(table)));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, v) in obj.try_iter()?.enumerate() {
            let v = v?;
            match to_toml(&v, &format!("{at}[{i}]"))? {
                Some(value) => items.push(value),
                None => {
                    return Err(PyValueError::new_err(format!(
                        "key `{at}[{i}]`: None is not a value (a list cannot have holes)"
                    )));
                }
            }
        }
        return Ok(Some(toml::Value::Array(items)));
    }
    Err(PyTypeError::new_err(format!(
        "key `{at}`: {} is not a survey value (use dict, list, str, bool, int or float)",
        obj.get_type().name()?
    )))
}

/// A TOML value as plain Python objects.
pub fn from_toml<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(a) => {
            let list = PyList::empty(py);
            for item in a {
                list.append(from_toml(py, item)?)?;
            }
            list.into_any()
        }
        toml::Value::Table(t) => {
            let dict = PyDict::new(py);
            for (k, item) in t {
                dict.set_item(k, from_toml(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

/// A JSON text (a summary) as Python objects, through the standard
/// library's reader.
pub fn json_to_py<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}
