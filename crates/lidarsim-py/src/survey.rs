//! `SurveyCore`: a checked survey and, once built, its flight (the world
//! and what follows from it).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use lidarsim::{Flight, Survey};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{from_toml, to_toml};
use crate::errors::survey_error;

/// A checked survey (the `lidarsim.Survey` wrapper holds one).
#[pyclass(module = "lidarsim._lidarsim", frozen)]
pub struct SurveyCore {
    pub(crate) survey: Arc<Survey>,
    flight: Mutex<Option<Arc<Flight>>>,
    /// Whether its text was made from a dict (its lines then mean nothing
    /// to the user, and errors show keys only).
    from_dict: bool,
}

impl SurveyCore {
    fn new(survey: Survey, from_dict: bool) -> Self {
        Self {
            survey: Arc::new(survey),
            flight: Mutex::new(None),
            from_dict,
        }
    }

    /// A core for `survey`, derived from this one's (same kind of
    /// messages).
    pub(crate) fn derived(&self, survey: Survey) -> Self {
        Self::new(survey, self.from_dict)
    }

    /// The survey's flight, its world built (with the GIL released) on
    /// first use.
    pub(crate) fn flight(&self, py: Python<'_>) -> PyResult<Arc<Flight>> {
        if let Some(f) = self.flight.lock().expect("flight lock").as_ref() {
            return Ok(Arc::clone(f));
        }
        let survey = Arc::clone(&self.survey);
        let built = py.detach(move || Flight::build(survey));
        let flight = Arc::new(built.map_err(|e| survey_error(py, &e, self.from_dict))?);
        *self.flight.lock().expect("flight lock") = Some(Arc::clone(&flight));
        Ok(flight)
    }

    /// The survey's flight if its world is built already.
    pub(crate) fn built_flight(&self) -> Option<Arc<Flight>> {
        self.flight.lock().expect("flight lock").clone()
    }

    fn from_text(
        py: Python<'_>,
        text: &str,
        path: &Path,
        seed: Option<u64>,
        from_dict: bool,
    ) -> PyResult<Self> {
        Survey::from_toml_with_seed(text, Some(path), seed)
            .map(|s| Self::new(s, from_dict))
            .map_err(|e| survey_error(py, &e, from_dict))
    }
}

/// Where relative file names of a survey given as text or a dict are
/// found: `base_dir`, else the working directory; `name` stands for the
/// file in messages.
fn pseudo_path(base_dir: Option<PathBuf>, name: &str) -> PathBuf {
    base_dir.unwrap_or_default().join(name)
}

#[pymethods]
impl SurveyCore {
    /// Reads and checks the survey file at `path`; `seed` replaces its
    /// seed before anything is drawn.
    #[staticmethod]
    #[pyo3(signature = (path, seed=None))]
    fn load(py: Python<'_>, path: PathBuf, seed: Option<u64>) -> PyResult<Self> {
        Survey::load_with_seed(&path, seed)
            .map(|s| Self::new(s, false))
            .map_err(|e| survey_error(py, &e, false))
    }

    /// Checks a survey given as TOML text.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir=None, seed=None))]
    fn from_toml(
        py: Python<'_>,
        text: &str,
        base_dir: Option<PathBuf>,
        seed: Option<u64>,
    ) -> PyResult<Self> {
        Self::from_text(py, text, &pseudo_path(base_dir, "<string>"), seed, false)
    }

    /// Checks a survey given as a dict with the survey file's keys.
    #[staticmethod]
    #[pyo3(signature = (d, base_dir=None, seed=None))]
    fn from_dict(
        py: Python<'_>,
        d: &Bound<'_, PyDict>,
        base_dir: Option<PathBuf>,
        seed: Option<u64>,
    ) -> PyResult<Self> {
        let value = to_toml(d.as_any(), "")?.unwrap_or(toml::Value::Table(Default::default()));
        let text = toml::to_string(&value).map_err(|e| {
            pyo3::exceptions::PyValueError::new_err(format!("cannot write the survey: {e}"))
        })?;
        Self::from_text(py, &text, &pseudo_path(base_dir, "<dict>"), seed, true)
    }

    /// The built-in demo survey (a town with streets, buildings and trees).
    #[staticmethod]
    #[pyo3(signature = (seed=None))]
    fn demo(py: Python<'_>, seed: Option<u64>) -> PyResult<Self> {
        let mut raw = lidarsim::demo::demo_survey();
        if seed.is_some() {
            raw.seed = seed;
        }
        let text = toml::to_string(&raw).expect("the demo survey serialises");
        Self::from_text(py, &text, Path::new("<demo>"), None, false)
    }

    /// The survey as a dict of survey-file keys: seed fixed, file paths
    /// absolute (what `survey.toml` of a run holds).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let raw = lidarsim::files::replayable(&self.survey);
        let value = toml::Value::try_from(&raw).map_err(|e| {
            pyo3::exceptions::PyValueError::new_err(format!("cannot read the survey: {e}"))
        })?;
        from_toml(py, &value)
    }

    /// The survey as TOML text (`to_dict` written out).
    fn to_toml(&self) -> PyResult<String> {
        toml::to_string(&lidarsim::files::replayable(&self.survey)).map_err(|e| {
            pyo3::exceptions::PyValueError::new_err(format!("cannot write the survey: {e}"))
        })
    }

    /// The seed of every random stream.
    #[getter]
    fn seed(&self) -> u64 {
        self.survey.seed
    }

    /// Warnings about the settings (each names its key), and, once the
    /// world is built, about the settings over the scene.
    fn warnings(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        Ok(self.flight(py)?.warnings().to_vec())
    }

    /// Builds the scene and index now (otherwise the first run does).
    fn build(&self, py: Python<'_>) -> PyResult<()> {
        self.flight(py).map(|_| ())
    }

    /// The run: see `run.rs`.
    #[pyo3(signature = (threads, progress=None))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        threads: usize,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        crate::run::run(py, &*self.flight(py)?, threads, progress)
    }

    /// A new survey with a mesh from arrays: see `scene_data.rs`.
    #[pyo3(signature = (vertices, faces, material, class_name, offset_m, scale, rotation_z_deg))]
    #[allow(clippy::too_many_arguments)]
    fn with_mesh(
        &self,
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        material: &str,
        class_name: &str,
        offset_m: [f64; 3],
        scale: f64,
        rotation_z_deg: f64,
    ) -> PyResult<SurveyCore> {
        self.mesh_from_arrays(
            py,
            vertices,
            faces,
            material,
            class_name,
            offset_m,
            scale,
            rotation_z_deg,
        )
    }

    /// A new survey with a terrain from a height array: see
    /// `scene_data.rs`.
    #[pyo3(signature = (heights, transform, material, class_name, nodata))]
    fn with_terrain(
        &self,
        py: Python<'_>,
        heights: PyReadonlyArray2<'_, f64>,
        transform: [f64; 6],
        material: &str,
        class_name: &str,
        nodata: Option<f64>,
    ) -> PyResult<SurveyCore> {
        self.terrain_from_array(py, heights, transform, material, class_name, nodata)
    }

    /// A new survey with a point cloud from arrays: see `scene_data.rs`.
    #[pyo3(signature = (points, voxel_m, material, class_name, classes))]
    fn with_point_cloud(
        &self,
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        voxel_m: f64,
        material: &str,
        class_name: Option<&str>,
        classes: Option<PyReadonlyArray1<'_, u8>>,
    ) -> PyResult<SurveyCore> {
        self.cloud_from_arrays(py, points, voxel_m, material, class_name, classes)
    }

    /// Part `k` of `n` into a directory: see `run.rs`.
    #[pyo3(signature = (out_dir, k, n, threads, overwrite=false))]
    fn run_part<'py>(
        &self,
        py: Python<'py>,
        out_dir: PathBuf,
        k: usize,
        n: usize,
        threads: usize,
        overwrite: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        crate::run::check_threads(threads)?;
        let flight = self.flight(py)?;
        crate::run::run_part(py, &flight, &out_dir, (k, n), threads, overwrite)
    }

    /// A streamed run: see `stream.rs`.
    #[pyo3(signature = (threads, min_points))]
    fn stream(
        &self,
        py: Python<'_>,
        threads: usize,
        min_points: usize,
    ) -> PyResult<crate::stream::PointStream> {
        crate::run::check_threads(threads)?;
        let flight = self.flight(py)?;
        Ok(crate::stream::PointStream::start(
            flight, threads, min_points,
        ))
    }

    /// One pulse's waveform: see `waveform.rs`.
    fn waveform<'py>(
        &self,
        py: Python<'py>,
        line: usize,
        pulse: u64,
    ) -> PyResult<Bound<'py, PyAny>> {
        crate::waveform::waveform(py, &*self.flight(py)?, line, pulse)
    }

    /// A run into a directory: see `run.rs`.
    #[pyo3(signature = (out_dir, threads, progress=None, overwrite=false, resume=false, no_space_check=false))]
    #[allow(clippy::too_many_arguments)]
    fn run_to<'py>(
        &self,
        py: Python<'py>,
        out_dir: PathBuf,
        threads: usize,
        progress: Option<Py<PyAny>>,
        overwrite: bool,
        resume: bool,
        no_space_check: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        crate::run::check_threads(threads)?;
        let flight = self.flight(py)?;
        crate::run::run_to(
            py,
            &flight,
            &out_dir,
            threads,
            progress,
            crate::run::DirOptions {
                overwrite,
                resume,
                no_space_check,
            },
        )
    }
}
