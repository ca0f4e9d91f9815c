//! `lidarsim twin` and `lidarsim compare` from the command line: a twin
//! that runs, directories it may not write, scans it cannot twin with the
//! options that help, and comparisons (a cloud against itself, clouds
//! without common ground, bad options).

use std::path::Path;
use std::process::Output;

use crate::kit::{GOOD, bin, run_survey, temp, write_las_points};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn twin(scan: &Path, dir: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("twin")
        .arg(scan)
        .arg("-o")
        .arg(dir)
        .args(extra)
        .output()
        .unwrap()
}

/// The twin of a simulated line over a plane reads the line back (300 m,
/// 50 m/s, 40 Hz, ±15°), runs, and is refused a directory holding
/// another's files unless --overwrite, which keeps them.
#[test]
fn a_twin_runs_and_keeps_to_its_own_files() {
    let dir = temp("twin");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success(), "{}", stderr(&o));
    let scan = out.join("points.las");
    let tw = dir.join("twin");
    let o = twin(&scan, &tw, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let said = stdout(&o);
    assert!(
        said.contains("flat at z = 0") && said.contains("oscillating"),
        "{said}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tw.join("twin.json")).unwrap()).unwrap();
    let acq = &report["acquisition"];
    let track = &acq["strips"][0]["track"];
    assert!(
        (track["height_m"].as_f64().unwrap() - 300.0).abs() < 3.0,
        "{track}"
    );
    assert!(
        (track["speed_mps"].as_f64().unwrap() - 50.0).abs() < 1.0,
        "{track}"
    );
    let scanner = &acq["scanner"];
    assert!((scanner["scan_frequency_hz"]["value"].as_f64().unwrap() - 40.0).abs() < 0.4);
    assert!((scanner["scan_angle_deg"]["value"].as_f64().unwrap() - 15.0).abs() <= 0.5);
    assert!(!tw.join("dtm.tif").exists(), "a flat ground needs no DTM");
    let o = bin()
        .arg("run")
        .arg(tw.join("survey.toml"))
        .arg("-o")
        .arg(dir.join("again"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("again/points.las").exists());
    // Its own directory again: fine. A foreign one: refused, then kept.
    assert!(twin(&scan, &tw, &[]).status.success());
    let foreign = dir.join("foreign");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("notes.txt"), "mine").unwrap();
    std::fs::write(foreign.join("survey.toml"), "# mine").unwrap();
    let o = twin(&scan, &foreign, &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--overwrite") && stderr(&o).contains("notes.txt"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read(foreign.join("survey.toml")).unwrap(),
        b"# mine"
    );
    assert!(twin(&scan, &foreign, &["--overwrite"]).status.success());
    assert_eq!(std::fs::read(foreign.join("notes.txt")).unwrap(), b"mine");
    std::fs::remove_dir_all(&dir).ok();
}

/// Points of a flat scan, 1 m apart over 60 m × 60 m.
fn grid_points(mut f: impl FnMut(usize, &mut las::Point)) -> Vec<las::Point> {
    (0..3600)
        .map(|i| {
            let mut p = las::Point {
                x: (i % 60) as f64,
                y: (i / 60) as f64,
                z: 100.0,
                return_number: 1,
                number_of_returns: 1,
                classification: las::point::Classification::Ground,
                ..Default::default()
            };
            f(i, &mut p);
            p
        })
        .collect()
}

/// A scan without GPS times cannot show its strips: the error names what
/// is missing and the options that plan lines instead, which then work.
#[test]
fn a_scan_without_times_gets_the_options_that_plan_its_lines() {
    let dir = temp("twin-no-time");
    let scan = dir.join("no-time.las");
    write_las_points(&scan, 0, &grid_points(|_, _| {}));
    let o = twin(&scan, &dir.join("t"), &[]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    for wanted in [
        "no-time.las",
        "neither GPS times nor scan angles",
        "point format 0",
        "--heading-deg",
        "--altitude-m",
        "--scan-angle-deg",
    ] {
        assert!(e.contains(wanted), "wanted {wanted} in {e}");
    }
    assert!(!e.contains("panicked"));
    assert!(!dir.join("t/survey.toml").exists());
    let o = twin(
        &scan,
        &dir.join("t"),
        &[
            "--heading-deg",
            "90",
            "--altitude-m",
            "400",
            "--scan-angle-deg",
            "20",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let survey = std::fs::read_to_string(dir.join("t/survey.toml")).unwrap();
    assert!(
        survey.contains("[plan]") && survey.contains("heading_deg = 90"),
        "{survey}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A scan whose angles reach 80°, as a terrestrial or mobile scanner's
/// do, is not twinned; a bad option is a usage error (status 2).
#[test]
fn a_terrestrial_scan_and_bad_options_are_refused() {
    let dir = temp("twin-tls");
    let scan = dir.join("tls.las");
    let points = grid_points(|i, p| {
        p.gps_time = Some(i as f64 * 1e-4);
        p.scan_angle = ((i % 160) as f32) - 80.0;
    });
    write_las_points(&scan, 1, &points);
    let o = twin(&scan, &dir.join("t"), &[]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("does not look like an airborne line scan"),
        "{e}"
    );
    for (args, wanted) in [
        (vec!["--species", "oak"], "--species oak"),
        (vec!["--altitude-m=-5"], "--altitude-m"),
        (vec!["--window", "1,2"], "--window 1,2"),
        (vec!["--instrument", "riegl_vq_999"], "unknown instrument"),
    ] {
        let o = twin(&scan, &dir.join("t"), &args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(wanted), "{args:?}: {}", stderr(&o));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A cloud against itself: every difference is zero, per cell too, and
/// the JSON and the page are written; clouds with no common ground and a
/// bad --area are refused.
#[test]
fn compare_gives_zero_differences_for_a_cloud_and_itself() {
    let dir = temp("compare");
    let trees = "\n[[tree]]\nposition_m = [0.0, 0.0, 0.0]\nspecies = \"pine\"\ndbh_m = 0.3\n\
                 height_m = 18.0\ncrown_base_m = 9.0\n\n[[tree]]\nposition_m = [30.0, 2.0, 0.0]\n\
                 species = \"spruce\"\ndbh_m = 0.25\nheight_m = 15.0\ncrown_base_m = 4.0\n";
    let (o, out) = run_survey(&dir, &format!("{GOOD}{trees}"));
    assert!(o.status.success(), "{}", stderr(&o));
    let cmp = dir.join("cmp");
    let o = bin()
        .arg("compare")
        .arg(&out)
        .arg(out.join("points.las"))
        .arg("-o")
        .arg(&cmp)
        .args(["--cell-m", "5"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(cmp.join("compare.json")).unwrap()).unwrap();
    let diffs = json["difference"].as_object().unwrap();
    assert!(
        diffs.values().filter(|v| !v.is_null()).count() >= 10,
        "{json}"
    );
    for (k, v) in diffs {
        assert!(v.is_null() || v.as_f64() == Some(0.0), "{k}: {v}");
    }
    for m in json["cells"]["metrics"].as_array().unwrap() {
        assert!(
            m["mean_difference"].is_null() || m["mean_difference"].as_f64() == Some(0.0),
            "{m}"
        );
    }
    let page = std::fs::read_to_string(cmp.join("compare.html")).unwrap();
    // Self-contained: inline SVG, nothing fetched.
    assert!(page.starts_with("<!doctype html>") && page.contains("<svg"));
    assert!(!page.contains("src=") && !page.contains("href=") && !page.contains("<script"));
    // Another cloud far away: nothing in common.
    let far = dir.join("far.las");
    write_las_points(
        &far,
        1,
        &grid_points(|i, p| {
            p.x += 5000.0;
            p.gps_time = Some(i as f64);
        }),
    );
    let o = bin().arg("compare").arg(&out).arg(&far).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("share no area"), "{}", stderr(&o));
    let o = bin()
        .arg("compare")
        .arg(&out)
        .arg(&out)
        .args(["--area", "5,5,1,1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).ok();
}
