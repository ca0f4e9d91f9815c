//! A whole run into an output directory: points, trajectory and summary.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::accel::{Bvh, RayCaster};
use crate::navigation::observed_pose;
use crate::output::{AtomicFile, LasSettings, LasWriter, PointSink, XyzWriter, write_atomic};
use crate::plan::{Plan, plan};
use crate::report::ReportSink;
use crate::sim::{RunCounts, Simulator, Timer};
use crate::survey::Survey;

/// A failure while writing the results.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {source}")]
pub struct RunError {
    /// The file or directory concerned.
    pub path: PathBuf,
    /// The I/O error.
    pub source: io::Error,
}

/// How to run.
pub struct RunOptions<'a> {
    /// Worker threads (≥ 1).
    pub threads: usize,
    /// Called with the number of pulses simulated so far.
    pub progress: &'a (dyn Fn(u64) + Sync),
}

/// Contents of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Version of the simulator.
    pub lidarsim_version: &'static str,
    /// True when every pulse was simulated and every file written.
    pub complete: bool,
    /// Seed of the random streams.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// Pulses emitted.
    pub pulses: u64,
    /// Points written.
    pub points: u64,
    /// Pulses with at least one echo.
    pub pulses_with_echo: u64,
    /// Points by return number (first, second, …).
    pub points_by_return: Vec<u64>,
    /// Sub-rays per pulse.
    pub subrays_per_pulse: usize,
    /// Laser wavelength, nm (for the record: reflectances are given at it).
    pub wavelength_nm: f64,
    /// Wall-clock time of the simulation (scene indexing excluded), s.
    pub wall_time_s: f64,
    /// Time to build the acceleration structure, s.
    pub index_time_s: f64,
    /// Simulated pulses per wall-clock second.
    pub pulses_per_second: f64,
    /// Expected swath width (pulse-weighted mean over lines), m.
    pub swath_width_m: f64,
    /// Expected point density of one line, per m².
    pub point_density_per_m2: f64,
    /// Expected nadir footprint diameter, m.
    pub footprint_diameter_m: f64,
    /// What the GPS time of the points means.
    pub gps_time: &'static str,
    /// LAS intensity per unit of echo energy amplitude.
    pub intensity_gain: f64,
    /// Reference range of Eq. 2, m.
    pub reference_range_m: f64,
    /// Primitives in the scene.
    pub scene_primitives: usize,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
    /// Warnings about the survey (see `lidarsim check`).
    pub warnings: Vec<String>,
    /// Trees placed by each `[[forest]]` entry.
    pub forest_trees: Vec<usize>,
    /// The expected figures per flight line.
    pub plan: Plan,
}

/// Simulates `survey` and writes `points.las` / `points.xyz`,
/// `trajectory.csv` and `summary.json` into `out_dir` (created if needed).
/// Files appear under their final names only when complete.
pub fn run_to_dir(
    survey: &Survey,
    out_dir: &Path,
    options: &RunOptions<'_>,
) -> Result<Summary, RunError> {
    let io_err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| RunError { path, source }
    };
    std::fs::create_dir_all(out_dir).map_err(io_err(out_dir))?;
    // A summary from an earlier run must not describe this one.
    let summary_path = out_dir.join("summary.json");
    match std::fs::remove_file(&summary_path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(io_err(&summary_path)(e)),
        _ => {}
    }

    let index_timer = Timer::start();
    let bvh = Bvh::build(survey.scene.clone());
    let index_time_s = index_timer.seconds();
    let plan = plan(survey, &bvh);

    let mut files = Vec::new();
    let mut sinks: Vec<Box<dyn PointSink>> = Vec::new();
    if survey.output.formats.las {
        let path = out_dir.join("points.las");
        sinks.push(Box::new(
            LasWriter::create(&path, las_settings(survey, &bvh)).map_err(io_err(&path))?,
        ));
        files.push("points.las".to_string());
    }
    if survey.output.formats.xyz {
        let path = out_dir.join("points.xyz");
        sinks.push(Box::new(XyzWriter::create(&path).map_err(io_err(&path))?));
        files.push("points.xyz".to_string());
    }

    // The survey as run, with the seed fixed and file paths made absolute,
    // so `lidarsim run DIR/survey.toml` repeats it and `lidarsim waveform`
    // can simulate any pulse again.
    let survey_path = out_dir.join("survey.toml");
    let text = toml::to_string(&replayable(survey))
        .map_err(|e| io_err(&survey_path)(io::Error::other(e)))?;
    write_atomic(&survey_path, text.as_bytes()).map_err(io_err(&survey_path))?;
    files.push("survey.toml".to_string());

    // The trajectory flown (trajectory.csv, kept under its first name, and
    // trajectory_true.csv) and the one the GNSS/IMU measured.
    for (name, observed) in [
        ("trajectory.csv", false),
        ("trajectory_true.csv", false),
        ("trajectory_observed.csv", true),
    ] {
        let path = out_dir.join(name);
        write_trajectory(survey, &path, observed).map_err(io_err(&path))?;
        files.push(name.to_string());
    }

    let mut report = ReportSink::new(covered_area(survey, &bvh, &plan), plan.point_density_per_m2);
    let sim = Simulator::new(survey, &bvh);
    let timer = Timer::start();
    let mut refs: Vec<&mut (dyn PointSink + 'static)> =
        sinks.iter_mut().map(|b| b.as_mut()).collect();
    refs.push(&mut report);
    let result = sim.run(options.threads, &mut refs, options.progress);
    drop(refs);
    let counts = match result {
        Ok(c) => c,
        Err(e) => {
            for s in sinks {
                s.discard();
            }
            return Err(io_err(out_dir)(e));
        }
    };
    for s in sinks {
        s.finish().map_err(io_err(out_dir))?;
    }
    let wall_time_s = timer.seconds();
    files.push("report.html".to_string());
    files.push("summary.json".to_string());
    let summary = summarize(
        survey,
        &counts,
        options.threads,
        wall_time_s,
        index_time_s,
        plan,
        files,
        bvh.scene().primitives.len(),
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
        if let Some(line) = survey.lines.get(l as usize) {
            let (plot, _) = crate::render::WaveformPlot::of_pulse(&sim, line, k);
            waveforms.push((format!("Line {} pulse {k}: {what}", l + 1), plot));
        }
    }
    let report_path = out_dir.join("report.html");
    let page =
        crate::report::html(survey, &summary, &report, &waveforms).map_err(io_err(&report_path))?;
    write_atomic(&report_path, page.as_bytes()).map_err(io_err(&report_path))?;

    let json = serde_json::to_vec_pretty(&summary).map_err(|e| io_err(&summary_path)(e.into()))?;
    write_atomic(&summary_path, &json).map_err(io_err(&summary_path))?;
    Ok(summary)
}

#[allow(clippy::too_many_arguments)]
fn summarize(
    survey: &Survey,
    counts: &RunCounts,
    threads: usize,
    wall_time_s: f64,
    index_time_s: f64,
    plan: Plan,
    files: Vec<String>,
    scene_primitives: usize,
) -> Summary {
    let last = counts
        .points_by_return
        .iter()
        .rposition(|&n| n > 0)
        .map_or(0, |i| i + 1);
    Summary {
        lidarsim_version: env!("CARGO_PKG_VERSION"),
        complete: true,
        seed: survey.seed,
        threads,
        pulses: counts.pulses,
        points: counts.points,
        pulses_with_echo: counts.pulses_with_echo,
        points_by_return: counts.points_by_return[..last].to_vec(),
        subrays_per_pulse: survey.scanner.subrays,
        wavelength_nm: survey.scanner.wavelength_nm,
        wall_time_s,
        index_time_s,
        pulses_per_second: if wall_time_s > 0.0 {
            counts.pulses as f64 / wall_time_s
        } else {
            0.0
        },
        swath_width_m: plan.swath_width_m,
        point_density_per_m2: plan.point_density_per_m2,
        footprint_diameter_m: plan.footprint_diameter_m,
        gps_time: if survey.output.gps_start_time_s.is_some() {
            "adjusted standard GPS time (GPS seconds minus 1e9), flight start at output.gps_start_time_s"
        } else {
            "seconds since the start of the flight"
        },
        intensity_gain: survey.intensity_gain,
        reference_range_m: survey.receiver.reference_range_m,
        scene_primitives,
        files,
        warnings: survey.warnings.clone(),
        forest_trees: survey.forest_trees.clone(),
        plan,
    }
}

/// The part of the scene the flight lines can see: each line's bounding box
/// widened by half its swath and 10 m, within the scene's bounds (x, y).
fn covered_area(survey: &Survey, caster: &dyn RayCaster, plan: &Plan) -> crate::geometry::Aabb {
    use crate::geometry::{Aabb, DVec3};
    let scene = caster.scene().bounds();
    let mut area = Aabb::EMPTY;
    for (line, lp) in survey.lines.iter().zip(&plan.lines) {
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

/// The raw survey with its seed fixed and relative file paths (meshes,
/// terrain rasters, point clouds, trajectory file) resolved against the
/// survey's directory.
pub fn replayable(survey: &Survey) -> crate::survey::RawSurvey {
    let mut raw = survey.raw.clone();
    raw.seed = Some(survey.seed);
    let base = survey
        .source
        .as_ref()
        .and_then(|p| p.parent())
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let resolve = |f: &mut String| {
        let p = base.join(&*f);
        if let Ok(abs) = std::path::absolute(&p) {
            *f = abs.display().to_string();
        }
    };
    let files = raw
        .meshes
        .iter_mut()
        .map(|m| &mut m.file)
        .chain(raw.terrains.iter_mut().map(|t| &mut t.file))
        .chain(raw.point_clouds.iter_mut().map(|c| &mut c.file));
    for f in files.flatten() {
        resolve(f);
    }
    if let Some(f) = raw.platform.trajectory_file.as_mut() {
        resolve(f);
    }
    raw
}

/// LAS header settings: offset at the scene centre rounded to 100 m (so
/// that coordinates stay small integers), the survey's scale, the creation
/// date from `SOURCE_DATE_EPOCH` if set (reproducible files) or today.
pub fn las_settings(survey: &Survey, caster: &dyn RayCaster) -> LasSettings {
    let b = caster.scene().bounds();
    let c = if b.is_empty() {
        crate::geometry::DVec3::ZERO
    } else {
        b.center()
    };
    let round = |v: f64| (v / 100.0).round() * 100.0;
    let now = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs() as i64)
        });
    LasSettings {
        scale_m: survey.output.las_scale_m,
        offset_m: [round(c.x), round(c.y), 0.0],
        adjusted_standard_gps_time: survey.output.gps_start_time_s.is_some(),
        file_source_id: if survey.lines.len() == 1 {
            (survey.lines[0].index + 1) as u16
        } else {
            0
        },
        creation_day_year: crate::output::day_of_year(now),
        generating_software: format!("lidarsim {}", env!("CARGO_PKG_VERSION")),
        error_extra_bytes: !survey.navigation.is_zero(),
    }
}

/// Writes the trajectory, one row per `trajectory_interval_s` of each
/// flight line: time (in the points' time base), position, attitude in
/// degrees, line number. `observed` selects the trajectory the GNSS/IMU
/// measured (biases and correlated errors; the per-pulse white noise is not
/// in it) instead of the one flown.
pub fn write_trajectory(survey: &Survey, path: &Path, observed: bool) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    let offset = survey.output.gps_start_time_s.unwrap_or(0.0);
    let dt = survey.output.trajectory_interval_s;
    let w = f.writer();
    writeln!(w, "gps_time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,line")?;
    for line in &survey.lines {
        let n = (line.duration_s() / dt).floor() as u64;
        for j in 0..=n {
            let t = j as f64 * dt;
            let truth = line.pose_at(t);
            let p = if observed {
                observed_pose(&truth, &survey.navigation, &line.nav_errors, t, None)
            } else {
                truth
            };
            writeln!(
                w,
                "{:.6},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{}",
                offset + line.start_time_s + t,
                p.position_m.x,
                p.position_m.y,
                p.position_m.z,
                p.attitude.roll_rad.to_degrees(),
                p.attitude.pitch_rad.to_degrees(),
                p.attitude.yaw_rad.to_degrees(),
                line.index
            )?;
        }
    }
    f.commit()
}
