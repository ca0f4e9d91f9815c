//! The broken-input corpus (`tests/corpus/`): every file is fed to the
//! binary, which must fail with a clear message — exit status 2 for a bad
//! survey (or a bad mesh or trajectory it names), 1 for an unreadable LAS
//! file — naming the file and, where meaningful, the line and the key,
//! never panicking and never leaving an output behind.
//!
//! Run with `--nocapture` to see every input and the first line the user
//! saw.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus")
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lidarsim-corpus-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn lidarsim(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lidarsim"))
        .args(args)
        .output()
        .unwrap()
}

/// Checks one failure: status, no panic, every expected fragment.
fn assert_clean_failure(what: &str, o: &Output, status: i32, expect: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(status), "{what}: {stderr}");
    assert!(!stderr.contains("panicked"), "{what}: {stderr}");
    for e in expect {
        assert!(stderr.contains(e), "{what}: wanted '{e}' in\n{stderr}");
    }
    stderr
}

/// `check` and `run` reject the survey; `run` writes nothing.
fn reject_survey(what: &str, survey: &Path, expect: &[&str], seen: &mut Vec<(String, String)>) {
    let stderr = assert_clean_failure(
        what,
        &lidarsim(&["check".as_ref(), survey.as_os_str()]),
        2,
        expect,
    );
    let out = temp(&format!("out-{}", what.replace('/', "-")));
    let o = lidarsim(&[
        "run".as_ref(),
        survey.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert_clean_failure(what, &o, 2, expect);
    let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
    assert!(left.is_empty(), "{what}: run left {left:?}");
    std::fs::remove_dir_all(&out).ok();
    let first = stderr.lines().next().unwrap_or("").to_string();
    seen.push((what.to_string(), first));
}

fn print(seen: &[(String, String)]) {
    for (what, first) in seen {
        println!("{what:<36} {first}");
    }
    println!("{} inputs rejected cleanly", seen.len());
}

#[test]
fn broken_surveys() {
    // (file, fragments of the message: place, key, reason)
    let cases: [(&str, &[&str]); 12] = [
        (
            "far_coordinates.toml",
            &[
                "far_coordinates.toml:12:15",
                "`polygon[0].vertices_m[0]`: coordinates must lie within ±1e8 m",
                "4 problems found",
            ],
        ),
        (
            "syntax_error.toml",
            &["syntax_error.toml:1:9", "unclosed table", "1 | [scanner"],
        ),
        (
            "wrong_types.toml",
            &[
                "wrong_types.toml:2:10",
                "`scanner.prf_hz`: invalid type: string \"fast\", expected a number",
                "wrong_types.toml:3:11",
                "`scanner.subrays`",
                "wrong_types.toml:6:11",
                "`flight_line[0].start_m`: invalid type: string \"north\", expected an array",
                "wrong_types.toml:8:13",
                "4 problems found",
            ],
        ),
        (
            "unknown_keys.toml",
            &[
                "unknown_keys.toml:2:1",
                "`scanner.prf_hertz`: unknown field `prf_hertz`",
                "valid keys here: prf_hz,",
                "unknown_keys.toml:4:2",
                "did you mean `platform`?",
                "unknown_keys.toml:11:1",
                "`flight_line[0].heading`",
            ],
        ),
        (
            "nan_inf.toml",
            &[
                "nan_inf.toml:2:10",
                "`scanner.prf_hz`: must be greater than 0 Hz, got NaN",
                "nan_inf.toml:3:18",
                "got inf",
                "`flight_line[0].start_m`: must hold finite numbers",
                "nan_inf.toml:7:9",
            ],
        ),
        (
            "negative_counts.toml",
            &[
                "negative_counts.toml:2:11",
                "`scanner.subrays`: must be a whole number from 1 to 10000, got -3",
                "negative_counts.toml:3:15",
                "`scanner.max_returns`",
            ],
        ),
        (
            "huge_numbers.toml",
            &[
                "huge_numbers.toml:2:10",
                "`scanner.prf_hz`: must be at most 10000000 Hz",
                "huge_numbers.toml:3:11",
                "got 99999999999",
                "huge_numbers.toml:7:9",
                "a flight line may take at most 24 h",
            ],
        ),
        (
            "integer_overflow.toml",
            &[
                "integer_overflow.toml:1:8",
                "`seed`",
                "TOML integers are 64-bit",
            ],
        ),
        (
            "empty.toml",
            &["empty.toml", "the survey needs flight lines"],
        ),
        (
            "non_utf8.toml",
            &["non_utf8.toml:3", "not valid UTF-8 (byte 31)"],
        ),
        (
            "impossible.toml",
            &[
                "impossible.toml:2:18",
                "`scanner.scan_angle_deg`: must be between 0 and 89°, got 95",
                "above the horizon",
                "impossible.toml:6:9",
                "the line has no length",
                "impossible.toml:7:13",
                "`flight_line[0].speed_mps`: must be greater than 0 m/s, got 0",
            ],
        ),
        (
            "no_such_file.toml",
            &["no_such_file.toml", "cannot read the survey file"],
        ),
    ];
    let mut seen = Vec::new();
    for (file, expect) in cases {
        let path = corpus().join("survey").join(file);
        reject_survey(&format!("survey/{file}"), &path, expect, &mut seen);
    }
    print(&seen);
}

/// A survey around a mesh or trajectory of the corpus.
fn survey_with(dir: &Path, template: &str, file: &Path) -> PathBuf {
    let text = template.replace("FILE", &file.display().to_string());
    let path = dir.join("survey.toml");
    std::fs::write(&path, text).unwrap();
    path
}

const MESH_SURVEY: &str = r#"[[flight_line]]
start_m = [0.0, -50.0, 300.0]
end_m = [0.0, 50.0, 300.0]
speed_mps = 50.0

[materials.grass]
reflectance = 0.4

[materials.tile]
reflectance = 0.3

[[mesh]]
file = "FILE"
material = "grass"
class = "roof"
"#;

#[test]
fn broken_meshes() {
    let cases: [(&str, &str); 11] = [
        (
            "truncated_vertex.obj",
            "line 3: vertex 'v 10 10' needs three numbers",
        ),
        (
            "truncated_face.obj",
            "holds no triangle with three distinct, finite corners",
        ),
        (
            "nan_vertices.obj",
            "holds no triangle with three distinct, finite corners",
        ),
        (
            "index_out_of_range.obj",
            "line 4: face corner 99 refers to no vertex (3 defined so far)",
        ),
        (
            "huge_index.obj",
            "line 4: face corner '99999999999999999999999' is not a vertex index",
        ),
        (
            "zero_index.obj",
            "line 4: face corner 0: OBJ indices start at 1",
        ),
        (
            "degenerate.obj",
            "holds no triangle with three distinct, finite corners",
        ),
        ("empty.obj", "holds no triangle"),
        ("non_utf8.obj", "line 4: not valid UTF-8"),
        (
            "missing_mtl.obj",
            "line 1: cannot load material library 'missing.mtl'",
        ),
        (
            "bad_mtl.obj",
            "line 1: cannot load material library 'bad.mtl'",
        ),
    ];
    let dir = temp("mesh");
    let mut seen = Vec::new();
    for (file, reason) in cases {
        let obj = corpus().join("obj").join(file);
        let survey = survey_with(&dir, MESH_SURVEY, &obj);
        reject_survey(
            &format!("obj/{file}"),
            &survey,
            &["survey.toml:13:8", "`mesh[0].file`", file, reason],
            &mut seen,
        );
    }
    std::fs::remove_dir_all(&dir).ok();
    print(&seen);
}

const TRAJECTORY_SURVEY: &str = r#"preset = "uav"

[platform]
trajectory_file = "FILE"

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

#[test]
fn broken_trajectories() {
    let cases: [(&str, &str); 8] = [
        ("missing_column.csv", "line 1: no column `pitch_deg`"),
        ("time_goes_back.csv", "line 4: times must increase"),
        ("nan.csv", "line 3: `x_m` is 'nan', not a number"),
        ("truncated_row.csv", "line 3: `z_m` is '', not a number"),
        ("empty.csv", "is empty"),
        ("header_only.csv", "holds no trajectory rows"),
        ("huge_time.csv", "a flight line may take at most 24 h"),
        ("non_utf8.csv", "did not contain valid UTF-8"),
    ];
    let dir = temp("trajectory");
    let mut seen = Vec::new();
    for (file, reason) in cases {
        let csv = corpus().join("trajectory").join(file);
        let survey = survey_with(&dir, TRAJECTORY_SURVEY, &csv);
        let mut expect = vec!["survey.toml:4:19", "`platform.trajectory_file`", reason];
        if file != "huge_time.csv" {
            expect.push(file);
        }
        reject_survey(&format!("trajectory/{file}"), &survey, &expect, &mut seen);
    }
    std::fs::remove_dir_all(&dir).ok();
    print(&seen);
}

#[test]
fn broken_las_files_for_render() {
    let cases: [(&str, &str); 10] = [
        ("empty.las", "the file ends early"),
        (
            "scale_nan.las",
            "point 1 has a coordinate that is not a finite number",
        ),
        ("truncated_header.las", "the file ends early"),
        (
            "truncated_points.las",
            "the header counts 40 points of 30 bytes, more than",
        ),
        ("count_too_large.las", "points outside the file"),
        ("offset_beyond_end.las", "the file ends early"),
        ("wrong_signature.las", "the file signature is not 'LASF'"),
        ("text_file.las", "the file signature is not 'LASF'"),
        ("record_length_1.las", "record length 1 is too small"),
        ("unknown_point_format.las", "invalid format number: 77"),
    ];
    let dir = temp("las");
    let png = dir.join("top.png");
    let mut seen = Vec::new();
    for (file, reason) in cases {
        let las = corpus().join("las").join(file);
        let o = lidarsim(&[
            "render".as_ref(),
            las.as_os_str(),
            "-o".as_ref(),
            png.as_os_str(),
        ]);
        let what = format!("las/{file}");
        let stderr = assert_clean_failure(&what, &o, 1, &[file, reason]);
        assert!(!png.exists(), "{what}: a picture was written");
        seen.push((what, stderr.lines().next().unwrap_or("").to_string()));
    }
    std::fs::remove_dir_all(&dir).ok();
    print(&seen);
}
