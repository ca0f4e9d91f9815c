//! A user's files are never lost (issue 44): split runs, merges, tiles and
//! foreign LAS/LAZ files under misuse, one test per kind of defect.
//!
//! 1. A merge never removes or writes into what it reads, and taking parts
//!    removes only what the part runs wrote.
//! 2. Every count read from a file or an argument is bounded before it
//!    sizes an allocation, a loop or a number of files.
//! 3. What would be silently wrong is refused, with the key named — or
//!    made right.
//! 4. Messages a person can act on: short numbers, the file named.
//! 5. Smaller inconsistencies.
//!
//! Every command runs under an address-space limit and a timeout
//! ([`crate::kit::limited`]); every input file is compared byte for byte
//! before and after.
//!
//! Long file: one test per kind of misuse, each building its own inputs
//! (forged LAZ tables, FIFOs, swapped parts) in a few lines of bytes.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Output;

use crate::kit::{crc32, limited, snapshot, temp};

/// A survey whose only point output is a plain LAS file: its parts are
/// stitched (`points.las` and `report.state` each).
const LAS_ONLY: &str = r#"seed = 5

[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15

[[flight_line]]
start_m = [0.0, -40.0, 300.0]
end_m = [0.0, 40.0, 300.0]
speed_mps = 50.0

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

/// `lidarsim ARGS` (paths and words alike), limited.
fn run(args: &[&dyn AsRef<OsStr>]) -> Output {
    let args: Vec<&OsStr> = args.iter().map(|a| a.as_ref()).collect();
    limited(&args)
}

/// The standard error of a command that must fail with `status`, without
/// a panic, holding every fragment of `expect`.
fn fails(o: &Output, status: i32, expect: &[&str]) -> String {
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(status), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    for x in expect {
        assert!(e.contains(x), "wanted '{x}' in\n{e}");
    }
    e
}

fn succeeds(o: &Output) -> String {
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{e}");
    e
}

/// Writes `text` as `dir/name` and returns its path.
fn write(dir: &Path, name: &str, text: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Parts 1..=n of `survey` into `dir/p1`, `dir/p2`, ….
fn parts(dir: &Path, survey: &Path, n: usize) -> Vec<PathBuf> {
    (1..=n)
        .map(|k| {
            let out = dir.join(format!("p{k}"));
            let part = format!("{k}/{n}");
            succeeds(&run(&[&"run", &survey, &"--part", &part, &"-o", &out]));
            out
        })
        .collect()
}

// 1. Data loss ----------------------------------------------------------

/// The output of a merge may not be a part, lie inside one or hold one:
/// refused before anything is touched, every part byte for byte as it
/// was, with and without `--take-parts`.
#[test]
fn a_merge_never_writes_where_its_parts_are() {
    let dir = temp("rel-where");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let p = parts(&dir, &survey, 3);
    let before = snapshot(&dir);
    let cases: [(PathBuf, &str); 4] = [
        (p[2].clone(), "is the directory of a part"),
        (p[0].clone(), "is the directory of a part"),
        (p[1].join("merged"), "lies inside the directory of a part"),
        (dir.clone(), "holds the directory of a part"),
    ];
    for (out, why) in &cases {
        for take in [false, true] {
            let mut args: Vec<&dyn AsRef<OsStr>> = vec![&"merge", &p[0], &p[1], &p[2], &"-o", out];
            if take {
                args.push(&"--take-parts");
            }
            fails(&run(&args), 1, &[why]);
            assert_eq!(snapshot(&dir), before, "{out:?} take {take}");
        }
        // A merge that follows its parts checks before it waits.
        fails(
            &run(&[&"merge", &"--follow", &p[0], &p[1], &p[2], &"-o", out]),
            1,
            &[why],
        );
        assert_eq!(snapshot(&dir), before);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A part written with `--overwrite` into a folder of the user's: taking
/// the parts removes the files the part wrote, keeps the user's and the
/// folder, and says so; parts that held nothing else are removed whole.
#[test]
fn taking_parts_removes_only_what_the_parts_wrote() {
    let dir = temp("rel-take");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let mine = dir.join("p2");
    std::fs::create_dir_all(mine.join("sub")).unwrap();
    write(&mine, "notes.txt", "my notes");
    write(&mine.join("sub"), "data.bin", [1u8, 2, 3]);
    let p: Vec<PathBuf> = (1..=3)
        .map(|k| {
            let out = dir.join(format!("p{k}"));
            let part = format!("{k}/3");
            succeeds(&run(&[
                &"run",
                &survey,
                &"--part",
                &part,
                &"--overwrite",
                &"-o",
                &out,
            ]));
            out
        })
        .collect();
    let out = dir.join("merged");
    let e = succeeds(&run(&[
        &"merge",
        &p[0],
        &p[1],
        &p[2],
        &"-o",
        &out,
        &"--take-parts",
    ]));
    assert!(
        e.contains("kept the part's directory") && e.contains("notes.txt"),
        "{e}"
    );
    assert!(out.join("points.las").is_file() && out.join("summary.json").is_file());
    assert!(!p[0].exists() && !p[2].exists());
    let mut left: Vec<String> = std::fs::read_dir(&mine)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["notes.txt", "sub"]);
    assert_eq!(std::fs::read(mine.join("notes.txt")).unwrap(), b"my notes");
    assert_eq!(std::fs::read(mine.join("sub/data.bin")).unwrap(), [1, 2, 3]);
    std::fs::remove_dir_all(&dir).ok();
}

/// A record that lists a file no part writes is refused before anything
/// is removed: a part's record cannot make a merge delete the user's
/// files.
#[test]
fn a_record_that_lists_foreign_files_is_refused() {
    let dir = temp("rel-forged-list");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let p = parts(&dir, &survey, 2);
    let victim = write(&dir, "victim.txt", "precious");
    let record = p[1].join("part.json");
    let text = std::fs::read_to_string(&record).unwrap();
    let forged = text.replace("\"part.json\"", "\"part.json\", \"../victim.txt\"");
    assert_ne!(forged, text);
    std::fs::write(&record, forged).unwrap();
    let out = dir.join("out");
    fails(
        &run(&[&"merge", &p[0], &p[1], &"-o", &out, &"--take-parts"]),
        1,
        &["p2/part.json", "../victim.txt", "a part never writes"],
    );
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert!(p[0].join("points.las").is_file());
    std::fs::remove_dir_all(&dir).ok();
}

/// A merge that fails once it has written files of its own removes them:
/// no `survey.toml` or trajectory stands in its output without points and
/// a summary. The part's report state is replaced by one that is not a
/// state, its record's length and checksum forged to match (the test's
/// own CRC-32), so that only the join of the reports finds it.
#[test]
fn a_merge_that_fails_leaves_nothing_of_its_own() {
    let dir = temp("rel-rollback");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let p = parts(&dir, &survey, 2);
    let bad = b"not a report state at all".to_vec();
    std::fs::write(p[1].join("report.state"), &bad).unwrap();
    let record = p[1].join("part.json");
    let mut r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&record).unwrap()).unwrap();
    r["report_bytes"] = bad.len().into();
    r["report_crc32"] = format!("{:08x}", crc32(&bad)).into();
    std::fs::write(&record, serde_json::to_vec_pretty(&r).unwrap()).unwrap();
    let out = dir.join("out");
    let before = snapshot(&p[0]);
    fails(
        &run(&[&"merge", &p[0], &p[1], &"-o", &out]),
        1,
        &["report.state"],
    );
    let left: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != ".lidarsim-output")
        .collect();
    assert!(left.is_empty(), "the failed merge left {left:?}");
    assert_eq!(snapshot(&p[0]), before);
    std::fs::remove_dir_all(&dir).ok();
}

/// A command that writes one file where the user says (`render -o`,
/// `waveform -o`, `demo --export-survey`) writes it where nothing is or
/// over a file lidarsim wrote, never over the cloud it reads or a file of
/// the user's.
#[test]
fn single_files_are_written_only_where_nothing_or_our_own_is() {
    let dir = temp("rel-own");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let out = dir.join("out");
    succeeds(&run(&[&"run", &survey, &"-o", &out]));
    let las = out.join("points.las");
    let photo = write(&dir, "photo.png", b"\x89PNG\r\n\x1a\nmy holiday");
    let notes = write(&dir, "notes.toml", "# my survey\nseed = 1\n");
    let before = snapshot(&dir);
    fails(
        &run(&[&"render", &las, &"-o", &las]),
        1,
        &["points.las", "not written by lidarsim"],
    );
    fails(
        &run(&[&"render", &las, &"-o", &photo]),
        1,
        &["photo.png", "not written by lidarsim"],
    );
    fails(
        &run(&[&"waveform", &out, &"--pulse", &"5", &"-o", &photo]),
        1,
        &["photo.png", "not written by lidarsim"],
    );
    fails(
        &run(&[&"demo", &"--export-survey", &notes, &"-o", &dir.join("d")]),
        1,
        &["notes.toml", "not written by lidarsim"],
    );
    assert_eq!(snapshot(&dir), before);
    // Its own picture it replaces.
    let png = dir.join("top.png");
    succeeds(&run(&[&"render", &las, &"-o", &png]));
    succeeds(&run(&[
        &"render",
        &las,
        &"-o",
        &png,
        &"--color",
        &"intensity",
    ]));
    std::fs::remove_dir_all(&dir).ok();
}

// 2. Numbers from files and arguments ----------------------------------

/// Part numbers beyond any split are refused by the argument parser.
#[test]
fn part_counts_beyond_any_split_are_refused() {
    let dir = temp("rel-part-n");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    for part in [
        "1/1000000000",
        "1/9223372036854775807",
        "1/18446744073709551615",
    ] {
        fails(
            &run(&[&"run", &survey, &"--part", &part, &"-o", &dir.join("o")]),
            2,
            &["N must be from 1 to 100000"],
        );
    }
    assert!(!dir.join("o").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A LAZ file whose chunk table counts 2³²−1 chunks, or lies at byte 2⁶²,
/// is refused by every command that reads point clouds, within the
/// address-space limit, naming the file.
#[test]
fn a_laz_with_a_forged_chunk_table_is_refused() {
    let dir = temp("rel-laz");
    let survey = write(
        &dir,
        "s.toml",
        LAS_ONLY.replace("seed = 5", "seed = 5\n\n[output]\nformats = [\"laz\"]"),
    );
    let run_dir = dir.join("run");
    succeeds(&run(&[&"run", &survey, &"-o", &run_dir]));
    let laz = std::fs::read(run_dir.join("points.laz")).unwrap();
    let start = u32::from_le_bytes(laz[96..100].try_into().unwrap()) as usize;
    let table = i64::from_le_bytes(laz[start..start + 8].try_into().unwrap()) as usize;
    let mut many = laz.clone();
    many[table + 4..table + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    let mut far = laz.clone();
    far[start..start + 8].copy_from_slice(&(1i64 << 62).to_le_bytes());
    for (bytes, why) in [
        (many, "counts 4294967295 chunks"),
        (far, "chunk table is said to be at byte 4611686018427387904"),
    ] {
        let case = dir.join("case");
        std::fs::create_dir_all(&case).unwrap();
        let forged = write(&case, "forged.laz", &bytes);
        fails(
            &run(&[&"render", &forged, &"-o", &case.join("x.png")]),
            1,
            &["forged.laz", why],
        );
        let cloud = write(
            &case,
            "cloud.toml",
            LAS_ONLY.replace(
                "[[polygon]]",
                "[[point_cloud]]\nfile = \"forged.laz\"\nmaterial = \"grass\"\n\n[[polygon]]",
            ),
        );
        fails(&run(&[&"check", &cloud]), 2, &["forged.laz", why]);
        // `waveform --near` reads the run's cloud.
        let wf = dir.join("wf");
        std::fs::create_dir_all(&wf).unwrap();
        std::fs::copy(run_dir.join("survey.toml"), wf.join("survey.toml")).unwrap();
        std::fs::write(wf.join("points.laz"), &bytes).unwrap();
        fails(
            &run(&[
                &"waveform",
                &wf,
                &"--near",
                &"0,0",
                &"-o",
                &wf.join("w.png"),
            ]),
            1,
            &["points.laz", why],
        );
        assert_eq!(std::fs::read(case.join("forged.laz")).unwrap(), bytes);
        std::fs::remove_dir_all(&case).ok();
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A part's record that claims 10¹² parts, a record that is a FIFO (no
/// writer: opening it would block) and one that is `/dev/zero` are
/// refused at once, naming the record.
#[test]
fn part_records_that_could_not_come_from_a_part_are_refused() {
    let dir = temp("rel-records");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let p = parts(&dir, &survey, 2);
    let record = p[1].join("part.json");
    let text = std::fs::read_to_string(&record).unwrap();
    let out = dir.join("out");
    std::fs::write(
        &record,
        text.replace("\"parts\": 2", "\"parts\": 1000000000000"),
    )
    .unwrap();
    fails(
        &run(&[&"merge", &p[0], &p[1], &"-o", &out]),
        1,
        &["p2/part.json", "N must be from 1 to 100000"],
    );
    #[cfg(unix)]
    {
        std::fs::remove_file(&record).unwrap();
        let fifo = std::ffi::CString::new(record.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path; mkfifo only creates the file.
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0);
        fails(
            &run(&[&"merge", &p[0], &p[1], &"-o", &out]),
            1,
            &["p2/part.json", "not a regular file"],
        );
        // A follower refuses it too, rather than waiting on it.
        fails(
            &run(&[&"merge", &"--follow", &p[0], &p[1], &"-o", &out]),
            1,
            &["p2/part.json", "not a regular file"],
        );
        std::fs::remove_file(&record).unwrap();
        std::os::unix::fs::symlink("/dev/zero", &record).unwrap();
        fails(
            &run(&[&"merge", &p[0], &p[1], &"-o", &out]),
            1,
            &["p2/part.json", "not a regular file"],
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A survey whose array is too long to parse within reason is refused
/// before it is parsed, at its line and key; so is a survey file beyond
/// the size bound.
#[test]
fn surveys_too_large_to_parse_are_refused_at_the_key() {
    let dir = temp("rel-big-survey");
    let pairs: Vec<String> = (0..200_000)
        .map(|i| format!("[{}, 0.5]", 400 + i))
        .collect();
    let text = LAS_ONLY.replace(
        "reflectance = 0.4",
        &format!("reflectance_spectrum = [{}]", pairs.join(", ")),
    );
    let survey = write(&dir, "s.toml", &text);
    fails(
        &run(&[&"check", &survey]),
        2,
        &[
            "`materials.grass.reflectance_spectrum`",
            "s.toml:14",
            "more than 100000 items",
        ],
    );
    let huge = write(&dir, "huge.toml", "#".repeat(17 << 20));
    fails(
        &run(&[&"check", &huge]),
        2,
        &["huge.toml", "more than the 16777216 bytes"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Tiles so small that a run would write tens of thousands of files are
/// refused before the run, at `tile_m`, with a size that fits; `check`
/// counts the files of a tile layout that is accepted.
#[test]
fn tiles_are_bounded_before_the_run() {
    let dir = temp("rel-tiles");
    let tiles = |m: &str| {
        LAS_ONLY.replace(
            "seed = 5",
            &format!("seed = 5\n\n[output]\nlayout = \"tiles\"\ntile_m = {m}"),
        )
    };
    let survey = write(&dir, "s.toml", tiles("1"));
    let e = fails(
        &run(&[&"run", &survey, &"-o", &dir.join("out")]),
        2,
        &[
            "`output.tile_m`",
            "s.toml:",
            "more than the 10000 a run writes",
        ],
    );
    assert!(e.contains("for example"), "{e}");
    assert!(!dir.join("out").exists());
    let survey = write(&dir, "s.toml", tiles("50"));
    let o = run(&[&"check", &survey]);
    succeeds(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("tiles: up to"), "{stdout}");
    std::fs::remove_dir_all(&dir).ok();
}

// 3. Silent wrong results ------------------------------------------------

/// Two parts' LAS files swapped (same length), or a few kilobytes of one
/// written over in place: the merge refuses, naming the part's file; the
/// parts are left as they are.
#[test]
fn a_merge_verifies_what_it_joins() {
    let dir = temp("rel-verify");
    // Two lines so that the two parts hold files of one length.
    let text = LAS_ONLY.replace(
        "[materials.grass]",
        "[[flight_line]]\nstart_m = [60.0, 40.0, 300.0]\nend_m = [60.0, -40.0, 300.0]\n\
         speed_mps = 50.0\n\n[materials.grass]",
    );
    let survey = write(&dir, "s.toml", text);
    let p = parts(&dir, &survey, 2);
    let (a, b) = (p[0].join("points.las"), p[1].join("points.las"));
    let (ba, bb) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(ba.len(), bb.len(), "the test needs parts of one length");
    std::fs::write(&a, &bb).unwrap();
    std::fs::write(&b, &ba).unwrap();
    let out = dir.join("out");
    fails(
        &run(&[&"merge", &p[0], &p[1], &"-o", &out]),
        1,
        &["p1/points.las", "is not the file part 1/2 wrote"],
    );
    std::fs::write(&a, &ba).unwrap();
    std::fs::write(&b, &bb).unwrap();
    let mut over = bb.clone();
    for byte in &mut over[2000..6000] {
        *byte = 0x5a;
    }
    std::fs::write(&b, &over).unwrap();
    let before = snapshot(&dir);
    fails(
        &run(&[&"merge", &p[0], &p[1], &"-o", &out, &"--take-parts"]),
        1,
        &["p2/points.las", "checksum"],
    );
    assert_eq!(snapshot(&dir), before, "refused before anything is written");
    std::fs::write(&b, &bb).unwrap();
    succeeds(&run(&[&"merge", &p[0], &p[1], &"-o", &out]));
    std::fs::remove_dir_all(&dir).ok();
}

/// Settings that used to run and give wrong points are refused at their
/// key: a divergence far below any beam's, an elliptical beam 10⁵ times
/// flatter than it is wide, GPS times too large to tell pulses apart.
#[test]
fn settings_that_would_give_wrong_points_are_refused_at_their_key() {
    let dir = temp("rel-settings");
    let cases: [(&str, &str, &[&str]); 3] = [
        (
            "scan_angle_deg = 15",
            "scan_angle_deg = 15\ndivergence_mrad = 1e-300",
            &["`scanner.divergence_mrad`", "at least 0.001 mrad", "1e-300"],
        ),
        (
            "scan_angle_deg = 15",
            "scan_angle_deg = 15\ndivergence_mrad = 0.001\ndivergence_along_mrad = 100",
            &["`scanner.divergence_along_mrad`", "100000 times"],
        ),
        (
            "[materials.grass]",
            "[[flight_line]]\nstart_m = [0.0, 40.0, 300.0]\nend_m = [0.0, -40.0, 300.0]\n\
             speed_mps = 50.0\n\n[platform]\nturn_time_s = 1e15\n\n[materials.grass]",
            &["`platform.turn_time_s`", "1e15"],
        ),
    ];
    for (old, new, expect) in cases {
        let survey = write(&dir, "s.toml", LAS_ONLY.replace(old, new));
        fails(&run(&[&"check", &survey]), 2, expect);
        fails(&run(&[&"run", &survey, &"-o", &dir.join("out")]), 2, expect);
        assert!(!dir.join("out").exists());
    }
    // A trajectory whose lines lie 10¹⁵ s apart: its pulses' GPS times
    // could not be told apart.
    write(
        &dir,
        "t.csv",
        "time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,line\n0,0,-40,300,0,0,0,1\n\
         1.6,0,40,300,0,0,0,1\n1e15,0,40,300,0,0,180,2\n1000000000000001.6,0,-40,300,0,0,180,2\n",
    );
    let text = LAS_ONLY.replace(
        "[[flight_line]]\nstart_m = [0.0, -40.0, 300.0]\nend_m = [0.0, 40.0, 300.0]\nspeed_mps = 50.0\n",
        "[platform]\ntrajectory_file = \"t.csv\"\n",
    );
    let survey = write(&dir, "s.toml", text);
    fails(
        &run(&[&"check", &survey]),
        2,
        &["`platform.trajectory_file`", "could not be told apart"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A point cloud in XYZ text with a coordinate that is NaN or infinite
/// is an error naming the file and the line, as an OBJ vertex is.
#[test]
fn a_cloud_point_that_is_not_finite_is_an_error_at_its_line() {
    let dir = temp("rel-xyz");
    for (value, line) in [("nan", 3), ("inf", 3), ("-inf", 3)] {
        write(
            &dir,
            "c.xyz",
            format!("# cloud\n1 2 3\n4 {value} 6\n7 8 9\n"),
        );
        let survey = write(
            &dir,
            "s.toml",
            LAS_ONLY.replace(
                "[[polygon]]",
                "[[point_cloud]]\nfile = \"c.xyz\"\nmaterial = \"grass\"\n\n[[polygon]]",
            ),
        );
        fails(
            &run(&[&"check", &survey]),
            2,
            &["c.xyz", &format!("line {line}"), "is not a finite number"],
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `waveform --near` finds a point, but when its GPS time is not a number
/// it names no pulse: an error, not a pulse of another time.
#[test]
fn a_point_without_a_time_names_no_pulse() {
    let dir = temp("rel-nan-time");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let out = dir.join("out");
    succeeds(&run(&[&"run", &survey, &"-o", &out]));
    let las = out.join("points.las");
    let mut b = std::fs::read(&las).unwrap();
    // LAS 1.4 R15 Table 3 and point format 6 (Table 13): the offset to
    // the points, the record length, the count; GPS time at byte 22.
    let start = u32::from_le_bytes(b[96..100].try_into().unwrap()) as usize;
    let len = u16::from_le_bytes(b[105..107].try_into().unwrap()) as usize;
    let n = u64::from_le_bytes(b[247..255].try_into().unwrap()) as usize;
    for i in 0..n {
        let at = start + i * len + 22;
        b[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    }
    std::fs::write(&las, &b).unwrap();
    fails(
        &run(&[
            &"waveform",
            &out,
            &"--near",
            &"0,0",
            &"-o",
            &dir.join("w.png"),
        ]),
        2,
        &["--near", "GPS time NaN is not a number"],
    );
    fails(
        &run(&[
            &"waveform",
            &out,
            &"--gps-time",
            &"1e9",
            &"-o",
            &dir.join("w.png"),
        ]),
        2,
        &["--gps-time 1e9", "no pulse was emitted"],
    );
    assert!(!dir.join("w.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// Channels turned so that their pulses miss the scene: `check` and `run`
/// warn, and a run that records no point says so; a channel tilted past
/// the horizon is counted.
#[test]
fn channels_that_cannot_reach_the_scene_are_warned_of() {
    let dir = temp("rel-tilt");
    let aside = LAS_ONLY
        .replace(
            "scan_angle_deg = 15",
            "scan_angle_deg = 5\n\n[[scanner.channels]]\nalong_tilt_deg = 45\nyaw_deg = 90",
        )
        .replace(
            "[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]",
            "[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]",
        );
    let survey = write(&dir, "s.toml", &aside);
    let o = run(&[&"check", &survey]);
    let e = succeeds(&o);
    assert!(e.contains("no pulse can hit the scene"), "{e}");
    let o = run(&[&"run", &survey, &"-o", &dir.join("out")]);
    let e = succeeds(&o);
    assert!(e.contains("no pulse can hit the scene"), "{e}");
    assert!(e.contains("the run recorded no point"), "{e}");
    let up = LAS_ONLY.replace(
        "scan_angle_deg = 15",
        "deflector = \"palmer\"\nscan_angle_deg = 50\n\n[[scanner.channels]]\nalong_tilt_deg = 45",
    );
    let survey = write(&dir, "s.toml", &up);
    let e = succeeds(&run(&[&"check", &survey]));
    assert!(
        e.contains("% of the pulses look at or above the horizon"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

// 4. Messages -------------------------------------------------------------

/// Extreme numbers appear in exponent form in `check`'s figures,
/// warnings and errors, never as hundreds of digits, and no line of
/// output is long.
#[test]
fn extreme_numbers_are_shown_in_exponent_form() {
    let dir = temp("rel-numbers");
    let cases = [
        (
            "scan_angle_deg = 15",
            "scan_angle_deg = 15\nmax_range_m = 1e300",
        ),
        (
            "scan_angle_deg = 15",
            "scan_angle_deg = 15\nmin_range_m = 1e300",
        ),
        (
            "scan_angle_deg = 15",
            "scan_angle_deg = 15\nsubrays = 1e300",
        ),
        ("speed_mps = 50.0", "speed_mps = 1e-300"),
        ("seed = 5", "seed = 5\n[output]\nlas_scale_m = 1e-300"),
    ];
    for (old, new) in cases {
        let survey = write(&dir, "s.toml", LAS_ONLY.replacen(old, new, 1));
        let o = run(&[&"check", &survey]);
        let all = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!all.contains("panicked"), "{all}");
        let longest = all
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(
            longest <= 24,
            "{new}: a number of {longest} digits in\n{all}"
        );
        let first = all.lines().next().unwrap_or("");
        assert!(
            first.len() < 300,
            "{new}: first line of {} bytes",
            first.len()
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `waveform --near` at a place far from every point says that no point
/// is near it (not that the file holds none); a trajectory saved with a
/// byte-order mark is read; one that names a column twice is refused.
#[test]
fn messages_say_what_is_wrong() {
    let dir = temp("rel-messages");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let out = dir.join("out");
    succeeds(&run(&[&"run", &survey, &"-o", &out]));
    fails(
        &run(&[
            &"waveform",
            &out,
            &"--near",
            &"1e200,0",
            &"-o",
            &dir.join("w.png"),
        ]),
        2,
        &["no point of", "is near that place", "1.00e200 m away"],
    );
    let track =
        "time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg\n0,0,-40,300,0,0,0\n1.6,0,40,300,0,0,0\n";
    let text = LAS_ONLY.replace(
        "[[flight_line]]\nstart_m = [0.0, -40.0, 300.0]\nend_m = [0.0, 40.0, 300.0]\nspeed_mps = 50.0\n",
        "[platform]\ntrajectory_file = \"t.csv\"\n",
    );
    let survey = write(&dir, "t.toml", text);
    write(&dir, "t.csv", format!("\u{feff}{track}"));
    succeeds(&run(&[&"check", &survey]));
    write(
        &dir,
        "t.csv",
        track
            .replace("yaw_deg\n", "yaw_deg,z_m\n")
            .replace(",0\n", ",0,1\n"),
    );
    fails(&run(&[&"check", &survey]), 2, &["t.csv", "line 1", "`z_m`"]);
    std::fs::remove_dir_all(&dir).ok();
}

// 5. Smaller inconsistencies ---------------------------------------------

/// A LAS file whose header counts no point but holds records, and one of
/// version 9.9, are refused by `render` with what is wrong.
#[test]
fn render_refuses_what_the_cloud_reader_refuses() {
    let dir = temp("rel-render");
    let survey = write(&dir, "s.toml", LAS_ONLY);
    let out = dir.join("out");
    succeeds(&run(&[&"run", &survey, &"-o", &out]));
    let b = std::fs::read(out.join("points.las")).unwrap();
    let mut zero = b.clone();
    zero[247..255].copy_from_slice(&0u64.to_le_bytes());
    let f = write(&dir, "zero.las", &zero);
    fails(
        &run(&[&"render", &f, &"-o", &dir.join("z.png")]),
        1,
        &["zero.las", "counts no point, but"],
    );
    let mut v = b.clone();
    v[24..26].copy_from_slice(&[9, 9]);
    let f = write(&dir, "v99.las", &v);
    fails(
        &run(&[&"render", &f, &"-o", &dir.join("v.png")]),
        1,
        &["v99.las", "LAS 9.9", "LAS 1.0 to 1.4"],
    );
    assert!(!dir.join("z.png").exists() && !dir.join("v.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// Risley prisms turning together trace a circle: `check` gives its scan
/// lines a spacing, not "0.00 m".
#[test]
fn risley_rotors_at_one_rate_have_a_line_spacing() {
    let dir = temp("rel-risley");
    let survey = write(
        &dir,
        "s.toml",
        LAS_ONLY.replace(
            "scan_frequency_hz = 40\nscan_angle_deg = 15",
            "deflector = \"risley\"\nprism_deviation_deg = [10, 10]\nrotor_frequency_hz = [50, 50]",
        ),
    );
    let o = run(&[&"check", &survey]);
    succeeds(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(!stdout.contains("every 0.00 m"), "{stdout}");
    assert!(stdout.contains("scan lines every 1.00 m"), "{stdout}");
    std::fs::remove_dir_all(&dir).ok();
}
