//! Point clouds as scene: LAS/LAZ files written by the `las` crate (an
//! independent writer) are voxelised and scanned again; the new points must
//! lie on the voxels' faces, which follow from the input points by
//! `floor(coordinate / voxel) · voxel` alone.

use std::path::{Path, PathBuf};

use las::point::Classification;
use lidarsim::Survey;
use lidarsim::sim::simulate_world_to_memory;
use lidarsim::survey::SurveyError;
use lidarsim::world::World;

fn write_cloud(path: &Path, points: &[([f64; 3], u8)]) {
    let mut writer = las::Writer::from_path(path, las::Header::default()).unwrap();
    for &([x, y, z], class) in points {
        writer
            .write_point(las::Point {
                x,
                y,
                z,
                classification: Classification::new(class).unwrap(),
                ..Default::default()
            })
            .unwrap();
    }
    writer.close().unwrap();
}

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("lidarsim-cloud-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Ground points every 0.1 m at z = 1.03 over 40 × 40 m (class 2), and the
/// surface of a 10 × 6 × 4.2 m box standing on it (class 6).
fn scene_points() -> Vec<([f64; 3], u8)> {
    let mut pts = Vec::new();
    for i in 0..400 {
        for j in 0..400 {
            let (x, y) = (-20.0 + 0.1 * i as f64 + 0.05, -20.0 + 0.1 * j as f64 + 0.05);
            if !(0.0..10.0).contains(&x) || !(0.0..6.0).contains(&y) {
                pts.push(([x, y, 1.03], 2));
            }
        }
    }
    // Roof at z = 5.23 and four walls, 0.1 m spacing.
    for i in 0..100 {
        for j in 0..60 {
            pts.push(([0.05 + 0.1 * i as f64, 0.05 + 0.1 * j as f64, 5.23], 6));
        }
    }
    for k in 0..42 {
        let z = 1.03 + 0.1 * k as f64;
        for i in 0..100 {
            let x = 0.05 + 0.1 * i as f64;
            pts.push(([x, 0.01, z], 6));
            pts.push(([x, 5.99, z], 6));
        }
        for j in 0..60 {
            let y = 0.05 + 0.1 * j as f64;
            pts.push(([0.01, y, z], 6));
            pts.push(([9.99, y, z], 6));
        }
    }
    pts
}

/// A survey and its world from TOML text.
fn load(text: &str) -> Result<(Survey, World), SurveyError> {
    let s = Survey::from_toml(text, None)?;
    let w = World::build(&s)?;
    Ok((s, w))
}

fn survey(file: &Path, extra: &str) -> (Survey, World) {
    let text = format!(
        r#"
seed = 2
[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 12
subrays = 1
[[flight_line]]
start_m = [105, -15, 200]
end_m = [105, 15, 200]
speed_mps = 40
[materials.any]
reflectance = 0.4
[[point_cloud]]
file = '{}'
material = 'any'
voxel_m = 0.5
{extra}
"#,
        file.display()
    );
    load(&text).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn rescanned_points_lie_on_voxel_tops_with_the_clouds_classes() {
    let path = dir().join("scene.las");
    write_cloud(&path, &scene_points());
    let (s, w) = survey(&path, "offset_m = [100, 0, 0]");
    // Voxels: ground 80 × 80 minus the 20 × 12 under the box; roof 20 × 12;
    // walls: every voxel of the box's outline from z-index 2 to 10
    // (1.03 → 2, 5.13 → 10): outline of a 20 × 12 block = 2·20 + 2·10 = 60
    // voxels per layer, 9 layers; the roof layer (5.23 → 10) is the same
    // layer as the walls' top, so its 20 × 12 voxels include the outline.
    let expect = 80 * 80 - 20 * 12 + 20 * 12 + 60 * 8;
    assert_eq!(w.scene().primitives.len(), expect);
    let pts = simulate_world_to_memory(&s, &w, 2);
    assert!(pts.len() > 2000, "{}", pts.len());
    let (mut ground, mut roof) = (0, 0);
    for p in &pts {
        let q = p.position_m;
        let on_box = (100.0..110.0).contains(&q.x) && (0.0..6.0).contains(&q.y);
        match p.classification {
            // Ground voxels span z 1.0..1.5: their tops at 1.5.
            2 => {
                assert!((q.z - 1.5).abs() < 0.01, "ground point at {q}");
                assert!(!on_box || q.x < 100.01 || q.x > 109.99, "{q}");
                ground += 1;
            }
            // Roof voxels span z 5.0..5.5 (5.23 → 10): tops at 5.5.
            6 => {
                assert!(q.z > 1.49 && q.z < 5.51, "building point at {q}");
                assert!(
                    (99.99..110.01).contains(&q.x) && (-0.01..6.01).contains(&q.y),
                    "{q}"
                );
                if (q.z - 5.5).abs() < 0.01 {
                    roof += 1;
                }
            }
            c => panic!("class {c} at {q}"),
        }
    }
    println!(
        "{} points: {ground} ground at z = 1.5, {roof} roof at z = 5.5",
        pts.len()
    );
    assert!(ground > 1000 && roof > 300, "{ground} {roof}");
}

#[test]
fn class_override_laz_and_errors() {
    let d = dir();
    let pts: Vec<([f64; 3], u8)> = (0..200)
        .flat_map(|i| {
            (0..200).map(move |j| ([-10.0 + 0.1 * i as f64, -10.0 + 0.1 * j as f64, 0.2], 5))
        })
        .collect();
    let laz = d.join("flat.laz");
    write_cloud(&laz, &pts);
    let las_path = d.join("flat.las");
    write_cloud(&las_path, &pts);
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    assert!(size(&laz) * 2 < size(&las_path), "the .laz is compressed");
    let (a, aw) = survey(&laz, "class = 'water'\noffset_m = [105, 0, 0]");
    let (_, bw) = survey(&las_path, "class = 'water'\noffset_m = [105, 0, 0]");
    assert_eq!(aw.scene().primitives.len(), 40 * 40);
    assert_eq!(aw.scene().primitives.len(), bw.scene().primitives.len());
    let out = simulate_world_to_memory(&a, &aw, 1);
    assert!(!out.is_empty());
    assert!(
        out.iter()
            .all(|p| p.classification == 9 && (p.position_m.z - 0.5).abs() < 0.01)
    );

    let bad = d.join("bad.las");
    std::fs::write(&bad, b"LASF but not really").unwrap();
    for (file, extra, key, what) in [
        (
            bad.clone(),
            "",
            "point_cloud[0].file",
            "cannot read point cloud",
        ),
        (
            d.join("none.las"),
            "",
            "point_cloud[0].file",
            "cannot read point cloud",
        ),
        (
            las_path.clone(),
            "class = 'trees'",
            "point_cloud[0].class",
            "unknown class",
        ),
    ] {
        let text = format!(
            "[[flight_line]]\nstart_m = [0, 0, 100]\nend_m = [0, 10, 100]\nspeed_mps = 10\n\
             [materials.any]\nreflectance = 0.4\n[[point_cloud]]\nfile = '{}'\nmaterial = 'any'\n{extra}\n",
            file.display()
        );
        let e = load(&text).unwrap_err();
        assert_eq!(e.diagnostics[0].key, key, "{e}");
        assert!(e.diagnostics[0].message.contains(what), "{e}");
    }
    let text = format!(
        "[[flight_line]]\nstart_m = [0, 0, 100]\nend_m = [0, 10, 100]\nspeed_mps = 10\n\
         [materials.any]\nreflectance = 0.4\n[[point_cloud]]\nfile = '{}'\nmaterial = 'any'\nvoxel_m = 0\n",
        las_path.display()
    );
    let e = load(&text).unwrap_err();
    assert_eq!(e.diagnostics[0].key, "point_cloud[0].voxel_m", "{e}");
}
