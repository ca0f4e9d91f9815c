//! Scene entries from NumPy arrays: a new survey with a mesh, a height
//! grid or a point cloud added as the next entry of its table
//! (`lidarsim::survey::data`), built exactly as the same geometry read
//! from a file.

use lidarsim::geometry::DVec3;
use lidarsim::scene::{MeshPlacement, SurfaceClass};
use lidarsim::survey::data::DataError;
use lidarsim::survey::spec::{MeshData, PointData};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::errors::SurveyError;
use crate::survey::SurveyCore;

/// `SurveyError` for `table[index]`'s argument at fault.
fn data_error(py: Python<'_>, table: &str, e: &DataError) -> PyErr {
    let key = format!("{table}.{}", e.what);
    let message = format!("key `{key}`: {}", e.reason);
    let err = SurveyError::new_err(message);
    let item = PyDict::new(py);
    let _ = item.set_item("file", py.None());
    let _ = item.set_item("line", py.None());
    let _ = item.set_item("column", py.None());
    let _ = item.set_item("key", &key);
    let _ = item.set_item("message", &e.reason);
    let _ = item.set_item("help", py.None());
    if let Ok(list) = PyList::new(py, [item]) {
        let _ = err.value(py).setattr("diagnostics", list);
    }
    err
}

/// `SurveyError` for an argument that is not what it must be.
fn refuse(py: Python<'_>, table: &str, what: &str, reason: String) -> PyErr {
    data_error(
        py,
        table,
        &DataError {
            what: what.to_string(),
            reason,
        },
    )
}

/// The class named `name` (the survey file's class names).
fn class(py: Python<'_>, table: &str, name: &str) -> PyResult<SurfaceClass> {
    SurfaceClass::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = SurfaceClass::ALL.iter().map(|(n, _)| *n).collect();
        refuse(
            py,
            table,
            "class",
            format!(
                "unknown class '{name}'; expected one of: {}",
                names.join(", ")
            ),
        )
    })
}

/// Rows of three coordinates as positions.
fn positions(
    py: Python<'_>,
    table: &str,
    what: &str,
    a: &PyReadonlyArray2<'_, f64>,
) -> PyResult<Vec<DVec3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(refuse(
            py,
            table,
            what,
            format!("an array of shape (n, 3) is needed, got {:?}", v.shape()),
        ));
    }
    Ok(v.rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect())
}

impl SurveyCore {
    /// A copy of this survey with `add` applied to it.
    fn with(
        &self,
        py: Python<'_>,
        table: &str,
        add: impl FnOnce(&mut lidarsim::Survey) -> Result<usize, DataError>,
    ) -> PyResult<SurveyCore> {
        let mut survey = (*self.survey).clone();
        add(&mut survey).map_err(|e| data_error(py, table, &e))?;
        Ok(self.derived(survey))
    }
}

impl SurveyCore {
    /// A new survey with a `[[mesh]]` of `faces` (rows of three vertex
    /// indices from 0) over `vertices` (rows of x, y, z in metres), placed
    /// as a `[[mesh]]` entry places its file: scaled, turned about the
    /// vertical by `rotation_z_deg`, moved by `offset_m`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn mesh_from_arrays(
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
        let table = "mesh";
        let vertices = positions(py, table, "vertices", &vertices)?;
        let f = faces.as_array();
        if f.ncols() != 3 {
            return Err(refuse(
                py,
                table,
                "faces",
                format!("an array of shape (m, 3) is needed, got {:?}", f.shape()),
            ));
        }
        let mut tri = Vec::with_capacity(f.nrows());
        for (i, r) in f.rows().into_iter().enumerate() {
            let mut t = [0u32; 3];
            for (k, &v) in t.iter_mut().zip(r.iter()) {
                *k = u32::try_from(v).map_err(|_| {
                    refuse(
                        py,
                        table,
                        &format!("faces[{i}]"),
                        format!("vertex index {v} is not from 0 to {}", u32::MAX),
                    )
                })?;
            }
            tri.push(t);
        }
        if !(scale.is_finite() && scale > 0.0) {
            return Err(refuse(
                py,
                table,
                "scale",
                format!("{scale} must be positive"),
            ));
        }
        if !(rotation_z_deg.is_finite() && offset_m.iter().all(|v| v.is_finite())) {
            return Err(refuse(
                py,
                table,
                "offset_m",
                "the offset and the rotation must be finite".to_string(),
            ));
        }
        let class = class(py, table, class_name)?;
        self.with(py, table, |s| {
            let material = s.material(material)?;
            s.add_mesh_data(
                MeshData {
                    vertices,
                    faces: tri,
                },
                MeshPlacement {
                    scale,
                    rotation_z_rad: rotation_z_deg.to_radians(),
                    offset_m: DVec3::from_array(offset_m),
                    default_class: class,
                    default_material: Some(material),
                    class_map: Vec::new(),
                },
            )
        })
    }

    /// A new survey with a `[[terrain]]` of `heights` (rows of the raster
    /// in its own order), north-up, georeferenced by `transform` (the
    /// affine `(a, b, c, d, e, f)` of rasterio: `x = a·col + c`,
    /// `y = e·row + f` at a pixel's corner, `b = d = 0`); nodes at pixel
    /// centres; NaN and `nodata` mark missing nodes.
    pub(crate) fn terrain_from_array(
        &self,
        py: Python<'_>,
        heights: PyReadonlyArray2<'_, f64>,
        transform: [f64; 6],
        material: &str,
        class_name: &str,
        nodata: Option<f64>,
    ) -> PyResult<SurveyCore> {
        let table = "terrain";
        let [a, b, c, d, e, f] = transform;
        if b != 0.0 || d != 0.0 {
            return Err(refuse(
                py,
                table,
                "transform",
                "rotates or shears the pixel grid; only north-up grids are supported \
                 (b = d = 0)"
                    .to_string(),
            ));
        }
        if !(a != 0.0 && e != 0.0 && [a, c, e, f].iter().all(|v| v.is_finite())) {
            return Err(refuse(
                py,
                table,
                "transform",
                format!(
                    "the pixel size ({a}, {e}) and corner ({c}, {f}) must be finite, the size not 0"
                ),
            ));
        }
        let h = heights.as_array();
        let (rows, cols) = (h.nrows(), h.ncols());
        if rows < 2 || cols < 2 {
            return Err(refuse(
                py,
                table,
                "heights",
                format!("a grid of {rows} × {cols} nodes: at least 2 × 2"),
            ));
        }
        if rows.saturating_mul(cols) > lidarsim::scene::terrain::MAX_NODES {
            return Err(refuse(
                py,
                table,
                "heights",
                format!(
                    "{rows} × {cols} nodes, more than {}",
                    lidarsim::scene::terrain::MAX_NODES
                ),
            ));
        }
        let values: Vec<f64> = h.iter().copied().collect();
        let grid = lidarsim::io::raster::raster_grid(cols, rows, (c, a, f, e), 0.5, nodata, |k| {
            values[k]
        })
        .map_err(|(row, col, v)| {
            refuse(
                py,
                table,
                &format!("heights[{row}, {col}]"),
                format!(
                    "{v} is not a height within ±{} m (mark missing nodes with NaN or nodata)",
                    lidarsim::scene::terrain::MAX_HEIGHT_M
                ),
            )
        })?;
        let class = class(py, table, class_name)?;
        self.with(py, table, |s| {
            let material = s.material(material)?;
            s.add_grid_data(grid, material, class)
        })
    }

    /// A new survey with a `[[point_cloud]]` of `points` (rows of x, y, z)
    /// as voxels of `voxel_m`, of class `class_name` or, without one, of
    /// the class most of a voxel's points have (`classes`: an ASPRS code
    /// per point; none, unclassified).
    pub(crate) fn cloud_from_arrays(
        &self,
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        voxel_m: f64,
        material: &str,
        class_name: Option<&str>,
        classes: Option<PyReadonlyArray1<'_, u8>>,
    ) -> PyResult<SurveyCore> {
        let table = "point_cloud";
        let positions = positions(py, table, "points", &points)?;
        let classes: Vec<u8> = classes.map_or_else(Vec::new, |c| c.as_array().to_vec());
        let class = class_name.map(|n| class(py, table, n)).transpose()?;
        self.with(py, table, |s| {
            let material = s.material(material)?;
            s.add_point_data(PointData { positions, classes }, voxel_m, material, class)
        })
    }
}
