//! `lidarsim`: command-line front end of the airborne LiDAR simulator.
//!
//! A thin layer over the `lidarsim` library: it parses arguments, loads and
//! checks the survey, runs it with a progress bar and reports errors with a
//! non-zero exit status (2 for a bad survey, 1 for a failed run).

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use lidarsim::Survey;
use lidarsim::accel::Bvh;
use lidarsim::plan::plan;
use lidarsim::run::{RunOptions, Summary, run_to_dir};

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
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Seed of all random streams (overrides the demo's).
        #[arg(long)]
        seed: Option<u64>,
        /// Also write the demo's survey as a TOML file, to start your own.
        #[arg(long, value_name = "FILE")]
        export_survey: Option<PathBuf>,
    },
    /// Simulate a survey file.
    Run {
        /// The survey (TOML).
        survey: PathBuf,
        /// Output directory.
        #[arg(short, long, default_value = "out")]
        output: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Seed of all random streams (overrides the file's).
        #[arg(long)]
        seed: Option<u64>,
    },
    /// Validate a survey file and print what it will give, without simulating.
    Check {
        /// The survey (TOML).
        survey: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Demo {
            output,
            threads,
            seed,
            export_survey,
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
                eprintln!("wrote the demo survey to {}", path.display());
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
            simulate(survey, &output, threads)
        }
        Command::Run {
            survey,
            output,
            threads,
            seed,
        } => match Survey::load_with_seed(&survey, seed) {
            Ok(s) => simulate(s, &output, threads),
            Err(e) => fail_survey(&e),
        },
        Command::Check { survey } => match Survey::load(&survey) {
            Ok(s) => {
                warn(&s);
                check(&s);
                ExitCode::SUCCESS
            }
            Err(e) => fail_survey(&e),
        },
    }
}

/// Prints a line to standard output, ignoring a closed pipe (`| head`).
macro_rules! say {
    ($($arg:tt)*) => {{
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

fn fail(code: u8, message: &str) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(code)
}

/// Reports every problem of a survey file, exit status 2.
fn fail_survey(e: &lidarsim::survey::SurveyError) -> ExitCode {
    for d in &e.diagnostics {
        eprintln!("error: {d}");
    }
    ExitCode::from(2)
}

/// Prints the survey's warnings to standard error.
fn warn(survey: &Survey) {
    let file = survey
        .source
        .as_ref()
        .map_or_else(|| "<demo>".to_string(), |p| p.display().to_string());
    for w in &survey.warnings {
        eprintln!("warning: {file}: {w}");
    }
}

fn simulate(survey: Survey, output: &Path, threads: Option<usize>) -> ExitCode {
    warn(&survey);
    let threads = match threads {
        Some(0) => return fail(2, "--threads must be at least 1"),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let total: u64 = survey.lines.iter().map(|l| survey.pulses_of(l)).sum();
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
    let progress = |done: u64| bar.set_position(done);
    let result = run_to_dir(
        &survey,
        output,
        &RunOptions {
            threads,
            progress: &progress,
        },
    );
    bar.finish_and_clear();
    match result {
        Ok(summary) => {
            report(&summary, output);
            ExitCode::SUCCESS
        }
        Err(e) => fail(1, &e.to_string()),
    }
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

fn check(survey: &Survey) {
    let bvh = Bvh::build(survey.scene.clone());
    let p = plan(survey, &bvh);
    say!(
        "survey OK: {} flight line(s), {} scene primitives, seed {}",
        survey.lines.len(),
        survey.scene.primitives.len(),
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
        "expected run size:    ~{} points, points.las ~{:.1} MB",
        p.pulses,
        p.expected_las_bytes as f64 / 1e6
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
