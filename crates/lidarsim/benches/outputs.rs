//! Output benchmark: file size and write rate of each point format for the
//! built-in demo (1.5 million pulses).
//!
//! Run with `cargo bench -p lidarsim --bench outputs` (or
//! `scripts/bench_outputs.sh`). The demo is simulated once per format on
//! all cores with waveform recording on (so every run does the same work),
//! and the one writer is wrapped in a sink that times only the calls into
//! it: the write rate is points per second of writer time (encoding,
//! compression, waveform quantisation and I/O into the page cache, plus
//! the final header rewrite and fsync), not of simulation, on the wall
//! clock (which includes waits for a core and for the disk) and in the
//! writer thread's CPU time. Prints plain `key value` lines.

use std::io;
use std::path::Path;
use std::time::{Duration, Instant};

use lidarsim::Survey;
use lidarsim::accel::Bvh;
use lidarsim::output::{
    LasSettings, LasWriter, PlyWriter, PointRecord, PointSink, WaveformBlock, XyzWriter,
};
use lidarsim::run::las_settings;
use lidarsim::sim::Simulator;

/// Times the calls into the sink it wraps: wall clock, and the CPU time of
/// the calling thread (the writer shares the cores with the workers, so
/// its wall-clock time includes the time it waited for a core).
struct Timed {
    inner: Option<Box<dyn PointSink>>,
    spent: Duration,
    cpu_s: f64,
    points: u64,
}

/// CPU seconds of the calling thread (0 where the platform does not tell).
fn thread_cpu() -> f64 {
    lidarsim::bench::thread_cpu_seconds().unwrap_or(0.0)
}

impl PointSink for Timed {
    fn write(&mut self, points: &[PointRecord]) -> io::Result<()> {
        self.write_block(points, &WaveformBlock::default())
    }
    fn write_block(&mut self, points: &[PointRecord], waveforms: &WaveformBlock) -> io::Result<()> {
        let (t, c) = (Instant::now(), thread_cpu());
        let r = self
            .inner
            .as_mut()
            .expect("sink open")
            .write_block(points, waveforms);
        self.spent += t.elapsed();
        self.cpu_s += thread_cpu() - c;
        self.points += points.len() as u64;
        r
    }
    fn finish(self: Box<Self>) -> io::Result<()> {
        Ok(())
    }
    fn discard(self: Box<Self>) {}
}

fn main() {
    let survey = Survey::from_raw(lidarsim::demo::demo_survey(), None).expect("demo survey");
    let bvh = Bvh::build(survey.scene.clone());
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/bench-outputs");
    std::fs::create_dir_all(&dir).expect("output directory");
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let base = las_settings(&survey, &bvh);
    let digitizer = lidarsim::run::digitizer(&survey, &bvh);
    let cases: [(&str, &[&str]); 6] = [
        ("las", &["points.las"]),
        ("laz", &["points.laz"]),
        ("las-waveform", &["points.las", "points.wdp"]),
        ("laz-waveform", &["points.laz", "points.wdp"]),
        ("ply", &["points.ply"]),
        ("xyz", &["points.xyz"]),
    ];
    for (format, files) in cases {
        let path = dir.join(files[0]);
        let sink: Box<dyn PointSink> = match format {
            "las" => Box::new(LasWriter::create(&path, base.clone()).unwrap()),
            "laz" => Box::new(
                LasWriter::create(
                    &path,
                    LasSettings {
                        compressed: true,
                        ..base.clone()
                    },
                )
                .unwrap(),
            ),
            "las-waveform" => Box::new(
                LasWriter::create(
                    &path,
                    LasSettings {
                        waveform: Some(digitizer),
                        ..base.clone()
                    },
                )
                .unwrap(),
            ),
            "laz-waveform" => Box::new(
                LasWriter::create(
                    &path,
                    LasSettings {
                        compressed: true,
                        waveform: Some(digitizer),
                        ..base.clone()
                    },
                )
                .unwrap(),
            ),
            "ply" => Box::new(PlyWriter::create(&path, [0.0; 3]).unwrap()),
            _ => Box::new(XyzWriter::create(&path, [0.0; 3]).unwrap()),
        };
        let mut timed = Timed {
            inner: Some(sink),
            spent: Duration::ZERO,
            cpu_s: 0.0,
            points: 0,
        };
        let sim = Simulator::new(&survey, &bvh).with_waveforms(true);
        sim.run(threads, &mut [&mut timed], &|_| {}).expect("run");
        let (t, c) = (Instant::now(), thread_cpu());
        timed.inner.take().unwrap().finish().expect("finish");
        let spent = timed.spent + t.elapsed();
        let cpu_s = timed.cpu_s + thread_cpu() - c;
        let bytes: u64 = files
            .iter()
            .map(|f| std::fs::metadata(dir.join(f)).map_or(0, |m| m.len()))
            .sum();
        println!(
            "{format}: files {} size_mb {:.1} bytes_per_point {:.1} write_s {:.2} points_per_s {:.0} \
             cpu_s {:.2} points_per_cpu_s {:.0} points {}",
            files.join("+"),
            bytes as f64 / 1e6,
            bytes as f64 / timed.points as f64,
            spent.as_secs_f64(),
            timed.points as f64 / spent.as_secs_f64(),
            cpu_s,
            timed.points as f64 / cpu_s,
            timed.points
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
