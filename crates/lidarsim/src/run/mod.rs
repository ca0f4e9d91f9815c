//! A whole run into an output directory: points, trajectory, report and
//! summary.
//!
//! [`run_to_dir`] prepares the directory ([`outdir`]), simulates the survey
//! into its point files and writes `summary.json` ([`crate::summary`]); a run
//! stopped early leaves its point files finished but under their
//! `.partial` names with a record a resumed run checks ([`resume`]). The
//! report's sample waveforms are pulses simulated again ([`replay`]).

pub mod merge;
pub mod outdir;
pub mod part;
pub mod replay;
pub mod resume;

pub use crate::summary::Summary;
pub use resume::NextPulse;

use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use crate::files::{
    data_files, digitizer, input_files, las_settings, point_files, replayable_with_data,
    write_trajectory,
};
use crate::output::layout::{StripWriter, TileWriter};
use crate::output::{
    FileError, LasSettings, LasWriter, PlyWriter, PointSink, XyzWriter, write_atomic,
};
use crate::plan::{Plan, plan};
use crate::report::ReportSink;
use crate::sim::{PulsePosition, RunControl, RunCounts, Simulator, Timer};
use crate::summary::Measured;
use crate::survey::{Layout, Survey};
use crate::world::World;

/// A failure while writing the results.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct RunError {
    /// The file or directory concerned.
    pub path: PathBuf,
    /// The I/O error.
    pub source: io::Error,
}

/// How to run.
pub struct RunOptions<'a> {
    /// Threads (≥ 1), the calling thread among them: it writes the
    /// blocks in order and simulates blocks in between.
    pub threads: usize,
    /// Called with the number of pulses simulated so far (those of an
    /// interrupted run included when resuming).
    pub progress: &'a (dyn Fn(u64) + Sync),
    /// When set (by a Ctrl-C handler, say), the run stops at the next block
    /// of pulses, finishes every point file for what was simulated (under
    /// its `.partial` name) and writes a `summary.json` with
    /// `"complete": false` and the next pulse.
    pub stop: Option<&'a AtomicBool>,
    /// Continue the interrupted run in the output directory instead of
    /// starting afresh (the survey must be the one it ran: its
    /// `survey.toml`).
    pub resume: bool,
    /// Write into a non-empty directory that no run wrote, replacing only
    /// the files a run writes ([`outdir::prepare_fresh`]).
    pub overwrite: bool,
    /// Run even when the expected output does not fit the free space of
    /// the output's file system or the expected memory is not available
    /// ([`crate::budget`]); otherwise such a run is refused before it
    /// starts.
    pub no_space_check: bool,
    /// Stop (as if interrupted) once this many pulses were simulated in
    /// this call, rounded up to a whole block of 2048: long runs in slices.
    pub pulse_budget: Option<u64>,
    /// Called, before simulating, with each warning about the survey over
    /// its scene ([`crate::plan::warnings`]; they also go into the summary).
    pub on_warning: Option<&'a (dyn Fn(&str) + Sync)>,
}

impl<'a> RunOptions<'a> {
    /// A fresh, uninterruptible run on `threads` threads.
    pub fn new(threads: usize, progress: &'a (dyn Fn(u64) + Sync)) -> Self {
        Self {
            threads,
            progress,
            stop: None,
            resume: false,
            overwrite: false,
            no_space_check: false,
            pulse_budget: None,
            on_warning: None,
        }
    }
}

/// Name of the saved report state of an interrupted run.
pub const REPORT_STATE: &str = "report.state";

/// A [`RunError`] from an error of the simulation or a sink: the file it
/// names (see [`crate::output::file_error`]), or `dir`.
fn run_error(dir: &Path, e: io::Error) -> RunError {
    if e.get_ref().is_some_and(|i| i.is::<FileError>()) {
        let kind = e.kind();
        if let Some(Ok(fe)) = e.into_inner().map(|i| i.downcast::<FileError>()) {
            return RunError {
                path: fe.path,
                source: fe.source,
            };
        }
        return RunError {
            path: dir.to_path_buf(),
            source: io::Error::from(kind),
        };
    }
    RunError {
        path: dir.to_path_buf(),
        source: e,
    }
}

/// Builds the world of `survey` ([`World::build`]) and runs it into
/// `out_dir` ([`run_world_to_dir`]); a problem the world finds in the
/// survey is an error naming the survey file.
pub fn run_to_dir(
    survey: &Survey,
    out_dir: &Path,
    options: &RunOptions<'_>,
) -> Result<Summary, RunError> {
    let world = World::build(survey).map_err(|e| RunError {
        path: PathBuf::from(survey.file_name()),
        source: io::Error::new(io::ErrorKind::InvalidData, e.to_string()),
    })?;
    run_world_to_dir(survey, &world, out_dir, options)
}

/// Opens the sinks of the point files `names`: created afresh, or
/// continued from the lengths an interrupted run recorded; `joined`, the
/// writer of a merge's `points.las` holding its parts' points already.
fn open_sinks(
    survey: &Survey,
    world: &World,
    out_dir: &Path,
    prev: Option<&resume::Interrupted>,
    joined: Option<Box<LasWriter>>,
) -> Result<Vec<Box<dyn PointSink>>, RunError> {
    let formats = &survey.output.formats;
    let origin = survey.output.offset_m.to_array();
    let created = |path: &Path| {
        let path = path.to_path_buf();
        move |source| RunError { path, source }
    };
    let len = |name: &str| -> Result<u64, RunError> {
        prev.and_then(|p| p.file_len(name)).ok_or_else(|| RunError {
            path: out_dir.join("summary.json"),
            source: io::Error::new(
                io::ErrorKind::InvalidData,
                format!("the interrupted run recorded no length of {name}"),
            ),
        })
    };
    let continued = |e| run_error(out_dir, e);
    let mut sinks: Vec<Box<dyn PointSink>> = Vec::new();
    if let Some(dir) = crate::files::layout_dir(survey) {
        let dir = out_dir.join(dir);
        let settings: Vec<LasSettings> = [(formats.las, false), (formats.laz, true)]
            .into_iter()
            .filter(|(on, _)| *on)
            .map(|(_, compressed)| LasSettings {
                compressed,
                ..las_settings(survey, world)
            })
            .collect();
        if let Layout::Tiles(tile_m) = survey.output.layout {
            sinks.push(Box::new(
                TileWriter::create(&dir, settings, tile_m, origin).map_err(created(&dir))?,
            ));
        } else {
            for s in settings {
                sinks.push(Box::new(
                    StripWriter::create(&dir, s).map_err(created(&dir))?,
                ));
            }
        }
    }
    if formats.las && survey.output.layout == Layout::Single {
        let path = out_dir.join("points.las");
        let mut settings = las_settings(survey, world);
        if formats.las_waveform {
            settings.waveform = Some(digitizer(survey, world));
        }
        sinks.push(match (prev, joined) {
            (_, Some(joined)) => joined,
            (None, None) => Box::new(LasWriter::create(&path, settings).map_err(created(&path))?),
            (Some(_), None) => {
                let wdp = if formats.las_waveform {
                    Some(len("points.wdp")?)
                } else {
                    None
                };
                Box::new(
                    LasWriter::resume(&path, settings, len("points.las")?, wdp)
                        .map_err(continued)?,
                )
            }
        });
    }
    if formats.laz && survey.output.layout == Layout::Single {
        let path = out_dir.join("points.laz");
        // With "las-waveform" too, the LAZ points are format 9 and refer to
        // the points.wdp the LAS writer writes (same base name, same
        // packets).
        let settings = LasSettings {
            compressed: true,
            waveform: formats.las_waveform.then(|| digitizer(survey, world)),
            waveform_file_shared: true,
            ..las_settings(survey, world)
        };
        sinks.push(Box::new(
            LasWriter::create(&path, settings).map_err(created(&path))?,
        ));
    }
    if formats.ply {
        let path = out_dir.join("points.ply");
        sinks.push(match prev {
            None => Box::new(PlyWriter::create(&path, origin).map_err(created(&path))?),
            Some(_) => {
                Box::new(PlyWriter::resume(&path, len("points.ply")?, origin).map_err(continued)?)
            }
        });
    }
    if formats.xyz {
        let path = out_dir.join("points.xyz");
        sinks.push(match prev {
            None => Box::new(XyzWriter::create(&path, origin).map_err(created(&path))?),
            Some(_) => {
                Box::new(XyzWriter::resume(&path, len("points.xyz")?, origin).map_err(continued)?)
            }
        });
    }
    Ok(sinks)
}

/// Simulates `survey` over `world` and writes the point files of
/// `[output] formats` (`points.las` with `points.wdp` for full waveforms,
/// `points.laz`, `points.ply`, `points.xyz`), the trajectories,
/// `report.html` and `summary.json` into `out_dir` (see [`outdir`] for
/// which directories it accepts). Files appear under their final names
/// only when complete. When `options.stop` interrupts the run, the point
/// files are finished for the pulses simulated so far but keep their
/// `.partial` names, and `summary.json` says `"complete": false` and where
/// to go on; with `options.resume` such a run is continued, and its files
/// end up byte for byte those of an uninterrupted run (apart from the
/// timings).
pub fn run_world_to_dir(
    survey: &Survey,
    world: &World,
    out_dir: &Path,
    options: &RunOptions<'_>,
) -> Result<Summary, RunError> {
    execute(survey, world, out_dir, options, Source::Simulate)
}

/// Where a run's points come from.
pub(crate) enum Source<'a> {
    /// The simulator.
    Simulate,
    /// The point files of the parts of a split run, in order, with the
    /// counts and simulation time they recorded ([`merge::merge`]); the
    /// output directory is ready, and `points.las` already holds the
    /// points of stitched parts (`joined`).
    Parts {
        /// The parts.
        parts: &'a [merge::PartInput],
        /// The writer of `points.las`, holding every part's points.
        joined: Option<Box<LasWriter>>,
        /// A file the merge leaves even if it fails: the first part's
        /// LAS file, moved into the output to be joined to.
        keep: Option<PathBuf>,
    },
}

/// [`run_world_to_dir`] with the points from `source`.
pub(crate) fn execute(
    survey: &Survey,
    world: &World,
    out_dir: &Path,
    options: &RunOptions<'_>,
    source: Source<'_>,
) -> Result<Summary, RunError> {
    // Dropped once the scope's threads (a merge's trajectory writer) have
    // ended: a failed fresh run or merge removes what they wrote too.
    let mut written = None;
    std::thread::scope(|scope| {
        execute_in(scope, survey, world, out_dir, options, source, &mut written)
    })
}

/// The trajectory files, by name, and whether each is the observed one.
const TRAJECTORY_FILES: [(&str, bool); 3] = [
    ("trajectory.csv", false),
    ("trajectory_true.csv", false),
    ("trajectory_observed.csv", true),
];

/// Writes the trajectory flown (`trajectory.csv`, kept under its first
/// name, and `trajectory_true.csv`, formatted once for both) and the one
/// the GNSS/IMU measured into `out_dir`.
fn write_trajectories(survey: &Survey, world: &World, out_dir: &Path) -> Result<(), RunError> {
    for observed in [false, true] {
        let paths: Vec<PathBuf> = TRAJECTORY_FILES
            .iter()
            .filter(|(_, o)| *o == observed)
            .map(|(name, _)| out_dir.join(name))
            .collect();
        let refs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
        write_trajectory(survey, &world.lines, &refs, observed).map_err(|source| RunError {
            path: paths[0].clone(),
            source,
        })?;
    }
    Ok(())
}

/// [`execute`] within `scope`, where a merge writes the trajectories while
/// it joins the parts' points.
fn execute_in<'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    survey: &'scope Survey,
    world: &'scope World,
    out_dir: &'scope Path,
    options: &RunOptions<'_>,
    source: Source<'_>,
    written: &mut Option<outdir::Rollback>,
) -> Result<Summary, RunError> {
    let io_err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| RunError { path, source }
    };
    // A merge's parts, and the writer holding its stitched parts' points.
    let (parts, joined, keep) = match source {
        Source::Simulate => (None, None, None),
        Source::Parts {
            parts,
            joined,
            keep,
        } => (Some(parts), joined, keep),
    };
    let summary_path = out_dir.join("summary.json");
    let state_path = out_dir.join(REPORT_STATE);
    let names = point_files(survey);
    let (prev, report_state) = if options.resume {
        if survey.output.formats.laz {
            return Err(RunError {
                path: summary_path,
                source: io::Error::new(
                    io::ErrorKind::Unsupported,
                    "this run wrote LAZ, which cannot be continued: run the survey again",
                ),
            });
        }
        if let Some(dir) = crate::files::layout_dir(survey) {
            return Err(RunError {
                path: summary_path,
                source: io::Error::new(
                    io::ErrorKind::Unsupported,
                    format!(
                        "this run wrote {dir}, which cannot be continued: run the survey again"
                    ),
                ),
            });
        }
        let (prev, state) = resume::read(out_dir, survey, &world.lines, &names)?;
        (Some(prev), state)
    } else {
        // A merge has made the directory ready itself.
        if parts.is_none() {
            outdir::check_inputs(out_dir, &input_files(survey))?;
            outdir::prepare_fresh(out_dir, options.overwrite)?;
        }
        (None, Vec::new())
    };
    // A fresh run or merge that fails from here on leaves nothing of its
    // own behind; a resumed one keeps what lets it be resumed again.
    *written = prev.is_none().then(|| outdir::Rollback::new(out_dir, keep));

    // What the run will cost, refused before any work when it cannot fit.
    let budget = crate::budget::estimate(survey, world, options.threads);
    if !options.no_space_check {
        let total: u64 = world.lines.iter().map(|l| survey.pulses_of(l)).sum();
        let share = match &prev {
            Some(p) => 1.0 - p.counts().pulse_slots as f64 / total.max(1) as f64,
            // The points are written already.
            None if joined.is_some() => 0.0,
            None => 1.0,
        };
        let short = budget.shortfalls(
            out_dir,
            crate::budget::free_bytes(out_dir),
            crate::budget::available_memory(),
            share,
        );
        if !short.is_empty() {
            return Err(RunError {
                path: out_dir.to_path_buf(),
                source: io::Error::new(
                    io::ErrorKind::StorageFull,
                    format!(
                        "{}; run fewer pulses, or pass --no-space-check (no_space_check) to \
                         run anyway (for example when most pulses miss the scene)",
                        short.join("; ")
                    ),
                ),
            });
        }
    }

    let plan = plan(survey, world);
    let scene_warnings = crate::plan::warnings(survey, world, &plan);
    if let Some(warn) = options.on_warning {
        for w in &scene_warnings {
            warn(w);
        }
    }

    let mut sinks = open_sinks(survey, world, out_dir, prev.as_ref(), joined)?;
    let mut files: Vec<String> = names.iter().map(|n| n.to_string()).collect();
    let layout_files = files.len();
    if let Some(dir) = crate::files::layout_dir(survey) {
        files.push(format!("{dir}/"));
    }

    // The survey as run (a resumed run has it already).
    if prev.is_none() {
        write_survey(survey, out_dir)?;
    }
    files.extend(data_files(survey).into_iter().map(|d| d.path));
    files.push("survey.toml".to_string());

    // The trajectories (a resumed run has them already); a merge writes
    // them on a thread of their own while it joins the parts' points.
    let mut trajectories = None;
    if prev.is_none() {
        if parts.is_some() {
            trajectories = Some(scope.spawn(|| write_trajectories(survey, world, out_dir)));
        } else {
            write_trajectories(survey, world, out_dir)?;
        }
    }
    let mut trajectories_written = move || match trajectories.take() {
        Some(t) => t.join().expect("the trajectory writer does not panic"),
        None => Ok(()),
    };
    files.extend(TRAJECTORY_FILES.iter().map(|(name, _)| name.to_string()));

    let area = covered_area(world, &plan);
    let mut report = ReportSink::new(area, plan.point_density_per_m2)
        .through(crate::report::section_y(world, area));
    let mut before = RunCounts::default();
    let mut start = PulsePosition::default();
    let mut wall_before = 0.0;
    if let Some(prev) = &prev {
        report.restore(&report_state).map_err(io_err(&state_path))?;
        before = prev.counts();
        start = prev.start();
        wall_before = prev.wall_time_s;
    }
    let sim = Simulator::new(survey, world).with_waveforms(survey.output.formats.las_waveform);
    let timer = Timer::start();
    let mut refs: Vec<&mut (dyn PointSink + 'static)> =
        sinks.iter_mut().map(|b| b.as_mut()).collect();
    let done_before = before.pulse_slots;
    let progress = |n: u64| (options.progress)(done_before + n);
    let control = RunControl {
        start,
        stop: options.stop,
        pulse_budget: options.pulse_budget,
        only: None,
    };
    let (result, wall_parts) = match parts {
        None => {
            refs.push(&mut report);
            (
                sim.run_from(options.threads, &mut refs, &progress, &control),
                None,
            )
        }
        Some(parts) => (
            merge::gather(parts, refs, &mut report, &progress),
            Some(parts.iter().map(|p| p.wall_time_s).sum::<f64>()),
        ),
    };
    let outcome = match result {
        Ok(o) => o,
        Err(e) => {
            for s in sinks {
                s.discard();
            }
            return Err(run_error(out_dir, e));
        }
    };
    let mut counts = before;
    counts.add(&outcome.counts);
    let measured = |counts: RunCounts| Measured {
        counts,
        threads: options.threads,
        // A merge: the parts' simulation time, summed.
        wall_time_s: wall_parts.unwrap_or(wall_before + timer.seconds()),
        index_time_s: world.index_time_s,
        scene_primitives: world.scene().primitives.len(),
        estimate: budget.clone(),
    };

    if let Some(next) = outcome.stopped_at {
        // Interrupted: every point file is finished for the pulses before
        // `next` but keeps its `.partial` name; the report's state and the
        // record of the files let a resumed run go on.
        for s in sinks {
            s.suspend().map_err(|e| run_error(out_dir, e))?;
        }
        let mut state = Vec::new();
        report.save(&mut state).map_err(io_err(&state_path))?;
        write_atomic(&state_path, &state).map_err(io_err(&state_path))?;
        let next = NextPulse::of(next);
        let record = resume::record(out_dir, &names, survey.seed, next, &counts, &state)
            .map_err(|e| run_error(out_dir, e))?;
        for f in files.iter_mut().take(layout_files) {
            f.push_str(".partial");
        }
        files.push(REPORT_STATE.to_string());
        files.push("summary.json".to_string());
        let mut summary = Summary::of(
            survey,
            world,
            plan,
            &measured(counts),
            files,
            &scene_warnings,
        );
        trajectories_written()?;
        summary.complete = false;
        summary.next_pulse = Some(next);
        summary.resume = Some(record);
        let json =
            serde_json::to_vec_pretty(&summary).map_err(|e| io_err(&summary_path)(e.into()))?;
        write_atomic(&summary_path, &json).map_err(io_err(&summary_path))?;
        if let Some(w) = written.take() {
            w.done();
        }
        return Ok(summary);
    }
    for s in sinks {
        s.finish().map_err(|e| run_error(out_dir, e))?;
    }

    files.push("report.html".to_string());
    files.push("summary.json".to_string());
    let summary = Summary::of(
        survey,
        world,
        plan,
        &measured(counts),
        files,
        &scene_warnings,
    );
    // The report, with the waveforms of a pulse with the most echoes and of
    // a single-echo pulse, simulated again.
    let mut waveforms = Vec::new();
    let picks = [
        report
            .richest_pulse
            .map(|(l, k, n)| (l, k, format!("{n} echoes"))),
        report
            .single_pulse
            .map(|(l, k)| (l, k, "a single echo".to_string())),
    ];
    for (l, k, what) in picks.into_iter().flatten() {
        if let Some(line) = world.lines.get(l as usize) {
            let (plot, _) = replay::pulse(&sim, line, k);
            waveforms.push((format!("Line {} pulse {k}: {what}", l + 1), plot));
        }
    }
    let report_path = out_dir.join("report.html");
    let page = crate::report::html(survey, &world.lines, &summary, &report, &waveforms)
        .map_err(io_err(&report_path))?;
    write_atomic(&report_path, page.as_bytes()).map_err(io_err(&report_path))?;

    trajectories_written()?;
    let json = serde_json::to_vec_pretty(&summary).map_err(|e| io_err(&summary_path)(e.into()))?;
    write_atomic(&summary_path, &json).map_err(io_err(&summary_path))?;
    match std::fs::remove_file(&state_path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(io_err(&state_path)(e)),
        _ => {}
    }
    if let Some(w) = written.take() {
        w.done();
    }
    Ok(summary)
}

/// Writes the survey as run into `out_dir/survey.toml`, with the seed
/// fixed and file paths made absolute, so that `lidarsim run
/// DIR/survey.toml` repeats it and `lidarsim waveform` can simulate any
/// pulse again; scene entries given as data are written beside it, as
/// files it names. Returns the survey's text.
pub(crate) fn write_survey(survey: &Survey, out_dir: &Path) -> Result<String, RunError> {
    let named = |path: PathBuf| move |source| RunError { path, source };
    for data in data_files(survey) {
        data.write(out_dir)
            .map_err(named(out_dir.join(&data.path)))?;
    }
    let path = out_dir.join("survey.toml");
    let text = survey_text(survey).map_err(|e| named(path.clone())(io::Error::other(e)))?;
    write_atomic(&path, text.as_bytes()).map_err(named(path))?;
    Ok(text)
}

/// The text [`write_survey`] writes for `survey`.
pub(crate) fn survey_text(survey: &Survey) -> Result<String, toml::ser::Error> {
    toml::to_string(&replayable_with_data(survey))
}

/// The part of the scene the flight lines can see: each line's bounding box
/// widened by half its swath and 10 m, within the scene's bounds (x, y).
pub(crate) fn covered_area(world: &World, plan: &Plan) -> crate::geometry::Aabb {
    use crate::geometry::{Aabb, DVec3};
    let scene = world.scene_bounds();
    let mut area = Aabb::EMPTY;
    for (line, lp) in world.lines.iter().zip(&plan.lines) {
        let m = DVec3::new(
            lp.swath_width_m / 2.0 + 10.0,
            lp.swath_width_m / 2.0 + 10.0,
            0.0,
        );
        area = area
            .union_point(line.start_m.min(line.end_m) - m)
            .union_point(line.start_m.max(line.end_m) + m);
    }
    if scene.is_empty() || area.is_empty() {
        return if scene.is_empty() { area } else { scene };
    }
    let min = area.min.max(scene.min);
    let max = area.max.min(scene.max);
    if min.x < max.x && min.y < max.y {
        Aabb { min, max }
    } else {
        scene
    }
}
