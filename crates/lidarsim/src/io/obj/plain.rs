//! OBJ text read line by line, without the OBJ parser: the plainest files
//! (vertices, triangles, names) read directly, and the first bad line of
//! any file found for messages (the parser names none).

use crate::geometry::MAX_COORDINATE_M;

use super::Group;

/// An OBJ file of the plainest kind, read without the OBJ parser: its
/// vertices and, per group, triangles.
pub(super) struct PlainObj {
    positions: Vec<f64>,
    /// Group name and its corner indices (0-based, three per triangle).
    groups: Vec<(String, Vec<u32>)>,
}

impl PlainObj {
    pub(super) fn groups(&self) -> Vec<Group<'_>> {
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
pub(super) fn plain_obj(text: &[u8]) -> Option<PlainObj> {
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
pub(super) fn bad_vertex(text: &[u8]) -> Option<(usize, String)> {
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
