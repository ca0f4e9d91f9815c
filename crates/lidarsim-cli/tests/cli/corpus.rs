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

use crate::kit::temp;

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus")
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
                "valid keys here: preset, prf_hz,",
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
            "line 2: vertex coordinate 'nan' is not a finite number within ±1e8 m",
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
        (
            "truncated_row.csv",
            "line 3: 3 values for the header's 8 columns",
        ),
        ("empty.csv", "is empty"),
        ("header_only.csv", "holds no trajectory rows"),
        ("huge_time.csv", "a flight line may take at most 24 h"),
        ("non_utf8.csv", "line 3: not valid UTF-8 (byte 92)"),
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
        ("scale_nan.las", "the header's x scale factor is NaN"),
        ("truncated_header.las", "the file ends early"),
        (
            "truncated_points.las",
            "the header counts 40 points of 30 bytes, more than",
        ),
        (
            "count_too_large.las",
            "the header counts 1000000000000 points of 30 bytes, more than the file's 1575 bytes",
        ),
        ("offset_beyond_end.las", "the file ends early"),
        (
            "wrong_signature.las",
            "is not a LAS or LAZ file (it starts with \"LASX\")",
        ),
        (
            "text_file.las",
            "is not a LAS or LAZ file (it starts with \"x y \")",
        ),
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

/// A survey naming one file of the corpus as `[[KIND]] file` (line 10).
const FILE_SURVEY: &str = r#"[[flight_line]]
start_m = [0.0, -50.0, 300.0]
end_m = [0.0, 50.0, 300.0]
speed_mps = 50.0

[materials.grass]
reflectance = 0.4

[[KIND]]
file = "FILE"
material = "grass"
"#;

/// Feeds every file of `folder` (with `cases` = (file, reason)) as the
/// `file` of a `[[kind]]` entry; the valid `good` baseline must pass
/// `check`, so each broken file fails for its own defect.
fn reject_files(folder: &str, kind: &str, good: &str, cases: &[(&str, &str)]) {
    let dir = temp(folder);
    let template = FILE_SURVEY.replace("KIND", kind);
    let good_survey = survey_with(&dir, &template, &corpus().join(folder).join(good));
    let o = lidarsim(&["check".as_ref(), good_survey.as_os_str()]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{folder}/{good}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let key = format!("`{kind}[0].file`");
    let mut seen = Vec::new();
    for (file, reason) in cases {
        let path = corpus().join(folder).join(file);
        let survey = survey_with(&dir, &template, &path);
        reject_survey(
            &format!("{folder}/{file}"),
            &survey,
            &["survey.toml:10:8", &key, file, reason],
            &mut seen,
        );
    }
    std::fs::remove_dir_all(&dir).ok();
    print(&seen);
}

#[test]
fn broken_geotiffs() {
    reject_files(
        "geotiff",
        "terrain",
        "good.tif",
        &[
            (
                "truncated.tif",
                "the file ends early: it is truncated or not a TIFF",
            ),
            (
                "not_a_tiff.tif",
                "not a readable TIFF: format error: TIFF signature not found",
            ),
            (
                "no_geotags.tif",
                "is not georeferenced: it has neither ModelPixelScaleTag + ModelTiepointTag nor \
                 ModelTransformationTag",
            ),
            (
                "rotated.tif",
                "ModelTransformationTag rotates or shears the pixel grid",
            ),
            (
                "one_pixel.tif",
                "a terrain needs at least 2 × 2 cells, got 1 × 1",
            ),
            ("all_nan.tif", "holds inf, not a height within ±100000 m"),
            (
                "huge_dimensions.tif",
                "4000000000 × 4000000000 cells exceed the limit of 100000000 cells",
            ),
            (
                "huge_strip.tif",
                "the header declares 9000 × 9000 uncompressed pixels of 32 bits (324000000 \
                 bytes), more than the file's 266 bytes",
            ),
            (
                "huge_tag.tif",
                "a tag declares more values than a GeoTIFF DEM can hold",
            ),
        ],
    );
}

#[test]
fn broken_ascii_grids() {
    reject_files(
        "asc",
        "terrain",
        "good.asc",
        &[
            ("missing_nrows.asc", "the header has no 'nrows'"),
            (
                "negative_cellsize.asc",
                "line 5: 'cellsize' must be greater than 0, got -2",
            ),
            (
                "zero_cellsize.asc",
                "line 5: 'cellsize' must be greater than 0, got 0",
            ),
            (
                "too_few_values.asc",
                "line 7: expected ncols × nrows = 3 × 2 = 6 values, found 5",
            ),
            (
                "too_many_values.asc",
                "line 7: more values than ncols × nrows = 3 × 2",
            ),
            ("non_numeric.asc", "line 7: 'five' is not a number"),
            (
                "huge.asc",
                "1000000000 × 1000000000 cells exceed the limit of 100000000 cells",
            ),
            (
                "fractional_ncols.asc",
                "line 1: 'ncols' must be a positive whole number, got 2.5",
            ),
            (
                "nan_header.asc",
                "line 3: header key 'xllcorner' must be finite",
            ),
            ("non_utf8.asc", "line 7: not valid UTF-8 (byte 3)"),
            ("empty.asc", "the header has no 'ncols'"),
        ],
    );
}

#[test]
fn broken_gltf_meshes() {
    reject_files(
        "gltf",
        "mesh",
        "good.glb",
        &[
            ("truncated.glb", "not a valid glTF 2.0 file"),
            (
                "bad_magic.glb",
                "is not a binary glTF (GLB): it does not start with the magic 'glTF'",
            ),
            ("empty.glb", "is empty"),
            (
                "not_gltf.gltf",
                "not a valid glTF 2.0 file: missing field `asset`",
            ),
            (
                "missing_buffer.gltf",
                "cannot load its buffer 'missing.bin': No such file or directory",
            ),
            (
                "buffer_too_short.glb",
                "cannot load its buffers: buffer 0: expected 60 bytes but received 24 bytes",
            ),
            (
                "accessor_past_buffer.glb",
                "accessor 0 counts 1000 elements of 12 bytes, past the end of buffer view 0 \
                 (48 bytes)",
            ),
            (
                "huge_count.glb",
                "accessor 0 counts 4611686018427387904 elements of 12 bytes, past the end",
            ),
            ("zero_count.glb", "accessor 1 counts no element"),
            (
                "nan_positions.glb",
                "holds no triangle with three distinct, finite corners",
            ),
            (
                "index_out_of_range.glb",
                "primitive 0: an index points past its vertices",
            ),
        ],
    );
}

#[test]
fn broken_point_clouds() {
    reject_files(
        "cloud",
        "point_cloud",
        "good.las",
        &[
            (
                "empty.las",
                "the file ends early: it is truncated or not a LAS file",
            ),
            (
                "truncated.las",
                "the file ends early: it is truncated or not a LAS file",
            ),
            (
                "truncated_points.las",
                "the header counts 16 points of 20 bytes, more than the file's 334 bytes hold",
            ),
            ("no_points.las", "holds no point"),
            ("scale_nan.las", "the header's x scale factor is NaN"),
            ("not_las.laz", "the file signature is not 'LASF'"),
            (
                "../las/count_too_large.las",
                "the header counts 1000000000000 points of 30 bytes, more than the file's",
            ),
            (
                "../las/truncated_points.las",
                "the header counts 40 points of 30 bytes, more than the file's 682 bytes hold",
            ),
            ("../las/record_length_1.las", "record length 1 is too small"),
            (
                "../las/unknown_point_format.las",
                "invalid format number: 77",
            ),
        ],
    );
}

/// Surveys wrong in their generator, point-cloud or output keys (no file
/// behind them but the valid `cloud/good.las`).
#[test]
fn broken_generator_cloud_and_output_keys() {
    let cases: [(&str, &[&str]); 14] = [
        (
            "fbm/zero_resolution.toml",
            &[
                "zero_resolution.toml:12:16",
                "`terrain[0].resolution_m`: must be greater than 0 m, got 0",
            ],
        ),
        (
            "fbm/negative_resolution.toml",
            &[
                "negative_resolution.toml:12:16",
                "`terrain[0].resolution_m`: must be greater than 0 m, got -5",
            ],
        ),
        (
            "fbm/nan_resolution.toml",
            &["nan_resolution.toml:12:16", "got NaN"],
        ),
        (
            "fbm/inverted_extent.toml",
            &[
                "inverted_extent.toml:11:12",
                "`terrain[0].extent_m`: must be [xmin, ymin, xmax, ymax] in metres with xmax > xmin",
            ],
        ),
        (
            "fbm/short_extent.toml",
            &[
                "short_extent.toml:11:12",
                "`terrain[0].extent_m`: must be [xmin, ymin, xmax, ymax]",
            ],
        ),
        (
            "fbm/absurd_resolution.toml",
            &[
                "absurd_resolution.toml:12:16",
                "`terrain[0].resolution_m`",
                "1000000001 × 1000000001 cells exceed the limit of 100000000 cells",
            ],
        ),
        (
            "cloud/voxel_zero.toml",
            &[
                "voxel_zero.toml:11:11",
                "`point_cloud[0].voxel_m`: must be between 0.01 and 1000 m, got 0",
            ],
        ),
        (
            "cloud/voxel_huge.toml",
            &["voxel_huge.toml:11:11", "between 0.01 and 1000 m, got 1e9"],
        ),
        (
            "output/unknown_epsg.toml",
            &[
                "unknown_epsg.toml:15:7",
                "`output.crs`: EPSG:999999 is not in the built-in table",
                "give its WKT with `crs_wkt` instead",
            ],
        ),
        (
            "output/malformed_crs.toml",
            &[
                "malformed_crs.toml:15:7",
                "`output.crs`: must be \"EPSG:code\", got 'UTM35'",
            ],
        ),
        (
            "output/malformed_crs_wkt.toml",
            &[
                "malformed_crs_wkt.toml:15:11",
                "`output.crs_wkt`: has unbalanced brackets or quotes",
            ],
        ),
        (
            "output/crs_twice.toml",
            &[
                "crs_twice.toml:16:11",
                "`output.crs_wkt`: give the CRS once",
            ],
        ),
        (
            "output/offset_not_finite.toml",
            &[
                "offset_not_finite.toml:15:12",
                "`output.offset_m`: must hold finite numbers",
            ],
        ),
        (
            "output/unknown_format.toml",
            &[
                "unknown_format.toml:15:19",
                "`output.formats[1]`: unknown format 'las-wavefrom'",
            ],
        ),
    ];
    let mut seen = Vec::new();
    for (file, expect) in cases {
        reject_survey(file, &corpus().join(file), expect, &mut seen);
    }
    print(&seen);
}
