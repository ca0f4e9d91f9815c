//! OBJ files read through the parser and the plain reader.

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
            parse_with_tobj(text.as_bytes(), Path::new("t.obj"), &dir, &HashMap::new()).unwrap();
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
            spectrum: Vec::new(),
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
