//! glTF 2.0 meshes written byte by byte after the specification (JSON with
//! a base64 data URI, and the binary GLB container), loaded through the
//! survey: node transforms, the Y-up → Z-up axis change, materials and
//! classes checked against values worked out by hand.

use std::path::{Path, PathBuf};

use lidarsim::Survey;
use lidarsim::accel::RayCaster;
use lidarsim::geometry::{DVec3, Ray};
use lidarsim::scene::SurfaceClass;
use lidarsim::world::World;

/// Indices 0 1 2 0 2 3 (u16) and a unit square in glTF's XZ plane (y = 0).
fn buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    for p in [
        [0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ] {
        for c in p {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    b
}

fn base64(data: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for chunk in data.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | (b as u32) << (16 - 8 * i));
        for i in 0..4 {
            if i <= chunk.len() {
                s.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A parent node (scale 2, translation (10, 3, −20)) holding a child node
/// "House_A" with the square (material "tiles", base colour mean 0.4) and
/// a second square primitive without material.
fn json(buffer_uri: Option<String>) -> String {
    let uri = buffer_uri.map_or(String::new(), |u| format!(r#""uri": "{u}", "#));
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"name": "site", "translation": [10, 3, -20], "scale": [2, 2, 2], "children": [1]}},
    {{"name": "House_A", "mesh": 0}}
  ],
  "meshes": [{{"name": "house_mesh", "primitives": [
    {{"attributes": {{"POSITION": 1}}, "indices": 0, "material": 0}},
    {{"attributes": {{"POSITION": 1}}, "indices": 0}}
  ]}}],
  "materials": [{{"name": "tiles", "pbrMetallicRoughness": {{"baseColorFactor": [0.2, 0.4, 0.6, 1.0]}}}}],
  "buffers": [{{{uri}"byteLength": 60}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 12, "target": 34963}},
    {{"buffer": 0, "byteOffset": 12, "byteLength": 48, "target": 34962}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3",
      "min": [0, 0, 0], "max": [1, 0, 1]}}
  ]
}}"#
    )
}

/// GLB container (glTF 2.0 §4.4): 12-byte header, JSON chunk padded with
/// spaces, BIN chunk padded with zeros, all little endian.
fn glb() -> Vec<u8> {
    let mut j = json(None).into_bytes();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut bin = buffer();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&j);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&bin);
    out
}

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("lidarsim-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The world of a survey with one mesh entry for `file`.
fn survey(file: &Path, extra: &str) -> Result<World, lidarsim::survey::SurveyError> {
    let text = format!(
        "[[flight_line]]\nstart_m = [0, 0, 100]\nend_m = [0, 10, 100]\nspeed_mps = 10\n\
         [materials.grey]\nreflectance = 0.25\n\
         [[mesh]]\nfile = '{}'\nmaterial = 'grey'\noffset_m = [100, 0, 0]\n{extra}\n",
        file.display()
    );
    World::build(&Survey::from_toml(&text, None)?)
}

#[test]
fn gltf_and_glb_load_with_node_transforms_axes_materials_and_classes() {
    let d = dir();
    let embedded = d.join("house.gltf");
    let data_uri = format!("data:application/octet-stream;base64,{}", base64(&buffer()));
    std::fs::write(&embedded, json(Some(data_uri))).unwrap();
    let external = d.join("house_ext.gltf");
    std::fs::write(d.join("house.bin"), buffer()).unwrap();
    std::fs::write(&external, json(Some("house.bin".into()))).unwrap();
    let binary = d.join("house.glb");
    std::fs::write(&binary, glb()).unwrap();
    for file in [&embedded, &external, &binary] {
        let s = survey(file, "classes = { 'House*' = 'roof' }").unwrap_or_else(|e| panic!("{e}"));
        let prims = &s.scene().primitives;
        assert_eq!(prims.len(), 4, "two squares of two triangles");
        // glTF (x, y, z) = (10 + 2x, 3, −20 + 2z) → world (x, −z, y), then
        // the survey offset of 100 m east.
        let b = s.scene().bounds();
        assert_eq!(b.min, DVec3::new(110.0, 18.0, 3.0), "{}", file.display());
        assert_eq!(b.max, DVec3::new(112.0, 20.0, 3.0), "{}", file.display());
        // The index orders the triangles by place: sorted, the entry's
        // 0.25 (the square without a glTF material) comes first.
        let mut refl: Vec<f64> = prims
            .iter()
            .map(|p| s.scene().materials[p.material as usize].reflectance)
            .collect();
        refl.sort_by(f64::total_cmp);
        assert_eq!(&refl[..2], [0.25, 0.25], "no glTF material: the entry's");
        assert!(
            (refl[2] - 0.4).abs() < 1e-6 && (refl[3] - 0.4).abs() < 1e-6,
            "{refl:?}"
        );
        assert!(prims.iter().all(|p| p.class == SurfaceClass::Roof));
        let hit = s
            .index()
            .closest_hit(
                &Ray::new(DVec3::new(111.5, 18.5, 50.0), -DVec3::Z),
                0.0,
                1e3,
            )
            .unwrap();
        assert!((hit.t - 47.0).abs() < 1e-9);
    }
    // Without a classes table: the material name "tiles" names no class,
    // nor does "House_A"/"house_mesh": the entry's class.
    let s = survey(&binary, "class = 'bridge'").unwrap();
    assert!(
        s.scene()
            .primitives
            .iter()
            .all(|p| p.class == SurfaceClass::Bridge)
    );

    // Errors name the key.
    let e = survey(&binary, "classes = { 'Shed*' = 'roof' }").unwrap_err();
    assert_eq!(e.diagnostics[0].key, "mesh[0].classes.Shed*", "{e}");
    assert!(e.diagnostics[0].message.contains("House_A"), "{e}");
    std::fs::write(d.join("broken.glb"), b"glTF\x02\0\0\0\x0c\0\0\0").unwrap();
    let e = survey(&d.join("broken.glb"), "").unwrap_err();
    assert_eq!(e.diagnostics[0].key, "mesh[0].file");
    assert!(e.diagnostics[0].message.contains("not a valid glTF"), "{e}");
    let e = survey(&d.join("missing.gltf"), "").unwrap_err();
    assert!(e.diagnostics[0].message.contains("missing.gltf"), "{e}");
    std::fs::write(d.join("nobin.gltf"), json(Some("nowhere.bin".into()))).unwrap();
    let e = survey(&d.join("nobin.gltf"), "").unwrap_err();
    assert!(
        e.diagnostics[0]
            .message
            .contains("cannot load its buffer 'nowhere.bin'"),
        "{e}"
    );
}
