//! The command line: bad input gets a clear message and a non-zero exit,
//! without a panic and without output that looks complete; good input runs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lidarsim"))
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lidarsim-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const GOOD: &str = r#"seed = 3

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

fn run_survey(dir: &Path, text: &str) -> (Output, PathBuf) {
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

/// Runs a broken survey and checks the failure is clean and informative.
fn assert_rejected(name: &str, text: &str, line: usize, key: &str, words: &str) {
    let dir = temp(name);
    let (o, out) = run_survey(&dir, text);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
    assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    let place = format!("survey.toml:{line}:");
    assert!(
        stderr.contains(&place),
        "{name}: wanted {place} in {stderr}"
    );
    assert!(stderr.contains(key), "{name}: wanted key {key} in {stderr}");
    assert!(
        stderr.contains(words),
        "{name}: wanted '{words}' in {stderr}"
    );
    for f in ["points.las", "points.xyz", "summary.json", "trajectory.csv"] {
        assert!(!out.join(f).exists(), "{name}: {f} was written");
    }
    // `check` rejects it the same way.
    let c = bin()
        .arg("check")
        .arg(dir.join("survey.toml"))
        .output()
        .unwrap();
    assert_eq!(c.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unknown_key() {
    let t = GOOD.replace("scan_angle_deg = 15", "scan_angle_deg = 15\nscan_angel = 3");
    assert_rejected(
        "unknown",
        &t,
        7,
        "key `scanner.scan_angel`:",
        "unknown field",
    );
}

#[test]
fn wrong_type() {
    let t = GOOD.replace("prf_hz = 20000", "prf_hz = \"fast\"");
    assert_rejected("type", &t, 4, "scanner.prf_hz", "invalid type");
}

#[test]
fn negative_and_zero_prf_and_speed() {
    let t = GOOD.replace("prf_hz = 20000", "prf_hz = -20000");
    assert_rejected("negprf", &t, 4, "scanner.prf_hz", "greater than 0");
    let t = GOOD.replace("prf_hz = 20000", "prf_hz = 0");
    assert_rejected("zeroprf", &t, 4, "scanner.prf_hz", "greater than 0");
    let t = GOOD.replace("speed_mps = 50.0", "speed_mps = 0.0");
    assert_rejected(
        "zerospeed",
        &t,
        11,
        "flight_line[0].speed_mps",
        "greater than 0",
    );
    let t = GOOD.replace("speed_mps = 50.0", "speed_mps = -3");
    assert_rejected(
        "negspeed",
        &t,
        11,
        "flight_line[0].speed_mps",
        "greater than 0",
    );
}

#[test]
fn empty_and_non_planar_polygons() {
    let t = GOOD.replace(
        "vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]",
        "vertices_m = []",
    );
    assert_rejected(
        "empty",
        &t,
        22,
        "polygon[0].vertices_m",
        "at least 3 vertices",
    );
    let t = GOOD.replace("[300, 300, 0]", "[300, 300, 2]");
    assert_rejected("warped", &t, 22, "polygon[0].vertices_m", "not planar");
}

#[test]
fn missing_material_and_mesh() {
    let t = GOOD.replace("material = \"grass\"", "material = \"lawn\"");
    assert_rejected(
        "nomat",
        &t,
        20,
        "polygon[0].material",
        "unknown material 'lawn'",
    );
    let t = format!("{GOOD}\n[[mesh]]\nfile = \"house.obj\"\nclass = \"roof\"\n");
    assert_rejected("noobj", &t, 25, "mesh[0].file", "house.obj");
}

#[test]
fn missing_material_inside_an_obj_file() {
    let dir = temp("objmat");
    std::fs::write(
        dir.join("house.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl brick\nf 1 2 3\n",
    )
    .unwrap();
    let t = format!("{GOOD}\n[[mesh]]\nfile = \"house.obj\"\n");
    let (o, out) = run_survey(&dir, &t);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr.contains("mesh[0].file") && stderr.contains("'brick'"),
        "{stderr}"
    );
    assert!(stderr.contains("line 4"), "{stderr}");
    assert!(!out.join("points.las").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn several_problems_are_reported_together() {
    let t = GOOD
        .replace("prf_hz = 20000", "prf_hz = -1")
        .replace("speed_mps = 50.0", "speed_mps = 0");
    let dir = temp("several");
    let (o, _) = run_survey(&dir, &t);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("scanner.prf_hz") && stderr.contains("flight_line[0].speed_mps"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn missing_file_and_bad_threads() {
    let o = bin().args(["run", "/nonexistent/s.toml"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("/nonexistent/s.toml") && !stderr.contains("panicked"));
    let dir = temp("threads");
    std::fs::write(dir.join("s.toml"), GOOD).unwrap();
    let o = bin()
        .arg("run")
        .arg(dir.join("s.toml"))
        .args(["--threads", "0", "-o"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn good_survey_runs_and_check_predicts_it() {
    let dir = temp("good");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "points.las",
        "points.xyz",
        "summary.json",
        "trajectory.csv",
        "report.html",
        "survey.toml",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
        assert!(!out.join(format!("{f}.partial")).exists());
    }
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    for key in [
        "pulses",
        "points",
        "pulses_with_echo",
        "subrays_per_pulse",
        "threads",
        "seed",
        "wall_time_s",
        "pulses_per_second",
        "swath_width_m",
        "point_density_per_m2",
    ] {
        assert!(summary.get(key).is_some(), "summary lacks {key}");
    }
    assert_eq!(summary["pulses"], 8000);
    let report = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(report.matches("data:image/png;base64,").count() >= 6);
    assert!(
        !report.contains("http://") && !report.contains("https://"),
        "self-contained"
    );
    assert_eq!(summary["seed"], 3);
    let swath = 2.0 * 300.0 * 15f64.to_radians().tan();
    assert!((summary["swath_width_m"].as_f64().unwrap() - swath).abs() < 1e-6);
    // Trajectory: one row per millisecond of the 0.4 s line, plus header.
    let traj = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert_eq!(traj.lines().count(), 1 + 401);
    assert!(traj.starts_with("gps_time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg"));

    let c = bin()
        .arg("check")
        .arg(dir.join("survey.toml"))
        .output()
        .unwrap();
    assert!(c.status.success());
    let text = String::from_utf8_lossy(&c.stdout);
    assert!(text.contains("pulses:               8000"), "{text}");
    assert!(text.contains(&format!("{swath:.1} m")), "{text}");
    assert!(text.contains("footprint diameter:   0.090 m"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn seed_changes_noise_but_not_geometry() {
    let noisy = GOOD.replace(
        "[output]",
        "[receiver]\nnoise = 0.01\nspeckle = true\n\n[output]",
    );
    let dir = temp("seed");
    std::fs::write(dir.join("s.toml"), &noisy).unwrap();
    let run = |seed: &str, sub: &str| {
        let out = dir.join(sub);
        let o = bin()
            .arg("run")
            .arg(dir.join("s.toml"))
            .args(["--seed", seed, "-o"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success());
        std::fs::read_to_string(out.join("points.xyz")).unwrap()
    };
    let a = run("1", "a");
    let b = run("1", "b");
    let c = run("2", "c");
    assert_eq!(a, b);
    assert_ne!(a, c);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn one_and_two_threads_write_identical_files() {
    let noisy = GOOD
        .replace(
            "[output]",
            "[receiver]\nnoise = 0.01\nspeckle = true\n\n[platform]\nsway = true\n\n[output]",
        )
        .replace("end_m = [0.0, 10.0, 300.0]", "end_m = [0.0, 60.0, 300.0]");
    let dir = temp("threads12");
    std::fs::write(dir.join("s.toml"), &noisy).unwrap();
    let run = |threads: &str| {
        let out = dir.join(format!("t{threads}"));
        let o = bin()
            .arg("run")
            .arg(dir.join("s.toml"))
            .args(["--threads", threads, "-o"])
            .arg(&out)
            .env("SOURCE_DATE_EPOCH", "1790000000")
            .output()
            .unwrap();
        assert!(o.status.success());
        out
    };
    let (a, b) = (run("1"), run("2"));
    for f in ["points.las", "points.xyz", "trajectory.csv"] {
        let (x, y) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(x.len() > 1000, "{f} is too small to mean anything");
        assert!(x == y, "{f} differs between 1 and 2 threads");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_writes_top_views_and_profiles_and_rejects_bad_options() {
    let dir = temp("render");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success());
    let las = out.join("points.las");
    for (color, extra) in [
        ("class", None),
        ("height", None),
        ("strip", Some("-20,0,20,0,2")),
    ] {
        let png = dir.join(format!("{color}.png"));
        let mut cmd = bin();
        cmd.arg("render")
            .arg(&las)
            .arg("-o")
            .arg(&png)
            .args(["--color", color]);
        if let Some(p) = extra {
            cmd.args(["--profile", p]);
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    }
    for bad in [
        vec!["--color", "rainbow"],
        vec!["--profile", "1,2,3"],
        vec!["--resolution", "-1"],
    ] {
        let o = bin()
            .arg("render")
            .arg(&las)
            .args(["-o"])
            .arg(dir.join("x.png"))
            .args(&bad)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    }
    let o = bin().args(["render", "/nonexistent.las"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_reads_laz_and_point_format_9() {
    // The fixture writes points.las (format 9 + points.wdp), points.laz
    // (format 9, compressed), points.ply and points.xyz.
    let dir = temp("render-laz");
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/fixtures/two-planes.toml");
    let out = dir.join("out");
    let o = bin()
        .arg("run")
        .arg(&fixture)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "points.las",
        "points.wdp",
        "points.laz",
        "points.ply",
        "points.xyz",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    for cloud in ["points.las", "points.laz"] {
        let png = dir.join(format!("{cloud}.png"));
        let o = bin()
            .arg("render")
            .arg(out.join(cloud))
            .arg("-o")
            .arg(&png)
            .args(["--color", "class"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{cloud}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(&std::fs::read(&png).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn waveform_plots_a_pulse_of_a_run() {
    let dir = temp("waveform");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success());
    assert!(out.join("survey.toml").exists());
    let png = dir.join("w.png");
    let o = bin()
        .arg("waveform")
        .arg(&out)
        .args(["--pulse", "100", "-o"])
        .arg(&png)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // One echo from the plane 300 m below at the pulse's scan angle.
    assert!(text.contains("1 echo(es)"), "{text}");
    assert!(text.contains("range 30"), "{text}");
    assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
    // The run's survey.toml repeats the run exactly.
    let again = dir.join("again");
    let o = bin()
        .arg("run")
        .arg(out.join("survey.toml"))
        .arg("-o")
        .arg(&again)
        .env("SOURCE_DATE_EPOCH", "1790000000")
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(
        std::fs::read(out.join("points.xyz")).unwrap(),
        std::fs::read(again.join("points.xyz")).unwrap()
    );
    for bad in [
        vec!["--pulse", "99999999"],
        vec!["--line", "5", "--pulse", "1"],
        vec![],
    ] {
        let o = bin().arg("waveform").arg(&out).args(&bad).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn suspicious_settings_are_warned_about_with_their_numbers() {
    // The line flies 2 km east of the scene (ground at z = 0 all the same),
    // and at 600 kHz pulses leave every 1.67 µs while the echo from the
    // swath edge, 300 / cos 15° = 310.6 m away, returns after 2.07 µs.
    let text = GOOD
        .replace("prf_hz = 20000", "prf_hz = 600000")
        .replace(
            "start_m = [0.0, -10.0, 300.0]",
            "start_m = [2000.0, -10.0, 300.0]",
        )
        .replace(
            "end_m = [0.0, 10.0, 300.0]",
            "end_m = [2000.0, 10.0, 300.0]",
        );
    let dir = temp("warn");
    std::fs::write(dir.join("s.toml"), &text).unwrap();
    let c = bin().arg("check").arg(dir.join("s.toml")).output().unwrap();
    let stderr = String::from_utf8_lossy(&c.stderr);
    assert!(c.status.success(), "{stderr}");
    assert!(stderr.contains("warning: "), "{stderr}");
    assert!(stderr.contains("no pulse can hit the scene"), "{stderr}");
    assert!(
        stderr.contains("multiple pulses in the air")
            && stderr.contains("2.07 µs")
            && stderr.contains("1.67 µs"),
        "{stderr}"
    );
    let (o, out) = run_survey(&dir, &text);
    assert!(o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("no pulse can hit the scene"), "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let warnings = summary["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().contains("no pulse can hit"))
    );
    assert_eq!(summary["points"], 0);
    std::fs::remove_dir_all(&dir).ok();
}

/// Regression: a run's survey.toml kept terrain raster paths relative to
/// the original survey, so `waveform` (which reloads it from the output
/// directory) could not find the raster.
#[test]
fn waveform_replays_a_run_over_a_relative_terrain_raster() {
    let dir = temp("waveform-terrain");
    std::fs::write(
        dir.join("dem.asc"),
        "ncols 3\nnrows 3\nxllcorner -300\nyllcorner -300\ncellsize 200\n\
         12 12 12\n12 12 12\n12 12 12\n",
    )
    .unwrap();
    let text = GOOD.replace(
        "[[polygon]]\nmaterial = \"grass\"\nclass = \"ground\"\n\
         vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]\n",
        "[[terrain]]\nfile = \"dem.asc\"\nmaterial = \"grass\"\n",
    );
    assert!(text.contains("[[terrain]]"));
    let (o, out) = run_survey(&dir, &text);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = bin()
        .arg("waveform")
        .arg(&out)
        .args(["--pulse", "100", "-o"])
        .arg(dir.join("w.png"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The flat raster at 12 m, 288 m below the 300 m line.
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("1 echo(es)") && text.contains("range 29"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `lidarsim bench` on short flat runs, 1, 2, 1 and 2 threads: one `scene
/// key value` line per figure, each a number a script can parse, and the
/// same LAS on 1 and 2 threads. Nothing here depends on how fast the
/// machine was: the figures' arithmetic is tested on fixed measurements
/// (`bench_figures_are_computed_from_the_measurements` in main.rs).
#[test]
fn bench_prints_figures_a_script_can_read() {
    let dir = temp("bench");
    let o = bin()
        .args([
            "bench",
            "--scene",
            "flat",
            "--threads",
            "1,2,1,2",
            "--pulses",
            "20000",
        ])
        .arg("--work-dir")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let value = |key: &str| -> String {
        let line = text
            .lines()
            .find(|l| l.strip_prefix("flat ").is_some_and(|r| r.starts_with(key)))
            .unwrap_or_else(|| panic!("no `flat {key}` line in\n{text}"));
        line.rsplit(' ').next().unwrap().to_string()
    };
    let num = |key: &str| {
        let v = value(key).parse::<f64>().unwrap();
        assert!(v.is_finite() && v >= 0.0, "`flat {key}` is {v}\n{text}");
        v
    };
    assert_eq!(num("primitives "), 62.0);
    for t in [1, 2] {
        assert_eq!(num(&format!("threads {t} pulses ")), 20000.0);
        for key in [
            "seconds",
            "pulses_per_s",
            "rays_per_s",
            "points_per_s",
            "cpu_s",
            "cores_busy",
            "write_cpu_s",
        ] {
            num(&format!("threads {t} {key} "));
        }
    }
    for key in [
        "load_s ",
        "scaling_1_to_2 ",
        "scaling_1_to_2_at_equal_cpu ",
        "scaling_1_to_2_median ",
        "peak_rss_mb ",
    ] {
        num(key);
    }
    assert_eq!(num("scaling_pairs "), 2.0);
    let hashes: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("flat threads "))
        .filter(|l| l.contains(" las_fnv1a "))
        .filter_map(|l| l.rsplit(' ').next())
        .collect();
    assert_eq!(hashes.len(), 4, "{text}");
    assert!(
        hashes.iter().all(|h| *h == hashes[0]),
        "thread counts must write the same LAS: {hashes:?}"
    );
    assert_eq!(value("identical_output "), "true");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs the binary under an address-space limit of `limit_kib` KiB (so
/// that an attempt at a huge allocation fails instead of swapping the
/// machine) and kills it if it has not finished after two minutes, far
/// longer than any case here needs: a regression fails rather than hangs.
fn run_limited(args: &[&std::ffi::OsStr], limit_kib: u64) -> Output {
    use std::process::Stdio;
    let child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {limit_kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_lidarsim"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || tx.send(child.wait_with_output()));
    match rx.recv_timeout(std::time::Duration::from_secs(120)) {
        Ok(o) => o.unwrap(),
        Err(_) => {
            let _ = Command::new("kill").arg("-9").arg(pid.to_string()).status();
            panic!("lidarsim {args:?} did not finish within two minutes");
        }
    }
}

/// Width and height of a PNG, from its IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
    let be = |at: usize| u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
    (be(16), be(20))
}

/// Writes a LAS file of points (x, y, z) with 1 cm precision.
fn write_las(path: &Path, points: &[(f64, f64, f64)]) {
    let mut builder = las::Builder::from((1, 2));
    builder.transforms = las::Vector {
        x: las::Transform {
            scale: 0.01,
            offset: 0.0,
        },
        y: las::Transform {
            scale: 0.01,
            offset: 0.0,
        },
        z: las::Transform {
            scale: 0.01,
            offset: 0.0,
        },
    };
    let mut w = las::Writer::from_path(path, builder.into_header().unwrap()).unwrap();
    for &(x, y, z) in points {
        w.write_point(las::Point {
            x,
            y,
            z,
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
}

/// `render` bounds the picture to 8192 px a side and 16 million pixels:
/// a finer `--resolution` is refused (exit status 2) with the smallest
/// that fits, and an automatic one is coarsened, whatever the extent of
/// the cloud or of the cross-section, within a 2 GiB address space.
#[test]
fn render_bounds_the_picture_size_instead_of_allocating_without_limit() {
    let dir = temp("render-limits");
    // 4000 km × 3000 km, corners and a few points between.
    let wide = dir.join("wide.las");
    let pts: Vec<(f64, f64, f64)> = (0..=100)
        .map(|i| (i as f64 * 4e4, i as f64 * 3e4, i as f64))
        .collect();
    write_las(&wide, &pts);
    // 400 m × 300 m.
    let small = dir.join("small.las");
    let pts: Vec<(f64, f64, f64)> = (0..=400)
        .flat_map(|i| (0..=30).map(move |j| (i as f64, j as f64 * 10.0, 0.5 * j as f64)))
        .collect();
    write_las(&small, &pts);
    let png = dir.join("x.png");
    let gib2 = 2 * 1024 * 1024;
    let run = |cloud: &Path, extra: &[&str]| {
        let _ = std::fs::remove_file(&png);
        let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), cloud.as_os_str()];
        args.extend(["-o".as_ref(), png.as_os_str()]);
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        run_limited(&args, gib2)
    };
    // Refused: the smallest pixel that fits 400 × 300 m in 16 M pixels is
    // √(400 · 300 / 16e6) = 0.0866 m; for 4000 km × 3000 km it is 866 m.
    for (cloud, res, smallest) in [
        (&small, "1e-9", 0.0866),
        (&small, "0.0001", 0.0866),
        (&small, "0.05", 0.0866),
        (&wide, "1", 866.0),
    ] {
        let o = run(cloud, &["--resolution", res]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{res}: {err}");
        assert!(!err.contains("panicked") && !png.exists(), "{res}: {err}");
        assert!(err.contains("8192 px a side and 16000000 pixels"), "{err}");
        let offered: f64 = err
            .split("the smallest pixel size that fits is ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|r| r.parse().ok())
            .unwrap_or_else(|| panic!("no smallest resolution in {err}"));
        assert!(
            offered >= smallest && offered < smallest * 1.01,
            "{res}: {offered} vs {smallest}"
        );
        // The resolution offered works.
        let o = run(cloud, &["--resolution", &offered.to_string()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (w, h) = png_size(&png);
        assert!(
            u64::from(w) * u64::from(h) <= 16_200_000 + 150 * 8192,
            "{w} × {h}"
        );
    }
    // Automatic: coarsened to fit.
    for (cloud, extra) in [
        (&wide, vec![]),
        (&wide, vec!["--profile", "0,0,4e6,3e6,1e5"]),
        (&small, vec!["--profile", "0,0,1e7,0,5"]),
    ] {
        let o = run(cloud, &extra);
        assert!(
            o.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let (w, h) = png_size(&png);
        assert!(w <= 8192 + 200 && h <= 8192 + 40, "{extra:?}: {w} × {h}");
    }
    // A cross-section 10 000 km long at 1 cm per pixel.
    let o = run(
        &small,
        &["--profile", "0,0,1e7,0,5", "--resolution", "0.01"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("the smallest pixel size that fits is 1230 m"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_of_a_survey_file_says_it_is_not_a_point_cloud() {
    let dir = temp("render-toml");
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, GOOD).unwrap();
    let o = bin()
        .arg("render")
        .arg(&survey)
        .arg("-o")
        .arg(dir.join("x.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("survey.toml is not a LAS or LAZ file (it starts with \"seed\"); render takes a point cloud such as points.las"),
        "{err}"
    );
    assert!(!err.contains("signature") && !err.contains("[115"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `waveform --near X,Y[,Z]` takes the pulse of the point of points.las
/// nearest to a place: its line from the point source ID, its pulse from
/// its GPS time (pulse k of the line at 20 kHz leaves at k / 20 000 s).
/// The pulse simulated again has an echo at that point's range.
#[test]
fn waveform_near_finds_the_pulse_of_the_nearest_point() {
    let dir = temp("waveform-near");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success());
    let xyz = std::fs::read_to_string(out.join("points.xyz")).unwrap();
    let png = dir.join("w.png");
    for row in [50usize, 3000, 7000] {
        let cols: Vec<&str> = xyz.lines().nth(row).unwrap().split_whitespace().collect();
        let num = |i: usize| cols[i].parse::<f64>().unwrap();
        let (x, y, z, gps, source, range) = (num(0), num(1), num(2), num(7), cols[9], num(12));
        let pulse = (gps * 20_000.0).round() as u64;
        for near in [format!("{x},{y}"), format!("{x},{y},{z}")] {
            let o = bin()
                .arg("waveform")
                .arg(&out)
                .args(["--near", &near, "-o"])
                .arg(&png)
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            assert_eq!(source, "1");
            // The point chosen: the one of the row (points.las and
            // points.xyz round to the millimetre each their own way).
            let chosen: Vec<f64> = text
                .split_once(&format!("nearest point to {near}: ("))
                .and_then(|(_, rest)| rest.split_once(" m away, line 1 (point source ID)"))
                .map(|(nums, _)| {
                    nums.split([',', ')', ' '])
                        .filter_map(|v| v.parse().ok())
                        .collect()
                })
                .unwrap_or_default();
            assert_eq!(chosen.len(), 4, "{text}");
            assert!(
                (chosen[0] - x).abs() <= 0.0015
                    && (chosen[1] - y).abs() <= 0.0015
                    && (chosen[2] - z).abs() <= 0.0015
                    && chosen[3] <= 0.003,
                "{text}"
            );
            assert!(
                text.contains(&format!("line 1 pulse {pulse} ")),
                "{near}: pulse {pulse} wanted: {text}"
            );
            let ranges: Vec<f64> = text
                .split("range ")
                .skip(1)
                .filter_map(|r| r.split(' ').next()?.parse().ok())
                .collect();
            assert!(
                ranges.iter().any(|r| (r - range).abs() < 0.0015),
                "{range} not among {ranges:?}"
            );
        }
    }
    for bad in [
        vec!["--near", "1"],
        vec!["--near", "a,b"],
        vec!["--near", "1,2,3,4"],
        vec!["--near", "0,0", "--pulse", "3"],
        vec!["--near", "0,0", "--gps-time", "0.1"],
    ] {
        let o = bin().arg("waveform").arg(&out).args(&bad).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // A run without points.las or points.laz.
    std::fs::remove_file(out.join("points.las")).unwrap();
    let o = bin()
        .arg("waveform")
        .arg(&out)
        .args(["--near", "0,0"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("neither points.las nor points.laz"));
    std::fs::remove_dir_all(&dir).ok();
}

/// The help says where pulse numbers and GPS times come from.
#[test]
fn waveform_help_says_where_pulses_come_from() {
    let o = bin().args(["waveform", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&o.stdout).replace(char::is_whitespace, " ");
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    for words in [
        "the point source ID of points.las",
        "1 for the first",
        "the gps_time of any point in points.las, points.xyz or points.ply",
        "--near <X,Y[,Z]>",
        "Point files have no pulse column",
    ] {
        assert!(help.contains(words), "no '{words}' in {help}");
    }
    assert!(!help.contains("points.xyz order"), "{help}");
}
