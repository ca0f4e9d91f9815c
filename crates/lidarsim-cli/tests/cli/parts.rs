//! Runs split into parts (`lidarsim run --part K/N`) and merged
//! (`lidarsim merge`) write the files of the unsplit run byte for byte, in
//! every output format and for any number of parts, the parts run in any
//! order; merges of parts that do not make one run are refused with the
//! reason.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::kit::{bin, temp};

/// Three lines of unequal length over a plane with a tree-lined roof, in
/// every point format (full waveforms, LAZ, PLY, XYZ), with navigation
/// errors: 3 × 0.5 to 1 s at 20 kHz.
const SURVEY: &str = r#"seed = 17
preset = "uav"

[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 18
subrays = 7

[receiver]
noise = 0.01

[[flight_line]]
start_m = [0.0, -25.0, 150.0]
end_m = [0.0, 25.0, 150.0]
speed_mps = 50.0

[[flight_line]]
start_m = [30.0, 25.0, 150.0]
end_m = [30.0, -15.0, 150.0]
speed_mps = 50.0

[[flight_line]]
start_m = [-30.0, -25.0, 150.0]
end_m = [-30.0, 0.0, 150.0]
speed_mps = 50.0

[output]
formats = ["las-waveform", "laz", "ply", "xyz"]

[materials.grass]
reflectance = 0.35

[materials.roof]
reflectance = 0.2

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]]

[[polygon]]
material = "roof"
class = "roof"
vertices_m = [[-12, -8, 6], [10, -8, 6], [10, 8, 9], [-12, 8, 9]]

[[tree]]
position_m = [20.0, 5.0, 0.0]
species = "spruce"
dbh_m = 0.3
height_m = 18.0
crown_base_m = 4.0
"#;

/// The same date in every LAS header, whichever day a test runs.
const EPOCH: &str = "1700000000";

fn lidarsim(args: &[&str]) -> Output {
    bin()
        .args(args)
        .env("SOURCE_DATE_EPOCH", EPOCH)
        .output()
        .unwrap()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The files of an unsplit run that a merge writes the same bytes of.
const SAME: [&str; 9] = [
    "points.las",
    "points.wdp",
    "points.laz",
    "points.ply",
    "points.xyz",
    "survey.toml",
    "trajectory.csv",
    "trajectory_true.csv",
    "trajectory_observed.csv",
];

/// The test survey with plain LAS as its only point output (whose parts
/// write `points.las`, joined by a merge).
fn las_only() -> String {
    SURVEY.replace(
        r#"formats = ["las-waveform", "laz", "ply", "xyz"]"#,
        r#"formats = ["las"]"#,
    )
}

/// Asserts that each of `files` is in `merged` exactly when it is in
/// `whole`, with the same bytes; `what` names the case in messages.
fn assert_same_files(whole: &Path, merged: &Path, files: &[&str], what: &str) {
    for f in files {
        let (a, b) = (whole.join(f), merged.join(f));
        assert_eq!(a.exists(), b.exists(), "{what}: {f}");
        if a.exists() {
            let (a, b) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
            assert!(
                a == b,
                "{what}: {f} differs ({} vs {} bytes)",
                a.len(),
                b.len()
            );
        }
    }
}

/// `summary.json` without its timings.
fn summary(dir: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    let m = v.as_object_mut().unwrap();
    for k in [
        "wall_time_s",
        "index_time_s",
        "pulses_per_second",
        "threads",
    ] {
        m.remove(k);
    }
    v
}

/// Runs the `n` parts of `survey` in the order `order` (1-based) into
/// `dir/pN-K`; returns their directories.
fn run_parts(dir: &Path, survey: &Path, n: usize, order: &[usize]) -> Vec<PathBuf> {
    order
        .iter()
        .map(|&k| {
            let out = dir.join(format!("p{n}-{k}"));
            let part = format!("{k}/{n}");
            ok(&lidarsim(&[
                "run",
                s(survey),
                "--part",
                &part,
                "--threads",
                "2",
                "-o",
                s(&out),
            ]));
            out
        })
        .collect()
}

#[test]
fn merged_parts_are_the_unsplit_run_byte_for_byte() {
    let dir = temp("parts");
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, SURVEY).unwrap();
    let whole = dir.join("whole");
    ok(&lidarsim(&[
        "run",
        s(&survey),
        "-o",
        s(&whole),
        "--threads",
        "2",
    ]));
    let points = summary(&whole)["points"].as_u64().unwrap();
    assert!(points > 40_000, "{points}");
    // 1 part; 2 and 3 (whole lines: 1 s, 0.8 s, 0.5 s); 7 (lines cut).
    for (n, order) in [
        (1, vec![1]),
        (2, vec![2, 1]),
        (3, vec![3, 1, 2]),
        (7, vec![5, 2, 7, 1, 6, 3, 4]),
    ] {
        let parts = run_parts(&dir, &survey, n, &order);
        let merged = dir.join(format!("merged-{n}"));
        let mut args = vec!["merge", "-o", s(&merged)];
        args.extend(parts.iter().map(|p| s(p)));
        ok(&lidarsim(&args));
        assert!(SAME.iter().all(|f| whole.join(f).exists()));
        assert_same_files(&whole, &merged, &SAME, &format!("{n} parts"));
        assert_eq!(summary(&whole), summary(&merged), "{n} parts: summary.json");
        assert!(merged.join("report.html").exists());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The images of a report (maps, profile, waveforms, patterns), as their
/// `data:` URIs, in order.
fn images(report: &Path) -> Vec<String> {
    let page = std::fs::read_to_string(report).unwrap();
    page.split("data:image/")
        .skip(1)
        .map(|rest| rest.split('"').next().unwrap().to_string())
        .collect()
}

/// A survey whose only point output is a plain LAS file has parts that
/// write it as the unsplit run encodes it, with what their reports
/// gathered, and a merge that copies their records: the same bytes, the
/// same summary and the same report pictures; a stitched part's file cut,
/// or changed in its header, or a report state replaced, is refused.
#[test]
fn stitched_las_parts_are_the_unsplit_run_byte_for_byte() {
    let dir = temp("parts-stitched");
    let survey = dir.join("survey.toml");
    let las_only = las_only();
    std::fs::write(&survey, &las_only).unwrap();
    let whole = dir.join("whole");
    ok(&lidarsim(&["run", s(&survey), "-o", s(&whole)]));
    for (n, order) in [
        (1, vec![1]),
        (2, vec![1, 2]),
        (3, vec![2, 3, 1]),
        (7, vec![7, 1, 4, 2, 6, 3, 5]),
    ] {
        let parts = run_parts(&dir, &survey, n, &order);
        for p in &parts {
            assert!(p.join("points.las").exists() && p.join("report.state").exists());
            assert!(!p.join("points.part").exists());
        }
        let merged = dir.join(format!("merged-{n}"));
        let mut args = vec!["merge", "-o", s(&merged)];
        args.extend(parts.iter().map(|p| s(p)));
        // Three parts are taken: the first part's file moved, not copied,
        // and the parts gone once merged.
        let take = n == 3;
        if take {
            args.push("--take-parts");
        }
        ok(&lidarsim(&args));
        for p in &parts {
            assert_eq!(p.exists(), !take, "{n} parts: {}", p.display());
        }
        assert!(whole.join("points.las").exists());
        assert_same_files(&whole, &merged, &SAME, &format!("{n} parts"));
        assert_eq!(summary(&whole), summary(&merged), "{n} parts: summary.json");
        let pictures = images(&whole.join("report.html"));
        assert!(pictures.len() >= 4, "{}", pictures.len());
        assert!(
            pictures == images(&merged.join("report.html")),
            "{n} parts: the report's pictures differ"
        );
    }
    let parts = run_parts(&dir, &survey, 2, &[1, 2]);
    let merge = || {
        let out = dir.join("refused");
        let o = lidarsim(&[
            "merge",
            "--overwrite",
            "-o",
            s(&out),
            s(&parts[0]),
            s(&parts[1]),
        ]);
        assert!(!o.status.success());
        let e = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!e.contains("panicked"), "{e}");
        assert!(!out.join("points.las").exists() && !out.join("summary.json").exists());
        e
    };
    let las = parts[1].join("points.las");
    let bytes = std::fs::read(&las).unwrap();
    std::fs::write(&las, &bytes[..bytes.len() - 30]).unwrap();
    let e = merge();
    assert!(
        e.contains("points.las") && e.contains("cut short or changed"),
        "{e}"
    );
    // Another coordinate scale in its header (LAS 1.4 R15 Table 3: the x
    // scale factor at byte 131), the length kept: the part's checksum
    // tells.
    let mut edited = bytes.clone();
    edited[131..139].copy_from_slice(&0.01f64.to_le_bytes());
    std::fs::write(&las, &edited).unwrap();
    let e = merge();
    assert!(
        e.contains("p2-2/points.las") && e.contains("is not the file part 2/2 wrote"),
        "{e}"
    );
    std::fs::write(&las, &bytes).unwrap();
    let state = parts[0].join("report.state");
    let saved = std::fs::read(&state).unwrap();
    let mut garbled = saved.clone();
    garbled[..8].copy_from_slice(b"NOTSTATE");
    std::fs::write(&state, &garbled).unwrap();
    let e = merge();
    assert!(
        e.contains("report.state") && e.contains("is not the file part 1/2 wrote"),
        "{e}"
    );
    std::fs::write(&state, &saved).unwrap();
    let out = dir.join("refused");
    ok(&lidarsim(&[
        "merge",
        "--overwrite",
        "-o",
        s(&out),
        s(&parts[1]),
        s(&parts[0]),
    ]));
    std::fs::remove_dir_all(&dir).ok();
}

/// `lidarsim merge --follow` started before any part exists, its part
/// directories given in advance.
fn follower(out: &Path, parts: &[PathBuf], extra: &[&str]) -> std::process::Child {
    let mut args = vec!["merge", "--follow", "--poll-seconds", "0.05", "-o", s(out)];
    args.extend_from_slice(extra);
    args.extend(parts.iter().map(|p| s(p)));
    bin()
        .args(&args)
        .env("SOURCE_DATE_EPOCH", EPOCH)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// A merge started before its parts (`--follow`), which then run one
/// after another in any order, writes the unsplit run's files: parts read
/// back whole (every format) and parts whose LAS files are joined (LAS
/// only, taken: moved and removed).
#[test]
fn a_merge_that_follows_its_parts_is_the_unsplit_run() {
    let dir = temp("parts-follow");
    let las_only = las_only();
    for (name, text, take) in [("all", SURVEY.to_string(), false), ("las", las_only, true)] {
        let here = dir.join(name);
        std::fs::create_dir_all(&here).unwrap();
        let survey = here.join("survey.toml");
        std::fs::write(&survey, &text).unwrap();
        let whole = here.join("whole");
        ok(&lidarsim(&["run", s(&survey), "-o", s(&whole)]));
        let dirs: Vec<PathBuf> = (1..=3).map(|k| here.join(format!("p3-{k}"))).collect();
        let merged = here.join("merged");
        // A safety net only: the parts below end in seconds.
        let mut extra = vec!["--give-up-after", "600"];
        if take {
            extra.push("--take-parts");
        }
        let child = follower(&merged, &dirs, &extra);
        run_parts(&here, &survey, 3, &[2, 3, 1]);
        let o = child.wait_with_output().unwrap();
        ok(&o);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("part 3 of 3 joined"), "{e}");
        assert_same_files(&whole, &merged, &SAME, name);
        assert_eq!(summary(&whole), summary(&merged), "{name}: summary.json");
        for d in &dirs {
            assert_eq!(d.exists(), !take, "{name}: {}", d.display());
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A merge following its parts gives up after the time given without a
/// part finishing, naming the parts it waited for, and refuses a part of
/// another run as soon as it finishes; neither leaves merged files, and
/// taken parts are left whole (the first one's LAS file copied, not
/// moved), to be merged again.
#[test]
fn a_merge_that_follows_its_parts_gives_up_or_refuses_with_the_reason() {
    let dir = temp("parts-follow-bad");
    let survey = dir.join("survey.toml");
    let las_only = las_only();
    std::fs::write(&survey, &las_only).unwrap();
    let done = run_parts(&dir, &survey, 2, &[1]);
    let never = dir.join("p2-2");
    let merged = dir.join("merged");
    let failed = |child: std::process::Child| {
        let o = child.wait_with_output().unwrap();
        assert!(!o.status.success());
        let e = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!e.contains("panicked"), "{e}");
        assert!(!merged.join("points.las").exists() && !merged.join("summary.json").exists());
        assert!(!merged.join("points.las.partial").exists());
        assert!(done[0].join("points.las").exists());
        e
    };
    let parts = [done[0].clone(), never.clone()];
    let e = failed(follower(
        &merged,
        &parts,
        &["--take-parts", "--give-up-after", "0.3"],
    ));
    assert!(
        e.contains("gave up after 0.3 s") && e.contains(s(&never)) && !e.contains(s(&done[0])),
        "{e}"
    );
    // Part 2 of another seed: refused once it finished, without waiting
    // for the time to give up.
    let other = dir.join("other.toml");
    std::fs::write(&other, las_only.replace("seed = 17", "seed = 18")).unwrap();
    let foreign = dir.join("foreign");
    ok(&lidarsim(&[
        "run",
        s(&other),
        "--part",
        "2/2",
        "-o",
        s(&foreign),
    ]));
    let parts = [done[0].clone(), foreign];
    let e = failed(follower(
        &merged,
        &parts,
        &["--overwrite", "--take-parts", "--give-up-after", "600"],
    ));
    assert!(
        e.contains(&format!("{}: part 2/2 is not of the run", s(&parts[1]))),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A merge that cannot build its survey's world (a scene file changed since
/// the parts ran) is refused, naming the file, and leaves the earlier run
/// in its output directory as it was.
#[test]
fn a_merge_that_cannot_build_its_world_keeps_the_earlier_run() {
    let dir = temp("parts-world");
    let mesh = dir.join("shed.obj");
    std::fs::write(&mesh, "v -5 -5 3\nv 5 -5 3\nv 5 5 3\nv -5 5 3\nf 1 2 3 4\n").unwrap();
    let survey = dir.join("survey.toml");
    let text =
        las_only() + "\n[[mesh]]\nfile = \"shed.obj\"\nmaterial = \"roof\"\nclass = \"roof\"\n";
    std::fs::write(&survey, text).unwrap();
    let parts = run_parts(&dir, &survey, 2, &[2, 1]);
    let out = dir.join("merged");
    let merge = || lidarsim(&["merge", "-o", s(&out), s(&parts[0]), s(&parts[1])]);
    ok(&merge());
    let files = tree(&out);
    assert!(files.iter().any(|f| f.ends_with("points.las")), "{files:?}");
    let before: Vec<Vec<u8>> = files
        .iter()
        .map(|f| std::fs::read(out.join(f)).unwrap())
        .collect();
    // A face naming a vertex the file does not have.
    std::fs::write(&mesh, "v -5 -5 3\nv 5 -5 3\nf 1 2 9\n").unwrap();
    let o = merge();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!e.contains("panicked") && e.contains("mesh[0]"), "{e}");
    assert_eq!(tree(&out), files, "{e}");
    for (f, bytes) in files.iter().zip(&before) {
        assert!(
            std::fs::read(out.join(f)).unwrap() == *bytes,
            "{} changed",
            f.display()
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Every file under `dir`, relative to it, sorted.
fn tree(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn merged_strips_and_tiles_are_the_unsplit_runs() {
    let dir = temp("parts-layouts");
    for (name, layout, n) in [
        ("strips", "layout = \"strips\"", 3),
        ("tiles", "layout = \"tiles\"\ntile_m = 40", 2),
    ] {
        let survey = dir.join(format!("{name}.toml"));
        let text = SURVEY.replace(
            "formats = [\"las-waveform\", \"laz\", \"ply\", \"xyz\"]",
            &format!("formats = [\"las\", \"laz\", \"xyz\"]\n{layout}"),
        );
        std::fs::write(&survey, text).unwrap();
        let whole = dir.join(format!("{name}-whole"));
        ok(&lidarsim(&["run", s(&survey), "-o", s(&whole)]));
        let order: Vec<usize> = (1..=n).rev().collect();
        let parts = run_parts(&dir, &survey, n, &order);
        let merged = dir.join(format!("{name}-merged"));
        let mut args = vec!["merge", "-o", s(&merged)];
        args.extend(parts.iter().map(|p| s(p)));
        ok(&lidarsim(&args));
        let files = tree(&whole.join(name));
        assert!(files.len() > 3, "{name}: {files:?}");
        assert_eq!(tree(&merged.join(name)), files, "{name}");
        for f in files {
            assert!(
                std::fs::read(whole.join(name).join(&f)).unwrap()
                    == std::fs::read(merged.join(name).join(&f)).unwrap(),
                "{name}: {} differs",
                f.display()
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn merges_of_parts_that_are_not_one_run_are_refused() {
    let dir = temp("bad-merge");
    let survey = dir.join("survey.toml");
    let short = SURVEY.replace(
        "end_m = [-30.0, 0.0, 150.0]",
        "end_m = [-30.0, -20.0, 150.0]",
    );
    std::fs::write(&survey, &short).unwrap();
    let parts = run_parts(&dir, &survey, 3, &[1, 2, 3]);
    let merge = |dirs: &[&Path]| {
        let out = dir.join("merged");
        let mut args = vec!["merge", "--overwrite", "-o", s(&out)];
        args.extend(dirs.iter().map(|p| s(p)));
        let o = lidarsim(&args);
        assert!(!o.status.success());
        let text = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!text.contains("panicked"), "{text}");
        text
    };
    let (p1, p2, p3) = (&parts[0], &parts[1], &parts[2]);
    // A part missing, two missing, one given twice.
    let e = merge(&[p1, p3]);
    assert!(e.contains("part 2/3 is missing"), "{e}");
    let e = merge(&[p2]);
    assert!(e.contains("parts 1/3, 3/3 are missing"), "{e}");
    let e = merge(&[p1, p2, p1, p3]);
    assert!(e.contains("part 1/3 is given twice"), "{e}");
    // A part of another number of parts, another seed, another survey.
    let other_n = run_parts(&dir, &survey, 2, &[2]);
    let e = merge(&[p1, p2, p3, &other_n[0]]);
    assert!(e.contains("one of 2 parts, not 3"), "{e}");
    let seeded = dir.join("seeded");
    ok(&lidarsim(&[
        "run",
        s(&survey),
        "--part",
        "3/3",
        "--seed",
        "99",
        "-o",
        s(&seeded),
    ]));
    let e = merge(&[p1, p2, &seeded]);
    assert!(
        e.contains("survey.toml differs") || e.contains("seed"),
        "{e}"
    );
    let other = dir.join("other.toml");
    std::fs::write(&other, short.replace("noise = 0.01", "noise = 0.02")).unwrap();
    let foreign = dir.join("foreign");
    ok(&lidarsim(&[
        "run",
        s(&other),
        "--part",
        "3/3",
        "-o",
        s(&foreign),
    ]));
    let e = merge(&[p1, p2, &foreign]);
    assert!(e.contains("survey.toml differs"), "{e}");
    // Not a part; a point file cut short; a survey edited afterwards.
    let stranger = dir.join("stranger");
    std::fs::create_dir_all(&stranger).unwrap();
    let e = merge(&[p1, p2, &stranger]);
    assert!(e.contains("not the record of a part"), "{e}");
    let cut = p3.join("points.part");
    let bytes = std::fs::read(&cut).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() - 10]).unwrap();
    let e = merge(&[p1, p2, p3]);
    assert!(e.contains("cut short or changed"), "{e}");
    std::fs::write(&cut, &bytes).unwrap();
    let toml = p2.join("survey.toml");
    let text = std::fs::read_to_string(&toml).unwrap();
    std::fs::write(&toml, text.replace("seed = 17", "seed = 18")).unwrap();
    let e = merge(&[p1, p2, p3]);
    assert!(e.contains("was changed after the part ran"), "{e}");
    std::fs::write(&toml, text).unwrap();
    // Put right, the merge goes through.
    let out = dir.join("merged");
    let mut args = vec!["merge", "--overwrite", "-o", s(&out)];
    args.extend([s(p3), s(p1), s(p2)]);
    ok(&lidarsim(&args));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bad_part_argument_is_refused() {
    let dir = temp("bad-part");
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, SURVEY).unwrap();
    for bad in ["0/3", "4/3", "x/3", "3", "1/0"] {
        let o = lidarsim(&["run", s(&survey), "--part", bad, "-o", s(&dir.join("o"))]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("K/N") || e.contains("K must be"), "{bad}: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
