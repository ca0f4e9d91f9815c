//! Triangle meshes from glTF 2.0 files (`.gltf` with embedded or external
//! buffers, or binary `.glb`), read with the `gltf` crate.
//!
//! The default scene (else the first) is walked from its root nodes; each
//! node's local transform (matrix, or translation · rotation · scale) is
//! applied after its parent's. Triangles, triangle strips and fans are
//! read; points and lines are skipped.
//!
//! Axes (glTF 2.0 §3.4): glTF is right-handed with +Y up and the front of
//! an asset facing +Z, in metres. Our world is X east, Y north, Z up, so a
//! glTF point `(x, y, z)` becomes `(x, −z, y)` — a rotation of +90° about
//! X, the inverse of what Blender's exporter applies, so Blender's own
//! coordinates come back. The `[[mesh]]` placement (scale, rotation about
//! the vertical, offset) follows.
//!
//! Material of a primitive: the survey's `[materials.NAME]` for the glTF
//! material's name, else the glTF material itself (reflectance = mean of
//! the base colour factor's RGB, Lambertian), else the mesh entry's default
//! material. Class: the entry's `classes` pattern matching the node name,
//! then the mesh name; else the first word of the material, node or mesh
//! name that names a class; else the entry's default class.

use std::collections::HashMap;
use std::path::Path;

use super::mesh::{MeshError, class_from_name, glob_match, mapped_class};
use crate::geometry::DVec3;
use crate::scene::{
    Material, MaterialId, MeshPlacement, ObjectId, Primitive, Scene, Shape, Triangle,
};
use glam::DMat4;

/// glTF (x, y, z) → world (x, −z, y).
fn gltf_to_world(p: DVec3) -> DVec3 {
    DVec3::new(p.x, -p.z, p.y)
}

/// A URI's percent-escapes decoded (`%20` → space), as the glTF reader
/// decodes buffer file names; malformed escapes are kept as they are.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && let (Some(h), Some(l)) = (
                bytes.get(i + 1).copied().and_then(hex),
                bytes.get(i + 2).copied().and_then(hex),
            )
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Loads a glTF 2.0 file into `scene` as triangles of a new object;
/// returns (triangles added, degenerate triangles skipped).
pub fn load_gltf(
    path: &Path,
    placement: &MeshPlacement,
    survey_materials: &HashMap<String, Material>,
    scene: &mut Scene,
) -> Result<(usize, usize), MeshError> {
    let (document, buffers) = open(path)?;
    let Some(root) = document
        .default_scene()
        .or_else(|| document.scenes().next())
    else {
        return Err(gltf_error(path, "has no scene".to_string()));
    };
    let nodes = placed_nodes(path, &root)?;
    check_class_patterns(path, placement, &nodes)?;

    let default_material = placement
        .default_material
        .clone()
        .map(|m| scene.add_material(m));
    let load = MeshLoad {
        path,
        placement,
        survey_materials,
        buffers: &buffers,
        default_material,
        object: scene.add_object(format!("mesh:{}", path.display())),
    };
    let mut count = Count::default();
    for node in &nodes {
        let Some(mesh) = node.node.mesh() else {
            continue;
        };
        let names = node_names(&node.node);
        for (k, prim) in mesh.primitives().enumerate() {
            let part = Part {
                prim: &prim,
                world: &node.world,
                names: &names,
                what: format!(
                    "mesh '{}' primitive {k}",
                    mesh.name()
                        .map_or_else(|| mesh.index().to_string(), str::to_string)
                ),
            };
            load.add_primitive(&part, scene, &mut count)?;
        }
    }
    if count.added == 0 {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok((count.added, count.skipped))
}

/// The error of a glTF file that cannot be read or breaks the rules.
fn gltf_error(path: &Path, reason: String) -> MeshError {
    MeshError::Gltf {
        path: path.to_path_buf(),
        reason,
    }
}

/// The file read and parsed, and its buffers loaded (those in files
/// checked first).
fn open(path: &Path) -> Result<(gltf::Document, Vec<gltf::buffer::Data>), MeshError> {
    let fail = |reason: String| gltf_error(path, reason);
    let bytes = crate::io::input::read_input(path, crate::io::input::MAX_INPUT_BYTES).map_err(
        |source| MeshError::Read {
            path: path.to_path_buf(),
            source,
        },
    )?;
    let is_glb = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if bytes.is_empty() {
        return Err(fail("is empty".to_string()));
    }
    if is_glb && !bytes.starts_with(b"glTF") {
        return Err(fail(
            "is not a binary glTF (GLB): it does not start with the magic 'glTF'".to_string(),
        ));
    }
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice(&bytes).map_err(|e| match e {
        gltf::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            fail("the file ends early: it is truncated".to_string())
        }
        other => fail(format!("not a valid glTF 2.0 file: {other}")),
    })?;
    drop(bytes);
    check_buffer_files(path, &document)?;
    let buffers = gltf::import_buffers(&document, path.parent(), blob)
        .map_err(|e| fail(format!("cannot load its buffers: {e}")))?;
    Ok((document, buffers))
}

/// Buffers in files are checked before the glTF reader opens them: a
/// regular file, within the size bound, at least as long as declared.
fn check_buffer_files(path: &Path, document: &gltf::Document) -> Result<(), MeshError> {
    for buffer in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = buffer.source()
            && !uri.starts_with("data:")
        {
            let file = path
                .parent()
                .unwrap_or(Path::new("."))
                .join(percent_decode(uri));
            let len = crate::io::input::check_input(&file, crate::io::input::MAX_INPUT_BYTES)
                .map_err(|e| gltf_error(path, format!("cannot load its buffer '{uri}': {e}")))?;
            if len < buffer.length() as u64 {
                return Err(gltf_error(
                    path,
                    format!(
                        "buffer '{uri}' has {len} bytes, fewer than the {} it declares",
                        buffer.length()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A node of the scene and its world matrix (its parents' transforms
/// applied after its own).
struct PlacedNode<'a> {
    node: gltf::Node<'a>,
    world: DMat4,
}

/// The scene's nodes with their world matrices, depth first.
fn placed_nodes<'a>(path: &Path, root: &gltf::Scene<'a>) -> Result<Vec<PlacedNode<'a>>, MeshError> {
    let mut nodes = Vec::new();
    let mut stack: Vec<(gltf::Node, DMat4, usize)> =
        root.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err(gltf_error(
                path,
                "node hierarchy deeper than 256 levels (a cycle?)".to_string(),
            ));
        }
        let m = node.transform().matrix();
        let local = DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from)));
        let world = parent * local;
        for child in node.children() {
            stack.push((child, world, depth + 1));
        }
        nodes.push(PlacedNode { node, world });
    }
    Ok(nodes)
}

/// The names a node's faces are classed by: the node's, then its mesh's.
fn node_names(node: &gltf::Node) -> Vec<String> {
    let mut names = Vec::new();
    if let Some(n) = node.name() {
        names.push(n.to_string());
    }
    if let Some(n) = node.mesh().and_then(|m| m.name().map(str::to_string)) {
        names.push(n);
    }
    names
}

/// Every `classes` pattern of the entry must match a name of a node with
/// a mesh.
fn check_class_patterns(
    path: &Path,
    placement: &MeshPlacement,
    nodes: &[PlacedNode],
) -> Result<(), MeshError> {
    let with_mesh = || nodes.iter().filter(|n| n.node.mesh().is_some());
    for (pattern, _) in &placement.class_map {
        if !with_mesh().any(|n| {
            node_names(&n.node)
                .iter()
                .any(|name| glob_match(pattern, name))
        }) {
            let mut all: Vec<String> = with_mesh().flat_map(|n| node_names(&n.node)).collect();
            all.dedup();
            return Err(MeshError::UnmatchedClassPattern {
                path: path.to_path_buf(),
                pattern: pattern.clone(),
                names: if all.is_empty() {
                    "none".to_string()
                } else {
                    all.join(", ")
                },
            });
        }
    }
    Ok(())
}

/// What the primitives of one file share as they are added.
struct MeshLoad<'a> {
    path: &'a Path,
    placement: &'a MeshPlacement,
    survey_materials: &'a HashMap<String, Material>,
    buffers: &'a [gltf::buffer::Data],
    /// The entry's `material`, added to the scene.
    default_material: Option<MaterialId>,
    /// The file's object in the scene.
    object: ObjectId,
}

/// One primitive of a node's mesh.
struct Part<'a> {
    prim: &'a gltf::Primitive<'a>,
    /// The node's world matrix.
    world: &'a DMat4,
    /// The node's names (`node_names`).
    names: &'a [String],
    /// How messages name it: "mesh 'NAME' primitive K".
    what: String,
}

/// Triangles added and degenerate triangles skipped.
#[derive(Default)]
struct Count {
    added: usize,
    skipped: usize,
}

impl MeshLoad<'_> {
    /// Adds one primitive's triangles to the scene.
    fn add_primitive(
        &self,
        part: &Part,
        scene: &mut Scene,
        count: &mut Count,
    ) -> Result<(), MeshError> {
        let material = self.material(part, scene)?;
        let class = part
            .names
            .iter()
            .find_map(|n| mapped_class(&self.placement.class_map, n))
            .or_else(|| part.prim.material().name().and_then(class_from_name))
            .or_else(|| part.names.iter().find_map(|n| class_from_name(n)))
            .unwrap_or(self.placement.default_class);
        let positions = self.positions(part)?;
        let corner = |i: u32| positions.get(i as usize).copied();
        for [a, b, c] in triangles(part.prim, self.buffers, positions.len()) {
            let (Some(a), Some(b), Some(c)) = (corner(a), corner(b), corner(c)) else {
                return Err(self.fail(format!("{}: an index points past its vertices", part.what)));
            };
            match Triangle::new(a, b, c) {
                Some(t) => {
                    scene.primitives.push(Primitive {
                        shape: Shape::Triangle(t),
                        material,
                        class,
                        object: self.object,
                    });
                    count.added += 1;
                }
                None => count.skipped += 1,
            }
        }
        Ok(())
    }

    /// An error of this file.
    fn fail(&self, reason: String) -> MeshError {
        gltf_error(self.path, reason)
    }

    /// The primitive's material: the survey's of its name, else its own
    /// (added to the scene), else the entry's.
    fn material(&self, part: &Part, scene: &mut Scene) -> Result<MaterialId, MeshError> {
        let mat = part.prim.material();
        let material = match mat.name() {
            Some(name) if self.survey_materials.contains_key(name) => {
                Some(scene.add_material(self.survey_materials[name].clone()))
            }
            _ if mat.index().is_some() => {
                let name = mat.name().map_or_else(
                    || format!("gltf material {}", mat.index().unwrap_or(0)),
                    str::to_string,
                );
                let c = mat.pbr_metallic_roughness().base_color_factor();
                let reflectance = f64::from(c[0] + c[1] + c[2]) / 3.0;
                if !(0.0..=1.0).contains(&reflectance) {
                    return Err(self.fail(format!(
                        "material '{name}': base colour gives reflectance {reflectance}, \
                         outside 0–1"
                    )));
                }
                Some(scene.add_material(Material {
                    name,
                    reflectance,
                    incidence_exponent: 1.0,
                    spectrum: Vec::new(),
                }))
            }
            _ => self.default_material,
        };
        material.ok_or_else(|| {
            self.fail(format!(
                "{} has no material; set the mesh's `material` key",
                part.what
            ))
        })
    }

    /// The primitive's vertices in the world frame, its accessors checked
    /// first.
    fn positions(&self, part: &Part) -> Result<Vec<DVec3>, MeshError> {
        let Some(pos_accessor) = part.prim.get(&gltf::Semantic::Positions) else {
            return Err(self.fail(format!("{} has no POSITION attribute", part.what)));
        };
        self.check_accessors(part, &pos_accessor)?;
        let reader = part
            .prim
            .reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
        let Some(positions) = reader.read_positions() else {
            return Err(self.fail(format!(
                "{}: POSITION (accessor {}) has no data",
                part.what,
                pos_accessor.index()
            )));
        };
        let place = self.placement.placer();
        Ok(positions
            .map(|p| {
                let local = part.world.transform_point3(DVec3::new(
                    f64::from(p[0]),
                    f64::from(p[1]),
                    f64::from(p[2]),
                ));
                place(gltf_to_world(local))
            })
            .collect())
    }

    /// The positions must be float VEC3 and the indices unsigned scalars,
    /// each inside its buffer (`check_accessor`).
    fn check_accessors(&self, part: &Part, positions: &gltf::Accessor) -> Result<(), MeshError> {
        use gltf::accessor::{DataType, Dimensions};
        let what = &part.what;
        if positions.data_type() != DataType::F32 || positions.dimensions() != Dimensions::Vec3 {
            return Err(self.fail(format!(
                "{what}: POSITION (accessor {}) must be float VEC3, got {:?} {:?}",
                positions.index(),
                positions.data_type(),
                positions.dimensions()
            )));
        }
        check_accessor(positions, self.buffers).map_err(|r| self.fail(format!("{what}: {r}")))?;
        if let Some(idx) = part.prim.indices() {
            if !matches!(
                idx.data_type(),
                DataType::U8 | DataType::U16 | DataType::U32
            ) || idx.dimensions() != Dimensions::Scalar
            {
                return Err(self.fail(format!(
                    "{what}: the indices (accessor {}) must be unsigned SCALAR integers, got \
                     {:?} {:?}",
                    idx.index(),
                    idx.data_type(),
                    idx.dimensions()
                )));
            }
            check_accessor(&idx, self.buffers).map_err(|r| self.fail(format!("{what}: {r}")))?;
        }
        Ok(())
    }
}

/// A primitive's triangles as indices into its `vertices` positions:
/// triangles, strips and fans; none for points and lines.
fn triangles(
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    vertices: usize,
) -> Vec<[u32; 3]> {
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..vertices as u32).collect(),
    };
    match prim.mode() {
        gltf::mesh::Mode::Triangles => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        gltf::mesh::Mode::TriangleStrip => (2..indices.len())
            .map(|i| {
                if i % 2 == 0 {
                    [indices[i - 2], indices[i - 1], indices[i]]
                } else {
                    [indices[i - 1], indices[i - 2], indices[i]]
                }
            })
            .collect(),
        gltf::mesh::Mode::TriangleFan => (2..indices.len())
            .map(|i| [indices[0], indices[i - 1], indices[i]])
            .collect(),
        _ => Vec::new(),
    }
}

/// Checks that an accessor's elements lie inside its buffer view and the
/// view inside its buffer, with checked arithmetic: the `gltf` crate's
/// readers index the buffers unchecked (and overflow on counts of 0 or
/// near 2⁶⁴), so a corrupt file must be refused before they run.
fn check_accessor(acc: &gltf::Accessor, buffers: &[gltf::buffer::Data]) -> Result<(), String> {
    let i = acc.index();
    let size = acc.size();
    // One element's bytes at `offset` of `view`, `count` times `stride` apart.
    let range = |what: &str,
                 view: &gltf::buffer::View,
                 offset: usize,
                 count: usize,
                 size: usize|
     -> Result<(), String> {
        if count == 0 {
            return Err(format!("{what} counts no element"));
        }
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(format!(
                "{what}: byte stride {stride} is shorter than an element ({size} bytes)"
            ));
        }
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|b| b.checked_add(size))
            .and_then(|b| b.checked_add(offset));
        match end {
            Some(end) if end <= view.length() => {}
            _ => {
                return Err(format!(
                    "{what} counts {count} elements of {size} bytes, past the end of buffer \
                     view {} ({} bytes)",
                    view.index(),
                    view.length()
                ));
            }
        }
        let buffer_len = buffers.get(view.buffer().index()).map_or(0, |d| d.0.len());
        match view.offset().checked_add(view.length()) {
            Some(end) if end <= buffer_len => Ok(()),
            _ => Err(format!(
                "buffer view {} (bytes {}..+{}) lies past the end of buffer {} ({buffer_len} \
                 bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index()
            )),
        }
    };
    match acc.view() {
        Some(view) => range(
            &format!("accessor {i}"),
            &view,
            acc.offset(),
            acc.count(),
            size,
        )?,
        None if acc.sparse().is_none() => {
            return Err(format!("accessor {i} has no buffer view"));
        }
        None => {}
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        if n > acc.count() {
            return Err(format!(
                "accessor {i}: {n} sparse elements for {} elements",
                acc.count()
            ));
        }
        let idx = sparse.indices();
        range(
            &format!("accessor {i} sparse indices"),
            &idx.view(),
            idx.offset(),
            n,
            idx.index_type().size(),
        )?;
        let values = sparse.values();
        range(
            &format!("accessor {i} sparse values"),
            &values.view(),
            values.offset(),
            n,
            size,
        )?;
    }
    Ok(())
}
