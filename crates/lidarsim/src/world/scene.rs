//! The scene of a survey built from its entries: polygons, meshes,
//! terrains and point clouds (read by [`crate::io`]), trees, then the
//! forests' trees placed on the ground of an index of all of that, and the
//! index of everything.

use crate::accel::{Bvh, ground_below};
use crate::geometry::DVec3;
use crate::geometry::MAX_COORDINATE_M;
use crate::io::tree_table::{TableSettings, read_tree_table};
use crate::message::num;
use crate::rng::Purpose;
use crate::scene::forest::{generate, polygon_area};
use crate::scene::terrain::HeightGrid;
use crate::scene::{Primitive, Scene, SceneObject, Shape};
use crate::survey::spec::{CloudSource, MeshSource, SceneSpec, TerrainSource};
use crate::survey::{KeyPath, Survey};

/// What [`build`] makes.
pub(super) struct Built {
    /// The index, owning the scene.
    pub index: Bvh,
    /// Trees placed by each `[[forest]]` entry.
    pub forest_trees: Vec<usize>,
    /// Warnings about the stands.
    pub warnings: Vec<String>,
    /// Time spent building the index, s.
    pub index_time_s: f64,
}

/// The index of `scene`, and how long it took to build.
fn index(scene: Scene) -> (Bvh, f64) {
    let t = std::time::Instant::now();
    let index = Bvh::build(scene);
    (index, t.elapsed().as_secs_f64())
}

/// Builds and indexes the scene of `survey`, adding its problems to
/// `problems`.
pub(super) fn build(survey: &Survey, problems: &mut Vec<(KeyPath, String)>) -> Built {
    let spec = &survey.scene_spec;
    let mut assembly = Assembly {
        scene: Scene::default(),
        owners: Vec::new(),
        problems,
    };
    assembly.add_polygons(spec);
    assembly.add_meshes(survey);
    assembly.add_terrains(spec);
    assembly.add_clouds(spec);
    assembly.add_trees(spec);
    assembly.add_tree_tables(survey);
    let stands = assembly.add_forests(spec);
    let Assembly {
        scene,
        owners,
        problems,
    } = assembly;
    check_far(&scene, &owners, problems);
    let (index, index_time_s) = index(scene);
    Built {
        index,
        forest_trees: stands.trees,
        warnings: stands.warnings,
        index_time_s,
    }
}

/// The scene as the survey's entries are added to it, with the problems
/// met on the way.
struct Assembly<'a> {
    scene: Scene,
    /// Which entry added which primitives, in order.
    owners: Vec<Owner>,
    problems: &'a mut Vec<(KeyPath, String)>,
}

/// The entry at `key` added the primitives from `first` up to the next
/// owner's.
struct Owner {
    key: KeyPath,
    first: usize,
}

/// What the `[[forest]]` entries placed.
struct Stands {
    /// Trees placed by each entry.
    trees: Vec<usize>,
    /// Stands with fewer trees than asked for.
    warnings: Vec<String>,
}

impl Assembly<'_> {
    /// The primitives added from now on belong to the entry at `key`.
    fn own(&mut self, key: KeyPath) {
        self.owners.push(Owner {
            key,
            first: self.scene.primitives.len(),
        });
    }

    /// The `[[polygon]]` entries.
    fn add_polygons(&mut self, spec: &SceneSpec) {
        for p in &spec.polygons {
            let key = KeyPath::root().key("polygon").index(p.index);
            self.own(key.key("vertices_m"));
            let material = self.scene.add_material(p.material.clone());
            let object = self.scene.add_object(format!("polygon[{}]", p.index));
            self.scene.primitives.push(Primitive {
                shape: Shape::Polygon(Box::new(p.polygon.clone())),
                material,
                class: p.class,
                object,
            });
        }
    }

    /// Meshes from OBJ and glTF files, or given as data.
    fn add_meshes(&mut self, survey: &Survey) {
        for m in &survey.scene_spec.meshes {
            let key = KeyPath::root().key("mesh").index(m.index);
            self.own(key.key("offset_m"));
            let scene = &mut self.scene;
            let loaded = match &m.source {
                MeshSource::Gltf(file) => {
                    crate::io::gltf::load_gltf(file, &m.placement, &survey.materials, scene)
                }
                MeshSource::Obj(file) => {
                    crate::io::obj::load_obj(file, &m.placement, &survey.materials, scene)
                }
                MeshSource::Data(data) => match &m.placement.default_material {
                    // Faces within the vertices were checked when it was added.
                    Some(material) => {
                        let material = scene.add_material(material.clone());
                        let name = format!("mesh[{}]:data", m.index);
                        Ok(m.placement.add_triangles(
                            scene,
                            &data.vertices,
                            &data.faces,
                            material,
                            name,
                        ))
                    }
                    None => {
                        self.problems
                            .push((key.key("material"), "is required".to_string()));
                        continue;
                    }
                },
            };
            if let Err(e) = loaded {
                let at = match &e {
                    crate::io::mesh::MeshError::UnmatchedClassPattern { pattern, .. } => {
                        key.key("classes").key(pattern)
                    }
                    _ => key.key("file"),
                };
                self.problems.push((at, e.to_string()));
            }
        }
    }

    /// Height grids from raster files, generated, or given as data.
    fn add_terrains(&mut self, spec: &SceneSpec) {
        for t in &spec.terrains {
            let key = KeyPath::root().key("terrain").index(t.index);
            self.own(key.clone());
            let (grid, name) = match &t.source {
                TerrainSource::File(path, name) => (
                    crate::io::raster::read_raster(path).map_err(|e| (key.key("file"), e)),
                    format!("terrain[{}]:{name}", t.index),
                ),
                TerrainSource::Fbm(fbm) => (
                    crate::scene::terrain::generate_fbm(fbm)
                        .map_err(|e| (key.key("resolution_m"), e)),
                    format!("terrain[{}]:fbm", t.index),
                ),
                TerrainSource::Grid(grid) => (
                    Ok(HeightGrid::clone(grid)),
                    format!("terrain[{}]:data", t.index),
                ),
            };
            match grid {
                Ok(mut grid) => {
                    grid.shift(t.offset_m);
                    let m = self.scene.add_material(t.material.clone());
                    crate::scene::terrain::add_terrain(&mut self.scene, grid, m, t.class, name);
                }
                Err((at, e)) => self.problems.push((at, e.to_string())),
            }
        }
    }

    /// Point clouds from files or given as data, as voxels.
    fn add_clouds(&mut self, spec: &SceneSpec) {
        for cl in &spec.clouds {
            let key = KeyPath::root().key("point_cloud").index(cl.index);
            self.own(key.key("offset_m"));
            let placement = crate::scene::cloud::CloudPlacement {
                voxel_m: cl.voxel_m,
                offset_m: cl.offset_m,
                material: self.scene.add_material(cl.material.clone()),
                class: cl.class,
            };
            let loaded = match &cl.source {
                CloudSource::File(file) => {
                    crate::io::cloud::load_point_cloud(file, &placement, &mut self.scene)
                }
                CloudSource::Data(points) => crate::io::cloud::add_point_data(
                    &points.positions,
                    &points.classes,
                    &placement,
                    &format!("point_cloud[{}]:data", cl.index),
                    &mut self.scene,
                ),
            };
            if let Err(e) = loaded {
                self.problems.push((key.key("file"), e.to_string()));
            }
        }
    }

    /// The `[[tree]]` entries.
    fn add_trees(&mut self, spec: &SceneSpec) {
        for (i, tree) in &spec.trees {
            self.own(KeyPath::root().key("tree").index(*i).key("position_m"));
            self.scene
                .add_tree(tree, &spec.foliage, format!("tree[{i}]"));
        }
    }

    /// Reads the survey's `[[tree_table]]` files into the scene, each
    /// problem at its entry's `file` key; refuses more trees than a survey
    /// may hold.
    fn add_tree_tables(&mut self, survey: &Survey) {
        let spec = &survey.scene_spec;
        let mut trees = spec.trees.len();
        for t in &spec.tree_tables {
            let key = KeyPath::root().key("tree_table").index(t.index);
            let settings = TableSettings {
                offset_m: t.offset_m,
                species: t.species,
                seed: crate::rng::entry_seed(t.survey_seed, Purpose::TreeTableSeed, t.index),
            };
            let table = match read_tree_table(&t.path, &settings) {
                Ok(table) => table,
                Err(e) => {
                    self.problems.push((key.key("file"), e.to_string()));
                    continue;
                }
            };
            trees += table.len();
            if trees as f64 > crate::survey::MAX_TREES {
                self.problems.push((
                    key.key("file"),
                    format!(
                        "'{}' brings the survey to {trees} trees; a survey may hold at most {}",
                        t.path.display(),
                        num(crate::survey::MAX_TREES)
                    ),
                ));
                continue;
            }
            self.own(key.key("file"));
            let index = t.index as u32;
            self.scene
                .add_trees(&table, &spec.foliage, |tree| SceneObject::TableTree {
                    table: index,
                    tree,
                });
        }
    }

    /// The `[[forest]]` stands, placed on the scene so far. Trees stand on
    /// the ground (or road, water) below them, else on any surface, else
    /// at z = 0.
    fn add_forests(&mut self, spec: &SceneSpec) -> Stands {
        let mut stands = Stands {
            trees: Vec::new(),
            warnings: Vec::new(),
        };
        if spec.forests.is_empty() {
            return stands;
        }
        let ground = Bvh::build(self.scene.clone());
        let ground_z = |x: f64, y: f64| ground_below(&ground, DVec3::new(x, y, 1e6)).max(-1e5);
        for (i, f) in spec.forests.iter().enumerate() {
            let Some(f) = f else {
                stands.trees.push(0);
                continue;
            };
            let fp = KeyPath::root().key("forest").index(i);
            let trees = generate(f, &ground_z);
            let wanted = (polygon_area(&f.area) / 10_000.0 * f.stems_per_ha).round() as usize;
            if trees.len() < wanted {
                stands.warnings.push(format!(
                    "key `{fp}`: placed {} of {wanted} trees: min_spacing_m = {} m leaves no \
                     room for {} stems/ha",
                    trees.len(),
                    f.min_spacing_m,
                    f.stems_per_ha
                ));
            }
            stands.trees.push(trees.len());
            self.own(fp.clone());
            self.scene.add_stand(i, &trees, &spec.foliage);
        }
        stands
    }
}

/// Refuses primitives beyond any projected coordinate system, naming the
/// first entry that put one there: they cannot be traced in the index's
/// f32 boxes.
fn check_far(scene: &Scene, owners: &[Owner], problems: &mut Vec<(KeyPath, String)>) {
    let bounds = scene.bounds();
    if bounds.is_empty() {
        return;
    }
    let far = bounds.min.abs().max(bounds.max.abs()).max_element();
    if far <= MAX_COORDINATE_M {
        return;
    }
    let reach = |range: std::ops::Range<usize>| {
        scene.primitives[range].iter().fold(0.0f64, |m, p| {
            let b = p.bounds();
            m.max(b.min.abs().max(b.max.abs()).max_element())
        })
    };
    let key = owners
        .iter()
        .enumerate()
        .find(|(k, owner)| {
            let to = owners
                .get(k + 1)
                .map_or(scene.primitives.len(), |next| next.first);
            reach(owner.first..to) > MAX_COORDINATE_M
        })
        .map_or_else(KeyPath::root, |(_, owner)| owner.key.clone());
    problems.push((
        key,
        format!(
            "this part of the scene reaches {} m from the origin: coordinates must lie within \
             ±{MAX_COORDINATE_M:e} m (shift them, e.g. by a mesh's offset_m)",
            num(far)
        ),
    ));
}
