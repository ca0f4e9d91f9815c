//! Disk errors: an output directory that cannot be created and a disk that
//! is full give a clear error naming the path, a non-zero exit, and no file
//! that looks finished (no final name, no `.partial` left, no summary).
//!
//! A full disk is a file-size limit (`RLIMIT_FSIZE`, with `SIGXFSZ`
//! ignored): once a file would grow past it, every write fails in the
//! kernel, as on a full file system (with EFBIG rather than ENOSPC). The
//! limit lets the survey and trajectories through and stops the point
//! file. (A link planted under a `.partial` name is not followed, so the
//! test cannot point the writer at `/dev/full`.)

use std::path::Path;
use std::process::{Command, Output};

use crate::kit::{Limit, limited_by, temp};

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

#[cfg(target_os = "linux")]
#[test]
fn full_disk_names_the_file_and_leaves_nothing_finished() {
    for (file, format) in [("points.las", "las"), ("points.xyz", "xyz")] {
        let dir = temp(file);
        let survey = dir.join("s.toml");
        std::fs::write(
            &survey,
            SURVEY.replace(
                r#"formats = ["las", "xyz"]"#,
                &format!("formats = [\"{format}\"]"),
            ),
        )
        .unwrap();
        let out = dir.join("out");
        // 16 000 pulses: 800 kB of LAS, 1.6 MB of text; the trajectories
        // take 60 kB each.
        let args = [
            "run".as_ref(),
            survey.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ];
        let o = limited_by(&args, Limit::FileSize(200_000));
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("{file} on a full disk: {}", stderr.trim());
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(stderr.contains(file), "{stderr}");
        assert!(stderr.contains("File too large"), "{stderr}");
        let left: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        for f in [file, "summary.json", "report.html"] {
            assert!(!left.iter().any(|n| n == f), "{f} left: {left:?}");
        }
        assert!(
            left.iter().all(|n| !n.ends_with(".partial")),
            "partial files left: {left:?}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
