//! `lidarsim`: command-line front end of the airborne LiDAR simulator.
//!
//! A thin layer over the `lidarsim` library: it parses arguments, loads and
//! checks the survey, runs it with a progress bar and reports errors with a
//! non-zero exit status (2 for a bad survey, 1 for a failed run).

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use lidarsim::Survey;
use lidarsim::plan::plan;
use lidarsim::run::{RunOptions, Summary, run_world_to_dir};
use lidarsim::world::{World, load};

mod cpu;

/// Prints a line to standard error, ignoring a closed pipe (`2>&1 | head`).
macro_rules! note {
    ($($arg:tt)*) => {{
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

/// Prints a line to standard output, ignoring a closed pipe (`| head`).
macro_rules! say {
    ($($arg:tt)*) => {{
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

#[derive(Parser)]
#[command(
    name = "lidarsim",
    version,
    about = "Airborne LiDAR simulator: full-waveform pulses over a 3D scene to a LAS point cloud"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Fly the built-in survey over the built-in town block (no input files).
    Demo {
        /// Output directory.
        #[arg(short, long, default_value = "demo-out")]
        output: PathBuf,
        /// Threads, the one writing the output among them (default: all
        /// cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Seed of all random streams (overrides the demo's; 0 to
        /// 9223372036854775807, the integers a TOML file can hold).
        #[arg(long, value_parser = seed_parser())]
        seed: Option<u64>,
        /// Write into a non-empty directory no run wrote, replacing only
        /// the files a run writes there.
        #[arg(long)]
        overwrite: bool,
        /// Run even if the expected output exceeds the free disk space or
        /// the expected memory is not available.
        #[arg(long)]
        no_space_check: bool,
        /// Also write the demo's survey as a TOML file, to start your own.
        #[arg(long, value_name = "FILE")]
        export_survey: Option<PathBuf>,
    },
    /// Simulate a survey file (Ctrl-C stops at the next block of pulses
    /// with valid files; `--resume DIR` continues such a run).
    Run {
        /// The survey (TOML).
        #[arg(required_unless_present = "resume")]
        survey: Option<PathBuf>,
        /// Output directory.
        #[arg(short, long, default_value = "out", conflicts_with = "resume")]
        output: PathBuf,
        /// Threads, the one writing the output among them (default: all
        /// cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Seed of all random streams (overrides the file's; 0 to
        /// 9223372036854775807, the integers a TOML file can hold).
        #[arg(long, conflicts_with = "resume", value_parser = seed_parser())]
        seed: Option<u64>,
        /// Write into a non-empty directory no run wrote, replacing only
        /// the files a run writes there (points.*, survey.toml,
        /// trajectory*.csv, summary.json, report.html) and keeping the rest.
        #[arg(long, conflicts_with = "resume")]
        overwrite: bool,
        /// Run even if the expected output exceeds the free disk space of
        /// the output directory or the expected memory is not available
        /// (see `lidarsim check`).
        #[arg(long)]
        no_space_check: bool,
        /// Continue the interrupted run in DIR (with its survey.toml) up to
        /// the files an uninterrupted run would have written.
        #[arg(long, value_name = "DIR", conflicts_with = "survey")]
        resume: Option<PathBuf>,
    },
    /// Validate a survey file and print what it will give, without simulating.
    Check {
        /// The survey (TOML).
        survey: PathBuf,
        /// Output directory whose free space the expected files are
        /// compared with.
        #[arg(short, long, default_value = "out")]
        output: PathBuf,
    },
    /// Plot the full waveform of one pulse of a run (simulated again from its survey.toml).
    /// Name the pulse by --line and --pulse, by a point's --gps-time, or by a
    /// place with --near.
    Waveform {
        /// Output directory of a run (it holds survey.toml, and points.las or
        /// points.laz for --near).
        dir: PathBuf,
        /// Pulse number within the flight line given by --line, from 0 (emitted
        /// at the line's start time + N / PRF). Point files have no pulse
        /// column: to find a point's pulse use --gps-time or --near.
        #[arg(long, conflicts_with_all = ["gps_time", "near"])]
        pulse: Option<u64>,
        /// Flight line number for --pulse, 1 for the first: the point source ID
        /// of points.las (point_source_id in points.xyz).
        #[arg(long, default_value_t = 1)]
        line: u32,
        /// Find the pulse by the GPS time of one of its points: the gps_time of
        /// any point in points.las, points.xyz or points.ply (it includes the
        /// survey's output.gps_start_time_s).
        #[arg(long, conflicts_with = "near")]
        gps_time: Option<f64>,
        /// Find the pulse of the point of DIR/points.las (or points.laz) nearest
        /// to X,Y or X,Y,Z, in the coordinates of that file (those of the
        /// survey plus output.offset_m); horizontal distance without Z.
        #[arg(long, value_name = "X,Y[,Z]", allow_hyphen_values = true)]
        near: Option<String>,
        /// Output PNG.
        #[arg(short, long, default_value = "waveform.png")]
        output: PathBuf,
    },
    /// Render a LAS or LAZ file (ours or anyone's) as a top view or a cross-section PNG.
    Render {
        /// The point cloud (LAS or LAZ).
        cloud: PathBuf,
        /// Output PNG.
        #[arg(short, long, default_value = "top.png")]
        output: PathBuf,
        /// Colours: height, intensity, class, return or strip.
        #[arg(long, default_value = "height")]
        color: String,
        /// Pixel size, m (default: from the point density).
        #[arg(long)]
        resolution: Option<f64>,
        /// Cross-section instead of top view: x0,y0,x1,y1,width (m).
        #[arg(long, value_name = "X0,Y0,X1,Y1,WIDTH", allow_hyphen_values = true)]
        profile: Option<String>,
    },
    /// Measure speed on the benchmark scenes (flat, 1 M-triangle terrain).
    Bench {
        /// Write the scenes (OBJ) and surveys (TOML) into DIR and stop.
        #[arg(long, value_name = "DIR")]
        export: Option<PathBuf>,
        /// Scenes to measure: flat, terrain (default both).
        #[arg(long, value_delimiter = ',')]
        scene: Vec<String>,
        /// Thread counts to run, one run each in this order (default 1,2;
        /// 1,2,1,2,… also prints the median speed-up over the pairs).
        #[arg(long, value_delimiter = ',', default_values_t = [1usize, 2])]
        threads: Vec<usize>,
        /// Working directory for the generated files (default: a temporary one).
        #[arg(long, value_name = "DIR")]
        work_dir: Option<PathBuf>,
        /// Pulses of the flight line (default: the benchmark's 500 000;
        /// fewer for profiling).
        #[arg(long, default_value_t = lidarsim_bench::PULSES)]
        pulses: u64,
    },
}

/// Seeds a survey file can hold: TOML integers are signed 64-bit.
fn seed_parser() -> clap::builder::RangedU64ValueParser<u64> {
    clap::value_parser!(u64).range(..=i64::MAX as u64)
}

/// Set by the first Ctrl-C (SIGINT) or SIGTERM: the run stops at the next
/// block of pulses and finishes its files.
static STOP: AtomicBool = AtomicBool::new(false);

/// Exit status of a run stopped by a signal (128 + SIGINT).
const INTERRUPTED: u8 = 130;

fn main() -> ExitCode {
    // Before anything built for x86-64-v3 runs (see cpu.rs).
    if let Some(feature) = cpu::missing() {
        cpu::refuse(feature);
        return ExitCode::from(1);
    }
    let cli = Cli::parse();
    // A second signal while the files are being finished ends the program
    // at once (leaving only `.partial` files behind).
    let handler = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            note!("\nstopped without finishing the files");
            std::process::exit(i32::from(INTERRUPTED));
        }
        note!("\ninterrupted: finishing the files for the pulses simulated so far…");
    });
    if let Err(e) = handler {
        note!("warning: Ctrl-C will not stop runs cleanly: {e}");
    }
    match cli.command {
        Command::Demo {
            output,
            threads,
            seed,
            export_survey,
            overwrite,
            no_space_check,
        } => {
            let mut raw = lidarsim::demo::demo_survey();
            if seed.is_some() {
                raw.seed = seed;
            }
            if let Some(path) = export_survey {
                let text = match toml::to_string(&raw) {
                    Ok(t) => t,
                    Err(e) => return fail(1, &format!("cannot serialise the demo survey: {e}")),
                };
                if let Err(e) = lidarsim::output::write_atomic(&path, text.as_bytes()) {
                    return fail(1, &format!("{}: {e}", path.display()));
                }
                note!("wrote the demo survey to {}", path.display());
            }
            let survey = match Survey::from_raw(raw, None) {
                Ok(s) => s,
                Err(problems) => {
                    let list: Vec<String> = problems
                        .iter()
                        .map(|(k, m)| format!("<demo>: key `{k}`: {m}"))
                        .collect();
                    return fail(1, &list.join("\n"));
                }
            };
            let world = match World::build(&survey) {
                Ok(w) => w,
                Err(e) => return fail_survey(&e),
            };
            let how = How {
                resume: false,
                overwrite,
                no_space_check,
            };
            simulate(&survey, &world, &output, threads, how)
        }
        Command::Run {
            survey,
            output,
            threads,
            seed,
            resume,
            overwrite,
            no_space_check,
        } => {
            let (path, output, resuming) = match (resume, survey) {
                (Some(dir), _) => (dir.join("survey.toml"), dir, true),
                (None, Some(survey)) => (survey, output, false),
                (None, None) => return fail(2, "give a survey file or --resume DIR"),
            };
            if resuming && !path.exists() {
                return fail(
                    2,
                    &format!(
                        "{}: no such file: {} does not hold a run to resume",
                        path.display(),
                        output.display()
                    ),
                );
            }
            let (survey, world) = match load(&path, seed) {
                Ok(loaded) => loaded,
                Err(e) => return fail_survey(&e),
            };
            let how = How {
                resume: resuming,
                overwrite,
                no_space_check,
            };
            simulate(&survey, &world, &output, threads, how)
        }
        Command::Render {
            cloud,
            output,
            color,
            resolution,
            profile,
        } => match render(&cloud, &output, &color, resolution, profile.as_deref()) {
            Ok(()) => {
                say!("wrote {}", output.display());
                ExitCode::SUCCESS
            }
            Err((code, msg)) => fail(code, &msg),
        },
        Command::Waveform {
            dir,
            pulse,
            line,
            gps_time,
            near,
            output,
        } => match waveform(&dir, pulse, line, gps_time, near.as_deref(), &output) {
            Ok(()) => ExitCode::SUCCESS,
            Err((code, msg)) => fail(code, &msg),
        },
        Command::Bench {
            export,
            scene,
            threads,
            work_dir,
            pulses,
        } => match bench(export, &scene, &threads, work_dir, pulses) {
            Ok(()) => ExitCode::SUCCESS,
            Err(msg) => fail(1, &msg),
        },
        Command::Check { survey, output } => match load(&survey, None) {
            Ok((s, w)) => {
                warn(&s, &w);
                check(&s, &w, &output);
                ExitCode::SUCCESS
            }
            Err(e) => fail_survey(&e),
        },
    }
}

/// `lidarsim bench`: export the scenes, or measure them and print one
/// `key value` line per figure.
fn bench(
    export: Option<PathBuf>,
    scenes: &[String],
    threads: &[usize],
    work_dir: Option<PathBuf>,
    pulses: u64,
) -> Result<(), String> {
    use lidarsim_bench::{BenchScene, export as export_scene, measure};
    let scenes: Vec<BenchScene> = if scenes.is_empty() {
        BenchScene::ALL.to_vec()
    } else {
        scenes
            .iter()
            .map(|n| {
                BenchScene::from_name(n)
                    .ok_or_else(|| format!("unknown bench scene '{n}'; expected flat or terrain"))
            })
            .collect::<Result<_, _>>()?
    };
    if let Some(dir) = export {
        for s in &scenes {
            let path =
                export_scene(*s, &dir, pulses).map_err(|e| format!("{}: {e}", dir.display()))?;
            println!("exported {}", path.display());
        }
        return Ok(());
    }
    let (dir, temporary) = match work_dir {
        Some(d) => (d, false),
        None => (
            std::env::temp_dir().join(format!("lidarsim-bench-{}", std::process::id())),
            true,
        ),
    };
    let result = (|| {
        for s in &scenes {
            let survey =
                export_scene(*s, &dir, pulses).map_err(|e| format!("{}: {e}", dir.display()))?;
            let f = measure(*s, &survey, &dir, threads)?;
            for line in figure_lines(&f) {
                println!("{line}");
            }
        }
        Ok(())
    })();
    if temporary {
        let _ = std::fs::remove_dir_all(&dir);
    }
    result
}

/// The `scene key value` lines `lidarsim bench` prints for one scene's
/// figures: load times, per-run rates, CPU figures and output hashes, the
/// speed-up of the second run over the first (measured, and at equal CPU
/// per pulse), whether every run wrote the same LAS, and the median
/// speed-up over repeated pairs of thread counts.
fn figure_lines(f: &lidarsim_bench::SceneFigures) -> Vec<String> {
    let name = f.scene.name();
    let mut out = vec![
        format!("{name} primitives {}", f.primitives),
        format!("{name} load_s {:.3}", f.parse_s + f.build_s),
        format!("{name} parse_s {:.3}", f.parse_s),
        format!("{name} build_s {:.3}", f.build_s),
    ];
    for r in &f.runs {
        let t = r.threads;
        out.push(format!("{name} threads {t} pulses {}", r.pulses));
        out.push(format!("{name} threads {t} seconds {:.3}", r.seconds));
        out.push(format!(
            "{name} threads {t} pulses_per_s {:.0}",
            r.pulses_per_s()
        ));
        out.push(format!(
            "{name} threads {t} rays_per_s {:.0}",
            r.rays as f64 / r.seconds
        ));
        out.push(format!(
            "{name} threads {t} points_per_s {:.0}",
            r.points as f64 / r.seconds
        ));
        out.push(format!("{name} threads {t} las_fnv1a {:016x}", r.las_hash));
        if let (Some(cpu), Some(busy), Some(write)) = (r.cpu_s, r.cores_busy(), r.write_cpu_s) {
            out.push(format!("{name} threads {t} cpu_s {cpu:.3}"));
            out.push(format!("{name} threads {t} cores_busy {busy:.2}"));
            out.push(format!("{name} threads {t} write_cpu_s {write:.3}"));
        }
    }
    if let [a, b, ..] = &f.runs[..] {
        let (ta, tb) = (a.threads, b.threads);
        out.push(format!(
            "{name} scaling_{ta}_to_{tb} {:.2}",
            b.pulses_per_s() / a.pulses_per_s()
        ));
        if let Some(x) = b.speedup_at_equal_cpu(a) {
            out.push(format!("{name} scaling_{ta}_to_{tb}_at_equal_cpu {x:.2}"));
        }
        out.push(format!(
            "{name} identical_output {}",
            f.runs.iter().all(|r| r.las_hash == a.las_hash)
        ));
        let pairs = lidarsim_bench::pair_speedups(&f.runs);
        if pairs.len() > 1
            && let Some(m) = lidarsim_bench::median(&pairs)
        {
            out.push(format!("{name} scaling_pairs {}", pairs.len()));
            out.push(format!("{name} scaling_{ta}_to_{tb}_median {m:.2}"));
        }
    }
    if let Some(bytes) = f.peak_rss_bytes {
        out.push(format!(
            "{name} peak_rss_mb {:.1}",
            bytes as f64 / 1048576.0
        ));
    }
    out
}

fn fail(code: u8, message: &str) -> ExitCode {
    note!("error: {message}");
    ExitCode::from(code)
}

/// Reports every problem of a survey file, exit status 2.
fn fail_survey(e: &lidarsim::survey::SurveyError) -> ExitCode {
    for (i, d) in e.diagnostics.iter().enumerate() {
        if i > 0 {
            note!("");
        }
        note!("error: {d}");
    }
    if e.diagnostics.len() > 1 {
        note!("\n{} problems found", e.diagnostics.len());
    }
    ExitCode::from(2)
}

/// The survey's file name for messages (`<demo>` for the built-in one).
fn source_name(survey: &Survey) -> String {
    survey
        .source
        .as_ref()
        .map_or_else(|| "<demo>".to_string(), |p| p.display().to_string())
}

/// Prints the survey's and its world's warnings to standard error.
fn warn(survey: &Survey, world: &World) {
    let file = source_name(survey);
    for w in &world.warnings_with(survey) {
        note!("warning: {file}: {w}");
    }
}

/// Test hook: `LIDARSIM_TEST_HOLD_AT_PULSE=N` makes a run wait, once N
/// pulses are written, until it is stopped (Ctrl-C or SIGTERM), after
/// printing "holding after K pulses" to standard error: tests interrupt a
/// run at a known point instead of after a guessed time.
fn hold_at_pulse() -> Option<u64> {
    std::env::var("LIDARSIM_TEST_HOLD_AT_PULSE")
        .ok()?
        .parse()
        .ok()
}

/// Waits for the stop flag (see [`hold_at_pulse`]).
fn hold_until_stopped(done: u64) {
    static ANNOUNCED: AtomicBool = AtomicBool::new(false);
    if !ANNOUNCED.swap(true, Ordering::SeqCst) {
        note!("holding after {done} pulses");
    }
    while !STOP.load(Ordering::SeqCst) {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

/// How `simulate` treats the output directory and the machine's limits.
struct How {
    /// Continue the interrupted run in the directory.
    resume: bool,
    /// Write into a foreign non-empty directory.
    overwrite: bool,
    /// Run even when the estimate exceeds disk or memory.
    no_space_check: bool,
}

fn simulate(
    survey: &Survey,
    world: &World,
    output: &Path,
    threads: Option<usize>,
    how: How,
) -> ExitCode {
    let How {
        resume,
        overwrite,
        no_space_check,
    } = how;
    warn(survey, world);
    if survey.output.formats.laz && !resume {
        note!(
            "note: this run writes LAZ, which cannot be continued: if it is stopped, run the \
             survey again"
        );
    }
    let threads = match threads {
        Some(0) => return fail(2, "--threads must be at least 1"),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let total: u64 = world.lines.iter().map(|l| survey.pulses_of(l)).sum();
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new(total);
        if let Ok(style) = ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} pulses ({per_sec}, eta {eta})",
        ) {
            b.set_style(style);
        }
        b
    } else {
        ProgressBar::hidden()
    };
    let hold = hold_at_pulse();
    let progress = |done: u64| {
        bar.set_position(done);
        if hold.is_some_and(|h| done >= h) {
            hold_until_stopped(done);
        }
    };
    let name = source_name(survey);
    let result = run_world_to_dir(
        survey,
        world,
        output,
        &RunOptions {
            threads,
            progress: &progress,
            stop: Some(&STOP),
            resume,
            overwrite,
            no_space_check,
            pulse_budget: None,
            on_warning: Some(&|w: &str| {
                bar.suspend(|| note!("warning: {name}: {w}"));
            }),
        },
    );
    bar.finish_and_clear();
    match result {
        Ok(summary) if !summary.complete => {
            let next = summary.next_pulse.unwrap_or_default();
            note!(
                "interrupted after {} pulses: the .partial files in {} hold them and are valid; \
                 summary.json says \"complete\": false, next pulse {} of line {}",
                summary.pulses,
                output.display(),
                next.pulse,
                next.line
            );
            if summary.resumable {
                note!("continue with: lidarsim run --resume {}", output.display());
            } else {
                note!("this run wrote LAZ, which cannot be continued: run the survey again");
            }
            ExitCode::from(INTERRUPTED)
        }
        Ok(summary) => {
            report(&summary, output);
            ExitCode::SUCCESS
        }
        Err(e) => fail(1, &e.to_string()),
    }
}

/// The point of a run's point file nearest to a place.
struct Nearest {
    /// Its coordinates, as in the file.
    at: [f64; 3],
    /// Its distance from the place, m.
    distance_m: f64,
    /// Its point source ID (flight line number, 1 for the first).
    source: u16,
    /// Its GPS time, s.
    gps_time_s: f64,
}

/// The point of a run's `points.las` (or `points.laz`) nearest to `near`
/// ("X,Y" or "X,Y,Z", horizontal distance without Z).
fn nearest_point(dir: &Path, near: &str) -> Result<Nearest, (u8, String)> {
    let q: Vec<f64> = near
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()
        .filter(|v: &Vec<f64>| (2..=3).contains(&v.len()) && v.iter().all(|x| x.is_finite()))
        .ok_or_else(|| (2, format!("--near {near}: expected X,Y or X,Y,Z in metres")))?;
    let cloud = ["points.las", "points.laz"]
        .iter()
        .map(|f| dir.join(f))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            (
                2,
                format!(
                    "--near: {} holds neither points.las nor points.laz (the run's [output] \
                     formats need las or laz)",
                    dir.display()
                ),
            )
        })?;
    let bad = |e: las::Error| {
        (
            1,
            format!(
                "{}: {}",
                cloud.display(),
                lidarsim::io::cloud::describe_las_error(&e)
            ),
        )
    };
    let mut reader = lidarsim::io::cloud::open_las(&cloud)
        .map_err(|why| (1, format!("{}: {why}", cloud.display())))?;
    let mut best: Option<([f64; 3], f64, u16, Option<f64>)> = None;
    loop {
        let batch = reader.read_points(1 << 16).map_err(bad)?;
        if batch.is_empty() {
            break;
        }
        for p in batch.points() {
            let p = p.map_err(bad)?;
            let (dx, dy) = (p.x - q[0], p.y - q[1]);
            let dz = q.get(2).map_or(0.0, |z| p.z - z);
            let d2 = dx * dx + dy * dy + dz * dz;
            if d2.is_finite() && best.is_none_or(|b| d2 < b.1) {
                best = Some(([p.x, p.y, p.z], d2, p.point_source_id, p.gps_time));
            }
        }
    }
    let (at, d2, source, gps) =
        best.ok_or_else(|| (2, format!("--near: {} holds no point", cloud.display())))?;
    let gps = gps.ok_or_else(|| {
        (
            2,
            format!(
                "--near: the points of {} carry no GPS time",
                cloud.display()
            ),
        )
    })?;
    Ok(Nearest {
        at,
        distance_m: d2.sqrt(),
        source,
        gps_time_s: gps,
    })
}

/// Simulates one pulse of a run again and plots its waveform.
fn waveform(
    dir: &Path,
    pulse: Option<u64>,
    line: u32,
    gps_time: Option<f64>,
    near: Option<&str>,
    output: &Path,
) -> Result<(), (u8, String)> {
    let survey_path = dir.join("survey.toml");
    let (survey, world) = load(&survey_path, None).map_err(|e| (2, e.to_string()))?;
    let offset = survey.output.gps_start_time_s.unwrap_or(0.0);
    let prf = survey.scanner.prf_hz;
    // The line and pulse: given, or found from a point's GPS time (and,
    // for --near, its point source ID).
    let (line_ref, k) = match (near, gps_time) {
        (Some(near), _) => {
            let Nearest {
                at: [x, y, z],
                distance_m: d,
                source,
                gps_time_s: gps,
            } = nearest_point(dir, near)?;
            let l = world
                .lines
                .get(usize::from(source).wrapping_sub(1))
                .ok_or_else(|| {
                    (
                        2,
                        format!(
                            "--near: the nearest point has point source ID {source}, but the \
                             survey has flight lines 1 to {}",
                            world.lines.len()
                        ),
                    )
                })?;
            let k = ((gps - offset - l.start_time_s) * prf).round().max(0.0) as u64;
            say!(
                "nearest point to {near}: ({x:.3}, {y:.3}, {z:.3}), {d:.3} m away, \
                 line {source} (point source ID), GPS time {gps:.6} s: pulse {k}"
            );
            (l, k)
        }
        (None, Some(t)) => {
            let t = t - offset;
            let l = world
                .lines
                .iter()
                .find(|l| t >= l.start_time_s - 0.5 / prf && t < l.start_time_s + l.duration_s())
                .ok_or_else(|| {
                    (
                        2,
                        format!("--gps-time {}: no flight line was flying then", t + offset),
                    )
                })?;
            (l, ((t - l.start_time_s) * prf).round().max(0.0) as u64)
        }
        (None, None) => {
            let l = world
                .lines
                .get((line as usize).wrapping_sub(1))
                .ok_or_else(|| {
                    (
                        2,
                        format!(
                            "--line {line}: the survey has {} line(s)",
                            world.lines.len()
                        ),
                    )
                })?;
            let k = pulse.ok_or_else(|| {
                (
                    2,
                    "give --pulse N (with --line L), --gps-time T or --near X,Y[,Z]".to_string(),
                )
            })?;
            (l, k)
        }
    };
    let n = survey.pulses_of(line_ref);
    if k >= n {
        return Err((
            2,
            format!(
                "pulse {k}: line {} has pulses 0 to {}",
                line_ref.index + 1,
                n - 1
            ),
        ));
    }
    let sim = lidarsim::sim::Simulator::new(&survey, &world);
    let (plot, scratch) = lidarsim::run::replay::pulse(&sim, line_ref, k);
    plot.render()
        .save_png(output)
        .map_err(|e| (1, format!("{}: {e}", output.display())))?;
    say!(
        "line {} pulse {k} (GPS time {:.6} s): {} sub-ray returns, {} echo(es)",
        line_ref.index + 1,
        offset + sim.pulse_time(line_ref, k),
        scratch.returns().len(),
        scratch.echoes().len()
    );
    for (i, e) in scratch.echoes().iter().enumerate() {
        say!(
            "  echo {}: range {:.3} m, peak {:.4}, energy amplitude {:.4}, width {:.2} ns",
            i + 1,
            e.range_m,
            e.peak_amplitude,
            e.amplitude,
            e.width_ns
        );
    }
    say!("wrote {}", output.display());
    Ok(())
}

/// Reads a LAS file and writes a top view or profile PNG. Errors carry the
/// exit status: 2 for bad arguments, 1 for unreadable or unwritable files.
fn render(
    cloud: &Path,
    output: &Path,
    color: &str,
    resolution: Option<f64>,
    profile: Option<&str>,
) -> Result<(), (u8, String)> {
    use lidarsim::render::ColorBy;
    let by = ColorBy::from_name(color).ok_or_else(|| {
        (
            2,
            format!("--color {color}: expected height, intensity, class, return or strip"),
        )
    })?;
    if resolution.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
        return Err((2, "--resolution must be a positive number of metres".into()));
    }
    let section = match profile {
        None => None,
        Some(p) => {
            let v: Vec<f64> = p
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    (
                        2,
                        format!("--profile {p}: expected five numbers x0,y0,x1,y1,width"),
                    )
                })?;
            if v.len() != 5 || v[4] <= 0.0 || v.iter().any(|x| !x.is_finite()) {
                return Err((
                    2,
                    format!("--profile {p}: expected x0,y0,x1,y1,width with width > 0"),
                ));
            }
            Some(v)
        }
    };
    let points = read_cloud(cloud).map_err(|e| (1, e))?;
    let img = match section {
        None => lidarsim::render::top_view(&points, by, resolution),
        Some(v) => {
            lidarsim::render::profile(&points, (v[0], v[1]), (v[2], v[3]), v[4], by, resolution)
        }
    }
    .map_err(|e| match resolution {
        Some(_) => (2, format!("--resolution: {e}")),
        None => (1, format!("{}: {e}", cloud.display())),
    })?;
    img.save_png(output)
        .map_err(|e| (1, format!("{}: {e}", output.display())))
}

/// Refuses a file that does not start as a LAS or LAZ file does ("LASF"),
/// saying so in words with its first bytes. Shorter files that begin like
/// one are left to the LAS reader, which says they end early.
fn check_las_signature(cloud: &Path) -> Result<(), String> {
    use std::io::Read;
    let Ok(file) = std::fs::File::open(cloud) else {
        return Ok(());
    };
    let mut head = Vec::with_capacity(4);
    if file.take(4).read_to_end(&mut head).is_err() || b"LASF".starts_with(&head) {
        return Ok(());
    }
    let shown: String = head
        .iter()
        .map(|&b| match b {
            b'"' => "\\\"".to_string(),
            0x20..=0x7e => char::from(b).to_string(),
            _ => format!("\\x{b:02x}"),
        })
        .collect();
    Err(format!(
        "{} is not a LAS or LAZ file (it starts with \"{shown}\"); render takes a point cloud \
         such as points.las",
        cloud.display()
    ))
}

/// Reads every point of a LAS file for rendering. Errors name the file and
/// say what is wrong in words (a truncated file, a header that promises
/// more points than the file holds) before any large allocation.
fn read_cloud(cloud: &Path) -> Result<Vec<lidarsim::render::RenderPoint>, String> {
    use lidarsim::io::cloud::{describe_las_error, open_las};
    use lidarsim::render::RenderPoint;
    let bad = |e: las::Error| format!("{}: {}", cloud.display(), describe_las_error(&e));
    check_las_signature(cloud)?;
    let mut reader = open_las(cloud).map_err(|why| format!("{}: {why}", cloud.display()))?;
    reader
        .read_all()
        .map_err(bad)?
        .points()
        .map(|p| {
            p.map(|p| RenderPoint {
                x: p.x,
                y: p.y,
                z: p.z,
                intensity: p.intensity,
                classification: u8::from(p.classification),
                return_number: p.return_number,
                number_of_returns: p.number_of_returns,
                source: p.point_source_id,
            })
        })
        .collect::<Result<Vec<RenderPoint>, _>>()
        .map_err(bad)
        .and_then(|points| {
            match points
                .iter()
                .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
            {
                Some(i) => Err(format!(
                    "{}: point {} has a coordinate that is not a finite number (check the \
                     header's scale and offset)",
                    cloud.display(),
                    i + 1
                )),
                None => Ok(points),
            }
        })
}

fn report(s: &Summary, output: &Path) {
    say!(
        "{} pulses → {} points ({} pulses with an echo) in {:.2} s: {:.0} pulses/s on {} thread(s)",
        s.pulses,
        s.points,
        s.pulses_with_echo,
        s.wall_time_s,
        s.pulses_per_second,
        s.threads
    );
    say!(
        "expected swath {:.1} m, density {:.2} points/m² per line",
        s.swath_width_m,
        s.point_density_per_m2
    );
    for f in &s.files {
        say!("wrote {}", output.join(f).display());
    }
}

fn check(survey: &Survey, world: &World, output: &Path) {
    use lidarsim::budget::{available_memory, estimate, free_bytes, human_bytes};
    let p = plan(survey, world);
    for w in lidarsim::plan::warnings(survey, world, &p) {
        note!("warning: {}: {w}", source_name(survey));
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let b = estimate(survey, world, threads);
    let (free, memory) = (free_bytes(output), available_memory());
    for s in b.shortfalls(output, free, memory, 1.0) {
        note!(
            "warning: {}: {s}: `lidarsim run` will refuse it without --no-space-check",
            source_name(survey)
        );
    }
    say!(
        "survey OK: {} flight line(s), {} scene primitives, seed {}",
        world.lines.len(),
        world.scene().primitives.len(),
        survey.seed
    );
    say!("pulses:               {}", p.pulses);
    say!("flight time:          {:.1} s", p.flight_time_s);
    say!("swath width:          {:.1} m", p.swath_width_m);
    say!(
        "point density:        {:.2} points/m² per line",
        p.point_density_per_m2
    );
    say!(
        "footprint diameter:   {:.3} m at nadir",
        p.footprint_diameter_m
    );
    say!(
        "expected points:      ~{} (one per pulse, more under crowns: {:.0} % of the area)",
        b.points,
        b.crown_cover * 100.0
    );
    for f in &b.files {
        say!("  {:<24}~{}", f.name, human_bytes(f.bytes));
    }
    say!(
        "expected output:      ~{}{}",
        human_bytes(b.total_bytes),
        free.map_or_else(String::new, |f| format!(
            " ({} free for {})",
            human_bytes(f),
            output.display()
        ))
    );
    say!(
        "expected memory:      ~{} on {threads} thread(s){}",
        human_bytes(b.memory_bytes),
        memory.map_or_else(String::new, |m| format!(" ({} available)", human_bytes(m)))
    );
    for l in &p.lines {
        say!(
            "  line {}: {} pulses, {:.1} s, {:.1} m above ground, swath {:.1} m, {:.2} pts/m², \
             scan lines every {:.2} m, footprints every {:.2} m across",
            l.line,
            l.pulses,
            l.duration_s,
            l.height_above_ground_m,
            l.swath_width_m,
            l.point_density_per_m2,
            l.scan_line_spacing_m,
            l.across_track_spacing_m
        );
    }
}

#[cfg(test)]
mod tests {
    use super::{figure_lines, read_cloud};
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    use std::cell::Cell;

    /// The LAS reader of `render` on 256 mangled copies of a valid file
    /// (bytes changed anywhere, the header most often, or cut short):
    /// never a panic or a huge allocation, errors name the file.
    #[test]
    fn render_reads_mangled_las_files_without_panicking() {
        let dir = std::env::temp_dir().join(format!("lidarsim-cli-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/corpus/las/count_too_large.las");
        let mut bytes = std::fs::read(good).unwrap();
        // Repair the corpus file's point count (40 points).
        bytes[247..255].copy_from_slice(&40u64.to_le_bytes());
        let path = dir.join("mangled.las");
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(read_cloud(&path).unwrap().len(), 40);
        let n = bytes.len();
        let at = prop_oneof![3 => 0..375usize, 1 => 0..n];
        let edits = proptest::collection::vec((at, any::<u8>()), 1..6);
        let cut = prop_oneof![3 => Just(n), 1 => 0..n];
        let mut runner = TestRunner::new_with_rng(
            Config {
                cases: 256,
                failure_persistence: None,
                ..Config::default()
            },
            TestRng::deterministic_rng(RngAlgorithm::ChaCha),
        );
        let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
        runner
            .run(&(edits, cut), |(edits, cut)| {
                let mut b = bytes.clone();
                for (at, v) in edits {
                    b[at] = v;
                }
                b.truncate(cut);
                std::fs::write(&path, &b).unwrap();
                match read_cloud(&path) {
                    Ok(points) => {
                        ok.set(ok.get() + 1);
                        prop_assert!(points.len() <= 40);
                    }
                    Err(e) => {
                        rejected.set(rejected.get() + 1);
                        prop_assert!(e.contains("mangled.las"), "{e}");
                    }
                }
                Ok(())
            })
            .unwrap();
        std::fs::remove_dir_all(&dir).ok();
        println!(
            "LAS for render: 256 cases, {} read, {} rejected naming the file",
            ok.get(),
            rejected.get()
        );
    }

    /// The bench's printed figures from fixed measurements: each rate is
    /// its count over the run's seconds, cores busy is CPU over wall time,
    /// the speed-ups follow from the rates (at equal CPU: times the ratio
    /// of CPU per pulse), and the median over two pairs is their mean.
    #[test]
    fn bench_figures_are_computed_from_the_measurements() {
        use lidarsim_bench::{BenchScene, RunFigures, SceneFigures};
        let run = |threads, seconds: f64, cpu_s: f64, hash| RunFigures {
            threads,
            pulses: 100_000,
            rays: 1_900_000,
            points: 120_000,
            seconds,
            las_hash: hash,
            cpu_s: Some(cpu_s),
            write_cpu_s: Some(0.0126),
        };
        let f = SceneFigures {
            scene: BenchScene::Flat,
            primitives: 62,
            parse_s: 0.25,
            build_s: 0.125,
            // 1 thread: 100 k/s on 1.00 core; 2 threads: 160 k/s on 1.60
            // cores (each pulse the same CPU), then 200 k/s and 240 k/s.
            runs: vec![
                run(1, 1.0, 1.0, 7),
                run(2, 0.625, 1.0, 7),
                run(1, 0.5, 0.5, 7),
                run(2, 100_000.0 / 240_000.0, 0.72, 8),
            ],
            peak_rss_bytes: Some(3 * 1048576 / 2),
        };
        let lines = figure_lines(&f);
        let has = |l: &str| assert!(lines.iter().any(|x| x == l), "no `{l}` in {lines:#?}");
        has("flat primitives 62");
        has("flat load_s 0.375");
        has("flat threads 1 pulses_per_s 100000");
        has("flat threads 1 rays_per_s 1900000");
        has("flat threads 1 points_per_s 120000");
        has("flat threads 2 pulses_per_s 160000");
        has("flat threads 2 cores_busy 1.60");
        has("flat threads 1 cores_busy 1.00");
        has("flat threads 1 las_fnv1a 0000000000000007");
        has("flat threads 1 write_cpu_s 0.013");
        has("flat scaling_1_to_2 1.60");
        // Equal CPU per pulse in the first pair: the measured speed-up.
        has("flat scaling_1_to_2_at_equal_cpu 1.60");
        // The fourth run wrote other bytes.
        has("flat identical_output false");
        // Pairs: 160/100 = 1.6 and 240/200 = 1.2; median 1.4.
        has("flat scaling_pairs 2");
        has("flat scaling_1_to_2_median 1.40");
        has("flat peak_rss_mb 1.5");
    }
}
