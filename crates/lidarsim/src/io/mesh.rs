//! What the mesh readers (OBJ, glTF) share: their errors, and the rules
//! that give a face its class from group and object names.

use std::path::PathBuf;

use crate::scene::SurfaceClass;

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
    fn class_hints_from_group_names() {
        assert_eq!(class_from_name("roof_1"), Some(SurfaceClass::Roof));
        assert_eq!(class_from_name("north-wall"), Some(SurfaceClass::Wall));
        assert_eq!(class_from_name("thing"), None);
    }
}
