//! Throughput benchmark: pulses per second on the demo scene, on a flat
//! plane and over forests of 100 and 10 000 trees, for 1 and 2 threads.
//!
//! Run with `cargo bench -p lidarsim-bench --bench throughput`. Each case runs
//! once to warm up, then `REPEATS` times; the median is reported, with the
//! spread (min–max), as plain `key value` lines a script can read. Points go
//! to a sink that only counts them, so the figures measure simulation, not
//! disk; one extra case writes the demo's LAS file to measure output cost.

use std::convert::Infallible;
use std::time::Instant;

use lidarsim::output::{PointRecord, PointSink};
use lidarsim::run::{RunOptions, run};
use lidarsim::sim::Simulator;
use lidarsim::world::World;
use lidarsim::{Flight, Survey};

const REPEATS: usize = 5;

#[derive(Default)]
struct Count(u64);

impl PointSink for Count {
    type Error = Infallible;
    fn write(&mut self, points: &[PointRecord]) -> Result<(), Infallible> {
        self.0 += points.len() as u64;
        Ok(())
    }
    fn finish(self: Box<Self>) -> Result<(), Infallible> {
        Ok(())
    }
    fn discard(self: Box<Self>) {}
}

fn flat_plane() -> Survey {
    // The demo's sensor over a 400 m × 400 m level plane, one 300 m line.
    let text = r#"
seed = 1
[scanner]
prf_hz = 100000
scan_frequency_hz = 50
scan_angle_deg = 20
divergence_mrad = 0.3
subrays = 19
pulse_fwhm_ns = 4.0
[[flight_line]]
start_m = [-150.0, 0.0, 500.0]
end_m = [150.0, 0.0, 500.0]
speed_mps = 60.0
[materials.ground]
reflectance = 0.2
[[polygon]]
material = "ground"
class = "ground"
vertices_m = [[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]]
"#;
    Survey::from_toml(text, None).expect("flat survey")
}

/// A stand of `trees` trees at 500 stems/ha (its area grows with the
/// count), flown by the same 40 m line with a narrow scan whose 52 m swath
/// lies inside the stand: every pulse meets the same density of crowns,
/// only the number of trees in the scene differs.
fn forest(trees: usize) -> Survey {
    let area_m2 = trees as f64 / 500.0 * 10_000.0;
    // Keep the stand's 5:4 aspect (50 m × 40 m for 100 trees).
    let w = (area_m2 * 1.25).sqrt();
    let h = area_m2 / w;
    let text = format!(
        r#"
seed = 1
[scanner]
prf_hz = 100000
scan_frequency_hz = 50
scan_angle_deg = 5
subrays = 19
[[flight_line]]
start_m = [0.0, -20.0, 300.0]
end_m = [0.0, 20.0, 300.0]
speed_mps = 20.0
[materials.ground]
reflectance = 0.25
[[polygon]]
material = "ground"
class = "ground"
vertices_m = [[-{gw}, -{gh}, 0], [{gw}, -{gh}, 0], [{gw}, {gh}, 0], [-{gw}, {gh}, 0]]
[[forest]]
rectangle_m = [-{hw}, -{hh}, {hw}, {hh}]
stems_per_ha = 500
species = {{ pine = 0.5, spruce = 0.3, birch = 0.2 }}
height_m = [14.0, 24.0]
min_spacing_m = 2.0
seed = 3
"#,
        hw = w / 2.0,
        hh = h / 2.0,
        gw = w / 2.0 + 50.0,
        gh = h / 2.0 + 50.0,
    );
    let s = Survey::from_toml(&text, None).expect("forest survey");
    let placed = World::build(&s).expect("forest world").forest_trees;
    assert_eq!(placed, [trees]);
    s
}

fn demo() -> Survey {
    Survey::from_raw(lidarsim::demo::demo_survey(), None).expect("demo survey")
}

fn bench(name: &str, survey: &Survey, threads: usize) {
    let world = World::build(survey).expect("world");
    let sim = Simulator::new(survey, &world);
    let run = || {
        let mut sink = Count::default();
        let t = Instant::now();
        let counts = sim.run(threads, &mut [&mut sink], &|_| {}).expect("run");
        (counts, t.elapsed().as_secs_f64())
    };
    let (counts, _) = run(); // warm-up
    let rates: Vec<f64> = (0..REPEATS)
        .map(|_| counts.pulses as f64 / run().1)
        .collect();
    let lo = rates.iter().cloned().fold(f64::MAX, f64::min);
    let hi = rates.iter().cloned().fold(f64::MIN, f64::max);
    let m = lidarsim_bench::median(&rates).expect("REPEATS > 0");
    let rays = m * survey.scanner.subrays as f64;
    let points = m * counts.points as f64 / counts.pulses as f64;
    println!(
        "{name} threads={threads} pulses_per_s={m:.0} (min {lo:.0}, max {hi:.0}) \
         rays_per_s={rays:.0} points_per_s={points:.0} pulses={}",
        counts.pulses
    );
}

fn main() {
    // `cargo bench` passes `--bench`; ignore arguments.
    let flat = flat_plane();
    let demo = demo();
    let (f100, f10k) = (forest(100), forest(10_000));
    for threads in [1, 2] {
        bench("flat", &flat, threads);
        bench("demo", &demo, threads);
        bench("forest100", &f100, threads);
        bench("forest10000", &f10k, threads);
    }
    // Whole run with LAS + XYZ output, 2 threads.
    let dir = std::env::temp_dir().join(format!("lidarsim-bench-{}", std::process::id()));
    let t = Instant::now();
    let s = run(
        &Flight::build(demo).expect("demo world"),
        &dir,
        &RunOptions::new(2, &|_| {}),
    )
    .expect("demo run");
    println!(
        "demo_with_output threads=2 pulses_per_s={:.0} seconds={:.2}",
        s.pulses as f64 / t.elapsed().as_secs_f64(),
        t.elapsed().as_secs_f64()
    );
    std::fs::remove_dir_all(&dir).ok();
}
