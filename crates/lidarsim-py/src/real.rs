//! Real scans from Python: the twin of a scan file (`lidarsim twin`) and
//! the comparison of two clouds (`lidarsim compare`), each cloud a file or
//! columns of NumPy arrays (a simulation's points), with the GIL released
//! while they are made.

use std::path::PathBuf;

use lidarsim::compare::{CompareOptions, compare as compare_clouds, table, write_comparison};
use lidarsim::scan::{ScanCloud, ScanFacts, read_scan};
use lidarsim::scene::Species;
use lidarsim::twin::acquisition::AcquisitionSettings;
use lidarsim::twin::trees::{TreeSettings, Window};
use lidarsim::twin::{TwinError, TwinOptions, twin as make_twin, write::write_twin};
use numpy::PyReadonlyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::json_to_py;
use crate::errors::{InputError, write_error};

/// A twin error as the Python exception of its kind: the scan that
/// cannot be read an `InputError`, a file that cannot be written an
/// `OutputError` (both `OSError`s), everything else (options, a scan that
/// cannot be twinned) a `ValueError`.
fn twin_error(e: TwinError) -> PyErr {
    match e {
        TwinError::Scan(_) => InputError::new_err(e.to_string()),
        TwinError::Write(w) => write_error(&w),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Makes the twin of the scan at `path` in `out_dir`; returns `survey`
/// (the path of its survey.toml), `summary` (lines of text) and `report`
/// (twin.json as a dict).
#[pyfunction]
#[pyo3(signature = (path, out_dir, overwrite=false, species="pine", instrument=None,
                    acquisition=None, window=None, chm_cell_m=None))]
#[allow(clippy::too_many_arguments)]
pub fn twin<'py>(
    py: Python<'py>,
    path: PathBuf,
    out_dir: PathBuf,
    overwrite: bool,
    species: &str,
    instrument: Option<String>,
    acquisition: Option<&Bound<'py, PyDict>>,
    window: Option<(f64, f64, f64)>,
    chm_cell_m: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let species = Species::from_name(species).ok_or_else(|| {
        PyValueError::new_err(format!(
            "species '{species}': expected pine, spruce or birch"
        ))
    })?;
    let get = |key: &str| -> PyResult<Option<f64>> {
        match acquisition {
            None => Ok(None),
            Some(d) => d.get_item(key)?.map(|v| v.extract::<f64>()).transpose(),
        }
    };
    let options = TwinOptions {
        trees: TreeSettings {
            window: window.map_or(Window::LIDR_BOOK, |(a_m, b, c_per_m)| Window {
                a_m,
                b,
                c_per_m,
            }),
            species,
            chm_cell_m,
            ..TreeSettings::default()
        },
        acquisition: AcquisitionSettings {
            altitude_m: get("altitude_m")?,
            speed_mps: get("speed_mps")?,
            prf_hz: get("prf_hz")?,
            scan_frequency_hz: get("scan_frequency_hz")?,
            scan_angle_deg: get("scan_angle_deg")?,
            heading_deg: get("heading_deg")?,
            line_spacing_m: get("line_spacing_m")?,
        },
        instrument,
    };
    let made = py.detach(|| {
        let cloud = read_scan(&path, &lidarsim::scan::no_progress)?;
        let twin = make_twin(&cloud, &options, &lidarsim::scan::no_progress)?;
        let survey = write_twin(&twin, &out_dir, overwrite)?;
        Ok::<_, TwinError>((survey, twin.summary_lines()))
    });
    let (survey, summary) = made.map_err(twin_error)?;
    let report = std::fs::read_to_string(out_dir.join("twin.json")).map_err(|e| {
        InputError::new_err(format!("{}: {e}", out_dir.join("twin.json").display()))
    })?;
    let out = PyDict::new(py);
    out.set_item("survey", survey)?;
    out.set_item("summary", PyList::new(py, summary)?)?;
    out.set_item("report", json_to_py(py, &report)?)?;
    Ok(out.into_any())
}

/// A cloud argument: a path, or a dict of columns (`x`, `y`, `z`,
/// `intensity`, `return_number`, `number_of_returns`, `classification`,
/// `gps_time`, `scan_angle_deg`, `point_source_id`, and `name`).
fn cloud_of(arg: &Bound<'_, PyAny>) -> PyResult<Result<ScanCloud, PathBuf>> {
    let Ok(d) = arg.cast::<PyDict>() else {
        return Ok(Err(arg.extract::<PathBuf>()?));
    };
    fn column<'py, T: numpy::Element + Copy>(
        d: &Bound<'py, PyDict>,
        key: &str,
    ) -> PyResult<Vec<T>> {
        let v = d
            .get_item(key)?
            .ok_or_else(|| PyValueError::new_err(format!("the cloud has no column `{key}`")))?;
        let a: PyReadonlyArray1<'_, T> = v.extract().map_err(|_| {
            PyValueError::new_err(format!(
                "column `{key}`: a 1-D array of the right type is needed"
            ))
        })?;
        Ok(a.as_array().to_vec())
    }
    let cloud = ScanCloud {
        name: d
            .get_item("name")?
            .map(|n| n.extract::<String>())
            .transpose()?
            .unwrap_or_else(|| "points".into()),
        x: column(d, "x")?,
        y: column(d, "y")?,
        z: column(d, "z")?,
        intensity: column(d, "intensity")?,
        return_number: column(d, "return_number")?,
        number_of_returns: column(d, "number_of_returns")?,
        classification: column(d, "classification")?,
        gps_time: column(d, "gps_time")?,
        scan_angle_deg: column(d, "scan_angle_deg")?,
        point_source_id: column(d, "point_source_id")?,
        facts: ScanFacts {
            version: "1.4".into(),
            point_format: 6,
            has_gps_time: true,
            scan_angle_step_deg: 0.006,
            epsg: None,
            wkt: None,
        },
    };
    let n = cloud.x.len();
    let lengths = [
        cloud.y.len(),
        cloud.z.len(),
        cloud.intensity.len(),
        cloud.return_number.len(),
        cloud.number_of_returns.len(),
        cloud.classification.len(),
        cloud.gps_time.len(),
        cloud.scan_angle_deg.len(),
        cloud.point_source_id.len(),
    ];
    if lengths.iter().any(|&l| l != n) || n == 0 {
        return Err(PyValueError::new_err(format!(
            "the cloud `{}`'s columns must have one value per point ({n} points)",
            cloud.name
        )));
    }
    Ok(Ok(cloud))
}

/// Compares clouds `a` and `b` (paths or column dicts); returns
/// compare.json as a dict with `table` (the text table) added, and writes
/// compare.json and compare.html into `out_dir` when given.
#[pyfunction]
#[pyo3(signature = (a, b, out_dir=None, overwrite=false, cell_m=20.0, area=None,
                    match_density=false, seed=1, labels=("A".to_string(), "B".to_string())))]
#[allow(clippy::too_many_arguments)]
pub fn compare<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    out_dir: Option<PathBuf>,
    overwrite: bool,
    cell_m: f64,
    area: Option<(f64, f64, f64, f64)>,
    match_density: bool,
    seed: u64,
    labels: (String, String),
) -> PyResult<Bound<'py, PyAny>> {
    let (a, b) = (cloud_of(a)?, cloud_of(b)?);
    let options = CompareOptions {
        area: area.map(|(x0, y0, x1, y1)| [x0, y0, x1, y1]),
        cell_m,
        match_density,
        seed,
        labels: [labels.0, labels.1],
    };
    let done = py.detach(|| {
        let read = |c: Result<ScanCloud, PathBuf>| match c {
            Ok(c) => Ok(c),
            Err(p) => read_scan(&p, &lidarsim::scan::no_progress)
                .map_err(|e| InputError::new_err(e.to_string())),
        };
        let (a, b) = (read(a)?, read(b)?);
        let c =
            compare_clouds(&a, &b, &options).map_err(|e| PyValueError::new_err(e.to_string()))?;
        if let Some(dir) = &out_dir {
            write_comparison(&c, dir, overwrite).map_err(|e| write_error(&e))?;
        }
        let json = serde_json::to_string(&c).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok::<_, PyErr>((json, table::text(&c)))
    });
    let (json, text) = done?;
    let out = json_to_py(py, &json)?;
    out.set_item("table", text)?;
    Ok(out)
}
