//! The performance benchmark of `lidarsim bench`: its scenes and the
//! measurement of a run on them (a crate of its own, beside the library,
//! so that process clocks and `/proc` reads stay out of its API).
//!
//! Three scenes, generated procedurally and written as OBJ meshes with a
//! survey file so that other simulators can be run on identical input
//! (`lidarsim bench --export DIR`):
//!
//! - **flat**: a 400 m × 400 m ground plane (reflectance 0.2) and five box
//!   buildings (reflectance 0.5): 62 triangles.
//! - **terrain**: a 708 × 708-vertex height grid (999 698 triangles) over
//!   x, y ∈ [−200, 200] m with
//!   `z = 10 + 8 sin(x/37) cos(y/53) + 4 sin((x+2y)/11) + 1.5 cos((3x−y)/4.3)
//!   + 0.4 sin(1.7x) sin(1.3y)`, and the same five boxes standing on it.
//! - **forest**: the flat scene's ground under a generated mixed stand
//!   (`[[forest]]`: 600 stems/ha of pine 0.5, spruce 0.3 and birch 0.2,
//!   12–26 m tall, 2 m apart at least) over the whole 400 m × 400 m, so
//!   that the swath lies inside it: about 9 600 trees.
//!
//! The survey is the reference simulator's benchmark: oscillating mirror,
//! 100 kHz, 50 Hz, ±20°, 0.5 mrad divergence, 19 sub-rays, 4 ns pulse, full
//! waveform, one 300 m line along +x at 500 m and 60 m/s (500 000 pulses),
//! LAS output. [`measure`] loads the scene from its files (timed: OBJ
//! parsing plus acceleration structure), runs the survey on 1 and 2 threads
//! and reports rates and peak memory.

use std::fmt::Write as _;
use std::io::{self, BufWriter, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use lidarsim::output::{
    AtFile, FileSink, LasWriter, PointRecord, PointSink, WaveformBlock, WriteError,
};
use lidarsim::sim::Simulator;
use lidarsim::{Flight, Survey};

/// A benchmark scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchScene {
    /// Ground plane and five boxes (62 triangles).
    Flat,
    /// One-million-triangle height grid and five boxes.
    Terrain,
    /// Flat ground under a 600 stems/ha mixed stand.
    Forest,
}

impl BenchScene {
    /// All scenes, in the order they are measured.
    pub const ALL: [BenchScene; 3] = [BenchScene::Flat, BenchScene::Terrain, BenchScene::Forest];

    /// Name used on the command line and in file names.
    pub fn name(self) -> &'static str {
        match self {
            BenchScene::Flat => "flat",
            BenchScene::Terrain => "terrain",
            BenchScene::Forest => "forest",
        }
    }

    /// Parses a name given by [`BenchScene::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// The five buildings: centre x, y; size x, y; height (m).
pub const BOXES: [[f64; 5]; 5] = [
    [-60.0, -50.0, 20.0, 30.0, 10.0],
    [0.0, 40.0, 40.0, 20.0, 25.0],
    [70.0, -20.0, 15.0, 15.0, 40.0],
    [100.0, 90.0, 30.0, 30.0, 15.0],
    [-110.0, 100.0, 25.0, 50.0, 8.0],
];

/// Vertices per side of the terrain grid.
pub const TERRAIN_VERTICES: usize = 708;
/// Half the side of both scenes, m.
pub const HALF_SIDE_M: f64 = 200.0;

/// Height of the benchmark terrain at (x, y), m.
pub fn terrain_height(x: f64, y: f64) -> f64 {
    10.0 + 8.0 * (x / 37.0).sin() * (y / 53.0).cos()
        + 4.0 * ((x + 2.0 * y) / 11.0).sin()
        + 1.5 * ((3.0 * x - y) / 4.3).cos()
        + 0.4 * (1.7 * x).sin() * (1.3 * y).sin()
}

/// Writes a number the way OBJ files usually hold them: fixed point with
/// millimetre-and-better precision, no exponent.
fn push_coord(s: &mut String, v: f64) {
    let _ = write!(s, "{v:.4}");
}

/// Writes the ground of `scene` as an OBJ file (group `ground`).
pub fn write_ground_obj(scene: BenchScene, path: &Path) -> io::Result<()> {
    let mut w = BufWriter::with_capacity(1 << 20, std::fs::File::create(path)?);
    writeln!(w, "# lidarsim benchmark ground: {}", scene.name())?;
    writeln!(w, "g ground")?;
    let mut line = String::with_capacity(64);
    match scene {
        BenchScene::Flat | BenchScene::Forest => {
            let h = HALF_SIDE_M;
            for (x, y) in [(-h, -h), (h, -h), (h, h), (-h, h)] {
                writeln!(w, "v {x} {y} 0")?;
            }
            writeln!(w, "f 1 2 3\nf 1 3 4")?;
        }
        BenchScene::Terrain => {
            let n = TERRAIN_VERTICES;
            let step = 2.0 * HALF_SIDE_M / (n - 1) as f64;
            for j in 0..n {
                let y = -HALF_SIDE_M + j as f64 * step;
                for i in 0..n {
                    let x = -HALF_SIDE_M + i as f64 * step;
                    line.clear();
                    line.push_str("v ");
                    push_coord(&mut line, x);
                    line.push(' ');
                    push_coord(&mut line, y);
                    line.push(' ');
                    push_coord(&mut line, terrain_height(x, y));
                    line.push('\n');
                    w.write_all(line.as_bytes())?;
                }
            }
            // Two counter-clockwise triangles per cell (normals up).
            for j in 0..n - 1 {
                for i in 0..n - 1 {
                    let a = j * n + i + 1;
                    let b = a + 1;
                    let c = a + n;
                    let d = c + 1;
                    writeln!(w, "f {a} {b} {d}\nf {a} {d} {c}")?;
                }
            }
        }
    }
    w.flush()
}

/// Base height of the benchmark boxes: level ground in the flat scene,
/// below the lowest terrain under the box in the terrain scene (so that the
/// walls reach into the ground).
fn box_base(scene: BenchScene, b: &[f64; 5]) -> (f64, f64) {
    match scene {
        BenchScene::Flat | BenchScene::Forest => (0.0, b[4]),
        BenchScene::Terrain => {
            // The terrain varies by at most ±13.9 m around 10 m.
            let top = terrain_height(b[0], b[1]) + b[4];
            (-5.0, top)
        }
    }
}

/// Writes the five boxes as an OBJ file: per box a group `roof_K` (top and
/// bottom) and a group `wall_K` (sides), 12 triangles each.
pub fn write_boxes_obj(scene: BenchScene, path: &Path) -> io::Result<()> {
    let mut w = BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "# lidarsim benchmark buildings: {}", scene.name())?;
    for (k, b) in BOXES.iter().enumerate() {
        let (z0, z1) = box_base(scene, b);
        let (hx, hy) = (b[2] / 2.0, b[3] / 2.0);
        let corners = [
            (b[0] - hx, b[1] - hy),
            (b[0] + hx, b[1] - hy),
            (b[0] + hx, b[1] + hy),
            (b[0] - hx, b[1] + hy),
        ];
        for z in [z0, z1] {
            for (x, y) in corners {
                writeln!(w, "v {x} {y} {z}")?;
            }
        }
        // Vertices of this box: bottom 1..4, top 5..8 (relative).
        let o = k * 8;
        let v = |i: usize| o + i;
        writeln!(w, "g roof_{k}")?;
        writeln!(
            w,
            "f {} {} {}\nf {} {} {}",
            v(5),
            v(6),
            v(7),
            v(5),
            v(7),
            v(8)
        )?;
        writeln!(
            w,
            "f {} {} {}\nf {} {} {}",
            v(1),
            v(3),
            v(2),
            v(1),
            v(4),
            v(3)
        )?;
        writeln!(w, "g wall_{k}")?;
        for s in 0..4 {
            let (a, b2) = (s + 1, (s + 1) % 4 + 1);
            writeln!(
                w,
                "f {} {} {}\nf {} {} {}",
                v(a),
                v(b2),
                v(b2 + 4),
                v(a),
                v(b2 + 4),
                v(a + 4)
            )?;
        }
    }
    w.flush()
}

/// Pulses of the benchmark's flight line (300 m at 60 m/s and 100 kHz).
pub const PULSES: u64 = 500_000;

/// The benchmark's survey settings: seed, scanner, output and a flight
/// line of `pulses` pulses starting at x = −150 m.
fn survey_head(pulses: u64) -> String {
    let end_x = -150.0 + pulses as f64 / 100_000.0 * 60.0;
    format!(
        r#"# lidarsim benchmark survey (the reference simulator's settings):
# oscillating mirror 100 kHz, 50 Hz, ±20°, 0.5 mrad, 19 sub-rays, 4 ns
# pulse, full-waveform echo detection, one 300 m line at 500 m, 60 m/s.
seed = 1

[scanner]
prf_hz = 100000
scan_frequency_hz = 50
scan_angle_deg = 20
mirror = "triangle"
divergence_mrad = 0.5
subrays = 19
pulse_fwhm_ns = 4.0

[output]
formats = ["las"]

[[flight_line]]
start_m = [-150.0, 0.0, 500.0]
end_m = [{end_x}, 0.0, 500.0]
speed_mps = 60.0

[materials.ground]
reflectance = 0.2
"#
    )
}

/// The `[[mesh]]` table of the ground at `ground`.
fn ground_mesh(ground: &str) -> String {
    format!(
        r#"
[[mesh]]
file = "{ground}"
material = "ground"
class = "ground"
"#
    )
}

/// The benchmark survey, with its meshes at `ground` and `boxes` (paths
/// written as given) and a flight line of `pulses` pulses (the benchmark's
/// [`PULSES`], or fewer for profiling), starting at x = −150 m.
pub fn survey_toml(ground: &str, boxes: &str, pulses: u64) -> String {
    let mut s = survey_head(pulses);
    s.push_str("\n[materials.building]\nreflectance = 0.5\n");
    s.push_str(&ground_mesh(ground));
    let _ = write!(
        s,
        "\n[[mesh]]\nfile = \"{boxes}\"\nmaterial = \"building\"\nclass = \"roof\"\n"
    );
    s
}

/// The forest benchmark survey: the ground mesh at `ground` under a
/// generated stand over the whole ground, and a flight line of `pulses`
/// pulses. The line's swath (±182 m at 500 m) lies inside the stand.
pub fn forest_survey_toml(ground: &str, pulses: u64) -> String {
    let h = HALF_SIDE_M;
    survey_head(pulses)
        + &ground_mesh(ground)
        + &format!(
            r#"
# A mixed stand of 600 stems/ha over the whole ground (about 9 600 trees).
[[forest]]
rectangle_m = [{x0:.1}, {x0:.1}, {h:.1}, {h:.1}]
stems_per_ha = 600
species = {{ pine = 0.5, spruce = 0.3, birch = 0.2 }}
height_m = [12.0, 26.0]
min_spacing_m = 2.0
seed = 3
"#,
            x0 = -h
        )
}

/// Writes a scene's OBJ files and survey (a line of `pulses` pulses) into
/// `dir` as `NAME-ground.obj`, `NAME-buildings.obj` (not for the forest)
/// and `NAME.toml`; returns the survey's path.
pub fn export(
    scene: BenchScene,
    dir: &Path,
    pulses: u64,
) -> Result<std::path::PathBuf, WriteError> {
    use lidarsim::output::own::{Mark, check_replaceable};
    std::fs::create_dir_all(dir).at(dir)?;
    let name = scene.name();
    // Every file written begins "# lidarsim benchmark": the scenes of an
    // earlier export are replaced, nothing else.
    for file in [
        format!("{name}-ground.obj"),
        format!("{name}-buildings.obj"),
        format!("{name}.toml"),
    ] {
        check_replaceable(&dir.join(&file), Mark::FirstLine("# lidarsim benchmark"))?;
    }
    let ground = format!("{name}-ground.obj");
    let ground_path = dir.join(&ground);
    write_ground_obj(scene, &ground_path).at(&ground_path)?;
    let text = if scene == BenchScene::Forest {
        forest_survey_toml(&ground, pulses)
    } else {
        let boxes = format!("{name}-buildings.obj");
        let boxes_path = dir.join(&boxes);
        write_boxes_obj(scene, &boxes_path).at(&boxes_path)?;
        survey_toml(&ground, &boxes, pulses)
    };
    let survey = dir.join(format!("{name}.toml"));
    std::fs::write(&survey, text).at(&survey)?;
    Ok(survey)
}

/// Peak resident memory of this process so far, bytes (Linux; `None`
/// elsewhere).
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Resets the peak resident memory counter to the current use (Linux ≥ 4.0;
/// silently does nothing elsewhere).
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The figures of one benchmark scene.
#[derive(Clone, Debug)]
pub struct SceneFigures {
    /// The scene.
    pub scene: BenchScene,
    /// Triangles in the scene.
    pub primitives: usize,
    /// Seconds to read the survey and its OBJ files.
    pub parse_s: f64,
    /// Seconds to build the acceleration structure.
    pub build_s: f64,
    /// One entry per thread count.
    pub runs: Vec<RunFigures>,
    /// Peak resident memory over load and runs, bytes.
    pub peak_rss_bytes: Option<u64>,
}

/// The figures of one run.
#[derive(Clone, Debug)]
pub struct RunFigures {
    /// Threads of the run (the one that writes among them).
    pub threads: usize,
    /// Pulses simulated.
    pub pulses: u64,
    /// Rays cast (pulses × sub-rays).
    pub rays: u64,
    /// Points written.
    pub points: u64,
    /// Wall-clock seconds of the run (simulation and LAS output).
    pub seconds: f64,
    /// FNV-1a hash of the LAS file written, to show that thread counts
    /// give identical output.
    pub las_hash: u64,
    /// CPU seconds the whole process spent in the run:
    /// divided by `seconds`, how many cores it kept busy (`None` where the
    /// platform does not tell).
    pub cpu_s: Option<f64>,
    /// CPU seconds spent writing the LAS file: encoding the points and the
    /// kernel's write path, read from the CPU clock of the thread that
    /// writes (the calling thread, which simulates blocks too) around each
    /// block's write and the final header and sync. It is the serial part
    /// of a run: however many threads simulate, one writes.
    pub write_cpu_s: Option<f64>,
}

impl RunFigures {
    /// Pulses per second.
    pub fn pulses_per_s(&self) -> f64 {
        self.pulses as f64 / self.seconds
    }

    /// CPU seconds per wall-clock second: how many cores the run kept busy.
    pub fn cores_busy(&self) -> Option<f64> {
        Some(self.cpu_s? / self.seconds)
    }

    /// The speed-up of `self` over `base` that the same work would show if
    /// each pulse had cost the same CPU time in both runs:
    /// `(pulses/s ratio) × (CPU per pulse of self) / (CPU per pulse of
    /// base)`, which for equal pulse counts is the ratio of the cores kept
    /// busy. On a shared machine the CPU time of the same work varies from
    /// run to run; this figure leaves that out and keeps what the program's
    /// own structure gives (idle cores, the writer's serial share).
    pub fn speedup_at_equal_cpu(&self, base: &RunFigures) -> Option<f64> {
        let per_pulse = |r: &RunFigures| Some(r.cpu_s? / r.pulses as f64);
        Some(self.pulses_per_s() / base.pulses_per_s() * per_pulse(self)? / per_pulse(base)?)
    }
}

/// The measured speed-ups of the second thread count over the first in
/// consecutive pairs of runs (`--threads 1,2,1,2,…`): for `runs` of thread
/// counts a, b, a, b, … the speed-ups of run 2 over run 1, run 4 over run
/// 3, and so on, as long as the pairs repeat the first pair's counts. Each
/// is a one-run figure; several pairs taken in turn show how much the
/// machine's speed moved between the two runs of a pair.
pub fn pair_speedups(runs: &[RunFigures]) -> Vec<f64> {
    let [first, second, ..] = runs else {
        return Vec::new();
    };
    runs.chunks_exact(2)
        .take_while(|p| p[0].threads == first.threads && p[1].threads == second.threads)
        .map(|p| p[1].pulses_per_s() / p[0].pulses_per_s())
        .collect()
}

/// The median of `values` (the mean of the middle two for an even count);
/// `None` when empty.
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some((v[n / 2 - 1] + v[n / 2]) / 2.0),
    }
}

/// CPU seconds used so far by this process (`CLOCK_PROCESS_CPUTIME_ID`)
/// or by the calling thread (`CLOCK_THREAD_CPUTIME_ID`); Linux only. These
/// clocks include the time since the last scheduler tick, unlike
/// `getrusage`, whose figures move in ticks (milliseconds): too coarse for
/// a writer's calls of a few microseconds each.
#[cfg(target_os = "linux")]
fn cpu_seconds(thread: bool) -> Option<f64> {
    let clock = if thread {
        libc::CLOCK_THREAD_CPUTIME_ID
    } else {
        libc::CLOCK_PROCESS_CPUTIME_ID
    };
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `clock_gettime` only writes the struct it is given.
    if unsafe { libc::clock_gettime(clock, &mut t) } != 0 {
        return None;
    }
    Some(t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9)
}

/// CPU time is not read on this platform.
#[cfg(not(target_os = "linux"))]
fn cpu_seconds(_thread: bool) -> Option<f64> {
    None
}

/// CPU seconds (user + system) this process has used so far; `None` where
/// the platform does not tell (only Linux is read).
pub fn process_cpu_seconds() -> Option<f64> {
    cpu_seconds(false)
}

/// CPU seconds (user + system) the calling thread has used so far; `None`
/// where the platform does not tell (only Linux is read).
pub fn thread_cpu_seconds() -> Option<f64> {
    cpu_seconds(true)
}

/// A sink that times the calls into the sink it wraps, so that a writer's
/// share of a run can be told from the simulation around it: wall-clock
/// time (which includes waits for a core and for the disk) and CPU time of
/// the calling thread, around every write and the finish.
pub struct TimedSink {
    inner: Box<FileSink>,
    spent: Duration,
    cpu_s: Option<f64>,
    points: u64,
}

/// What a [`TimedSink`] measured over its whole output.
#[derive(Clone, Copy, Debug)]
pub struct WriteTime {
    /// Points written.
    pub points: u64,
    /// Wall-clock seconds spent in the wrapped sink.
    pub seconds: f64,
    /// CPU seconds spent in the wrapped sink (`None` where the platform
    /// does not tell).
    pub cpu_s: Option<f64>,
}

impl TimedSink {
    /// Wraps `inner`.
    pub fn new(inner: Box<FileSink>) -> Self {
        Self {
            inner,
            spent: Duration::ZERO,
            cpu_s: Some(0.0),
            points: 0,
        }
    }

    /// Runs `f` on the wrapped sink, adding its wall-clock and CPU time.
    fn timed<R>(&mut self, f: impl FnOnce(&mut Box<FileSink>) -> R) -> R {
        let (t, c0) = (Instant::now(), thread_cpu_seconds());
        let r = f(&mut self.inner);
        let c1 = thread_cpu_seconds();
        self.spent += t.elapsed();
        self.cpu_s = self.cpu_s.and_then(|s| Some(s + c1? - c0?));
        r
    }

    /// Finishes the wrapped sink (timed too) and returns the times.
    pub fn finish_timed(self) -> Result<WriteTime, WriteError> {
        let Self {
            inner,
            mut spent,
            cpu_s,
            points,
        } = self;
        let (t, c0) = (Instant::now(), thread_cpu_seconds());
        inner.finish()?;
        let c1 = thread_cpu_seconds();
        spent += t.elapsed();
        Ok(WriteTime {
            points,
            seconds: spent.as_secs_f64(),
            cpu_s: cpu_s.and_then(|s| Some(s + c1? - c0?)),
        })
    }
}

impl PointSink for TimedSink {
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        self.points += points.len() as u64;
        self.timed(|s| s.write(points))
    }
    fn write_block(
        &mut self,
        points: &[PointRecord],
        waveforms: &WaveformBlock,
    ) -> Result<(), WriteError> {
        self.points += points.len() as u64;
        self.timed(|s| s.write_block(points, waveforms))
    }
    fn finish(self: Box<Self>) -> Result<(), WriteError> {
        self.finish_timed().map(|_| ())
    }
    fn discard(self: Box<Self>) {
        self.inner.discard();
    }
}

/// 64-bit FNV-1a hash of a LAS file without its creation day and year (header
/// bytes 90–93, LAS 1.4 R15 Table 3), so that runs on different days
/// compare.
fn fnv1a(path: &Path) -> io::Result<u64> {
    let bytes = std::fs::read(path)?;
    Ok(bytes
        .iter()
        .enumerate()
        .filter(|(i, _)| !(90..94).contains(i))
        .fold(0xcbf2_9ce4_8422_2325u64, |h, (_, &b)| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        }))
}

/// Loads `survey_path` (timed), then runs it once per entry of `threads`,
/// writing `points.las` into `work_dir`.
pub fn measure(
    scene: BenchScene,
    survey_path: &Path,
    work_dir: &Path,
    threads: &[usize],
) -> Result<SceneFigures, String> {
    reset_peak_rss();
    let t0 = Instant::now();
    let survey = Survey::load(survey_path).map_err(|e| e.to_string())?;
    let parse_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let flight = Flight::build(survey).map_err(|e| e.to_string())?;
    let build_s = t1.elapsed().as_secs_f64();
    let (survey, world) = (flight.survey(), flight.world());
    let primitives = world.scene().primitives.len();
    let sim = Simulator::new(survey, world);
    let subrays = survey.scanner.subrays as u64;
    let mut runs = Vec::new();
    for &n in threads {
        let path = work_dir.join(format!("{}-{n}.las", scene.name()));
        let settings = flight.las_settings();
        let cpu0 = process_cpu_seconds();
        let t = Instant::now();
        let las = LasWriter::create(&path, settings).map_err(|e| e.to_string())?;
        let mut las = TimedSink::new(Box::new(las));
        let counts = sim
            .run(n, &mut [&mut las as &mut FileSink], &|_| {})
            .map_err(|e| e.to_string())?;
        let write = las.finish_timed().map_err(|e| e.to_string())?;
        let seconds = t.elapsed().as_secs_f64();
        let cpu_s = process_cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
        let write_cpu_s = write.cpu_s;
        let las_hash = fnv1a(&path).map_err(|e| e.to_string())?;
        let _ = std::fs::remove_file(&path);
        runs.push(RunFigures {
            threads: n,
            pulses: counts.pulses,
            rays: counts.pulses * subrays,
            points: counts.points,
            seconds,
            las_hash,
            cpu_s,
            write_cpu_s,
        });
    }
    Ok(SceneFigures {
        scene,
        primitives,
        parse_s,
        build_s,
        runs,
        peak_rss_bytes: peak_rss_bytes(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(threads: usize, pulses: u64, seconds: f64, cpu_s: Option<f64>) -> RunFigures {
        RunFigures {
            threads,
            pulses,
            rays: pulses * 19,
            points: pulses,
            seconds,
            las_hash: 0,
            cpu_s,
            write_cpu_s: None,
        }
    }

    /// With equal pulse counts, the speed-up at equal CPU cost per pulse is
    /// the ratio of the cores kept busy; a run whose pulses cost more CPU
    /// (a slower moment of the machine) is credited for it.
    #[test]
    fn speedup_at_equal_cpu_is_the_ratio_of_busy_cores() {
        let one = run(1, 500_000, 0.60, Some(0.63));
        // Two threads, each pulse 10 % dearer in CPU: 1.90 busy cores.
        let two = run(2, 500_000, 0.363, Some(0.6897));
        let raw = two.pulses_per_s() / one.pulses_per_s();
        let fair = two.speedup_at_equal_cpu(&one).unwrap();
        let busy = (0.6897 / 0.363) / (0.63 / 0.60);
        assert!((fair - busy).abs() < 1e-12, "{fair} vs {busy}");
        assert!((fair / raw - 0.6897 / 0.63).abs() < 1e-12);
        // Different pulse counts: per pulse, not per run.
        let half = run(2, 250_000, 0.1815, Some(0.34485));
        assert!((half.speedup_at_equal_cpu(&one).unwrap() - busy).abs() < 1e-9);
        assert_eq!(run(2, 1, 1.0, None).speedup_at_equal_cpu(&one), None);
        assert_eq!(two.speedup_at_equal_cpu(&run(1, 1, 1.0, None)), None);
    }

    /// Pairs are consecutive runs with the first pair's thread counts; the
    /// median is the middle value, or the mean of the middle two.
    #[test]
    fn pair_speedups_and_their_median() {
        // 1 thread at 500 k/s, then 2 threads at 950 k/s, 1.2 M/s, 0.8 M/s
        // against 1 thread at 500 k/s, 600 k/s, 400 k/s.
        let runs = [
            run(1, 500_000, 1.0, None),
            run(2, 500_000, 500_000.0 / 950_000.0, None),
            run(1, 600_000, 1.0, None),
            run(2, 1_200_000, 1.0, None),
            run(1, 400_000, 1.0, None),
            run(2, 800_000, 1.0, None),
            // A different pair ends the sequence.
            run(1, 1, 1.0, None),
            run(4, 1, 1.0, None),
        ];
        let s = pair_speedups(&runs);
        assert_eq!(s.len(), 3);
        for (got, want) in s.iter().zip([1.9, 2.0, 2.0]) {
            assert!((got - want).abs() < 1e-12, "{s:?}");
        }
        assert_eq!(median(&s), Some(2.0));
        assert!((median(&[1.9, 2.0, 1.5, 1.8]).unwrap() - 1.85).abs() < 1e-12);
        assert_eq!(median(&[]), None);
        assert!(pair_speedups(&runs[..1]).is_empty());
        // An odd run at the end has no partner.
        assert_eq!(pair_speedups(&runs[..3]).len(), 1);
    }

    #[test]
    fn terrain_grid_has_the_reference_triangle_count() {
        let n = TERRAIN_VERTICES;
        assert_eq!(2 * (n - 1) * (n - 1), 999_698);
    }

    #[test]
    fn exported_flat_scene_loads_with_62_triangles_and_classes() {
        let dir = std::env::temp_dir().join(format!("lidarsim-bench-{}", std::process::id()));
        let survey = export(BenchScene::Flat, &dir, PULSES).unwrap();
        let s = Survey::load(&survey).unwrap();
        let w = lidarsim::world::World::build(&s).unwrap();
        assert_eq!(w.scene().primitives.len(), 62);
        use lidarsim::scene::SurfaceClass;
        let count = |c| w.scene().primitives.iter().filter(|p| p.class == c).count();
        assert_eq!(count(SurfaceClass::Ground), 2);
        assert_eq!(count(SurfaceClass::Roof), 5 * 4);
        assert_eq!(count(SurfaceClass::Wall), 5 * 8);
        // 300 m at 60 m/s and 100 kHz.
        assert_eq!(s.pulses_of(&w.lines[0]), 500_000);
        // Box roofs at their heights.
        let b = w.scene().bounds();
        assert!((b.max.z - 40.0).abs() < 1e-9);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
