//! What the command-line tests share: the binary, a fresh temporary
//! directory, a good survey and a run of a survey text.

// Each test file uses some of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `lidarsim` binary.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lidarsim"))
}

/// An empty directory for test `name`.
pub fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lidarsim-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A short survey over a plane that runs in a moment.
pub const GOOD: &str = r#"seed = 3

[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15

[[flight_line]]
start_m = [0.0, -10.0, 300.0]
end_m = [0.0, 10.0, 300.0]
speed_mps = 50.0

[output]
formats = ["las", "xyz"]

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

/// Writes `text` as `dir/survey.toml` and runs it into `dir/out`.
pub fn run_survey(dir: &Path, text: &str) -> (Output, PathBuf) {
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, text).unwrap();
    let out = dir.join("out");
    let o = bin()
        .arg("run")
        .arg(&survey)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    (o, out)
}

/// Writes a LAS 1.2 file of points (x, y, z) with 1 cm precision.
pub fn write_las(path: &Path, points: &[(f64, f64, f64)]) {
    let points: Vec<las::Point> = points
        .iter()
        .map(|&(x, y, z)| las::Point {
            x,
            y,
            z,
            ..Default::default()
        })
        .collect();
    write_las_points(path, 0, &points);
}

/// Writes `points` as a LAS 1.2 file of point format `format` (0–3) with
/// 1 cm precision.
pub fn write_las_points(path: &Path, format: u8, points: &[las::Point]) {
    let mut builder = las::Builder::from((1, 2));
    builder.point_format = las::point::Format::new(format).unwrap();
    let centimetres = las::Transform {
        scale: 0.01,
        offset: 0.0,
    };
    builder.transforms = las::Vector {
        x: centimetres,
        y: centimetres,
        z: centimetres,
    };
    let mut w = las::Writer::from_path(path, builder.into_header().unwrap()).unwrap();
    for p in points {
        w.write_point(p.clone()).unwrap();
    }
    w.close().unwrap();
}
