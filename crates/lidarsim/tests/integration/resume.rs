//! Interrupt and resume: a run stopped at a block boundary leaves valid
//! files for what it simulated (LAS header counts and bounds checked by the
//! independent `las` reader) and a summary saying where to go on; resumed,
//! possibly several times, it ends with the files of an uninterrupted run,
//! byte for byte.
//!
//! Compared byte for byte: points.las, points.xyz, survey.toml and the three
//! trajectories. summary.json is compared with its wall-clock fields
//! (`wall_time_s`, `index_time_s`, `pulses_per_second`) removed, report.html
//! with its "source", "wall time" and "pulses per second" rows removed: the
//! timings are of the sessions, and the resumed run reads the survey from
//! the output directory's survey.toml.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use lidarsim::Survey;
use lidarsim::output::{PointRecord, PointSink};
use lidarsim::run::{RunOptions, Summary};

use crate::kit::run_to_dir;
use lidarsim::sim::{BLOCK_PULSES, PulsePosition, RunControl, Simulator};
use lidarsim::world::World;

use crate::kit::fresh;

/// Two lines of 1.2 s at 20 kHz (12 blocks of 2048 pulses each), GNSS/IMU
/// errors on (LAS extra bytes), LAS and XYZ.
const SURVEY: &str = r#"seed = 11
preset = "uav"

[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15
subrays = 3

[[flight_line]]
start_m = [0.0, -30.0, 300.0]
end_m = [0.0, 30.0, 300.0]
speed_mps = 50.0

[[flight_line]]
start_m = [40.0, 30.0, 300.0]
end_m = [40.0, -30.0, 300.0]
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
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]

[[polygon]]
material = "roof"
class = "building"
vertices_m = [[-10, -10, 8], [30, -10, 8], [30, 10, 12], [-10, 10, 12]]
"#;

fn survey() -> Survey {
    Survey::from_toml(SURVEY, None).unwrap()
}

/// Runs (or resumes) with a stop flag raised after `batches` progress
/// reports of this session.
fn session(s: &Survey, out: &Path, resume: bool, batches: u32, threads: usize) -> Summary {
    let stop = AtomicBool::new(false);
    let seen = AtomicU32::new(0);
    let progress = |_| {
        if seen.fetch_add(1, Ordering::SeqCst) + 1 >= batches {
            stop.store(true, Ordering::SeqCst);
        }
    };
    let mut o = RunOptions::new(threads, &progress);
    o.stop = Some(&stop);
    o.resume = resume;
    run_to_dir(s, out, &o).unwrap()
}

fn summary_without_timings(dir: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    let m = v.as_object_mut().unwrap();
    for k in ["wall_time_s", "index_time_s", "pulses_per_second"] {
        assert!(m.remove(k).is_some(), "{k} missing");
    }
    v
}

fn report_without_timings(dir: &Path) -> String {
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let mut out = String::new();
    for row in html.split("<tr>") {
        if [
            "<th>source</th>",
            "<th>wall time</th>",
            "<th>pulses per second</th>",
        ]
        .iter()
        .any(|k| row.starts_with(k))
        {
            continue;
        }
        out.push_str(row);
    }
    out
}

const SAME_BYTES: [&str; 6] = [
    "points.las",
    "points.xyz",
    "survey.toml",
    "trajectory.csv",
    "trajectory_true.csv",
    "trajectory_observed.csv",
];

fn assert_same_run(a: &Path, b: &Path) {
    for f in SAME_BYTES {
        let (x, y) = (
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
        );
        assert!(x == y, "{f} differs ({} vs {} bytes)", x.len(), y.len());
    }
    assert_eq!(summary_without_timings(a), summary_without_timings(b));
    assert_eq!(report_without_timings(a), report_without_timings(b));
    for d in [a, b] {
        assert!(!d.join("report.state").exists());
        let names: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.ends_with(".partial")), "{names:?}");
    }
}

/// The LAS file of an interrupted run, read by the `las` crate: its header
/// counts and bounds agree with its points, which are those of the
/// uninterrupted run's first pulses.
fn check_prefix(part: &Path, full: &Path, summary: &Summary) {
    let mut r = las::Reader::from_path(part.join("points.las.partial")).unwrap();
    let header = r.header().clone();
    let points: Vec<las::Point> = r
        .read_all()
        .unwrap()
        .points()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(header.number_of_points(), points.len() as u64);
    assert_eq!(points.len() as u64, summary.points);
    let mut by_return = [0u64; 15];
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &points {
        by_return[usize::from(p.return_number) - 1] += 1;
        for (a, v) in [p.x, p.y, p.z].into_iter().enumerate() {
            lo[a] = lo[a].min(v);
            hi[a] = hi[a].max(v);
        }
    }
    for (i, n) in by_return.iter().enumerate() {
        let h = header.number_of_points_by_return(i as u8 + 1).unwrap_or(0);
        assert_eq!(h, *n, "return {}", i + 1);
    }
    let b = header.bounds();
    for (a, (min, max)) in [(b.min.x, b.max.x), (b.min.y, b.max.y), (b.min.z, b.max.z)]
        .into_iter()
        .enumerate()
    {
        assert!((min - lo[a]).abs() < 1e-9 && (max - hi[a]).abs() < 1e-9);
    }
    // The points are the first ones of the full run.
    let full_points: Vec<las::Point> = las::Reader::from_path(full.join("points.las"))
        .unwrap()
        .read_all()
        .unwrap()
        .points()
        .take(points.len())
        .collect::<Result<_, _>>()
        .unwrap();
    assert!(points == full_points);
    // The XYZ file: header line plus one line per point.
    let xyz = std::fs::read_to_string(part.join("points.xyz.partial")).unwrap();
    assert_eq!(xyz.lines().count() as u64, summary.points + 1);
}

#[test]
fn interrupted_then_resumed_equals_uninterrupted() {
    let s = survey();
    let full = fresh("full");
    let reference = run_to_dir(&s, &full, &RunOptions::new(2, &|_| {})).unwrap();
    assert!(reference.complete && reference.next_pulse.is_none());
    let lines = World::build(&s).unwrap().lines;
    let total: u64 = lines.iter().map(|l| s.pulses_of(l)).sum();
    assert_eq!(reference.pulses, total);

    let part = fresh("part");
    let first = session(&s, &part, false, 1, 1);
    assert!(!first.complete);
    let next = first.next_pulse.unwrap();
    assert_eq!(next.pulse % lidarsim::sim::BLOCK_PULSES, 0);
    assert!(first.pulses < total);
    // Pulses before `next` were all simulated, none after.
    let before: u64 = lines[..next.line as usize - 1]
        .iter()
        .map(|l| s.pulses_of(l))
        .sum::<u64>()
        + next.pulse;
    assert_eq!(first.pulses, before);
    check_prefix(&part, &full, &first);
    let json = summary_without_timings(&part);
    assert_eq!(json["complete"], false);
    assert_eq!(json["next_pulse"]["pulse"], next.pulse);
    assert!(part.join("report.state").exists());
    assert!(!part.join("report.html").exists());
    println!(
        "interrupted at line {} pulse {} after {} of {total} pulses ({} points)",
        next.line, next.pulse, first.pulses, first.points
    );

    let resumed = run_to_dir(&Survey::load(&part.join("survey.toml")).unwrap(), &part, &{
        let mut o = RunOptions::new(2, &|_| {});
        o.resume = true;
        o
    })
    .unwrap();
    assert!(resumed.complete);
    assert_same_run(&full, &part);
    // Nothing left to resume.
    let mut o = RunOptions::new(1, &|_| {});
    o.resume = true;
    let e = run_to_dir(&s, &part, &o).unwrap_err();
    assert!(e.to_string().contains("nothing to resume"), "{e}");
    std::fs::remove_dir_all(&full).ok();
    std::fs::remove_dir_all(&part).ok();
}

/// Sessions with a budget of 5 blocks (10 240 pulses; lines of 24 000),
/// alternately on 1 and 2 threads: they stop at pulses 10 240 and 20 480 of
/// line 1; the third finishes line 1 (3 520 pulses) and goes on into line 2
/// up to the next block boundary past its budget (8 192); the fourth stops
/// at 18 432, the fifth completes — deterministic, unlike a stop flag
/// raised from another thread.
#[test]
fn many_interruptions_across_lines_still_equal_one_run() {
    let s = survey();
    let full = fresh("full1");
    run_to_dir(&s, &full, &RunOptions::new(1, &|_| {})).unwrap();
    let part = fresh("many");
    let budget = 5 * lidarsim::sim::BLOCK_PULSES;
    let mut stops = Vec::new();
    let mut resume = false;
    loop {
        let s2 = if resume {
            Survey::load(&part.join("survey.toml")).unwrap()
        } else {
            survey()
        };
        let mut o = RunOptions::new(1 + stops.len() % 2, &|_| {});
        o.resume = resume;
        o.pulse_budget = Some(budget);
        let summary = run_to_dir(&s2, &part, &o).unwrap();
        if summary.complete {
            break;
        }
        let next = summary.next_pulse.unwrap();
        stops.push((next.line, next.pulse));
        resume = true;
        assert!(stops.len() < 20);
    }
    println!("stops (line, pulse): {stops:?}");
    assert_eq!(stops, [(1, 10_240), (1, 20_480), (2, 8_192), (2, 18_432)]);
    assert_same_run(&full, &part);
    std::fs::remove_dir_all(&full).ok();
    std::fs::remove_dir_all(&part).ok();
}

#[test]
fn resume_refuses_changed_files() {
    let s = survey();
    let part = fresh("changed");
    let first = session(&s, &part, false, 1, 1);
    assert!(!first.complete);
    // Cut short behind the run's back: fewer bytes than recorded.
    let las = part.join("points.las.partial");
    let mut bytes = std::fs::read(&las).unwrap();
    bytes.truncate(bytes.len() - 30);
    std::fs::write(&las, &bytes).unwrap();
    let mut o = RunOptions::new(1, &|_| {});
    o.resume = true;
    let e = run_to_dir(&s, &part, &o).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("points.las") && msg.contains("shorter than"),
        "{msg}"
    );
    // The file is left as it was.
    assert_eq!(std::fs::read(&las).unwrap(), bytes);
    // A different seed is refused too.
    let other = Survey::from_toml_with_seed(SURVEY, None, Some(12)).unwrap();
    let e = run_to_dir(&other, &part, &o).unwrap_err();
    assert!(e.to_string().contains("seed"), "{e}");
    std::fs::remove_dir_all(&part).ok();
}

/// Counts the blocks written to it and raises a stop flag at the first.
struct StopAtFirstBlock {
    stop: Arc<AtomicBool>,
    blocks: u64,
    writer: std::thread::ThreadId,
}

impl PointSink for StopAtFirstBlock {
    type Error = std::convert::Infallible;
    fn write(&mut self, _points: &[PointRecord]) -> Result<(), Self::Error> {
        assert_eq!(
            std::thread::current().id(),
            self.writer,
            "written off the caller"
        );
        self.blocks += 1;
        self.stop.store(true, Ordering::SeqCst);
        Ok(())
    }
    fn finish(self: Box<Self>) -> Result<(), Self::Error> {
        Ok(())
    }
    fn discard(self: Box<Self>) {}
}

/// One thread is one thread: the calling thread simulates a block, writes
/// it, and only then takes the next, so a stop raised while the first block
/// is written leaves exactly that block. (With a worker thread beside the
/// writer, the worker would have simulated the next blocks meanwhile, and
/// the writer, having them in order, would write them.) With two threads the
/// calling thread writes too, and what was written is a prefix of whole
/// blocks ending where the outcome says.
#[test]
fn one_thread_simulates_and_writes_in_turn_on_the_calling_thread() {
    let s = survey();
    let world = World::build(&s).unwrap();
    let sim = Simulator::new(&s, &world);
    for threads in [1, 2] {
        let stop = Arc::new(AtomicBool::new(false));
        let mut sink = StopAtFirstBlock {
            stop: Arc::clone(&stop),
            blocks: 0,
            writer: std::thread::current().id(),
        };
        let control = RunControl {
            stop: Some(&*stop),
            ..RunControl::default()
        };
        let out = sim
            .run_from(threads, &mut [&mut sink], &|_| {}, &control)
            .unwrap();
        let written = sink.blocks;
        assert!(written >= 1);
        if threads == 1 {
            assert_eq!(written, 1, "one thread wrote {written} blocks");
        }
        assert_eq!(
            out.counts.pulses,
            written * BLOCK_PULSES,
            "{threads} threads"
        );
        assert_eq!(
            out.stopped_at,
            Some(PulsePosition {
                line: 0,
                pulse: written * BLOCK_PULSES
            }),
            "{threads} threads"
        );
    }
}

/// Runs `text` to `full`, and in `part` stops it after one block and
/// resumes it: the two directories' `files` must be equal byte for byte.
fn interrupt_and_resume_equal(text: &str, name: &str, files: &[&str]) {
    let s = Survey::from_toml(text, None).unwrap();
    let full = fresh(&format!("{name}-full"));
    run_to_dir(&s, &full, &RunOptions::new(2, &|_| {})).unwrap();
    let part = fresh(name);
    let first = session(&s, &part, false, 1, 1);
    assert!(!first.complete && first.resumable);
    for f in files {
        assert!(part.join(format!("{f}.partial")).exists(), "{f}.partial");
        assert!(!part.join(f).exists(), "{f} under its final name");
    }
    let mut o = RunOptions::new(2, &|_| {});
    o.resume = true;
    let s2 = Survey::load(&part.join("survey.toml")).unwrap();
    assert!(run_to_dir(&s2, &part, &o).unwrap().complete);
    for f in files {
        let (x, y) = (
            std::fs::read(full.join(f)).unwrap(),
            std::fs::read(part.join(f)).unwrap(),
        );
        assert!(x == y, "{f} differs ({} vs {} bytes)", x.len(), y.len());
    }
    std::fs::remove_dir_all(&full).ok();
    std::fs::remove_dir_all(&part).ok();
}

#[test]
fn full_waveform_and_ply_runs_resume_to_the_same_bytes() {
    let text = SURVEY.replace(
        r#"formats = ["las", "xyz"]"#,
        r#"formats = ["las-waveform", "ply", "xyz"]"#,
    );
    interrupt_and_resume_equal(
        &text,
        "wdp",
        &["points.las", "points.wdp", "points.ply", "points.xyz"],
    );
}

/// A polygon fires in only part of its pulse slots: the run resumes at
/// the slot it stopped at, not at the count of pulses that left, and its
/// summary counts both.
#[test]
fn a_polygon_run_resumes_at_its_pulse_slot() {
    let text = SURVEY.replace(
        "scan_frequency_hz = 40\nscan_angle_deg = 15",
        "deflector = \"polygon\"\nfacets = 4\nscan_frequency_hz = 20\nscan_angle_deg = 45",
    );
    assert_ne!(text, SURVEY);
    interrupt_and_resume_equal(&text, "polygon", &["points.las", "points.xyz"]);
    // 4 facets sweep 180° each; ±45° of it fires: half the slots, to
    // within the slot at each end of a line (1000 slots per line).
    let s = Survey::from_toml(&text, None).unwrap();
    let out = fresh("polygon-counts");
    let summary = run_to_dir(&s, &out, &RunOptions::new(2, &|_| {})).unwrap();
    assert_eq!(summary.pulse_slots, 2 * 24_000);
    let share = summary.pulses as f64 / summary.pulse_slots as f64;
    assert!((share - 0.5).abs() <= 2e-3, "{share}");
    std::fs::remove_dir_all(&out).ok();
}

/// A LAZ run cannot be continued: it says so in its summary, and a resume
/// is refused with the reason instead of being offered.
#[test]
fn an_interrupted_laz_run_is_not_resumable() {
    let text = SURVEY.replace(r#"formats = ["las", "xyz"]"#, r#"formats = ["laz"]"#);
    let s = Survey::from_toml(&text, None).unwrap();
    let part = fresh("laz");
    let first = session(&s, &part, false, 1, 1);
    assert!(!first.complete && !first.resumable);
    assert!(part.join("points.laz.partial").exists());
    let mut o = RunOptions::new(1, &|_| {});
    o.resume = true;
    let e = run_to_dir(&s, &part, &o).unwrap_err();
    assert!(e.to_string().contains("LAZ"), "{e}");
    std::fs::remove_dir_all(&part).ok();
}

/// `--resume` trusts nothing in `summary.json` that the files do not
/// confirm: a next pulse moved forward or back (alone, or with the pulse
/// count edited to match), an edited survey.toml or a point file changed
/// at its end are refused, and once everything is put back the resume
/// gives the uninterrupted run.
#[test]
fn resume_refuses_an_edited_summary_survey_or_file() {
    let s = survey();
    let full = fresh("edited-full");
    run_to_dir(&s, &full, &RunOptions::new(1, &|_| {})).unwrap();
    let part = fresh("edited");
    let first = session(&s, &part, false, 2, 1);
    assert!(!first.complete);
    let summary_path = part.join("summary.json");
    let original = std::fs::read(&summary_path).unwrap();
    let resume = |s: &Survey| {
        let mut o = RunOptions::new(1, &|_| {});
        o.resume = true;
        run_to_dir(s, &part, &o)
    };
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut v: serde_json::Value = serde_json::from_slice(&original).unwrap();
        f(&mut v);
        std::fs::write(&summary_path, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
    };
    let pulses = first.pulses;
    for (what, delta) in [("forward", 2048i64), ("back", -2048)] {
        let moved = (pulses as i64 + delta) as u64;
        edit(&|v| v["next_pulse"]["pulse"] = moved.into());
        let e = resume(&s).unwrap_err().to_string();
        assert!(e.contains("does not follow"), "{what}: {e}");
        edit(&|v| {
            v["next_pulse"]["pulse"] = moved.into();
            v["pulses"] = moved.into();
            v["pulse_slots"] = moved.into();
        });
        let e = resume(&s).unwrap_err().to_string();
        assert!(e.contains("summary.json was edited"), "{what}: {e}");
    }
    std::fs::write(&summary_path, &original).unwrap();
    let toml_path = part.join("survey.toml");
    let toml = std::fs::read(&toml_path).unwrap();
    std::fs::write(&toml_path, [&toml[..], b"\n# edited\n"].concat()).unwrap();
    let e = resume(&s).unwrap_err().to_string();
    assert!(e.contains("survey.toml") && e.contains("changed"), "{e}");
    std::fs::write(&toml_path, &toml).unwrap();
    // The last point record's bytes changed in place (same length).
    let las = part.join("points.las.partial");
    let bytes = std::fs::read(&las).unwrap();
    let mut changed = bytes.clone();
    let n = changed.len();
    changed[n - 5] ^= 0xff;
    std::fs::write(&las, &changed).unwrap();
    let e = resume(&s).unwrap_err().to_string();
    assert!(e.contains("different"), "{e}");
    std::fs::write(&las, &bytes).unwrap();
    assert!(resume(&s).unwrap().complete);
    assert_same_run(&full, &part);
    std::fs::remove_dir_all(&full).ok();
    std::fs::remove_dir_all(&part).ok();
}
