//! Ctrl-C and resume through the binary: SIGINT to a running simulation
//! stops it at a block boundary with valid files and `"complete": false`;
//! `lidarsim run --resume DIR` finishes it, and the result equals an
//! uninterrupted run byte for byte.
//!
//! Compared byte for byte: points.las, points.xyz, survey.toml and the
//! three trajectories. summary.json is compared without its wall-clock
//! fields (`wall_time_s`, `index_time_s`, `pulses_per_second`) and
//! report.html without its "source", "wall time" and "pulses per second"
//! rows: timings belong to the sessions, and the resumed run reads its
//! survey from the output directory (its "source").

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, ChildStderr, ExitStatus};
use std::process::{Command, Stdio};

use crate::kit::temp;

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lidarsim"));
    c.env("SOURCE_DATE_EPOCH", "1790000000");
    c
}

/// About 2 s of simulation on one thread: one 8 s line at 30 kHz over a
/// plane and a sloping roof, with GNSS/IMU errors.
const SURVEY: &str = r#"seed = 5
preset = "survey-grade"

[scanner]
prf_hz = 30000
scan_frequency_hz = 40
scan_angle_deg = 20
subrays = 7

[[flight_line]]
start_m = [0.0, -200.0, 400.0]
end_m = [0.0, 200.0, 400.0]
speed_mps = 50.0

[output]
formats = ["las", "xyz"]

[materials.grass]
reflectance = 0.4

[materials.roof]
reflectance = 0.2

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-400, -400, 0], [400, -400, 0], [400, 400, 0], [-400, 400, 0]]

[[polygon]]
material = "roof"
class = "building"
vertices_m = [[-20, -20, 8], [30, -20, 8], [30, 20, 12], [-20, 20, 12]]
"#;

/// Starts `lidarsim run SURVEY -o OUT` on one thread, held by the test
/// hook after `pulses` pulses, and returns once it says it is holding.
fn held_run(survey: &Path, out: &Path, pulses: u64) -> (Child, BufReader<ChildStderr>) {
    let mut child = bin()
        .arg("run")
        .arg(survey)
        .args(["--threads", "1", "-o"])
        .arg(out)
        .env("LIDARSIM_TEST_HOLD_AT_PULSE", pulses.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    loop {
        line.clear();
        let n = stderr.read_line(&mut line).unwrap();
        assert!(n > 0, "the run ended before holding");
        if line.starts_with("holding after") {
            break;
        }
    }
    (child, stderr)
}

/// Waits for a child started by [`held_run`]: its status and the rest of
/// its standard error.
fn finish(mut child: Child, mut stderr: BufReader<ChildStderr>) -> (ExitStatus, String) {
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    (child.wait().unwrap(), rest)
}

fn json(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap()
}

fn without_timings(mut v: serde_json::Value) -> serde_json::Value {
    let m = v.as_object_mut().unwrap();
    for k in ["wall_time_s", "index_time_s", "pulses_per_second"] {
        assert!(m.remove(k).is_some(), "{k} missing");
    }
    v
}

fn report_without_timings(dir: &Path) -> String {
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    html.split("<tr>")
        .filter(|row| {
            ![
                "<th>source</th>",
                "<th>wall time</th>",
                "<th>pulses per second</th>",
            ]
            .iter()
            .any(|k| row.starts_with(k))
        })
        .collect()
}

#[test]
fn sigint_then_resume_equals_an_uninterrupted_run() {
    let dir = temp("sigint");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, SURVEY).unwrap();

    // The reference.
    let full = dir.join("full");
    let o = bin()
        .arg("run")
        .arg(&survey)
        .args(["--threads", "1", "-o"])
        .arg(&full)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // The interrupted run: held by the test hook once 4096 pulses are
    // written, then SIGINT — the same point whatever the machine's speed.
    let part = dir.join("part");
    let (child, stderr) = held_run(&survey, &part, 4096);
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let (status, stderr) = finish(child, stderr);
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains("lidarsim run --resume"), "{stderr}");
    let s = json(&part);
    assert_eq!(s["complete"], false);
    let total = json(&full)["pulses"].as_u64().unwrap();
    let done = s["pulses"].as_u64().unwrap();
    let next = s["next_pulse"]["pulse"].as_u64().unwrap();
    assert!(done >= 4096 && done < total, "{done} of {total}");
    assert_eq!(next, done);
    assert_eq!(next % 2048, 0);
    // Valid LAS for what was written, under its partial name until the
    // run is complete: header count = bytes on disk.
    assert!(!part.join("points.las").exists());
    let las = std::fs::read(part.join("points.las.partial")).unwrap();
    let count = u64::from_le_bytes(las[247..255].try_into().unwrap());
    let offset = u64::from(u32::from_le_bytes(las[96..100].try_into().unwrap()));
    let record = u64::from(u16::from_le_bytes(las[105..107].try_into().unwrap()));
    assert_eq!(las.len() as u64, offset + count * record);
    assert_eq!(count, s["points"].as_u64().unwrap());
    println!("interrupted after {done} of {total} pulses ({count} points)");

    // Resume.
    let o = bin()
        .args(["run", "--threads", "1", "--resume"])
        .arg(&part)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "points.las",
        "points.xyz",
        "survey.toml",
        "trajectory.csv",
        "trajectory_true.csv",
        "trajectory_observed.csv",
    ] {
        let (x, y) = (
            std::fs::read(full.join(f)).unwrap(),
            std::fs::read(part.join(f)).unwrap(),
        );
        assert!(x == y, "{f} differs ({} vs {} bytes)", x.len(), y.len());
    }
    assert_eq!(without_timings(json(&full)), without_timings(json(&part)));
    assert_eq!(report_without_timings(&full), report_without_timings(&part));
    assert!(!part.join("report.state").exists());

    // Resuming a complete run, or a directory without a run, is refused.
    for d in [&part, &dir] {
        let o = bin().args(["run", "--resume"]).arg(d).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && !stderr.contains("panicked"),
            "{stderr}"
        );
        assert!(
            stderr.contains("nothing to resume") || stderr.contains("no such file"),
            "{stderr}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A second Ctrl-C while the files of an interrupted run are being
/// finished ends the program at once. Whenever it lands, nothing that looks
/// complete is left: either summary.json says "complete": false and the
/// point files keep their .partial names, or there is no summary and no
/// point file under its final name. Both signals are sent at once, so
/// which of the two states results depends on the machine; each is
/// checked.
#[test]
fn a_second_ctrl_c_leaves_nothing_that_looks_complete() {
    let dir = temp("twice");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, SURVEY).unwrap();
    for round in 0..3 {
        let part = dir.join(format!("part{round}"));
        let (child, stderr) = held_run(&survey, &part, 2048);
        for _ in 0..2 {
            let kill = Command::new("kill")
                .args(["-INT", &child.id().to_string()])
                .status()
                .unwrap();
            assert!(kill.success());
        }
        let (status, stderr) = finish(child, stderr);
        assert_eq!(status.code(), Some(130), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        for name in ["points.las", "points.xyz"] {
            assert!(
                !part.join(name).exists(),
                "round {round}: {name} under its final name\n{stderr}"
            );
        }
        if part.join("summary.json").exists() {
            assert_eq!(json(&part)["complete"], false);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
