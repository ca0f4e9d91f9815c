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

mod plain;

use std::collections::HashMap;
use std::io::BufReader;
use std::path::Path;

use super::mesh::{MeshError, class_from_name, glob_match, mapped_class};
use crate::geometry::DVec3;
use crate::scene::{Material, MeshPlacement, Primitive, Scene, Shape, SurfaceClass, Triangle};
use plain::{bad_vertex, first_bad_line, plain_obj};

/// Name of the pseudo material library holding the survey's materials.
const SURVEY_LIBRARY: &str = "<survey materials>";

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
    let placer = placement.placer();
    let place = |x: f64, y: f64, z: f64| placer(DVec3::new(x, y, z));
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
        spectrum: Vec::new(),
    })
}

#[cfg(test)]
mod tests;
