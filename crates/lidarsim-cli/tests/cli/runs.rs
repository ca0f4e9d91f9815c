//! Good surveys run: the files a run writes, what `check` predicts of it,
//! seeds, thread counts and the warnings of suspicious settings.

use crate::kit::{GOOD, bin, run_survey, temp};

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
