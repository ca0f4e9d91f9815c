//! What a survey asks to be built, checked but not yet built: the entries
//! of its scene and the sources of its flight lines. [`crate::world`]
//! builds them, reading the files they name.

use std::path::PathBuf;
use std::sync::Arc;

use crate::geometry::DVec3;
use crate::scene::forest::ForestSpec;
use crate::scene::terrain::{FbmSpec, HeightGrid};
use crate::scene::{Material, MeshPlacement, Polygon, Species, SurfaceClass, TreeSpec};
use crate::sensor::platform::Interpolation;

/// The scene's entries, each with its index in its survey table (for
/// messages and object names). Entries with a problem are left out.
#[derive(Clone, Debug, Default)]
pub struct SceneSpec {
    /// `[[polygon]]` entries.
    pub polygons: Vec<PolygonEntry>,
    /// `[[mesh]]` entries.
    pub meshes: Vec<MeshEntry>,
    /// `[[terrain]]` entries.
    pub terrains: Vec<TerrainEntry>,
    /// `[[point_cloud]]` entries.
    pub clouds: Vec<CloudEntry>,
    /// `[[tree]]` entries, with their index.
    pub trees: Vec<(usize, TreeSpec)>,
    /// `[[forest]]` entries, with their index (`None` for one with a
    /// problem, so that forests keep their numbers).
    pub forests: Vec<Option<ForestSpec>>,
    /// `[[tree_table]]` entries.
    pub tree_tables: Vec<TreeTableEntry>,
    /// How crowns are filled (`[vegetation]`).
    pub foliage: crate::scene::FoliageSettings,
}

/// A checked `[[polygon]]`.
#[derive(Clone, Debug)]
pub struct PolygonEntry {
    /// Index in `[[polygon]]`.
    pub index: usize,
    /// The polygon.
    pub polygon: Polygon,
    /// Its material.
    pub material: Material,
    /// Its class.
    pub class: SurfaceClass,
}

/// A checked `[[mesh]]`.
#[derive(Clone, Debug)]
pub struct MeshEntry {
    /// Index in `[[mesh]]`.
    pub index: usize,
    /// Where its triangles come from.
    pub source: MeshSource,
    /// Where it goes and what it defaults to.
    pub placement: MeshPlacement,
}

/// Where a mesh's triangles come from.
#[derive(Clone, Debug)]
pub enum MeshSource {
    /// An OBJ file (relative paths resolved against the survey's
    /// directory).
    Obj(PathBuf),
    /// A glTF file (`.gltf`, `.glb`).
    Gltf(PathBuf),
    /// Vertices and faces given by a program ([`crate::survey::data`]).
    Data(Arc<MeshData>),
}

/// A triangle mesh as data: vertices, m, and faces as triples of vertex
/// indices (counter-clockwise or not: surfaces are two-sided).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshData {
    /// Vertex positions, before the placement, m.
    pub vertices: Vec<DVec3>,
    /// Triangles as indices into `vertices`.
    pub faces: Vec<[u32; 3]>,
}

/// Where a terrain's heights come from.
#[derive(Clone, Debug)]
pub enum TerrainSource {
    /// A GeoTIFF or ESRI ASCII grid, and its name as written.
    File(PathBuf, String),
    /// Generated fractional Brownian motion.
    Fbm(FbmSpec),
    /// A height grid given by a program ([`crate::survey::data`]).
    Grid(Arc<HeightGrid>),
}

/// A checked `[[terrain]]`.
#[derive(Clone, Debug)]
pub struct TerrainEntry {
    /// Index in `[[terrain]]`.
    pub index: usize,
    /// The heights.
    pub source: TerrainSource,
    /// Its material.
    pub material: Material,
    /// Its class.
    pub class: SurfaceClass,
    /// Added to every node, m.
    pub offset_m: DVec3,
}

/// A checked `[[tree_table]]`: a CSV file of trees, read by
/// [`crate::io::tree_table`].
#[derive(Clone, Debug)]
pub struct TreeTableEntry {
    /// Index in `[[tree_table]]`.
    pub index: usize,
    /// The CSV file (relative paths resolved against the survey's
    /// directory).
    pub path: PathBuf,
    /// Added to every tree's position, m.
    pub offset_m: DVec3,
    /// Species of rows that name none.
    pub species: Option<Species>,
    /// The survey's seed, from which rows without a `seed` take theirs.
    pub survey_seed: u64,
}

/// A checked `[[point_cloud]]`.
#[derive(Clone, Debug)]
pub struct CloudEntry {
    /// Index in `[[point_cloud]]`.
    pub index: usize,
    /// Where its points come from.
    pub source: CloudSource,
    /// Voxel edge, m.
    pub voxel_m: f64,
    /// Added to every point, m.
    pub offset_m: DVec3,
    /// Material of all voxels.
    pub material: Material,
    /// Class of all voxels; `None` takes it from the points.
    pub class: Option<SurfaceClass>,
}

/// Where a point cloud's points come from.
#[derive(Clone, Debug)]
pub enum CloudSource {
    /// A LAS, LAZ or XYZ text file.
    File(PathBuf),
    /// Points given by a program ([`crate::survey::data`]).
    Data(Arc<PointData>),
}

/// Points as data: positions, m, and each one's ASPRS class code (or
/// none: unclassified).
#[derive(Clone, Debug, PartialEq)]
pub struct PointData {
    /// Positions, before the entry's offset, m.
    pub positions: Vec<DVec3>,
    /// ASPRS classification of each point; empty for none.
    pub classes: Vec<u8>,
}

/// Where the flight lines come from: exactly one of the three.
#[derive(Clone, Debug, Default)]
pub struct LineSpec {
    /// `[[flight_line]]` entries: start, end and ground speed.
    pub straight: Vec<(DVec3, DVec3, f64)>,
    /// A `[plan]`.
    pub plan: Option<PlanSpec>,
    /// `[platform] trajectory_file` and its interpolation.
    pub trajectory: Option<(PathBuf, Interpolation)>,
}

/// A checked `[plan]`: parallel lines over an area.
#[derive(Clone, Debug)]
pub struct PlanSpec {
    /// The area's outline in plan.
    pub area: Vec<[f64; 2]>,
    /// Heading as a yaw angle (counter-clockwise from north), rad.
    pub yaw_rad: f64,
    /// Distance between lines, m.
    pub spacing_m: f64,
    /// Length flown beyond the area at both ends, m.
    pub run_in_m: f64,
    /// Height above the ground at the area's centre, m.
    pub altitude_m: f64,
    /// Ground speed, m/s.
    pub speed_mps: f64,
}
