//! Output benchmark: file size and write rate of each point format for the
//! built-in demo (1.5 million pulses).
//!
//! Run with `cargo bench -p lidarsim-bench --bench outputs` (or
//! `scripts/bench_outputs.sh`). The demo is simulated once per format on
//! all cores with waveform recording on (so every run does the same work),
//! and the one writer is wrapped in a sink that times only the calls into
//! it: the write rate is points per second of writer time (encoding,
//! compression, waveform quantisation and I/O into the page cache, plus
//! the final header rewrite and fsync), not of simulation, on the wall
//! clock (which includes waits for a core and for the disk) and in the
//! CPU time of the thread that writes. Prints plain `key value` lines.

use std::path::Path;

use lidarsim::Survey;
use lidarsim::files::las_settings;
use lidarsim::output::{FileSink, LasSettings, LasWriter, PlyWriter, XyzWriter};
use lidarsim::sim::Simulator;
use lidarsim::world::World;
use lidarsim_bench::TimedSink;

fn main() {
    let survey = Survey::from_raw(lidarsim::demo::demo_survey(), None).expect("demo survey");
    let world = World::build(&survey).expect("world");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/bench-outputs");
    std::fs::create_dir_all(&dir).expect("output directory");
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let base = las_settings(&survey, &world);
    let digitizer = lidarsim::files::digitizer(&survey, &world);
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
        let sink: Box<FileSink> = match format {
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
        let mut timed = TimedSink::new(sink);
        let sim = Simulator::new(&survey, &world).with_waveforms(true);
        sim.run(threads, &mut [&mut timed], &|_| {}).expect("run");
        let w = timed.finish_timed().expect("finish");
        let cpu_s = w.cpu_s.unwrap_or(0.0);
        let bytes: u64 = files
            .iter()
            .map(|f| std::fs::metadata(dir.join(f)).map_or(0, |m| m.len()))
            .sum();
        println!(
            "{format}: files {} size_mb {:.1} bytes_per_point {:.1} write_s {:.2} points_per_s {:.0} \
             cpu_s {:.2} points_per_cpu_s {:.0} points {}",
            files.join("+"),
            bytes as f64 / 1e6,
            bytes as f64 / w.points as f64,
            w.seconds,
            w.points as f64 / w.seconds,
            cpu_s,
            w.points as f64 / cpu_s,
            w.points
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
