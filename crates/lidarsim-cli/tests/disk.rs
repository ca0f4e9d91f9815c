//! Disk errors: an output directory that cannot be created and a disk that
//! is full give a clear error naming the path, a non-zero exit, and no file
//! that looks finished (no final name, no `.partial` left, no summary).
//!
//! A full disk is `/dev/full` (every write fails with ENOSPC): the test
//! plants `points.las.partial` (or `points.xyz.partial`) as a symbolic link
//! to it, so the writer opens the device as its temporary file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lidarsim-disk-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SURVEY: &str = r#"[scanner]
prf_hz = 20000
scan_angle_deg = 15

[[flight_line]]
start_m = [0.0, -20.0, 300.0]
end_m = [0.0, 20.0, 300.0]
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

fn run(survey: &Path, out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lidarsim"))
        .arg("run")
        .arg(survey)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

#[test]
fn output_directory_that_cannot_be_created() {
    let dir = temp("nodir");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, SURVEY).unwrap();
    // A regular file where a directory should be (permissions would not
    // stop root, which CI may be).
    let blocker = dir.join("file");
    std::fs::write(&blocker, "not a directory").unwrap();
    let out = blocker.join("out");
    let o = run(&survey, &out);
    let stderr = String::from_utf8_lossy(&o.stderr);
    println!("unwritable: {}", stderr.trim());
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains(&out.display().to_string()), "{stderr}");
    assert!(
        stderr.contains("cannot create the output directory: Not a directory"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn full_disk_names_the_file_and_leaves_nothing_finished() {
    if !Path::new("/dev/full").exists() {
        eprintln!("no /dev/full here: skipped");
        return;
    }
    for file in ["points.las", "points.xyz"] {
        let dir = temp(file);
        let survey = dir.join("s.toml");
        std::fs::write(&survey, SURVEY).unwrap();
        let out = dir.join("out");
        std::fs::create_dir_all(&out).unwrap();
        let partial = out.join(format!("{file}.partial"));
        std::os::unix::fs::symlink("/dev/full", &partial).unwrap();
        let o = run(&survey, &out);
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("{file} on a full disk: {}", stderr.trim());
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(stderr.contains(file), "{stderr}");
        assert!(stderr.contains("No space left on device"), "{stderr}");
        let left: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        for f in ["points.las", "points.xyz", "summary.json", "report.html"] {
            assert!(!left.iter().any(|n| n == f), "{f} left: {left:?}");
        }
        assert!(
            left.iter().all(|n| !n.ends_with(".partial")),
            "partial files left: {left:?}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
