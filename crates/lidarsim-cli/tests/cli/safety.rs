//! Data safety through the binary: a run never writes over its own input,
//! never follows a link planted among its output names, never leaves an
//! earlier run's files beside its own summary, and never accepts a seed
//! its own survey.toml could not hold.

use std::path::Path;
use std::process::{Command, Output};
use std::sync::LazyLock;

use crate::kit::{GOOD, temp};

fn bin() -> Command {
    let mut c = crate::kit::bin();
    c.env("SOURCE_DATE_EPOCH", "1790000000");
    c
}

/// A user's survey: the shared good one under a comment of their own.
static SURVEY: LazyLock<String> =
    LazyLock::new(|| format!("# my own survey, with my comments\n{GOOD}"));

fn run(survey: &Path, out: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("run")
        .arg(survey)
        .arg("-o")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn run_into_the_surveys_own_directory_keeps_the_survey() {
    let dir = temp("own");
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, &*SURVEY).unwrap();
    for extra in [&[][..], &["--overwrite"][..]] {
        let o = run(&survey, &dir, extra);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            stderr.contains("write over or remove this input"),
            "{stderr}"
        );
        assert_eq!(std::fs::read_to_string(&survey).unwrap(), *SURVEY);
        assert_eq!(names(&dir), ["survey.toml"]);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_foreign_directory_needs_overwrite_and_keeps_its_other_files() {
    let dir = temp("foreign");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, &*SURVEY).unwrap();
    let out = dir.join("data");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("field-notes.txt"), "mine").unwrap();
    let o = run(&survey, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    assert!(stderr.contains("field-notes.txt") && stderr.contains("--overwrite"));
    assert_eq!(names(&out), ["field-notes.txt"]);
    let o = run(&survey, &out, &["--overwrite"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(out.join("field-notes.txt")).unwrap(), b"mine");
    assert!(out.join("points.las").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[cfg(unix)]
#[test]
fn a_planted_partial_link_does_not_overwrite_its_target() {
    let dir = temp("link");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, &*SURVEY).unwrap();
    let out = dir.join("out");
    // A first run marks the directory as a run's; then a link is planted.
    assert!(run(&survey, &out, &[]).status.success());
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "precious").unwrap();
    for name in ["points.las.partial", "points.las", "summary.json.partial"] {
        std::fs::remove_file(out.join(name)).ok();
        std::os::unix::fs::symlink(&victim, out.join(name)).unwrap();
        let o = run(&survey, &out, &[]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious", "{name}");
        let meta = std::fs::symlink_metadata(out.join("points.las")).unwrap();
        assert!(
            meta.file_type().is_file(),
            "{name}: points.las is not a file"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A rerun with other formats into the same directory: the first run's
/// point files are gone, and the summary lists exactly what is there.
#[test]
fn a_rerun_with_other_formats_leaves_no_stale_files() {
    let dir = temp("rerun");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, &*SURVEY).unwrap();
    let out = dir.join("out");
    assert!(run(&survey, &out, &[]).status.success());
    assert!(out.join("points.xyz").exists());
    std::fs::write(
        &survey,
        SURVEY.replace(r#"formats = ["las", "xyz"]"#, r#"formats = ["ply"]"#),
    )
    .unwrap();
    let o = run(&survey, &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let mut listed: Vec<String> = summary["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect();
    listed.push(".lidarsim-output".into());
    listed.sort();
    assert_eq!(names(&out), listed);
    assert!(!out.join("points.las").exists() && !out.join("points.xyz").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn seeds_beyond_toml_integers_are_refused_and_the_largest_reads_back() {
    let dir = temp("seed");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, &*SURVEY).unwrap();
    let out = dir.join("out");
    let o = run(&survey, &out, &["--seed", "9223372036854775808"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("9223372036854775807"), "{stderr}");
    assert!(!out.exists());
    let o = run(&survey, &out, &["--seed", "9223372036854775807"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The survey.toml the run wrote reads back, with that seed.
    let c = bin()
        .arg("check")
        .arg(out.join("survey.toml"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&c.stdout);
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    assert!(stdout.contains("seed 9223372036854775807"), "{stdout}");
    std::fs::remove_dir_all(&dir).ok();
}
