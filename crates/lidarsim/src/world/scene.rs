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
use crate::survey::spec::{CloudSource, MeshSource, TerrainSource};
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
    let root = KeyPath::root();
    let spec = &survey.scene_spec;
    let mut scene = Scene::default();
    let mut owners: Vec<(KeyPath, usize)> = Vec::new();
    for p in &spec.polygons {
        let key = root.key("polygon").index(p.index);
        owners.push((key.key("vertices_m"), scene.primitives.len()));
        let material = scene.add_material(p.material.clone());
        let object = scene.add_object(format!("polygon[{}]", p.index));
        scene.primitives.push(Primitive {
            shape: Shape::Polygon(Box::new(p.polygon.clone())),
            material,
            class: p.class,
            object,
        });
    }
    for m in &spec.meshes {
        let key = root.key("mesh").index(m.index);
        owners.push((key.key("offset_m"), scene.primitives.len()));
        let loaded = match &m.source {
            MeshSource::Gltf(file) => {
                crate::io::gltf::load_gltf(file, &m.placement, &survey.materials, &mut scene)
            }
            MeshSource::Obj(file) => {
                crate::io::obj::load_obj(file, &m.placement, &survey.materials, &mut scene)
            }
            MeshSource::Data(data) => match &m.placement.default_material {
                // Faces within the vertices were checked when it was added.
                Some(material) => {
                    let material = scene.add_material(material.clone());
                    let name = format!("mesh[{}]:data", m.index);
                    Ok(m.placement.add_triangles(
                        &mut scene,
                        &data.vertices,
                        &data.faces,
                        material,
                        name,
                    ))
                }
                None => {
                    problems.push((key.key("material"), "is required".to_string()));
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
            problems.push((at, e.to_string()));
        }
    }
    for t in &spec.terrains {
        let key = root.key("terrain").index(t.index);
        owners.push((key.clone(), scene.primitives.len()));
        let (grid, name) = match &t.source {
            TerrainSource::File(path, name) => (
                crate::io::raster::read_raster(path).map_err(|e| (key.key("file"), e)),
                format!("terrain[{}]:{name}", t.index),
            ),
            TerrainSource::Fbm(fbm) => (
                crate::scene::terrain::generate_fbm(fbm).map_err(|e| (key.key("resolution_m"), e)),
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
                let m = scene.add_material(t.material.clone());
                crate::scene::terrain::add_terrain(&mut scene, grid, m, t.class, name);
            }
            Err((at, e)) => problems.push((at, e.to_string())),
        }
    }
    for cl in &spec.clouds {
        let key = root.key("point_cloud").index(cl.index);
        owners.push((key.key("offset_m"), scene.primitives.len()));
        let placement = crate::scene::cloud::CloudPlacement {
            voxel_m: cl.voxel_m,
            offset_m: cl.offset_m,
            material: scene.add_material(cl.material.clone()),
            class: cl.class,
        };
        let loaded = match &cl.source {
            CloudSource::File(file) => {
                crate::io::cloud::load_point_cloud(file, &placement, &mut scene)
            }
            CloudSource::Data(points) => crate::io::cloud::add_point_data(
                &points.positions,
                &points.classes,
                &placement,
                &format!("point_cloud[{}]:data", cl.index),
                &mut scene,
            ),
        };
        if let Err(e) = loaded {
            problems.push((key.key("file"), e.to_string()));
        }
    }
    let foliage = &spec.foliage;
    for (i, tree) in &spec.trees {
        owners.push((
            root.key("tree").index(*i).key("position_m"),
            scene.primitives.len(),
        ));
        scene.add_tree(tree, foliage, format!("tree[{i}]"));
    }
    add_tree_tables(&mut scene, survey, &mut owners, problems);
    let mut forest_trees = Vec::new();
    let mut warnings = Vec::new();
    if spec.forests.is_empty() {
        check_far(&scene, &owners, problems);
        let (index, index_time_s) = index(scene);
        return Built {
            index,
            forest_trees,
            warnings,
            index_time_s,
        };
    }
    // Trees stand on the ground (or road, water) below them, else on any
    // surface, else at z = 0.
    let ground = Bvh::build(scene.clone());
    let ground_z = |x: f64, y: f64| ground_below(&ground, DVec3::new(x, y, 1e6)).max(-1e5);
    for (i, f) in spec.forests.iter().enumerate() {
        let Some(f) = f else {
            forest_trees.push(0);
            continue;
        };
        let fp = root.key("forest").index(i);
        let trees = generate(f, &ground_z);
        let wanted = (polygon_area(&f.area) / 10_000.0 * f.stems_per_ha).round() as usize;
        if trees.len() < wanted {
            warnings.push(format!(
                "key `{fp}`: placed {} of {wanted} trees: min_spacing_m = {} m leaves no room \
                 for {} stems/ha",
                trees.len(),
                f.min_spacing_m,
                f.stems_per_ha
            ));
        }
        forest_trees.push(trees.len());
        owners.push((fp.clone(), scene.primitives.len()));
        scene.add_stand(i, &trees, foliage);
    }
    check_far(&scene, &owners, problems);
    let (index, index_time_s) = index(scene);
    Built {
        index,
        forest_trees,
        warnings,
        index_time_s,
    }
}

/// Reads the survey's `[[tree_table]]` files into `scene`, each problem at
/// its entry's `file` key; refuses more trees than a survey may hold.
fn add_tree_tables(
    scene: &mut Scene,
    survey: &Survey,
    owners: &mut Vec<(KeyPath, usize)>,
    problems: &mut Vec<(KeyPath, String)>,
) {
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
                problems.push((key.key("file"), e.to_string()));
                continue;
            }
        };
        trees += table.len();
        if trees as f64 > crate::survey::MAX_TREES {
            problems.push((
                key.key("file"),
                format!(
                    "'{}' brings the survey to {trees} trees; a survey may hold at most {}",
                    t.path.display(),
                    num(crate::survey::MAX_TREES)
                ),
            ));
            continue;
        }
        owners.push((key.key("file"), scene.primitives.len()));
        let index = t.index as u32;
        scene.add_trees(&table, &spec.foliage, |tree| SceneObject::TableTree {
            table: index,
            tree,
        });
    }
}

/// Refuses primitives beyond any projected coordinate system, naming the
/// first entry that put one there: they cannot be traced in the index's
/// f32 boxes.
fn check_far(scene: &Scene, owners: &[(KeyPath, usize)], problems: &mut Vec<(KeyPath, String)>) {
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
        .find(|(k, (_, from))| {
            let to = owners
                .get(k + 1)
                .map_or(scene.primitives.len(), |(_, t)| *t);
            reach(*from..to) > MAX_COORDINATE_M
        })
        .map_or_else(KeyPath::root, |(_, (key, _))| key.clone());
    problems.push((
        key,
        format!(
            "this part of the scene reaches {} m from the origin: coordinates must lie within \
             ±{MAX_COORDINATE_M:e} m (shift them, e.g. by a mesh's offset_m)",
            num(far)
        ),
    ));
}
