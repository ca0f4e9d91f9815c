//! Building worlds: the scene from the files a survey names, forests on
//! the ground, flight lines over it; problems at the survey's keys.

use std::path::Path;

use super::World;
use crate::scene::{Shape, SurfaceClass};
use crate::survey::{Survey, SurveyError};

const MINIMAL: &str = r#"
[[flight_line]]
start_m = [0.0, -100.0, 500.0]
end_m = [0.0, 100.0, 500.0]
speed_mps = 50.0

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

/// The survey and world of a TOML text (`base` resolves relative files).
fn build(
    text: &str,
    base: Option<&Path>,
    seed: Option<u64>,
) -> Result<(Survey, World), SurveyError> {
    let survey = Survey::from_toml_with_seed(text, base, seed)?;
    let world = World::build(&survey)?;
    Ok((survey, world))
}

#[test]
fn a_minimal_survey_builds_one_line_over_its_polygon() {
    let (s, w) = build(MINIMAL, None, None).unwrap();
    assert_eq!(w.lines.len(), 1);
    assert_eq!(s.pulses_of(&w.lines[0]), 400_000);
    assert_eq!(w.scene().primitives.len(), 1);
}

#[test]
fn forests_stand_on_the_ground_and_follow_the_seed() {
    let text = format!(
        "{}\n[[forest]]\nrectangle_m = [-50, -50, 50, 50]\nstems_per_ha = 300\n",
        MINIMAL.replace(
            "[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]",
            "[-300, -300, -7], [300, -300, -7], [300, 300, -7], [-300, 300, -7]"
        )
    );
    let (_, a) = build(&text, None, None).unwrap();
    assert_eq!(a.forest_trees, [300]);
    let trunks = |w: &World| -> Vec<crate::geometry::Aabb> {
        w.scene()
            .primitives
            .iter()
            .filter(|p| matches!(p.shape, Shape::Trunk(_)))
            .map(|p| p.bounds())
            .collect()
    };
    assert!(trunks(&a).iter().all(|b| b.min.z == -7.0));
    let (_, b) = build(&text, None, Some(99)).unwrap();
    assert_ne!(trunks(&a)[0], trunks(&b)[0]);
    assert!(a.warnings.is_empty());
    // Too many stems for the spacing: placed anyway, with a warning.
    let crowded = text.replace(
        "stems_per_ha = 300",
        "stems_per_ha = 5000\nmin_spacing_m = 4",
    );
    let (_, c) = build(&crowded, None, None).unwrap();
    assert!(c.forest_trees[0] < 5000);
    assert!(c.warnings[0].contains("forest[0]"), "{:?}", c.warnings);
}

#[test]
fn mesh_class_patterns_map_groups_and_name_their_key() {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/x.toml");
    let text = |classes: &str| {
        format!(
            "[[flight_line]]\nstart_m = [0, -50, 300]\nend_m = [0, 50, 300]\nspeed_mps = 50\n\
             [[mesh]]\nfile = \"house.obj\"\nclass = \"roof\"\nclasses = {{ {classes} }}\n"
        )
    };
    let (_, w) =
        build(&text("\"wall*\" = \"bridge\""), Some(&base), None).unwrap_or_else(|e| panic!("{e}"));
    let count = |c: SurfaceClass| w.scene().primitives.iter().filter(|p| p.class == c).count();
    // house.obj: the gable walls (south, north) are pentagons of three
    // triangles, east and west quads of two: 10 triangles become
    // bridge, no wall is left.
    assert_eq!(count(SurfaceClass::Bridge), 10);
    assert_eq!(count(SurfaceClass::Wall), 0);
    assert!(count(SurfaceClass::Roof) > 0);

    let e = build(
        &text("\"wal*\" = \"wall\", roofs = \"roof\""),
        Some(&base),
        None,
    )
    .unwrap_err();
    assert_eq!(e.diagnostics.len(), 1, "{e}");
    assert_eq!(e.diagnostics[0].key, "mesh[0].classes.roofs");
    assert!(
        e.diagnostics[0]
            .message
            .contains("no group or object name matches 'roofs'")
    );
    assert_eq!(e.diagnostics[0].line, 8);
    let e = build(&text("\"wall*\" = \"lava\""), Some(&base), None).unwrap_err();
    assert!(
        e.diagnostics[0].message.contains("unknown class 'lava'"),
        "{e}"
    );
    assert_eq!(e.diagnostics[0].line, 8);
}

#[test]
fn terrain_example_loads_with_trees_on_the_terrain() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/terrain.toml");
    let s = Survey::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let w = World::build(&s).unwrap_or_else(|e| panic!("{e}"));
    let b = w.scene().bounds();
    // The bounds kept from the index's build are the scene's own.
    assert_eq!(w.scene_bounds(), b);
    // The fBm terrain: extent [-300, -200, 300, 200] on a 2 m grid,
    // relief 35 m from z = 0; tree crowns reach higher.
    assert_eq!(
        (b.min.x, b.min.y, b.max.x, b.max.y),
        (-300.0, -200.0, 300.0, 200.0)
    );
    assert_eq!(b.min.z, 0.0);
    let terrain = w
        .scene()
        .primitives
        .iter()
        .filter(|p| matches!(p.shape, Shape::Terrain(_)))
        .count();
    // 300 × 200 cells in 16-cell tiles: ceil(300/16) × ceil(200/16).
    assert_eq!(terrain, 19 * 13);
    // Every trunk stands on the terrain: its base is within the relief.
    for p in &w.scene().primitives {
        if let Shape::Trunk(_) = &p.shape {
            let z = p.bounds().min.z;
            assert!((0.0..=35.0001).contains(&z), "trunk base at {z}");
        }
    }
    assert!(w.forest_trees[0] > 1000, "{:?}", w.forest_trees);
}

/// A `[[tree_table]]` row gives the primitives of the `[[tree]]` entry
/// with the same keys (its offset added); a bad cell is reported at the
/// table's `file` key, naming the line and column.
#[test]
fn a_tree_table_gives_the_trees_its_rows_describe() {
    let dir = std::env::temp_dir().join(format!("lidarsim-world-table-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("trees.csv"),
        "# two trees\nid,x_m,y_m,z_m,species,height_m,crown_base_m,crown_radius_m,dbh_m,seed\n\
         1,10,20,0,pine,18,9,2.5,0.25,7\n",
    )
    .unwrap();
    let table = format!("{MINIMAL}\n[[tree_table]]\nfile = \"trees.csv\"\noffset_m = [-5, 5, 0]\n");
    let entry = format!(
        "{MINIMAL}\n[[tree]]\nposition_m = [5, 25, 0]\nspecies = \"pine\"\nheight_m = 18\n\
         crown_base_m = 9\ncrown_radius_m = 2.5\ndbh_m = 0.25\nseed = 7\n"
    );
    let survey_path = dir.join("s.toml");
    let (_, a) = build(&table, Some(&survey_path), None).unwrap();
    let (_, b) = build(&entry, Some(&survey_path), None).unwrap();
    let shapes = |w: &World| -> Vec<String> {
        w.scene()
            .primitives
            .iter()
            .map(|p| format!("{:?}", p.shape))
            .collect()
    };
    assert_eq!(shapes(&a), shapes(&b));
    assert_eq!(a.scene().primitives.len(), 3);
    std::fs::write(
        dir.join("trees.csv"),
        "x_m,y_m,z_m,height_m\n1,2,0,15\n1,2,0,tall\n",
    )
    .unwrap();
    let text = format!("{MINIMAL}\n[[tree_table]]\nfile = \"trees.csv\"\nspecies = \"birch\"\n");
    let e = build(&text, Some(&survey_path), None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("tree_table[0].file") && e.contains("line 3, column 4 (height_m)"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
