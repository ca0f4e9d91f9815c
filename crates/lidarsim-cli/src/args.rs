//! The command line as clap parses it: the commands and their options.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use crate::console::fail;

/// The whole command line: one of the commands.
#[derive(Parser)]
#[command(
    name = "lidarsim",
    version,
    about = "Airborne LiDAR simulator: full-waveform pulses over a 3D scene to a LAS point cloud"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Subcommand)]
pub enum Command {
    /// Fly the built-in survey over the built-in town block (no input files).
    Demo(DemoArgs),
    /// Simulate a survey file (Ctrl-C stops at the next block of pulses
    /// with valid files; `--resume DIR` continues such a run).
    Run(RunArgs),
    /// Validate a survey file and print what it will give, without simulating.
    Check(CheckArgs),
    /// Plot the full waveform of one pulse of a run (simulated again from its survey.toml).
    /// Name the pulse by --line and --pulse, by a point's --gps-time, or by a
    /// place with --near.
    Waveform(WaveformArgs),
    /// Render a LAS or LAZ file (ours or anyone's) as a top view or a cross-section PNG.
    Render(RenderArgs),
    /// Measure speed on the benchmark scenes (flat, 1 M-triangle terrain, forest stand).
    Bench(BenchArgs),
    /// Join the parts of a split run (`lidarsim run SURVEY --part K/N`) into
    /// the files one unsplit run writes, byte for byte.
    Merge(MergeArgs),
    /// Make a survey that re-flies a real airborne scan (LAS or LAZ): its
    /// ground, trees and acquisition read from the points, written as
    /// DIR/survey.toml with the files it uses and twin.json (what was
    /// read and how sure it is).
    Twin(TwinArgs),
    /// Compare two point clouds (LAS, LAZ, or a run's directory) with the
    /// field's metrics over their common area, overall and per grid cell:
    /// a table, and DIR/compare.json and DIR/compare.html with -o DIR.
    Compare(CompareArgs),
}

/// The options of `lidarsim twin`.
#[derive(Args)]
pub struct TwinArgs {
    /// The real scan (LAS or LAZ).
    pub scan: PathBuf,
    /// Directory for survey.toml, trees.csv, dtm.tif and twin.json.
    #[arg(short, long)]
    pub output: PathBuf,
    /// An instrument preset for the scanner's other keys (divergence,
    /// pulse, returns, wavelength): see `lidarsim check` or docs/survey.md.
    #[arg(long, value_name = "PRESET")]
    pub instrument: Option<String>,
    /// Species of every tree: pine, spruce or birch.
    #[arg(long, default_value = "pine")]
    pub species: String,
    /// Flying height above the ground, m (default: read from the scan
    /// angles).
    #[arg(long, value_name = "H")]
    pub altitude_m: Option<f64>,
    /// Ground speed, m/s (default: read from the GPS times).
    #[arg(long, value_name = "V")]
    pub speed_mps: Option<f64>,
    /// Pulse rate, Hz (default: the one that gives the scan's density).
    #[arg(long, value_name = "HZ")]
    pub prf_hz: Option<f64>,
    /// Mirror cycles (polygon: scan lines) per second (default: read from
    /// the sweeps of the beam).
    #[arg(long, value_name = "HZ")]
    pub scan_frequency_hz: Option<f64>,
    /// Largest scan angle, degrees (default: read).
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub scan_angle_deg: Option<f64>,
    /// Compass heading of lines planned over the scan, degrees: for a scan
    /// without GPS times or scan angles (with --altitude-m and
    /// --scan-angle-deg).
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub heading_deg: Option<f64>,
    /// Distance between planned lines, m (default: 30 % side overlap).
    #[arg(long, value_name = "M")]
    pub line_spacing_m: Option<f64>,
    /// The tree tops' window diameter A + B·h + C·h² (m, h the height):
    /// A,B,C (default 3,0.1,0, the lidR book's; Popescu & Wynne's is
    /// 2.51503,0,0.00901).
    #[arg(long, value_name = "A,B,C")]
    pub window: Option<String>,
    /// Cell of the canopy height model, m (default: about one first return
    /// per cell).
    #[arg(long, value_name = "M")]
    pub chm_cell_m: Option<f64>,
    /// Write into a non-empty directory no twin wrote, replacing only the
    /// twin's files there.
    #[arg(long)]
    pub overwrite: bool,
}

/// The options of `lidarsim compare`.
#[derive(Args)]
pub struct CompareArgs {
    /// The first cloud (LAS or LAZ, or a run's output directory), e.g. the
    /// real scan.
    pub a: PathBuf,
    /// The second cloud, e.g. the simulation.
    pub b: PathBuf,
    /// Directory for compare.json and compare.html (default: only the
    /// table).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Compare only within XMIN,YMIN,XMAX,YMAX (m, the clouds'
    /// coordinates).
    #[arg(long, value_name = "XMIN,YMIN,XMAX,YMAX", allow_hyphen_values = true)]
    pub area: Option<String>,
    /// Edge of the grid cells of the per-cell metrics, m.
    #[arg(long, default_value_t = 20.0)]
    pub cell_m: f64,
    /// Thin the cloud of more pulses per m² to the other's pulse density
    /// first (keeping all returns of a kept pulse).
    #[arg(long)]
    pub match_density: bool,
    /// Seed of the thinning's choice of pulses.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Names of the two clouds in the table and the page.
    #[arg(long, value_name = "A,B")]
    pub labels: Option<String>,
    /// Write into a non-empty directory, replacing only compare.json and
    /// compare.html.
    #[arg(long)]
    pub overwrite: bool,
}

/// The options of `lidarsim demo`.
#[derive(Args)]
pub struct DemoArgs {
    /// Output directory.
    #[arg(short, long, default_value = "demo-out")]
    pub output: PathBuf,
    /// Threads, the one writing the output among them (default: all
    /// cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of all random streams (overrides the demo's; 0 to
    /// 9223372036854775807, the integers a TOML file can hold).
    #[arg(long, value_parser = seed_parser())]
    pub seed: Option<u64>,
    /// Write into a non-empty directory no run wrote, replacing only
    /// the files a run writes there.
    #[arg(long)]
    pub overwrite: bool,
    /// Run even if the expected output exceeds the free disk space or
    /// the expected memory is not available.
    #[arg(long)]
    pub no_space_check: bool,
    /// Also write the demo's survey as a TOML file, to start your own.
    #[arg(long, value_name = "FILE")]
    pub export_survey: Option<PathBuf>,
}

/// The options of `lidarsim run`.
#[derive(Args)]
pub struct RunArgs {
    /// The survey (TOML).
    #[arg(required_unless_present = "resume")]
    pub survey: Option<PathBuf>,
    /// Output directory.
    #[arg(short, long, default_value = "out", conflicts_with = "resume")]
    pub output: PathBuf,
    /// Threads, the one writing the output among them (default: all
    /// cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of all random streams (overrides the file's; 0 to
    /// 9223372036854775807, the integers a TOML file can hold).
    #[arg(long, conflicts_with = "resume", value_parser = seed_parser())]
    pub seed: Option<u64>,
    /// Write into a non-empty directory no run wrote, replacing only
    /// the files a run writes there (points.*, survey.toml,
    /// trajectory*.csv, summary.json, report.html) and keeping the rest.
    #[arg(long, conflicts_with = "resume")]
    pub overwrite: bool,
    /// Run even if the expected output exceeds the free disk space of
    /// the output directory or the expected memory is not available
    /// (see `lidarsim check`).
    #[arg(long)]
    pub no_space_check: bool,
    /// Continue the interrupted run in DIR (with its survey.toml) up to
    /// the files an uninterrupted run would have written.
    #[arg(long, value_name = "DIR", conflicts_with = "survey")]
    pub resume: Option<PathBuf>,
    /// Simulate only part K of N (K from 1): whole flight lines where
    /// there are enough, otherwise equal shares of the pulses, into the
    /// output directory with part.json for `lidarsim merge`: its points as
    /// points.las and report.state when a plain LAS file is the survey's
    /// only point output, else as points.part.
    #[arg(long, value_name = "K/N", conflicts_with = "resume", value_parser = part_parser)]
    pub part: Option<(usize, usize)>,
}

/// Parses `K/N` with `1 ≤ K ≤ N ≤ MAX_PARTS`.
fn part_parser(text: &str) -> Result<(usize, usize), String> {
    let (k, n) = text
        .split_once('/')
        .ok_or_else(|| format!("'{text}' is not K/N (for example 2/7)"))?;
    let number = |s: &str| {
        s.trim()
            .parse::<usize>()
            .map_err(|_| format!("'{text}' is not K/N: '{s}' is not a whole number"))
    };
    let (k, n) = (number(k)?, number(n)?);
    lidarsim::run::part::check_part_number(k, n)?;
    Ok((k, n))
}

/// The options of `lidarsim merge`.
#[derive(Args)]
pub struct MergeArgs {
    /// The parts' output directories, in any order.
    #[arg(required = true, value_name = "PART_DIR")]
    pub parts: Vec<PathBuf>,
    /// Output directory of the merged run.
    #[arg(short, long, default_value = "out")]
    pub output: PathBuf,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write into a non-empty directory no run wrote, replacing only
    /// the files a run writes there.
    #[arg(long)]
    pub overwrite: bool,
    /// Merge even if the expected output exceeds the free disk space.
    #[arg(long)]
    pub no_space_check: bool,
    /// Take the parts: move the first part's LAS file into the output
    /// instead of copying it, and remove the parts' directories once
    /// merged.
    #[arg(long)]
    pub take_parts: bool,
    /// Start before the parts finish: the part directories need not exist
    /// yet, and each part is joined as soon as its record says it
    /// finished (for a merge job that runs beside its job array).
    #[arg(long)]
    pub follow: bool,
    /// With --follow: seconds between two looks at the parts not finished.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0, requires = "follow",
          value_parser = seconds_parser())]
    pub poll_seconds: f64,
    /// With --follow: give up (exit non-zero, naming the parts not
    /// finished) after this many seconds without a part finishing.
    #[arg(long, value_name = "SECONDS", requires = "follow", value_parser = seconds_parser())]
    pub give_up_after: Option<f64>,
}

/// The options of `lidarsim check`.
#[derive(Args)]
pub struct CheckArgs {
    /// The survey (TOML).
    pub survey: PathBuf,
    /// Output directory whose free space the expected files are
    /// compared with.
    #[arg(short, long, default_value = "out")]
    pub output: PathBuf,
}

/// The options of `lidarsim waveform`.
#[derive(Args)]
pub struct WaveformArgs {
    /// Output directory of a run (it holds survey.toml, and points.las or
    /// points.laz for --near).
    pub dir: PathBuf,
    /// Pulse number within the flight line given by --line, from 0 (emitted
    /// at the line's start time + N / PRF). Point files have no pulse
    /// column: to find a point's pulse use --gps-time or --near.
    #[arg(long, conflicts_with_all = ["gps_time", "near"])]
    pub pulse: Option<u64>,
    /// Flight line number for --pulse, 1 for the first: the point source ID
    /// of points.las (point_source_id in points.xyz).
    #[arg(long, default_value_t = 1)]
    pub line: u32,
    /// Find the pulse by the GPS time of one of its points: the gps_time of
    /// any point in points.las, points.xyz or points.ply (it includes the
    /// survey's output.gps_start_time_s).
    #[arg(long, conflicts_with = "near")]
    pub gps_time: Option<f64>,
    /// Find the pulse of the point of DIR/points.las (or points.laz) nearest
    /// to X,Y or X,Y,Z, in the coordinates of that file (those of the
    /// survey plus output.offset_m); horizontal distance without Z.
    #[arg(long, value_name = "X,Y[,Z]", allow_hyphen_values = true)]
    pub near: Option<String>,
    /// Output PNG.
    #[arg(short, long, default_value = "waveform.png")]
    pub output: PathBuf,
}

/// The options of `lidarsim render`.
#[derive(Args)]
pub struct RenderArgs {
    /// The point cloud (LAS or LAZ).
    pub cloud: PathBuf,
    /// Output PNG.
    #[arg(short, long, default_value = "top.png")]
    pub output: PathBuf,
    /// Colours: height, intensity, class, return, strip or time (GPS time:
    /// the order in which the scanner drew its pattern).
    #[arg(long, default_value = "height")]
    pub color: String,
    /// Pixel size, m (default: from the point density).
    #[arg(long)]
    pub resolution: Option<f64>,
    /// Cross-section instead of top view: x0,y0,x1,y1,width (m).
    #[arg(long, value_name = "X0,Y0,X1,Y1,WIDTH", allow_hyphen_values = true)]
    pub profile: Option<String>,
}

/// The options of `lidarsim bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Write the scenes (OBJ) and surveys (TOML) into DIR and stop.
    #[arg(long, value_name = "DIR")]
    pub export: Option<PathBuf>,
    /// Scenes to measure: flat, terrain, forest (default all three).
    #[arg(long, value_delimiter = ',')]
    pub scene: Vec<String>,
    /// Thread counts to run, one run each in this order (default 1,2;
    /// 1,2,1,2,… also prints the median speed-up over the pairs).
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 2])]
    pub threads: Vec<usize>,
    /// Working directory for the generated files (default: a temporary one).
    #[arg(long, value_name = "DIR")]
    pub work_dir: Option<PathBuf>,
    /// Pulses of the flight line (default: the benchmark's 500 000;
    /// fewer for profiling).
    #[arg(long, default_value_t = lidarsim_bench::PULSES)]
    pub pulses: u64,
}

/// Seeds a survey file can hold: TOML integers are signed 64-bit.
fn seed_parser() -> clap::builder::RangedU64ValueParser<u64> {
    clap::value_parser!(u64).range(..=i64::MAX as u64)
}

/// A duration in seconds: a finite number, at least 0.01 and at most a
/// year.
fn seconds_parser() -> impl clap::builder::TypedValueParser<Value = f64> {
    use clap::builder::TypedValueParser;
    clap::builder::StringValueParser::new().try_map(|text: String| {
        let s: f64 = text
            .trim()
            .parse()
            .map_err(|_| format!("{text:?} is not a number of seconds"))?;
        if (0.01..=3.2e7).contains(&s) {
            Ok(s)
        } else {
            Err(format!(
                "{text} s is out of range: give 0.01 to 32000000 seconds"
            ))
        }
    })
}

/// `threads`, or every core; a zero is refused.
pub fn threads_or_all(threads: Option<usize>) -> Result<usize, ExitCode> {
    match threads {
        Some(0) => Err(fail(2, "--threads must be at least 1")),
        Some(n) => Ok(n),
        None => Ok(std::thread::available_parallelism().map_or(1, |n| n.get())),
    }
}
