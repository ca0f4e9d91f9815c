//! Property-based fuzzing of every input parser, a bounded number of cases
//! each (deterministic seed, so CI sees the same cases every run): survey
//! TOML, OBJ meshes (through a survey), trajectory CSV, the LAS header
//! read when a run is resumed, ESRI ASCII grids, GeoTIFF bytes, GLB bytes
//! and LAS point clouds read as scene geometry. None may panic; failures
//! must be reported as errors that name their place. Run with
//! `--nocapture` for the counts.

use std::cell::Cell;
use std::path::Path;

use lidarsim::output::{LasSettings, LasWriter, PointRecord, PointSink};
use lidarsim::sensor::platform::Interpolation;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

use crate::kit::temp;

const CASES: u32 = 256;

fn runner(cases: u32) -> TestRunner {
    TestRunner::new_with_rng(
        Config {
            cases,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::deterministic_rng(RngAlgorithm::ChaCha),
    )
}

/// A fuzz run that only accepted or only rejected checked half of what it
/// should: the mutations must reach both the reader's success and its
/// errors (the runs are deterministic, so this cannot flicker).
fn both_paths_taken(accepted: u32, rejected: u32) {
    assert!(
        accepted > 0 && rejected > 0,
        "{accepted} accepted, {rejected} rejected: the cases do not exercise both"
    );
}

const SURVEY: &str = r#"seed = 4
[scanner]
prf_hz = 50000
scan_angle_deg = 20
subrays = 7
[receiver]
noise = 0.01
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
[[tree]]
position_m = [10, 10, 0]
species = "pine"
dbh_m = 0.3
height_m = 15
crown_base_m = 6
"#;

/// A number as a TOML or text token: ordinary, extreme or not finite.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (-1e4f64..1e4).prop_map(|v| format!("{v}")),
        6 => (-5i64..100).prop_map(|v| v.to_string()),
        1 => prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("1e308".to_string()),
        Just("-0".to_string()),
        Just("99999999999999999999".to_string()),
        Just("\"x\"".to_string()),
        Just("[]".to_string()),
        Just("[1, 2]".to_string()),
        Just("true".to_string()),
        ],
    ]
}

/// A number as text, mostly an ordinary one.
fn plain_number() -> impl Strategy<Value = String> {
    prop_oneof![
        9 => (-100f64..100.0).prop_map(|v| format!("{v}")),
        1 => number(),
    ]
}

/// The valid survey with one value replaced, or a few bytes mangled.
fn mutated_survey() -> impl Strategy<Value = String> {
    let values: Vec<(usize, usize)> = {
        // Byte ranges of the values (after "= ").
        let mut v = Vec::new();
        let mut at = 0;
        for line in SURVEY.split_inclusive('\n') {
            if let Some(eq) = line.find(" = ") {
                v.push((at + eq + 3, at + line.trim_end().len()));
            }
            at += line.len();
        }
        v
    };
    let replace = (0..values.len(), number()).prop_map(move |(i, n)| {
        let (a, b) = values[i];
        format!("{}{n}{}", &SURVEY[..a], &SURVEY[b..])
    });
    let mangle =
        proptest::collection::vec((0..SURVEY.len(), any::<u8>(), 0u8..3), 1..6).prop_map(|edits| {
            let mut b = SURVEY.as_bytes().to_vec();
            for (at, byte, op) in edits {
                let at = at.min(b.len());
                match op {
                    0 => b.insert(at, byte),
                    1 if at < b.len() => {
                        b.remove(at);
                    }
                    _ => b.truncate(at),
                }
            }
            String::from_utf8_lossy(&b).into_owned()
        });
    prop_oneof![3 => replace, 1 => mangle]
}

#[test]
fn survey_toml_never_panics_and_errors_name_their_place() {
    let mut runner = runner(CASES);
    let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
    runner
        .run(&mutated_survey(), |text| {
            match lidarsim::world::from_toml(&text, Some(Path::new("fuzz.toml"))) {
                Ok(_) => ok.set(ok.get() + 1),
                Err(e) => {
                    rejected.set(rejected.get() + 1);
                    prop_assert!(!e.diagnostics.is_empty());
                    let lines = text.lines().count().max(1);
                    for d in &e.diagnostics {
                        prop_assert!(d.line <= lines + 1, "{d}");
                        prop_assert!(d.file == "fuzz.toml");
                        prop_assert!(!d.to_string().is_empty());
                    }
                }
            }
            Ok(())
        })
        .unwrap();
    println!(
        "survey TOML: {CASES} cases, {} accepted, {} rejected with diagnostics",
        ok.get(),
        rejected.get()
    );
    both_paths_taken(ok.get(), rejected.get());
    assert_eq!(ok.get() + rejected.get(), CASES);
}

/// One OBJ line: vertices and faces with awkward numbers, material
/// statements, garbage.
fn obj_line() -> impl Strategy<Value = String> {
    let index = prop_oneof![
        8 => (1i64..8).prop_map(|i| i.to_string()),
        1 => (-6i64..1).prop_map(|i| i.to_string()),
        1 => Just("99999999999999999999".to_string()),
        1 => Just("1/2/3".to_string()),
        1 => Just("x".to_string()),
    ];
    prop_oneof![
        8 => proptest::collection::vec(plain_number(), 3).prop_map(|v| format!("v {}", v.join(" "))),
        4 => proptest::collection::vec(index, 3..5).prop_map(|v| format!("f {}", v.join(" "))),
        1 => Just("usemtl grass".to_string()),
        1 => Just("g roof_1".to_string()),
        1 => prop_oneof![
            proptest::collection::vec(number(), 0..5).prop_map(|v| format!("v {}", v.join(" "))),
            Just("usemtl nowhere".to_string()),
            Just("mtllib missing.mtl".to_string()),
            "[ -~]{0,20}",
        ],
    ]
}

fn vertex() -> impl Strategy<Value = String> {
    proptest::collection::vec(plain_number(), 3).prop_map(|v| format!("v {}", v.join(" ")))
}

#[test]
fn obj_meshes_never_panic() {
    let dir = temp("obj");
    let obj = dir.join("m.obj");
    let survey = SURVEY.to_string()
        + &format!(
            "[[mesh]]\nfile = \"{}\"\nmaterial = \"grass\"\nclass = \"roof\"\n",
            obj.display()
        );
    let mut runner = runner(CASES);
    let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
    runner
        .run(
            &(
                proptest::collection::vec(vertex(), 0..8),
                proptest::collection::vec(obj_line(), 0..8),
            ),
            |(vertices, lines)| {
                std::fs::write(
                    &obj,
                    format!("{}\n{}", vertices.join("\n"), lines.join("\n")),
                )
                .unwrap();
                match lidarsim::world::from_toml(&survey, None) {
                    Ok(_) => ok.set(ok.get() + 1),
                    Err(e) => {
                        rejected.set(rejected.get() + 1);
                        let mesh = e.diagnostics.iter().find(|d| d.key == "mesh[0].file");
                        prop_assert!(mesh.is_some(), "{e}");
                        prop_assert!(mesh.unwrap().message.contains("m.obj"), "{e}");
                    }
                }
                Ok(())
            },
        )
        .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    println!(
        "OBJ: {CASES} cases, {} accepted, {} rejected naming the file",
        ok.get(),
        rejected.get()
    );
    both_paths_taken(ok.get(), rejected.get());
}

fn csv_row() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => (proptest::collection::vec(plain_number(), 6), 0u8..2).prop_map(|(v, line)| {
            format!("T,{},{line}", v.join(","))
        }),
        1 => "[ -~]{0,30}",
        1 => Just(String::new()),
    ]
}

#[test]
fn trajectory_csv_never_panics() {
    let dir = temp("csv");
    let csv = dir.join("t.csv");
    let header = "gps_time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,line";
    let mut runner = runner(CASES);
    let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
    runner
        .run(
            &(proptest::collection::vec(csv_row(), 0..10), any::<bool>()),
            |(rows, spline)| {
                // Times increase row by row, except where a row says
                // otherwise; line values change at most a few times.
                let rows: Vec<String> = rows
                    .iter()
                    .enumerate()
                    .map(|(i, r)| r.replacen('T', &(i as f64 * 0.5).to_string(), 1))
                    .collect();
                std::fs::write(&csv, format!("{header}\n{}", rows.join("\n"))).unwrap();
                let interpolation = if spline {
                    Interpolation::Spline
                } else {
                    Interpolation::Linear
                };
                match lidarsim::io::trajectory::read_trajectory(&csv, interpolation) {
                    Ok(lines) => {
                        ok.set(ok.get() + 1);
                        for (start, track) in &lines {
                            prop_assert!(start.is_finite() && track.duration_s() >= 0.0);
                        }
                    }
                    Err(e) => {
                        rejected.set(rejected.get() + 1);
                        prop_assert!(e.contains("t.csv"), "{e}");
                    }
                }
                Ok(())
            },
        )
        .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    println!(
        "trajectory CSV: {CASES} cases, {} accepted, {} rejected naming the file",
        ok.get(),
        rejected.get()
    );
    both_paths_taken(ok.get(), rejected.get());
}

fn las_settings() -> LasSettings {
    LasSettings {
        scale_m: 0.001,
        offset_m: [0.0, 0.0, 0.0],
        adjusted_standard_gps_time: false,
        file_source_id: 1,
        creation_day_year: (1, 2026),
        generating_software: "fuzz".into(),
        error_extra_bytes: false,
        origin_m: [0.0; 3],
        attribute_extra_bytes: true,
        crs_wkt: None,
        compressed: false,
        waveform: None,
        waveform_file_shared: false,
    }
}

#[test]
fn las_header_of_a_resumed_run_never_panics() {
    // A valid interrupted file: 20 points.
    let dir = temp("las");
    let good = dir.join("good.las");
    let mut w = Box::new(LasWriter::create(&good, las_settings()).unwrap());
    let points: Vec<PointRecord> = (0..20u32)
        .map(|i| PointRecord {
            position_m: lidarsim::geometry::DVec3::new(f64::from(i), 2.0, 3.0),
            gps_time_s: f64::from(i),
            intensity: 100,
            amplitude: 1.0,
            echo_width_ns: 4.0,
            range_m: 500.0,
            return_number: 1,
            number_of_returns: 1,
            scan_direction_positive: true,
            edge_of_flight_line: false,
            scan_angle_deg: 0.0,
            classification: 2,
            point_source_id: 1,
            pulse_index: u64::from(i),
            object_id: None,
            component: Default::default(),
            channel: 0,
            error_m: lidarsim::geometry::DVec3::ZERO,
            beam_dir: -lidarsim::geometry::DVec3::Z,
            incidence_angle_deg: Some(0.0),
            echo_time_ps: 3.3e6,
        })
        .collect();
    w.write(&points).unwrap();
    w.finish().unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let path = dir.join("points.las");
    let mut runner = runner(CASES);
    let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
    let edits = proptest::collection::vec((0..bytes.len(), any::<u8>()), 0..4);
    let n = bytes.len();
    let len = prop_oneof![3 => Just(n), 1 => 0..n + 10];
    runner
        .run(&(edits, len), |(edits, len)| {
            let mut b = bytes.clone();
            for (at, v) in edits {
                b[at] = v;
            }
            std::fs::write(dir.join("points.las.partial"), &b).unwrap();
            match LasWriter::resume(&path, las_settings(), len as u64, None) {
                Ok(w) => {
                    ok.set(ok.get() + 1);
                    Box::new(w).finish().unwrap();
                }
                Err(e) => {
                    rejected.set(rejected.get() + 1);
                    prop_assert!(e.to_string().contains("points.las"), "{e}");
                }
            }
            let _ = std::fs::remove_file(dir.join("points.las.partial"));
            Ok(())
        })
        .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    println!(
        "LAS header (resume): {CASES} cases, {} accepted, {} rejected naming the file",
        ok.get(),
        rejected.get()
    );
    both_paths_taken(ok.get(), rejected.get());
}

/// Applies byte edits (set, insert, remove) and a final length to `bytes`;
/// half the edits fall in `hot` (the header), where they matter most.
fn mutate(bytes: &[u8], edits: &[(usize, u8, u8, bool)], hot: usize, len: usize) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for &(at, v, op, in_hot) in edits {
        if b.is_empty() {
            break;
        }
        let at = if in_hot {
            at % hot.min(b.len())
        } else {
            at % b.len()
        };
        match op {
            0 | 1 => b[at] = v,
            2 => b.insert(at, v),
            _ => {
                b.remove(at);
            }
        }
    }
    b.truncate(len);
    b
}

fn edits() -> impl Strategy<Value = Vec<(usize, u8, u8, bool)>> {
    proptest::collection::vec((any::<usize>(), any::<u8>(), 0u8..4, any::<bool>()), 0..5)
}

/// Whole length mostly, else cut anywhere.
fn length(n: usize) -> impl Strategy<Value = usize> {
    prop_oneof![4 => Just(usize::MAX), 1 => 0..n]
}

fn corpus_file(rel: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../lidarsim-cli/tests/corpus")
        .join(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn data_file(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name),
    )
    .unwrap()
}

/// One ESRI ASCII header line: a known key (or a misspelt one) with an
/// awkward value, sometimes none.
fn asc_header_line() -> impl Strategy<Value = String> {
    let key = prop_oneof![
        Just("ncols"),
        Just("nrows"),
        Just("xllcorner"),
        Just("yllcenter"),
        Just("cellsize"),
        Just("dx"),
        Just("NODATA_value"),
        Just("xllcenter"),
        Just("cellsise"),
    ];
    let value = prop_oneof![
        6 => (0i64..6).prop_map(|v| v.to_string()),
        2 => plain_number(),
        1 => number(),
        1 => Just("1000000000".to_string()),
        1 => Just(String::new()),
    ];
    (key, value).prop_map(|(k, v)| format!("{k} {v}"))
}

#[test]
fn esri_ascii_grids_never_panic_and_errors_name_the_file() {
    let dir = temp("asc");
    let path = dir.join("g.asc");
    let valid = "ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 2\nNODATA_value -9999\n";
    let mut runner = runner(CASES);
    let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
    let text = (
        prop_oneof![
            3 => Just(valid.to_string()),
            2 => proptest::collection::vec(asc_header_line(), 0..8)
                .prop_map(|l| l.join("\n") + "\n"),
        ],
        prop_oneof![
            3 => proptest::collection::vec(plain_number(), 9),
            1 => proptest::collection::vec(plain_number(), 0..14),
        ],
        proptest::collection::vec((0..400usize, any::<u8>()), 0..2),
    );
    runner
        .run(&text, |(header, values, bytes)| {
            let mut b = format!("{header}{}\n", values.join(" ")).into_bytes();
            for (at, v) in bytes {
                let at = at % b.len();
                b[at] = v;
            }
            std::fs::write(&path, &b).unwrap();
            match lidarsim::io::raster::read_raster(&path) {
                Ok(g) => {
                    ok.set(ok.get() + 1);
                    let (c, r) = (g.cols, g.rows);
                    prop_assert!(c >= 2 && r >= 2 && g.heights.len() == c * r);
                }
                Err(e) => {
                    rejected.set(rejected.get() + 1);
                    prop_assert!(e.to_string().contains("g.asc"), "{e}");
                }
            }
            Ok(())
        })
        .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    println!(
        "ESRI ASCII: {CASES} cases, {} accepted, {} rejected naming the file",
        ok.get(),
        rejected.get()
    );
    both_paths_taken(ok.get(), rejected.get());
}

#[test]
fn geotiff_bytes_never_panic_and_errors_name_the_file() {
    // GDAL's DEFLATE-compressed tiled rasters (rasterio fixtures) and the
    // corpus' uncompressed strip.
    let sources = [
        data_file("dem_area.tif"),
        data_file("dem_point.tif"),
        corpus_file("geotiff/good.tif"),
    ];
    let dir = temp("tif");
    let path = dir.join("dem.tif");
    let mut runner = runner(CASES);
    let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
    runner
        .run(&(0..sources.len(), edits(), length(2000)), |(k, e, len)| {
            let b = mutate(&sources[k], &e, 600, len);
            std::fs::write(&path, &b).unwrap();
            match lidarsim::io::raster::read_raster(&path) {
                Ok(g) => {
                    ok.set(ok.get() + 1);
                    prop_assert!(g.heights.len() == g.cols * g.rows);
                    prop_assert!(g.heights.iter().any(|h| h.is_finite()));
                }
                Err(e) => {
                    rejected.set(rejected.get() + 1);
                    prop_assert!(e.to_string().contains("dem.tif"), "{e}");
                }
            }
            Ok(())
        })
        .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    println!(
        "GeoTIFF: {CASES} cases, {} accepted, {} rejected naming the file",
        ok.get(),
        rejected.get()
    );
    both_paths_taken(ok.get(), rejected.get());
}

/// A small survey whose only scene entry names `entry` (a `[[mesh]]` or
/// `[[point_cloud]]` table).
fn scene_survey(entry: &str) -> String {
    format!(
        "[[flight_line]]\nstart_m = [0.0, -50.0, 300.0]\nend_m = [0.0, 50.0, 300.0]\n\
         speed_mps = 50.0\n[materials.grass]\nreflectance = 0.4\n{entry}"
    )
}

#[test]
fn glb_bytes_never_panic_and_errors_name_the_file() {
    let glb = corpus_file("gltf/good.glb");
    // The JSON chunk: its numbers (counts, offsets, lengths, indices) are
    // what a digit edit changes.
    let json_len = u32::from_le_bytes([glb[12], glb[13], glb[14], glb[15]]) as usize;
    let dir = temp("glb");
    let path = dir.join("m.glb");
    let survey = scene_survey(&format!(
        "[[mesh]]\nfile = \"{}\"\nmaterial = \"grass\"\n",
        path.display()
    ));
    let digit_edits = proptest::collection::vec((0..json_len, 0u32..10, 0u32..1000), 0..4);
    let mut runner = runner(CASES);
    let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
    runner
        .run(
            &(digit_edits, edits(), length(glb.len())),
            |(digits, e, len)| {
                // Replace a digit of the JSON by a number (same length is not
                // kept: the chunk length then disagrees, another error).
                let mut b = glb.clone();
                for (at, d, n) in digits {
                    let at = 20 + at;
                    if b[at].is_ascii_digit() {
                        if n < 500 {
                            b[at] = b'0' + d as u8;
                        } else {
                            let s = (n * 977 + d).to_string();
                            b.splice(at..=at, s.bytes());
                        }
                    }
                }
                let b = mutate(&b, &e, 20 + json_len, len);
                std::fs::write(&path, &b).unwrap();
                match lidarsim::world::from_toml(&survey, None) {
                    Ok(_) => ok.set(ok.get() + 1),
                    Err(e) => {
                        rejected.set(rejected.get() + 1);
                        let d = e.diagnostics.iter().find(|d| d.key == "mesh[0].file");
                        prop_assert!(d.is_some(), "{e}");
                        prop_assert!(d.unwrap().message.contains("m.glb"), "{e}");
                    }
                }
                Ok(())
            },
        )
        .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    println!(
        "GLB: {CASES} cases, {} accepted, {} rejected naming the file",
        ok.get(),
        rejected.get()
    );
    both_paths_taken(ok.get(), rejected.get());
}

#[test]
fn las_point_cloud_bytes_never_panic_and_errors_name_the_file() {
    let las = corpus_file("cloud/good.las");
    let dir = temp("cloud");
    let path = dir.join("c.las");
    let survey = scene_survey(&format!(
        "[[point_cloud]]\nfile = \"{}\"\nmaterial = \"grass\"\nvoxel_m = 0.5\n",
        path.display()
    ));
    let mut runner = runner(CASES);
    let (ok, rejected, far_off) = (Cell::new(0u32), Cell::new(0u32), Cell::new(0u32));
    runner
        .run(&(edits(), length(las.len())), |(e, len)| {
            // The header is the first 227 bytes.
            let b = mutate(&las, &e, 227, len);
            std::fs::write(&path, &b).unwrap();
            match lidarsim::world::from_toml(&survey, None) {
                Ok(_) => ok.set(ok.get() + 1),
                Err(e) => {
                    rejected.set(rejected.get() + 1);
                    let d = e
                        .diagnostics
                        .iter()
                        .find(|d| d.key == "point_cloud[0].file");
                    // A cloud that reads but lies absurdly far (a mutated
                    // scale or offset) is refused by the scene-wide extent
                    // check, or by the LAS output's coordinate range;
                    // anything else names the file.
                    let far = e.diagnostics.iter().any(|d| {
                        d.message.contains("coordinates must lie within ±1e8 m")
                            || d.key == "output.las_scale_m"
                    });
                    prop_assert!(d.is_some() || far, "{e}");
                    if d.is_none() {
                        far_off.set(far_off.get() + 1);
                    }
                    if let Some(d) = d {
                        prop_assert!(d.message.contains("c.las"), "{e}");
                    }
                }
            }
            Ok(())
        })
        .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    println!(
        "LAS point cloud: {CASES} cases, {} accepted, {} rejected ({} naming the file, {} by \
         the scene's ±1e8 m extent check)",
        ok.get(),
        rejected.get(),
        rejected.get() - far_off.get(),
        far_off.get()
    );
    both_paths_taken(ok.get(), rejected.get());
}
