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

use crate::geometry::MAX_COORDINATE_M;
use std::collections::HashMap;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use crate::geometry::{DMat3, DVec3};
use crate::scene::{Material, MeshPlacement, Primitive, Scene, Shape, SurfaceClass, Triangle};

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

/// Faces of one OBJ group or object with one material: corners are
/// indices into `positions` (x, y, z per vertex), three per triangle.
struct Group<'a> {
    name: &'a str,
    material_id: Option<usize>,
    positions: &'a [f64],
    indices: &'a [u32],
}

/// The OBJ parser's reading of `text` (the file at `path`), with the
/// survey's materials offered as one more library and every `mtllib` and
/// `usemtl` checked with its line.
fn parse_with_tobj(
    text: &[u8],
    path: &Path,
    base: &Path,
    survey_materials: &HashMap<String, Material>,
) -> Result<(Vec<tobj::Model>, Vec<tobj::Material>), MeshError> {
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
        if let Err(e) =
            crate::io::input::check_input(&base.join(lib), crate::io::input::MAX_INPUT_BYTES)
        {
            mtl_errors.push(MeshError::MaterialLibrary {
                path: path.to_path_buf(),
                line: *line,
                library: lib.clone(),
                reason: e.to_string(),
            });
        } else if let Err(e) = tobj::load_mtl(base.join(lib)) {
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
    let mut source = BufReader::new(std::io::Read::chain(&prefix[..], text));
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
        reason: match first_bad_line(text) {
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
    Ok((models, mtl_materials))
}

/// The OBJ parser's models as groups of faces.
fn tobj_groups(models: &[tobj::Model]) -> Vec<Group<'_>> {
    models
        .iter()
        .map(|m| Group {
            name: &m.name,
            material_id: m.mesh.material_id,
            positions: &m.mesh.positions,
            indices: &m.mesh.indices,
        })
        .collect()
}

/// An OBJ file of the plainest kind, read without the OBJ parser: its
/// vertices and, per group, triangles.
struct PlainObj {
    positions: Vec<f64>,
    /// Group name and its corner indices (0-based, three per triangle).
    groups: Vec<(String, Vec<u32>)>,
}

impl PlainObj {
    fn groups(&self) -> Vec<Group<'_>> {
        self.groups
            .iter()
            .map(|(name, indices)| Group {
                name,
                material_id: None,
                positions: &self.positions,
                indices,
            })
            .collect()
    }
}

/// Reads `text` if it holds only blank lines, `#` comments, `s` lines,
/// vertices `v x y z`, triangles `f i j k` of vertex indices (1-based, or
/// negative from the last vertex) of vertices defined before them, and
/// `o`/`g` names; `None` for anything else (materials, texture
/// coordinates, normals, polygons, problems), which the OBJ parser reads.
/// The result is the OBJ parser's to the bit: the same numbers (both parse
/// with `str::parse::<f64>`), the same groups (a name closes the faces
/// before it; the last group always counts, as the parser keeps it).
fn plain_obj(text: &[u8]) -> Option<PlainObj> {
    let mut positions: Vec<f64> = Vec::with_capacity(text.len() / 40);
    let mut groups = Vec::new();
    let mut name = "unnamed_object".to_string();
    let mut faces: Vec<u32> = Vec::new();
    for raw in text.split(|&b| b == b'\n') {
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let line = std::str::from_utf8(raw).ok()?;
        let mut words = line.split_whitespace();
        match words.next() {
            None | Some("#") | Some("s") => {}
            Some("v") => {
                for _ in 0..3 {
                    let v = words.next()?.parse::<f64>().ok()?;
                    // A bad coordinate is reported by the full parser's path.
                    if v.is_nan() || v.abs() > MAX_COORDINATE_M {
                        return None;
                    }
                    positions.push(v);
                }
                if words.next().is_some() {
                    return None;
                }
            }
            Some("f") => {
                let defined = (positions.len() / 3) as i64;
                for _ in 0..3 {
                    let k: i64 = words.next()?.parse().ok()?;
                    let index = if k > 0 { k - 1 } else { defined + k };
                    if !(0..defined).contains(&index) {
                        return None;
                    }
                    faces.push(index as u32);
                }
                if words.next().is_some() {
                    return None;
                }
            }
            Some("o") | Some("g") if line.starts_with(['o', 'g']) => {
                if !faces.is_empty() {
                    groups.push((std::mem::take(&mut name), std::mem::take(&mut faces)));
                }
                name = line[1..].trim().to_string();
                if name.is_empty() {
                    name = "unnamed_object".to_string();
                }
            }
            Some(_) => return None,
        }
    }
    groups.push((name, faces));
    Some(PlainObj { positions, groups })
}

/// The first vertex (`v x y z`) with a coordinate that is not a finite
/// number within ±[`MAX_COORDINATE_M`]: its 1-based line and what is wrong
/// (the OBJ parser would let it through and the faces using it would be
/// dropped as degenerate without a word).
fn bad_vertex(text: &[u8]) -> Option<(usize, String)> {
    for (i, raw) in text.split(|&b| b == b'\n').enumerate() {
        let line = String::from_utf8_lossy(raw);
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        for w in words.take(3) {
            if let Ok(v) = w.parse::<f64>()
                && (v.is_nan() || v.abs() > MAX_COORDINATE_M)
            {
                return Some((
                    i + 1,
                    format!(
                        "vertex coordinate '{w}' is not a finite number within ±{MAX_COORDINATE_M:e} m"
                    ),
                ));
            }
        }
    }
    None
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
    let text = crate::io::input::read_input(path, crate::io::input::MAX_INPUT_BYTES).map_err(
        |source| MeshError::Read {
            path: path.to_path_buf(),
            source,
        },
    )?;
    let base = path.parent().unwrap_or(Path::new("."));
    // Plain files (vertices, triangles, groups) take the fast reader; the
    // others, and every file with a problem to report, the OBJ parser.
    let plain = plain_obj(&text);
    let parsed;
    let (groups, mtl_materials) = match &plain {
        Some(p) => (p.groups(), Vec::new()),
        None => {
            if let Some((line, why)) = bad_vertex(&text) {
                return Err(MeshError::Parse {
                    path: path.to_path_buf(),
                    reason: format!("line {line}: {why}"),
                });
            }
            parsed = parse_with_tobj(&text, path, base, survey_materials)?;
            (tobj_groups(&parsed.0), parsed.1.clone())
        }
    };

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
        if !groups.iter().any(|g| glob_match(pattern, g.name)) {
            let mut names: Vec<&str> = groups.iter().map(|g| g.name).collect();
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
    for group in &groups {
        let (material, class_hint) = match group.material_id {
            Some(id) => *resolved.get(id).ok_or_else(|| MeshError::Parse {
                path: path.to_path_buf(),
                reason: format!(
                    "object '{}' uses a material that was not loaded",
                    group.name
                ),
            })?,
            None => match default_material {
                Some(m) => (m, None),
                None if group.indices.is_empty() => continue,
                None => {
                    return Err(MeshError::NoMaterial {
                        path: path.to_path_buf(),
                    });
                }
            },
        };
        let class = mapped_class(&placement.class_map, group.name)
            .or(class_hint)
            .or_else(|| class_from_name(group.name))
            .unwrap_or(placement.default_class);
        let corner = |k: u32| {
            let k = k as usize * 3;
            match group.positions.get(k..k + 3) {
                Some(p) => place(p[0], p[1], p[2]),
                None => DVec3::NAN,
            }
        };
        for face in group.indices.chunks_exact(3) {
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

    /// Per group: name, material and each triangle's corner coordinates.
    type Faces = Vec<(String, Option<usize>, Vec<[f64; 9]>)>;

    fn faces(groups: &[Group]) -> Faces {
        groups
            .iter()
            .map(|g| {
                let corner = |k: u32| &g.positions[k as usize * 3..k as usize * 3 + 3];
                let tris = g
                    .indices
                    .chunks_exact(3)
                    .map(|f| {
                        let mut t = [0.0; 9];
                        for (i, &k) in f.iter().enumerate() {
                            t[3 * i..3 * i + 3].copy_from_slice(corner(k));
                        }
                        t
                    })
                    .collect();
                (g.name.to_string(), g.material_id, tris)
            })
            .collect()
    }

    /// The fast reader of plain files gives the OBJ parser's groups and
    /// corners to the bit, and leaves every other kind of file to it.
    #[test]
    fn plain_reader_matches_the_obj_parser() {
        let plain = [
            "v 0 0 0\nv 1 0 0\nv 0 1 0.1\nf 1 2 3\n",
            "# comment\n\ng roof_1\nv 0.1 0.2 0.3\nv 1e1 -2.5 3\r\nv 7 8 9.000000001\ns off\nf -3 -2 -1\nf 3 1 2\n\
             o wall north\ng empty\ng\nv 5 5 5\nf 1 2 4\ng last\n",
            "g a\nv 1 2 3\nv 4 5 6\nv 7 8 10\nf 1 2 3\ng b\nf 2 3 1\ng a\nf 3 1 2\n",
            "",
        ];
        let dir = std::env::temp_dir();
        for (i, text) in plain.iter().enumerate() {
            let fast = plain_obj(text.as_bytes()).unwrap_or_else(|| panic!("case {i} not plain"));
            let (models, _) =
                parse_with_tobj(text.as_bytes(), Path::new("t.obj"), &dir, &HashMap::new())
                    .unwrap();
            let parsed = tobj_groups(&models);
            assert_eq!(faces(&fast.groups()), faces(&parsed), "case {i}");
        }
        // Boxes as the benchmark writes them: a group per box, 12
        // triangles each, indices counted from the file's start.
        let path = dir.join("boxes.obj");
        let mut text = String::new();
        for b in 0..5 {
            text.push_str(&format!("g box_{b}\n"));
            for k in 0..8 {
                let (x, y, z) = (b * 20 + (k & 1) * 10, ((k >> 1) & 1) * 10, (k >> 2) * 8);
                text.push_str(&format!("v {x} {y} {z}\n"));
            }
            let o = b * 8;
            for f in [
                [1, 3, 4],
                [1, 4, 2],
                [5, 6, 8],
                [5, 8, 7],
                [1, 2, 6],
                [1, 6, 5],
                [3, 7, 8],
                [3, 8, 4],
                [1, 5, 7],
                [1, 7, 3],
                [2, 4, 8],
                [2, 8, 6],
            ] {
                text.push_str(&format!("f {} {} {}\n", o + f[0], o + f[1], o + f[2]));
            }
        }
        let text = text.into_bytes();
        let fast = plain_obj(&text).unwrap();
        let (models, _) = parse_with_tobj(&text, &path, &dir, &HashMap::new()).unwrap();
        let parsed = tobj_groups(&models);
        assert!(faces(&parsed).iter().map(|g| g.2.len()).sum::<usize>() > 50);
        assert_eq!(faces(&fast.groups()), faces(&parsed));
        // Anything else is the parser's.
        for other in [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n",
            "v 0 0 0\nvt 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n",
            "v 0 0 0 1\n",
            "usemtl x\n",
            "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n",
            "v 0 0 0\nf 0 1 1\n",
            " g indented\n",
            "v 0 0 zero\n",
            "l 1 2\n",
        ] {
            assert!(plain_obj(other.as_bytes()).is_none(), "{other:?}");
        }
    }

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
