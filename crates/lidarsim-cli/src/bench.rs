//! `lidarsim bench`: the benchmark scenes exported, or measured with one
//! `scene key value` line per figure.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::args::BenchArgs;
use crate::console::fail;

/// `lidarsim bench`: exit status 1 for any failure.
pub fn command(args: BenchArgs) -> ExitCode {
    let BenchArgs {
        export,
        scene,
        threads,
        work_dir,
        pulses,
    } = args;
    match bench(export, &scene, &threads, work_dir, pulses) {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => fail(1, &msg),
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
                BenchScene::from_name(n).ok_or_else(|| {
                    format!("unknown bench scene '{n}'; expected flat, terrain or forest")
                })
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

#[cfg(test)]
mod tests {
    use super::figure_lines;

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
