//! `[materials]`, `[[polygon]]`, `[[mesh]]`, `[[terrain]]` and
//! `[[point_cloud]]`: the scene's entries, checked; the files they name are
//! read by [`crate::world`].

use std::collections::HashMap;
use std::path::Path;

use super::{Bounds, Checker, Materials};
use crate::geometry::DVec3;
use crate::scene::terrain::FbmSpec;
use crate::scene::{Material, MeshPlacement, Polygon, SurfaceClass};
use crate::survey::spec::{
    CloudEntry, CloudSource, MeshEntry, MeshSource, PolygonEntry, TerrainEntry, TerrainSource,
};
use crate::survey::{KeyPath, MAX_POLYGON_VERTICES, RawSurvey, raw};

/// Checks `[materials]`.
pub(crate) fn materials(c: &mut Checker, raw: &RawSurvey) -> Materials {
    let root = KeyPath::root();
    let mut materials: HashMap<String, Material> = HashMap::new();
    for (name, m) in &raw.materials {
        let mp = root.key("materials").key(name);
        let spectrum = match &m.reflectance_spectrum {
            Some(pairs) => spectrum(c, mp.key("reflectance_spectrum"), pairs),
            None => Vec::new(),
        };
        if m.reflectance.is_some() && m.reflectance_spectrum.is_some() {
            c.err(
                mp.key("reflectance_spectrum"),
                "give reflectance or reflectance_spectrum, not both",
            );
        } else if m.reflectance.is_none() && m.reflectance_spectrum.is_none() {
            c.err(
                mp.key("reflectance"),
                "is required: reflectance from 0 to 1 (or reflectance_spectrum, \
                 [[nm, reflectance], ...])",
            );
        }
        let reflectance = c.number(
            mp.key("reflectance"),
            m.reflectance,
            0.0,
            Bounds::between(0.0, 1.0, ""),
        );
        let incidence_exponent = c.number(
            mp.key("incidence_exponent"),
            m.incidence_exponent,
            1.0,
            Bounds::between(0.0, 1000.0, ""),
        );
        materials.insert(
            name.clone(),
            Material {
                name: name.clone(),
                reflectance,
                incidence_exponent,
                spectrum,
            },
        );
    }
    Materials(materials)
}

/// A reflectance spectrum: pairs `[nm, reflectance]`, at least two, by
/// strictly increasing wavelength, reflectances from 0 to 1.
fn spectrum(c: &mut Checker, key: KeyPath, pairs: &[Vec<f64>]) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(pairs.len());
    if pairs.len() < 2 {
        c.err(
            key.clone(),
            format!(
                "give at least two [nm, reflectance] pairs, got {}",
                pairs.len()
            ),
        );
    }
    for (i, p) in pairs.iter().enumerate() {
        let k = key.index(i);
        let &[nm, r] = p.as_slice() else {
            c.err(
                k,
                format!("must be a pair [nm, reflectance], got {} numbers", p.len()),
            );
            continue;
        };
        if !(nm.is_finite() && nm > 0.0) {
            c.err(k, format!("wavelength must be above 0 nm, got {nm}"));
            continue;
        }
        if !(0.0..=1.0).contains(&r) {
            c.err(k, format!("reflectance must be from 0 to 1, got {r}"));
            continue;
        }
        if let Some(&(prev, _)) = out.last()
            && nm <= prev
        {
            c.err(
                k,
                format!("wavelengths must increase: {nm} nm follows {prev} nm"),
            );
            continue;
        }
        out.push((nm, r));
    }
    out
}

/// Checks `[[polygon]]` entries: their vertices must make a planar
/// polygon.
pub(crate) fn polygons(c: &mut Checker, raw: &RawSurvey, mats: &Materials) -> Vec<PolygonEntry> {
    let mut out = Vec::new();
    for (i, poly) in raw.polygons.iter().enumerate() {
        let pp = KeyPath::root().key("polygon").index(i);
        let class = c.class(pp.key("class"), &poly.class);
        let material = mats.named(c, pp.key("material"), &poly.material, true);
        let vertices = match &poly.vertices_m {
            None => {
                c.err(
                    pp.key("vertices_m"),
                    "is required: a list of [x, y, z] points",
                );
                None
            }
            Some(vs) if vs.len() > MAX_POLYGON_VERTICES => {
                c.err(
                    pp.key("vertices_m"),
                    format!(
                        "has {} vertices; a polygon may have at most {MAX_POLYGON_VERTICES}: \
                         give detailed shapes as a mesh ([[mesh]], OBJ or glTF)",
                        vs.len()
                    ),
                );
                None
            }
            Some(vs) => {
                let mut ok = Vec::with_capacity(vs.len());
                for (j, v) in vs.iter().enumerate() {
                    if let Some(p) = c.point(pp.key("vertices_m").index(j), &Some(v.clone())) {
                        ok.push(p);
                    }
                }
                (ok.len() == vs.len()).then_some(ok)
            }
        };
        let Some(vertices) = vertices else { continue };
        match Polygon::new(vertices) {
            Ok(polygon) => {
                if let Some(material) = material {
                    out.push(PolygonEntry {
                        index: i,
                        polygon,
                        material,
                        class,
                    });
                }
            }
            Err(e) => c.err(pp.key("vertices_m"), e.to_string()),
        }
    }
    out
}

/// Checks `[[mesh]]` entries (the files are read by the world).
pub(crate) fn meshes(
    c: &mut Checker,
    raw: &RawSurvey,
    mats: &Materials,
    base: &Path,
) -> Vec<MeshEntry> {
    let mut out = Vec::new();
    for (i, mesh) in raw.meshes.iter().enumerate() {
        let mp = KeyPath::root().key("mesh").index(i);
        let class = c.class(mp.key("class"), &mesh.class);
        let offset = match &mesh.offset_m {
            None => Some(DVec3::ZERO),
            some => c.point(mp.key("offset_m"), some),
        };
        let scale = c.positive(mp.key("scale"), mesh.scale, 1.0, "");
        let rotation = c.number(
            mp.key("rotation_z_deg"),
            mesh.rotation_z_deg,
            0.0,
            Bounds::between(-360.0, 360.0, "°"),
        );
        let default_material = match &mesh.material {
            None => None,
            name => match mats.named(c, mp.key("material"), name, false) {
                Some(m) => Some(m),
                None => continue,
            },
        };
        let Some(file) = &mesh.file else {
            c.err(
                mp.key("file"),
                "is required: path of an OBJ, glTF (.gltf) or binary glTF (.glb) file",
            );
            continue;
        };
        let mut class_map = Vec::new();
        for (pattern, name) in mesh.classes.iter().flatten() {
            let key = mp.key("classes").key(pattern);
            if pattern.is_empty() {
                c.err(key, "an empty pattern matches nothing");
                continue;
            }
            class_map.push((pattern.clone(), c.class(key, &Some(name.clone()))));
        }
        let Some(offset) = offset else { continue };
        let full = base.join(file);
        let gltf = full
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"));
        out.push(MeshEntry {
            index: i,
            source: if gltf {
                MeshSource::Gltf(full)
            } else {
                MeshSource::Obj(full)
            },
            placement: MeshPlacement {
                scale,
                rotation_z_rad: rotation.to_radians(),
                offset_m: offset,
                default_class: class,
                default_material,
                class_map,
            },
        });
    }
    out
}

/// Checks `[[terrain]]` entries: a raster file or the fBm generator's
/// settings.
pub(crate) fn terrains(
    c: &mut Checker,
    raw: &RawSurvey,
    mats: &Materials,
    base: &Path,
    survey_seed: u64,
) -> Vec<TerrainEntry> {
    let mut out = Vec::new();
    for (index, t) in raw.terrains.iter().enumerate() {
        let tp = KeyPath::root().key("terrain").index(index);
        if let Some(entry) = terrain(c, &tp, t, mats, base, survey_seed, index) {
            out.push(entry);
        }
    }
    out
}

/// Checks one `[[terrain]]` entry.
fn terrain(
    c: &mut Checker,
    tp: &KeyPath,
    t: &raw::RawTerrain,
    mats: &Materials,
    base: &Path,
    survey_seed: u64,
    index: usize,
) -> Option<TerrainEntry> {
    let class = match &t.class {
        None => SurfaceClass::Ground,
        some => c.class(tp.key("class"), some),
    };
    let material = mats.named(c, tp.key("material"), &t.material, true);
    let offset = match &t.offset_m {
        None => Some(DVec3::ZERO),
        some => c.point(tp.key("offset_m"), some),
    };
    let fbm_keys = [
        ("extent_m", t.extent_m.is_some()),
        ("resolution_m", t.resolution_m.is_some()),
        ("relief_m", t.relief_m.is_some()),
        ("wavelength_m", t.wavelength_m.is_some()),
        ("octaves", t.octaves.is_some()),
        ("seed", t.seed.is_some()),
    ];
    let source = match (&t.file, &t.generator) {
        (Some(_), Some(_)) => {
            c.err(
                tp.key("generator"),
                "give either `file` (a raster) or `generator`, not both",
            );
            None
        }
        (None, None) => {
            c.err(
                tp.key("file"),
                "is required: a GeoTIFF (.tif) or ESRI ASCII grid (.asc) file, or set \
                 `generator = \"fbm\"`",
            );
            None
        }
        (Some(file), None) => {
            for (key, set) in fbm_keys {
                if set {
                    c.err(
                        tp.key(key),
                        "belongs to `generator = \"fbm\"`; a raster `file` gives its own grid",
                    );
                }
            }
            Some(TerrainSource::File(base.join(file), file.clone()))
        }
        (None, Some(generator)) if generator == "fbm" => {
            let extent = match &t.extent_m {
                Some(e)
                    if e.len() == 4
                        && e.iter().all(|v| v.is_finite())
                        && e[2] > e[0]
                        && e[3] > e[1] =>
                {
                    Some([e[0], e[1], e[2], e[3]])
                }
                Some(_) => {
                    c.err(
                        tp.key("extent_m"),
                        "must be [xmin, ymin, xmax, ymax] in metres with xmax > xmin and \
                         ymax > ymin",
                    );
                    None
                }
                None => {
                    c.err(
                        tp.key("extent_m"),
                        "is required: [xmin, ymin, xmax, ymax] in metres",
                    );
                    None
                }
            };
            let resolution_m = c.positive(tp.key("resolution_m"), t.resolution_m, 1.0, " m");
            let relief_m = c.number(
                tp.key("relief_m"),
                t.relief_m,
                20.0,
                Bounds::between(0.0, 1e4, " m"),
            );
            let octaves = c.count(tp.key("octaves"), t.octaves, 6, 1, 16) as u32;
            let extent = extent?;
            let wavelength_m = c.positive(
                tp.key("wavelength_m"),
                t.wavelength_m,
                ((extent[2] - extent[0]).max(extent[3] - extent[1]) / 2.0).max(resolution_m),
                " m",
            );
            let spec = FbmSpec {
                extent_m: extent,
                resolution_m,
                relief_m,
                wavelength_m,
                octaves,
                seed: t.seed.unwrap_or_else(|| {
                    crate::rng::entry_seed(survey_seed, crate::rng::Purpose::TerrainSeed, index)
                }),
            };
            let (cols, rows) = spec.nodes();
            if cols < 2 || rows < 2 {
                c.err(
                    tp.key("resolution_m"),
                    format!("{resolution_m} m leaves fewer than 2 × 2 grid nodes in the extent"),
                );
                return None;
            }
            Some(TerrainSource::Fbm(spec))
        }
        (None, Some(other)) => {
            c.err(
                tp.key("generator"),
                format!("unknown generator '{other}'; expected \"fbm\""),
            );
            None
        }
    };
    Some(TerrainEntry {
        index,
        source: source?,
        material: material?,
        class,
        offset_m: offset?,
    })
}

/// Checks `[[point_cloud]]` entries.
pub(crate) fn clouds(
    c: &mut Checker,
    raw: &RawSurvey,
    mats: &Materials,
    base: &Path,
) -> Vec<CloudEntry> {
    let mut out = Vec::new();
    for (i, pc) in raw.point_clouds.iter().enumerate() {
        let pp = KeyPath::root().key("point_cloud").index(i);
        let class = pc
            .class
            .as_ref()
            .map(|_| c.class(pp.key("class"), &pc.class));
        let voxel_m = c.number(
            pp.key("voxel_m"),
            pc.voxel_m,
            0.5,
            Bounds::between(0.01, 1000.0, " m"),
        );
        let offset = match &pc.offset_m {
            None => Some(DVec3::ZERO),
            some => c.point(pp.key("offset_m"), some),
        };
        let material = mats.named(c, pp.key("material"), &pc.material, true);
        let Some(file) = &pc.file else {
            c.err(pp.key("file"), "is required: path of a LAS or LAZ file");
            continue;
        };
        let (Some(material), Some(offset_m)) = (material, offset) else {
            continue;
        };
        out.push(CloudEntry {
            index: i,
            source: CloudSource::File(base.join(file)),
            voxel_m,
            offset_m,
            material,
            class,
        });
    }
    out
}
