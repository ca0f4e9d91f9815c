//! Bad surveys: a clear message with file, line and key, exit status 2,
//! no panic and no output that looks complete; `check` agrees with `run`.

use crate::kit::{GOOD, bin, run_survey, temp};

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
