//! Property-based fuzzing of every input parser, a bounded number of cases
//! each (deterministic seed, so CI sees the same cases every run): survey
//! TOML, OBJ meshes (through a survey), trajectory CSV and the LAS header
//! read when a run is resumed. None may panic; failures must be reported
//! as errors that name their place. Run with `--nocapture` for the counts.

use std::cell::Cell;
use std::path::{Path, PathBuf};

use lidarsim::Survey;
use lidarsim::output::{LasSettings, LasWriter, PointRecord, PointSink};
use lidarsim::platform::Interpolation;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

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

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lidarsim-fuzz-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
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
            match Survey::from_toml(&text, Some(Path::new("fuzz.toml"))) {
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
                match Survey::from_toml(&survey, None) {
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
                match lidarsim::survey::read_trajectory(&csv, interpolation) {
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
            object_id: 0,
            component: 0,
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
            std::fs::write(&path, &b).unwrap();
            match LasWriter::resume(&path, las_settings(), len as u64) {
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
}
