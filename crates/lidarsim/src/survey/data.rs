//! Scene entries given as data by a program rather than as files a survey
//! names: a triangle mesh, a height grid, a point cloud to voxelise. Each
//! becomes the next entry of its survey table (`[[mesh]]`, `[[terrain]]`,
//! `[[point_cloud]]`) and is built exactly as the same geometry read from
//! a file: the same placement, materials, classes and voxels. A run into a
//! directory writes them beside its `survey.toml` as files the command
//! line reads ([`crate::files::data_files`]), so that the directory can be
//! run again.

use std::sync::Arc;

use super::Survey;
use super::spec::{
    CloudEntry, CloudSource, MeshData, MeshEntry, MeshSource, PointData, TerrainEntry,
    TerrainSource,
};
use crate::geometry::{DVec3, MAX_COORDINATE_M};
use crate::scene::terrain::{HeightGrid, MAX_NODES};
use crate::scene::{Material, MeshPlacement, SurfaceClass, Triangle};

/// Largest number of points of a point cloud given as data.
pub const MAX_POINTS: usize = 500_000_000;

/// Why scene data was refused, naming the argument at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{what}: {reason}")]
pub struct DataError {
    /// The argument (`vertices`, `faces[12]`, `material`).
    pub what: String,
    /// What is wrong.
    pub reason: String,
}

fn refuse(what: impl Into<String>, reason: impl Into<String>) -> DataError {
    DataError {
        what: what.into(),
        reason: reason.into(),
    }
}

/// The first position of `points` that is not finite or lies beyond the
/// coordinate limit, as an error about `what[i]`.
fn check_positions(what: &str, points: &[DVec3]) -> Result<(), DataError> {
    match points
        .iter()
        .position(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE_M)
    {
        None => Ok(()),
        Some(i) => Err(refuse(
            format!("{what}[{i}]"),
            format!(
                "({}, {}, {}) must be finite and within ±{MAX_COORDINATE_M:e} m",
                points[i].x, points[i].y, points[i].z
            ),
        )),
    }
}

impl Survey {
    /// The survey's material `name`, as a `[[mesh]] material` names it.
    pub fn material(&self, name: &str) -> Result<Material, DataError> {
        self.materials.get(name).cloned().ok_or_else(|| {
            let mut known: Vec<&str> = self.materials.keys().map(String::as_str).collect();
            known.sort_unstable();
            refuse(
                "material",
                format!(
                    "'{name}' is not in [materials] (it has: {})",
                    if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })
    }

    /// Adds a `[[mesh]]` of `mesh`'s triangles placed by `placement`
    /// (whose default material and class every face takes); returns its
    /// index. Faces must name existing vertices, and one at least must be
    /// a triangle (not a line or a point) once placed.
    pub fn add_mesh_data(
        &mut self,
        mesh: MeshData,
        placement: MeshPlacement,
    ) -> Result<usize, DataError> {
        if placement.default_material.is_none() {
            return Err(refuse("material", "is required"));
        }
        check_positions("vertices", &mesh.vertices)?;
        let n = mesh.vertices.len();
        if let Some((i, f)) = mesh
            .faces
            .iter()
            .enumerate()
            .find(|(_, f)| f.iter().any(|&k| k as usize >= n))
        {
            return Err(refuse(
                format!("faces[{i}]"),
                format!("{f:?} names a vertex beyond the {n} given (counted from 0)"),
            ));
        }
        let any_triangle = {
            let place = placement.placer();
            let corner = |k: u32| place(mesh.vertices[k as usize]);
            mesh.faces
                .iter()
                .any(|f| Triangle::new(corner(f[0]), corner(f[1]), corner(f[2])).is_some())
        };
        if !any_triangle {
            return Err(refuse(
                "faces",
                format!(
                    "none of the {} faces is a triangle (each has coinciding or aligned corners)",
                    mesh.faces.len()
                ),
            ));
        }
        let index = self.raw.meshes.len() + self.data_entries(|s| &s.meshes, |m| m.is_data());
        self.scene_spec.meshes.push(MeshEntry {
            index,
            source: MeshSource::Data(Arc::new(mesh)),
            placement,
        });
        Ok(index)
    }

    /// Adds a `[[terrain]]` of `grid`'s heights (NaN for nodata), of
    /// `material` and `class`; returns its index.
    pub fn add_grid_data(
        &mut self,
        grid: HeightGrid,
        material: Material,
        class: SurfaceClass,
    ) -> Result<usize, DataError> {
        if grid.cols < 2 || grid.rows < 2 {
            return Err(refuse(
                "heights",
                format!(
                    "a grid of {} × {} nodes: at least 2 × 2",
                    grid.rows, grid.cols
                ),
            ));
        }
        if grid.cols.saturating_mul(grid.rows) > MAX_NODES {
            return Err(refuse(
                "heights",
                format!("{} × {} nodes, more than {MAX_NODES}", grid.rows, grid.cols),
            ));
        }
        if grid.heights.len() != grid.cols * grid.rows {
            return Err(refuse(
                "heights",
                format!(
                    "{} values for {} × {} nodes",
                    grid.heights.len(),
                    grid.rows,
                    grid.cols
                ),
            ));
        }
        if !grid.spacing_m.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(refuse(
                "spacing_m",
                format!("{:?} must be positive", grid.spacing_m),
            ));
        }
        let corner = DVec3::new(grid.origin_m[0], grid.origin_m[1], grid.z_offset_m);
        let far = corner
            + DVec3::new(
                grid.spacing_m[0] * (grid.cols - 1) as f64,
                grid.spacing_m[1] * (grid.rows - 1) as f64,
                0.0,
            );
        check_positions("origin_m", &[corner, far])?;
        if let Some(i) = grid
            .heights
            .iter()
            .position(|h| h.is_infinite() || h.abs() > crate::scene::terrain::MAX_HEIGHT_M as f32)
        {
            return Err(refuse(
                format!("heights[{}, {}]", i / grid.cols, i % grid.cols),
                format!(
                    "{} m: heights are finite, within ±{} m (NaN for nodata)",
                    grid.heights[i],
                    crate::scene::terrain::MAX_HEIGHT_M
                ),
            ));
        }
        if grid.heights.iter().all(|h| h.is_nan()) {
            return Err(refuse("heights", "every node is nodata"));
        }
        let index = self.raw.terrains.len() + self.data_entries(|s| &s.terrains, |t| t.is_data());
        self.scene_spec.terrains.push(TerrainEntry {
            index,
            source: TerrainSource::Grid(Arc::new(grid)),
            material,
            class,
            offset_m: DVec3::ZERO,
        });
        Ok(index)
    }

    /// Adds a `[[point_cloud]]` of `points` as voxels of `voxel_m`, of
    /// `material` and `class` (`None`: each voxel the class most of its
    /// points have); returns its index.
    pub fn add_point_data(
        &mut self,
        points: PointData,
        voxel_m: f64,
        material: Material,
        class: Option<SurfaceClass>,
    ) -> Result<usize, DataError> {
        if !(voxel_m.is_finite() && voxel_m > 0.0) {
            return Err(refuse("voxel_m", format!("{voxel_m} must be positive")));
        }
        if points.positions.is_empty() {
            return Err(refuse("points", "no point given"));
        }
        if points.positions.len() > MAX_POINTS {
            return Err(refuse(
                "points",
                format!("{} points, more than {MAX_POINTS}", points.positions.len()),
            ));
        }
        check_positions("points", &points.positions)?;
        if !points.classes.is_empty() && points.classes.len() != points.positions.len() {
            return Err(refuse(
                "classes",
                format!(
                    "{} codes for {} points",
                    points.classes.len(),
                    points.positions.len()
                ),
            ));
        }
        let index = self.raw.point_clouds.len() + self.data_entries(|s| &s.clouds, |c| c.is_data());
        self.scene_spec.clouds.push(CloudEntry {
            index,
            source: CloudSource::Data(Arc::new(points)),
            voxel_m,
            offset_m: DVec3::ZERO,
            material,
            class,
        });
        Ok(index)
    }

    /// How many entries of one table were given as data.
    fn data_entries<T>(
        &self,
        table: impl Fn(&super::spec::SceneSpec) -> &Vec<T>,
        is_data: impl Fn(&T) -> bool,
    ) -> usize {
        table(&self.scene_spec)
            .iter()
            .filter(|e| is_data(e))
            .count()
    }
}

impl MeshEntry {
    /// Whether it was given as data.
    pub fn is_data(&self) -> bool {
        matches!(self.source, MeshSource::Data(_))
    }
}

impl TerrainEntry {
    /// Whether it was given as data.
    pub fn is_data(&self) -> bool {
        matches!(self.source, TerrainSource::Grid(_))
    }
}

impl CloudEntry {
    /// Whether it was given as data.
    pub fn is_data(&self) -> bool {
        matches!(self.source, CloudSource::Data(_))
    }
}
