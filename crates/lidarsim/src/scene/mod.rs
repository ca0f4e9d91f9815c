//! The scene: surfaces and volumes with materials and ground-truth classes.
//!
//! A [`Scene`] is a flat list of [`Primitive`]s — planar polygons, mesh
//! triangles, tree trunks (opaque cones) and tree crowns (volumes the beam
//! penetrates) — the [`Material`]s they refer to and the [`SceneObject`]s
//! they belong to (one per survey polygon, mesh or tree). It knows nothing
//! about rays beyond the exact per-primitive intersection; finding the
//! closest hit among many primitives is the job of [`crate::accel`], and the
//! way through crowns that of [`crate::canopy`].

pub mod cloud;
pub mod foliage;
pub mod forest;
mod polygon;
mod species;
pub mod terrain;
pub mod tree;
mod triangle;

pub use foliage::{FoliageModel, FoliageSettings};
pub use polygon::{PLANARITY_TOLERANCE_M, Polygon, PolygonError};
pub use species::{Species, SpeciesPreset};
pub use tree::{Crown, CrownLevel, CrownProfile, Envelope, TreeSpec, Trunk};
pub use triangle::{
    Coverage, EdgeTest, Straddle, Triangle, TriangleFan, bundle_cone, bundle_spread,
};

use crate::geometry::{Aabb, DVec3, Ray, VerticalCylinder};

/// Where a mesh goes in the world and what it defaults to.
#[derive(Clone, Debug)]
pub struct MeshPlacement {
    /// Uniform scale applied first.
    pub scale: f64,
    /// Rotation about the vertical, radians, applied after scaling.
    pub rotation_z_rad: f64,
    /// Translation applied last, m.
    pub offset_m: DVec3,
    /// Class for faces whose material and group name say nothing.
    pub default_class: SurfaceClass,
    /// Material for faces before any `usemtl` (a survey material name).
    pub default_material: Option<Material>,
    /// Group/object name patterns and their classes (see the module
    /// documentation).
    pub class_map: Vec<(String, SurfaceClass)>,
}

impl MeshPlacement {
    /// Where a vertex of the mesh's own frame goes: scaled, turned about
    /// the vertical, then moved (the rotation worked out once).
    pub fn placer(&self) -> impl Fn(DVec3) -> DVec3 + '_ {
        let rotation = crate::geometry::DMat3::from_rotation_z(self.rotation_z_rad);
        move |p| rotation * (p * self.scale) + self.offset_m
    }

    /// Adds the triangles `faces` (indices into `vertices`, in the mesh's
    /// own frame) as one new object `name` of the placement's default
    /// material (`material`) and class; returns the triangles added and
    /// the degenerate ones skipped.
    pub fn add_triangles(
        &self,
        scene: &mut Scene,
        vertices: &[DVec3],
        faces: &[[u32; 3]],
        material: MaterialId,
        name: impl Into<String>,
    ) -> (usize, usize) {
        let object = scene.add_object(name);
        let place = self.placer();
        let corner = |k: u32| vertices.get(k as usize).map_or(DVec3::NAN, |&v| place(v));
        let (mut added, mut skipped) = (0, 0);
        for f in faces {
            match Triangle::new(corner(f[0]), corner(f[1]), corner(f[2])) {
                Some(t) => {
                    scene.primitives.push(Primitive {
                        shape: Shape::Triangle(t),
                        material,
                        class: self.default_class,
                        object,
                    });
                    added += 1;
                }
                None => skipped += 1,
            }
        }
        (added, skipped)
    }
}

/// Ground-truth class of a surface. It becomes the LAS classification of
/// the points that surface returns (ASPRS standard classes, LAS 1.4 R15
/// Table 17).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceClass {
    /// Bare earth, lawns, fields: ASPRS 2.
    Ground,
    /// Streets and paved areas: ASPRS 11 (road surface).
    Road,
    /// Roof planes: ASPRS 6 (building).
    Roof,
    /// Building walls: ASPRS 6 (building).
    Wall,
    /// Vegetation: ASPRS 3, 4 or 5 by height above ground.
    Vegetation,
    /// Water surfaces: ASPRS 9.
    Water,
    /// Bridge decks: ASPRS 17.
    Bridge,
    /// Anything else: ASPRS 1 (unclassified).
    Unclassified,
}

impl SurfaceClass {
    /// All classes with their names in survey files.
    pub const ALL: [(&'static str, SurfaceClass); 8] = [
        ("ground", SurfaceClass::Ground),
        ("road", SurfaceClass::Road),
        ("roof", SurfaceClass::Roof),
        ("wall", SurfaceClass::Wall),
        ("vegetation", SurfaceClass::Vegetation),
        ("water", SurfaceClass::Water),
        ("bridge", SurfaceClass::Bridge),
        ("unclassified", SurfaceClass::Unclassified),
    ];

    /// Parses a class name as written in survey files and OBJ/MTL hints.
    pub fn from_name(name: &str) -> Option<Self> {
        let lower = name.trim().to_ascii_lowercase();
        Self::ALL
            .iter()
            .find(|(n, _)| *n == lower)
            .map(|(_, c)| *c)
            .or(match lower.as_str() {
                "building" => Some(SurfaceClass::Roof),
                "unknown" => Some(SurfaceClass::Unclassified),
                _ => None,
            })
    }

    /// The name used in survey files.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, c)| *c == self)
            .map(|(n, _)| *n)
            .unwrap_or("unclassified")
    }

    /// Whether this is what points stand on: ground, road or water (the
    /// surfaces heights above ground and flying heights are measured from).
    pub fn is_ground(self) -> bool {
        matches!(
            self,
            SurfaceClass::Ground | SurfaceClass::Road | SurfaceClass::Water
        )
    }

    /// ASPRS classification code for a point of this class that lies
    /// `height_above_ground_m` above the ground beneath it (only used for
    /// vegetation: low < 0.5 m ≤ medium < 2 m ≤ high, the usual split of
    /// ASPRS classes 3/4/5, which the LAS specification leaves to the user).
    pub fn asprs_code(self, height_above_ground_m: f64) -> u8 {
        match self {
            SurfaceClass::Ground => 2,
            SurfaceClass::Road => 11,
            SurfaceClass::Roof | SurfaceClass::Wall => 6,
            SurfaceClass::Water => 9,
            SurfaceClass::Bridge => 17,
            SurfaceClass::Unclassified => 1,
            SurfaceClass::Vegetation => {
                if height_above_ground_m < LOW_VEGETATION_MAX_M {
                    3
                } else if height_above_ground_m < MEDIUM_VEGETATION_MAX_M {
                    4
                } else {
                    5
                }
            }
        }
    }
}

/// Upper height of low vegetation (ASPRS 3), m.
pub const LOW_VEGETATION_MAX_M: f64 = 0.5;
/// Upper height of medium vegetation (ASPRS 4), m; above is high (5).
pub const MEDIUM_VEGETATION_MAX_M: f64 = 2.0;

/// Optical properties of a surface at the laser wavelength.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name in the survey file or MTL file.
    pub name: String,
    /// Reflectance `refl`, 0–1 (specification, "Target reflectance").
    pub reflectance: f64,
    /// Exponent `a` of the incidence model `cos(α)^a` (1 = Lambertian).
    pub incidence_exponent: f64,
    /// Reflectance against wavelength, `(nm, 0–1)` by increasing
    /// wavelength, for scanners whose channels differ in wavelength; empty:
    /// `reflectance` at every wavelength.
    pub spectrum: Vec<(f64, f64)>,
}

impl Material {
    /// Reflectance at `wavelength_nm`: `reflectance`, or the spectrum
    /// interpolated linearly between its wavelengths and held at its
    /// first and last values beyond them.
    pub fn reflectance_at(&self, wavelength_nm: f64) -> f64 {
        let s = &self.spectrum;
        let (Some(first), Some(last)) = (s.first(), s.last()) else {
            return self.reflectance;
        };
        if wavelength_nm <= first.0 {
            return first.1;
        }
        if wavelength_nm >= last.0 {
            return last.1;
        }
        let i = s.partition_point(|p| p.0 <= wavelength_nm);
        let ((x0, y0), (x1, y1)) = (s[i - 1], s[i]);
        y0 + (y1 - y0) * (wavelength_nm - x0) / (x1 - x0)
    }
}

/// Index of a material in [`Scene::materials`].
pub type MaterialId = u32;
/// Index of an object in [`Scene::objects`].
pub type ObjectId = u32;

/// A survey entry that produced primitives: one polygon, mesh, terrain,
/// point cloud or tree.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneObject {
    /// An entry by its human-readable name (`polygon[3]`,
    /// `mesh[0]:house.obj`, `tree[2]`).
    Named(String),
    /// Tree `tree` of the survey's `[[forest]]` entry `forest`: a stand
    /// has up to millions, named by their two numbers rather than a text
    /// each.
    StandTree {
        /// Index of the `[[forest]]` entry.
        forest: u32,
        /// Index of the tree in the stand, in the order it was placed.
        tree: u32,
    },
    /// Row `tree` of the survey's `[[tree_table]]` entry `table`.
    TableTree {
        /// Index of the `[[tree_table]]` entry.
        table: u32,
        /// Index of the tree among the table's rows.
        tree: u32,
    },
}

impl std::fmt::Display for SceneObject {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneObject::Named(name) => f.write_str(name),
            SceneObject::StandTree { forest, tree } => write!(f, "forest[{forest}].tree[{tree}]"),
            SceneObject::TableTree { table, tree } => {
                write!(f, "tree_table[{table}].tree[{tree}]")
            }
        }
    }
}

impl SceneObject {
    /// Bytes its name takes on the heap.
    pub fn heap_bytes(&self) -> usize {
        match self {
            SceneObject::Named(name) => name.capacity(),
            SceneObject::StandTree { .. } | SceneObject::TableTree { .. } => 0,
        }
    }
}

/// The geometric shape of a primitive: a closed set, so an enum.
#[derive(Clone, Debug)]
pub enum Shape {
    /// A planar polygon of any vertex count.
    Polygon(Box<Polygon>),
    /// A mesh triangle.
    Triangle(Triangle),
    /// A tree's stem: an opaque cone.
    Trunk(Trunk),
    /// A tree's crown: a volume the beam penetrates (never a closest hit).
    Crown(Box<Crown>),
    /// A block of cells of a terrain height grid.
    Terrain(terrain::TerrainTile),
    /// An opaque box: one occupied voxel of a point cloud.
    Voxel(cloud::Voxel),
}

/// One surface of the scene.
#[derive(Clone, Debug)]
pub struct Primitive {
    /// Geometry.
    pub shape: Shape,
    /// Material index.
    pub material: MaterialId,
    /// Ground-truth class.
    pub class: SurfaceClass,
    /// The survey entry it came from.
    pub object: ObjectId,
}

impl Primitive {
    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        match &self.shape {
            Shape::Polygon(p) => p.bounds(),
            Shape::Triangle(t) => Aabb::from_points(&t.vertices()),
            Shape::Trunk(t) => t.bounds(),
            Shape::Crown(c) => c.bounds(),
            Shape::Terrain(t) => t.bounds(),
            Shape::Voxel(v) => v.bounds,
        }
    }

    /// The upright cylinder that bounds a tree's stem or crown (`None` for
    /// other shapes).
    #[inline]
    pub fn bounds_cylinder(&self) -> Option<VerticalCylinder> {
        match &self.shape {
            Shape::Trunk(t) => Some(t.bounds_cylinder()),
            Shape::Crown(c) => Some(c.bounds_cylinder()),
            _ => None,
        }
    }

    /// True for volumes (crowns), which rays pass through.
    #[inline]
    pub fn is_volume(&self) -> bool {
        matches!(self.shape, Shape::Crown(_))
    }

    /// Distance to the surface along `ray`, if hit within `(t_min, t_max)`.
    /// Volumes are never hit.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        match &self.shape {
            Shape::Polygon(p) => p.intersect(ray, t_min, t_max),
            Shape::Triangle(t) => t.intersect(ray, t_min, t_max),
            Shape::Trunk(t) => t.intersect(ray, t_min, t_max).map(|(d, _)| d),
            Shape::Crown(_) => None,
            Shape::Terrain(t) => t.intersect(ray, t_min, t_max),
            Shape::Voxel(v) => v.intersect(ray, t_min, t_max),
        }
    }

    /// True for planar shapes, whose normal is the same everywhere.
    #[inline]
    pub fn is_flat(&self) -> bool {
        matches!(self.shape, Shape::Polygon(_) | Shape::Triangle(_))
    }

    /// Unit surface normal at the point `p` on the surface (either side).
    #[inline]
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        match &self.shape {
            Shape::Polygon(poly) => poly.normal(),
            Shape::Triangle(t) => t.normal(),
            Shape::Trunk(t) => t.normal_at(p),
            Shape::Crown(_) => DVec3::Z,
            Shape::Terrain(t) => t.normal_at(p),
            Shape::Voxel(v) => v.normal_at(p),
        }
    }
}

/// All surfaces of a survey, with their materials and source objects.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Surfaces.
    pub primitives: Vec<Primitive>,
    /// Materials referenced by [`Primitive::material`].
    pub materials: Vec<Material>,
    /// Objects referenced by [`Primitive::object`].
    pub objects: Vec<SceneObject>,
}

impl Scene {
    /// Bounding box of all primitives ([`Aabb::EMPTY`] for an empty scene).
    pub fn bounds(&self) -> Aabb {
        self.primitives
            .iter()
            .fold(Aabb::EMPTY, |b, p| b.union(p.bounds()))
    }

    /// Adds a material and returns its id; an identical material (same
    /// name and values) is reused.
    pub fn add_material(&mut self, material: Material) -> MaterialId {
        if let Some(i) = self.materials.iter().position(|m| *m == material) {
            return i as MaterialId;
        }
        self.materials.push(material);
        (self.materials.len() - 1) as MaterialId
    }

    /// Adds a tree as two primitives: its trunk (opaque, bark) and its crown
    /// (a volume, foliage; no incidence term), both of class vegetation.
    pub fn add_tree(
        &mut self,
        tree: &TreeSpec,
        foliage: &FoliageSettings,
        name: impl Into<String>,
    ) {
        let object = self.add_object(name);
        let materials = self.tree_materials(tree, foliage);
        for crown in [false, true] {
            let part = tree_part(tree, crown, materials, object, foliage);
            self.primitives.push(part);
        }
    }

    /// The ids of a tree's bark and foliage materials, added if new (the
    /// crown's reflectance as `foliage`'s model has it).
    pub(crate) fn tree_materials(
        &mut self,
        tree: &TreeSpec,
        foliage: &FoliageSettings,
    ) -> (MaterialId, MaterialId) {
        let species = tree.species.name();
        let bark = self.add_named_material(species, " bark", tree.bark_reflectance, 1.0);
        let crown = tree.crown_reflectance(foliage);
        let foliage = self.add_named_material(species, " foliage", crown, 0.0);
        (bark, foliage)
    }

    /// [`Scene::add_material`] for the material named `prefix` + `suffix`,
    /// without building the name when the material is there already (a
    /// stand adds the same few materials for every tree).
    fn add_named_material(
        &mut self,
        prefix: &str,
        suffix: &str,
        reflectance: f64,
        incidence_exponent: f64,
    ) -> MaterialId {
        let same = |m: &Material| {
            m.reflectance == reflectance
                && m.spectrum.is_empty()
                && m.incidence_exponent == incidence_exponent
                && m.name.len() == prefix.len() + suffix.len()
                && m.name.starts_with(prefix)
                && m.name.ends_with(suffix)
        };
        match self.materials.iter().position(same) {
            Some(i) => i as MaterialId,
            None => self.add_material(Material {
                name: format!("{prefix}{suffix}"),
                reflectance,
                incidence_exponent,
                spectrum: Vec::new(),
            }),
        }
    }

    /// Adds an object record and returns its id.
    pub fn add_object(&mut self, name: impl Into<String>) -> ObjectId {
        self.objects.push(SceneObject::Named(name.into()));
        (self.objects.len() - 1) as ObjectId
    }
}

/// The trunk of `tree` (bark) or, with `crown`, its crown (foliage), of
/// object `object`, `materials` being its bark and foliage: a tree's two
/// primitives, as [`Scene::add_tree`] and [`Scene::add_stand`] make them.
pub(crate) fn tree_part(
    tree: &TreeSpec,
    crown: bool,
    (bark, foliage): (MaterialId, MaterialId),
    object: ObjectId,
    settings: &FoliageSettings,
) -> Primitive {
    let (shape, material) = if crown {
        (Shape::Crown(Box::new(tree.crown(settings))), foliage)
    } else {
        (Shape::Trunk(tree.trunk()), bark)
    };
    Primitive {
        shape,
        material,
        class: SurfaceClass::Vegetation,
        object,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn asprs_codes() {
        assert_eq!(SurfaceClass::Ground.asprs_code(0.0), 2);
        assert_eq!(SurfaceClass::Road.asprs_code(0.0), 11);
        assert_eq!(SurfaceClass::Roof.asprs_code(8.0), 6);
        assert_eq!(SurfaceClass::Wall.asprs_code(3.0), 6);
        assert_eq!(SurfaceClass::Water.asprs_code(0.0), 9);
        assert_eq!(SurfaceClass::Unclassified.asprs_code(0.0), 1);
        assert_eq!(SurfaceClass::Vegetation.asprs_code(0.2), 3);
        assert_eq!(SurfaceClass::Vegetation.asprs_code(1.0), 4);
        assert_eq!(SurfaceClass::Vegetation.asprs_code(12.0), 5);
        for (name, class) in SurfaceClass::ALL {
            assert_eq!(SurfaceClass::from_name(name), Some(class));
            assert_eq!(class.name(), name);
        }
    }

    #[test]
    fn reflectance_is_interpolated_between_the_spectrum_wavelengths() {
        // Green vegetation: dark in the green, bright in the near infrared.
        let leaf = Material {
            name: "leaf".into(),
            reflectance: 0.0,
            incidence_exponent: 1.0,
            spectrum: vec![(532.0, 0.08), (905.0, 0.44), (1550.0, 0.3)],
        };
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(leaf.reflectance_at(532.0), 0.08));
        assert!(close(leaf.reflectance_at(905.0), 0.44));
        // A third of the way from 905 to 1550 nm.
        assert!(close(leaf.reflectance_at(1120.0), 0.44 - 0.14 / 3.0));
        // Held at the ends.
        assert!(close(leaf.reflectance_at(400.0), 0.08));
        assert!(close(leaf.reflectance_at(2000.0), 0.3));
        let flat = Material {
            spectrum: Vec::new(),
            reflectance: 0.25,
            ..leaf
        };
        assert!(close(flat.reflectance_at(532.0), 0.25));
    }
}
