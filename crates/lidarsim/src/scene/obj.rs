//! Triangle meshes from Wavefront OBJ files with their MTL materials.
//!
//! Material of a face: the survey's `[materials.NAME]` entry when the OBJ's
//! `usemtl NAME` matches one, otherwise the MTL material of that name, whose
//! reflectance is the MTL key `reflectance` if present, else the mean of the
//! diffuse colour `Kd`; its incidence exponent is the MTL key
//! `incidence_exponent` (default 1, Lambertian). Faces before any `usemtl`
//! take the mesh entry's default material.
//!
//! Class of a face: the survey's `classes` table entry whose pattern matches
//! the OBJ group/object name (`"wall*" = "wall"`; `*` matches any run of
//! characters; an exact name wins over patterns, then the pattern with the
//! most literal characters), else the MTL key `class` of its material, else
//! the first word of the group/object name that names a class (`g roof_1`,
//! `o wall-north`), else the mesh entry's default class. A pattern that
//! matches no group or object of the file is an error (a typo would
//! otherwise change nothing).

use std::collections::HashMap;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use super::{Material, Primitive, Scene, Shape, SurfaceClass, Triangle};
use crate::geometry::{DMat3, DVec3};

/// Why a mesh could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The mesh file (OBJ or glTF) could not be read.
    #[error("cannot read mesh file '{path}': {source}")]
    Read {
        /// File that failed.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The OBJ parser rejected the file.
    #[error("'{path}' is not a valid OBJ file: {reason}")]
    Parse {
        /// File that failed.
        path: PathBuf,
        /// The parser's reason.
        reason: String,
    },
    /// An MTL library named by `mtllib` could not be loaded.
    #[error("'{path}' line {line}: cannot load material library '{library}': {reason}")]
    MaterialLibrary {
        /// OBJ file.
        path: PathBuf,
        /// Line of the `mtllib` statement.
        line: usize,
        /// The library as named in the OBJ file.
        library: String,
        /// Why it failed.
        reason: String,
    },
    /// `usemtl` names a material found neither in the MTL files nor in the
    /// survey's `[materials]`.
    #[error(
        "'{path}' line {line}: material '{name}' is defined neither in the OBJ's MTL files \
         nor in the survey's [materials]"
    )]
    UnknownMaterial {
        /// OBJ file.
        path: PathBuf,
        /// Line of the `usemtl` statement.
        line: usize,
        /// Material name.
        name: String,
    },
    /// A material's parameters are out of range.
    #[error("material '{name}': {reason}")]
    BadMaterial {
        /// Material name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// Faces come before any `usemtl` and the mesh entry names no default
    /// material.
    #[error(
        "'{path}': faces before the first 'usemtl' have no material; set the mesh's \
         `material` key"
    )]
    NoMaterial {
        /// OBJ file.
        path: PathBuf,
    },
    /// A glTF file could not be read or breaks the glTF 2.0 specification.
    #[error("'{path}': {reason}")]
    Gltf {
        /// The glTF file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A `classes` pattern matches no group or object name of the file.
    #[error("'{path}': no group or object name matches '{pattern}' (names in the file: {names})")]
    UnmatchedClassPattern {
        /// OBJ file.
        path: PathBuf,
        /// The pattern.
        pattern: String,
        /// The file's group/object names, comma separated.
        names: String,
    },
    /// The file holds no usable triangle.
    #[error("'{path}' holds no triangle with three distinct, finite corners")]
    Empty {
        /// OBJ file.
        path: PathBuf,
    },
}

/// Name of the pseudo material library holding the survey's materials.
/// The first line of an OBJ text that cannot be read, and why: bytes that
/// are not UTF-8, a vertex without three numbers, a face corner that is not
/// an index of a vertex defined before it (OBJ indices start at 1; negative
/// ones count back from the last vertex). The OBJ parser names no line, so
/// this finds it for the message.
pub fn first_bad_line(text: &[u8]) -> Option<(usize, String)> {
    let mut vertices: i64 = 0;
    for (i, raw) in text.split(|&b| b == b'\n').enumerate() {
        let n = i + 1;
        let Ok(line) = std::str::from_utf8(raw) else {
            return Some((n, "not valid UTF-8".to_string()));
        };
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let numbers = words.take(3).filter(|w| w.parse::<f64>().is_ok()).count();
                if numbers < 3 {
                    return Some((
                        n,
                        format!("vertex '{}' needs three numbers x y z", line.trim()),
                    ));
                }
                vertices += 1;
            }
            Some("f") => {
                for w in words {
                    let index = w.split('/').next().unwrap_or("");
                    let Ok(k) = index.parse::<i64>() else {
                        return Some((
                            n,
                            format!("face corner '{w}' is not a vertex index (or too large)"),
                        ));
                    };
                    if k == 0 {
                        return Some((n, "face corner 0: OBJ indices start at 1".to_string()));
                    }
                    if k > vertices || -k > vertices {
                        return Some((
                            n,
                            format!(
                                "face corner {k} refers to no vertex ({vertices} defined so far)"
                            ),
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    None
}

const SURVEY_LIBRARY: &str = "<survey materials>";

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

/// Whether `name` matches `pattern`, where `*` stands for any run of
/// characters (possibly empty) and everything else for itself.
pub fn glob_match(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == name;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if name.len() < first.len() + last.len() || !name.starts_with(first) || !name.ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    true
}

/// The class the `class_map` gives a group/object name: an exact name
/// first, then the matching pattern with the most literal characters (the
/// first in `map` order among equals).
pub(crate) fn mapped_class(map: &[(String, SurfaceClass)], name: &str) -> Option<SurfaceClass> {
    map.iter()
        .enumerate()
        .filter(|(_, (p, _))| glob_match(p, name))
        .max_by_key(|(i, (p, _))| {
            (
                !p.contains('*'),
                p.chars().filter(|c| *c != '*').count(),
                std::cmp::Reverse(*i),
            )
        })
        .map(|(_, (_, c))| *c)
}

/// Loads an OBJ file into `scene` as triangles belonging to a new object.
///
/// `survey_materials` are the survey's `[materials]`, which take precedence
/// over MTL materials of the same name. Returns the number of triangles
/// added. Degenerate faces are skipped (and counted in the second value).
pub fn load_obj(
    path: &Path,
    placement: &MeshPlacement,
    survey_materials: &HashMap<String, Material>,
    scene: &mut Scene,
) -> Result<(usize, usize), MeshError> {
    let text = std::fs::read(path).map_err(|source| MeshError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or(Path::new("."));

    // Collect `mtllib` and `usemtl` statements with their lines first, so
    // that errors can name the line (the OBJ parser does not).
    let mut libraries = Vec::new();
    let mut uses = Vec::new();
    for (i, raw) in text.split(|&b| b == b'\n').enumerate() {
        let line = String::from_utf8_lossy(raw);
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("mtllib ") {
            libraries.push((i + 1, rest.trim().to_string()));
        } else if let Some(rest) = line.strip_prefix("usemtl ") {
            uses.push((i + 1, rest.trim().to_string()));
        }
    }
    let mut mtl_errors = Vec::new();
    for (line, lib) in &libraries {
        if let Err(e) = tobj::load_mtl(base.join(lib)) {
            mtl_errors.push(MeshError::MaterialLibrary {
                path: path.to_path_buf(),
                line: *line,
                library: lib.clone(),
                reason: describe_load_error(&e, &base.join(lib)),
            });
        }
    }
    if let Some(e) = mtl_errors.into_iter().next() {
        return Err(e);
    }

    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // The survey's materials are offered to the OBJ parser as one more
    // material library, named by a line put in front of the file, so that
    // `usemtl NAME` of a survey-only material starts its own group of faces.
    let prefix = format!("mtllib {SURVEY_LIBRARY}\n").into_bytes();
    let mut source = BufReader::new(std::io::Read::chain(&prefix[..], &text[..]));
    let (models, materials) = tobj::load_obj_buf(&mut source, &options, |p| {
        if p == Path::new(SURVEY_LIBRARY) {
            let mut names: Vec<&String> = survey_materials.keys().collect();
            names.sort();
            let list = names
                .iter()
                .map(|n| tobj::Material {
                    name: (*n).clone(),
                    ..Default::default()
                })
                .collect();
            let index = names
                .iter()
                .enumerate()
                .map(|(i, n)| ((*n).clone(), i))
                .collect();
            Ok((list, index))
        } else {
            tobj::load_mtl(base.join(p))
        }
    })
    .map_err(|e| MeshError::Parse {
        path: path.to_path_buf(),
        reason: match first_bad_line(&text) {
            Some((line, why)) => format!("line {line}: {why}"),
            None => e.to_string(),
        },
    })?;
    let mtl_materials = materials.unwrap_or_default();

    for (line, name) in &uses {
        if !survey_materials.contains_key(name) && !mtl_materials.iter().any(|m| &m.name == name) {
            return Err(MeshError::UnknownMaterial {
                path: path.to_path_buf(),
                line: *line,
                name: name.clone(),
            });
        }
    }

    // Resolve every MTL material to a scene material and class hint.
    let mut resolved: Vec<(u32, Option<SurfaceClass>)> = Vec::with_capacity(mtl_materials.len());
    for m in &mtl_materials {
        let class_hint = match m.unknown_param.get("class") {
            None => None,
            Some(c) => Some(
                SurfaceClass::from_name(c).ok_or_else(|| MeshError::BadMaterial {
                    name: m.name.clone(),
                    reason: format!(
                        "unknown class '{c}'; expected one of: {}",
                        SurfaceClass::ALL.map(|(n, _)| n).join(", ")
                    ),
                })?,
            ),
        };
        let material = match survey_materials.get(&m.name) {
            Some(sm) => sm.clone(),
            None => mtl_to_material(m)?,
        };
        resolved.push((scene.add_material(material), class_hint));
    }
    let default_material = placement
        .default_material
        .clone()
        .map(|m| scene.add_material(m));

    for (pattern, _) in &placement.class_map {
        if !models.iter().any(|m| glob_match(pattern, &m.name)) {
            let mut names: Vec<&str> = models.iter().map(|m| m.name.as_str()).collect();
            names.dedup();
            return Err(MeshError::UnmatchedClassPattern {
                path: path.to_path_buf(),
                pattern: pattern.clone(),
                names: if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                },
            });
        }
    }

    let object = scene.add_object(format!("mesh:{}", path.display()));
    let rotation = DMat3::from_rotation_z(placement.rotation_z_rad);
    let place = |x: f64, y: f64, z: f64| {
        rotation * (DVec3::new(x, y, z) * placement.scale) + placement.offset_m
    };
    let (mut added, mut skipped) = (0usize, 0usize);
    for model in &models {
        let mesh = &model.mesh;
        let (material, class_hint) = match mesh.material_id {
            Some(id) => *resolved.get(id).ok_or_else(|| MeshError::Parse {
                path: path.to_path_buf(),
                reason: format!(
                    "object '{}' uses a material that was not loaded",
                    model.name
                ),
            })?,
            None => match default_material {
                Some(m) => (m, None),
                None if mesh.indices.is_empty() => continue,
                None => {
                    return Err(MeshError::NoMaterial {
                        path: path.to_path_buf(),
                    });
                }
            },
        };
        let class = mapped_class(&placement.class_map, &model.name)
            .or(class_hint)
            .or_else(|| class_from_name(&model.name))
            .unwrap_or(placement.default_class);
        let corner = |k: u32| {
            let k = k as usize * 3;
            match mesh.positions.get(k..k + 3) {
                Some(p) => place(p[0], p[1], p[2]),
                None => DVec3::NAN,
            }
        };
        for face in mesh.indices.chunks_exact(3) {
            match Triangle::new(corner(face[0]), corner(face[1]), corner(face[2])) {
                Some(t) => {
                    scene.primitives.push(Primitive {
                        shape: Shape::Triangle(t),
                        material,
                        class,
                        object,
                    });
                    added += 1;
                }
                None => skipped += 1,
            }
        }
    }
    if added == 0 {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok((added, skipped))
}

fn describe_load_error(e: &tobj::LoadError, path: &Path) -> String {
    match e {
        tobj::LoadError::OpenFileFailed => match std::fs::metadata(path) {
            Err(io) => io.to_string(),
            Ok(_) => "the file cannot be opened".to_string(),
        },
        other => other.to_string(),
    }
}

fn mtl_to_material(m: &tobj::Material) -> Result<Material, MeshError> {
    let bad = |reason: String| MeshError::BadMaterial {
        name: m.name.clone(),
        reason,
    };
    let reflectance = match m.unknown_param.get("reflectance") {
        Some(s) => s
            .trim()
            .parse::<f64>()
            .map_err(|_| bad(format!("reflectance '{s}' is not a number")))?,
        None => match m.diffuse {
            Some(kd) => (kd[0] + kd[1] + kd[2]) / 3.0,
            None => {
                return Err(bad(
                    "has neither a `reflectance` key nor a diffuse colour `Kd`".to_string(),
                ));
            }
        },
    };
    if !(0.0..=1.0).contains(&reflectance) {
        return Err(bad(format!("reflectance {reflectance} is outside 0–1")));
    }
    let incidence_exponent = match m.unknown_param.get("incidence_exponent") {
        Some(s) => s
            .trim()
            .parse::<f64>()
            .map_err(|_| bad(format!("incidence_exponent '{s}' is not a number")))?,
        None => 1.0,
    };
    if !(incidence_exponent.is_finite() && incidence_exponent >= 0.0) {
        return Err(bad(format!(
            "incidence_exponent {incidence_exponent} must be ≥ 0"
        )));
    }
    Ok(Material {
        name: m.name.clone(),
        reflectance,
        incidence_exponent,
    })
}

/// The first word of an OBJ object/group name that names a class.
pub(crate) fn class_from_name(name: &str) -> Option<SurfaceClass> {
    name.split(|c: char| !c.is_ascii_alphanumeric())
        .find_map(SurfaceClass::from_name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glob_patterns() {
        assert!(glob_match("wall*", "wall_north"));
        assert!(glob_match("wall*", "wall"));
        assert!(!glob_match("wall*", "awall"));
        assert!(glob_match("*roof*", "house_roof_2"));
        assert!(glob_match("a*b*c", "axxbyyc"));
        assert!(!glob_match("a*b*c", "axxcyyb"));
        assert!(!glob_match("ab*ba", "aba"));
        assert!(glob_match("roof", "roof") && !glob_match("roof", "roofs"));
        let map = vec![
            ("*".to_string(), SurfaceClass::Unclassified),
            ("wall*".to_string(), SurfaceClass::Wall),
            ("wall_glass".to_string(), SurfaceClass::Water),
            ("w*".to_string(), SurfaceClass::Road),
        ];
        assert_eq!(mapped_class(&map, "wall_glass"), Some(SurfaceClass::Water));
        assert_eq!(mapped_class(&map, "wall_1"), Some(SurfaceClass::Wall));
        assert_eq!(mapped_class(&map, "window"), Some(SurfaceClass::Road));
        assert_eq!(
            mapped_class(&map, "chimney"),
            Some(SurfaceClass::Unclassified)
        );
        assert_eq!(mapped_class(&map[1..], "chimney"), None);
    }

    #[test]
    fn class_map_overrides_mtl_and_name_hints_and_unmatched_patterns_fail() {
        let dir = std::env::temp_dir().join(format!("lidarsim-objmap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("m.mtl"),
            "newmtl tiles\nKd 0.5 0.5 0.5\nclass roof\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("m.obj"),
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl tiles\n\
             g Dach_1\nf 1 2 3\ng Mauer_Nord\nf 1 2 3\ng wall_x\nf 1 2 3\ng other\nf 1 2 3\n",
        )
        .unwrap();
        let placement = |map: &[(&str, SurfaceClass)]| MeshPlacement {
            scale: 1.0,
            rotation_z_rad: 0.0,
            offset_m: DVec3::ZERO,
            default_class: SurfaceClass::Ground,
            default_material: None,
            class_map: map.iter().map(|(p, c)| (p.to_string(), *c)).collect(),
        };
        let mut scene = Scene::default();
        let map = [
            ("Dach*", SurfaceClass::Bridge),
            ("Mauer*", SurfaceClass::Wall),
        ];
        load_obj(
            &dir.join("m.obj"),
            &placement(&map),
            &HashMap::new(),
            &mut scene,
        )
        .unwrap();
        let classes: Vec<SurfaceClass> = scene.primitives.iter().map(|p| p.class).collect();
        // Dach_1 and Mauer_Nord by the map (over the MTL's roof); wall_x and
        // other keep the MTL class.
        assert_eq!(
            classes,
            [
                SurfaceClass::Bridge,
                SurfaceClass::Wall,
                SurfaceClass::Roof,
                SurfaceClass::Roof
            ]
        );
        let e = load_obj(
            &dir.join("m.obj"),
            &placement(&[("Wand*", SurfaceClass::Wall)]),
            &HashMap::new(),
            &mut scene,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("'Wand*'") && e.contains("Mauer_Nord"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn class_hints_from_group_names() {
        assert_eq!(class_from_name("roof_1"), Some(SurfaceClass::Roof));
        assert_eq!(class_from_name("north-wall"), Some(SurfaceClass::Wall));
        assert_eq!(class_from_name("thing"), None);
    }

    #[test]
    fn loads_obj_with_mtl_materials_and_classes() {
        let dir = std::env::temp_dir().join(format!("lidarsim-obj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("h.mtl"),
            "newmtl tiles\nKd 0.2 0.4 0.6\nclass roof\n\nnewmtl paint\nreflectance 0.7\nincidence_exponent 2\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("h.obj"),
            "mtllib h.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
             g top\nusemtl tiles\nf 1 2 3 4\ng wall_a\nusemtl paint\nf 1 2 3\n",
        )
        .unwrap();
        let mut scene = Scene::default();
        let placement = MeshPlacement {
            scale: 2.0,
            rotation_z_rad: 0.0,
            offset_m: DVec3::new(10.0, 0.0, 0.0),
            default_class: SurfaceClass::Unclassified,
            default_material: None,
            class_map: Vec::new(),
        };
        let (added, skipped) =
            load_obj(&dir.join("h.obj"), &placement, &HashMap::new(), &mut scene).unwrap();
        assert_eq!((added, skipped), (3, 0));
        let roof: Vec<_> = scene
            .primitives
            .iter()
            .filter(|p| p.class == SurfaceClass::Roof)
            .collect();
        assert_eq!(roof.len(), 2);
        let m = &scene.materials[roof[0].material as usize];
        assert!((m.reflectance - 0.4).abs() < 1e-12);
        let wall = scene
            .primitives
            .iter()
            .find(|p| p.class == SurfaceClass::Wall)
            .unwrap();
        let m = &scene.materials[wall.material as usize];
        assert_eq!((m.reflectance, m.incidence_exponent), (0.7, 2.0));
        let b = scene.bounds();
        assert_eq!(b.min, DVec3::new(10.0, 0.0, 0.0));
        assert_eq!(b.max, DVec3::new(12.0, 2.0, 0.0));

        // `usemtl` of a material defined only in the survey, and two MTL
        // materials of the same name with different values in two meshes.
        std::fs::write(
            dir.join("s.obj"),
            "mtllib h.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl paint\nf 1 2 3\n\
             usemtl survey_only\nf 1 2 3\n",
        )
        .unwrap();
        std::fs::write(dir.join("h2.mtl"), "newmtl paint\nreflectance 0.1\n").unwrap();
        std::fs::write(
            dir.join("t.obj"),
            "mtllib h2.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl paint\nf 1 2 3\n",
        )
        .unwrap();
        let mut survey = HashMap::new();
        survey.insert(
            "survey_only".to_string(),
            Material {
                name: "survey_only".into(),
                reflectance: 0.33,
                incidence_exponent: 1.0,
            },
        );
        let mut scene = Scene::default();
        load_obj(&dir.join("s.obj"), &placement, &survey, &mut scene).unwrap();
        load_obj(&dir.join("t.obj"), &placement, &survey, &mut scene).unwrap();
        let refl: Vec<f64> = scene
            .primitives
            .iter()
            .map(|p| scene.materials[p.material as usize].reflectance)
            .collect();
        assert_eq!(refl, [0.7, 0.33, 0.1]);

        // A class an MTL names that does not exist is an error.
        std::fs::write(dir.join("c.mtl"), "newmtl x\nKd 0.5 0.5 0.5\nclass rooof\n").unwrap();
        std::fs::write(
            dir.join("c.obj"),
            "mtllib c.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl x\nf 1 2 3\n",
        )
        .unwrap();
        let e = load_obj(&dir.join("c.obj"), &placement, &survey, &mut scene).unwrap_err();
        assert!(e.to_string().contains("unknown class 'rooof'"), "{e}");

        // A usemtl that nothing defines is an error naming the line.
        std::fs::write(
            dir.join("bad.obj"),
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl nope\nf 1 2 3\n",
        )
        .unwrap();
        let e = load_obj(
            &dir.join("bad.obj"),
            &placement,
            &HashMap::new(),
            &mut scene,
        )
        .unwrap_err();
        assert!(
            matches!(e, MeshError::UnknownMaterial { line: 4, .. }),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
