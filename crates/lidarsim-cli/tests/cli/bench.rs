//! `lidarsim bench`: figures a script can read.

use crate::kit::{bin, temp};

/// `lidarsim bench` on short flat runs, 1, 2, 1 and 2 threads: one `scene
/// key value` line per figure, each a number a script can parse, and the
/// same LAS on 1 and 2 threads. Nothing here depends on how fast the
/// machine was: the figures' arithmetic is tested on fixed measurements
/// (`bench_figures_are_computed_from_the_measurements` in src/bench.rs).
#[test]
fn bench_prints_figures_a_script_can_read() {
    let dir = temp("bench");
    let o = bin()
        .args([
            "bench",
            "--scene",
            "flat",
            "--threads",
            "1,2,1,2",
            "--pulses",
            "20000",
        ])
        .arg("--work-dir")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let value = |key: &str| -> String {
        let line = text
            .lines()
            .find(|l| l.strip_prefix("flat ").is_some_and(|r| r.starts_with(key)))
            .unwrap_or_else(|| panic!("no `flat {key}` line in\n{text}"));
        line.rsplit(' ').next().unwrap().to_string()
    };
    let num = |key: &str| {
        let v = value(key).parse::<f64>().unwrap();
        assert!(v.is_finite() && v >= 0.0, "`flat {key}` is {v}\n{text}");
        v
    };
    assert_eq!(num("primitives "), 62.0);
    for t in [1, 2] {
        assert_eq!(num(&format!("threads {t} pulses ")), 20000.0);
        for key in [
            "seconds",
            "pulses_per_s",
            "rays_per_s",
            "points_per_s",
            "cpu_s",
            "cores_busy",
            "write_cpu_s",
        ] {
            num(&format!("threads {t} {key} "));
        }
    }
    for key in [
        "load_s ",
        "scaling_1_to_2 ",
        "scaling_1_to_2_at_equal_cpu ",
        "scaling_1_to_2_median ",
        "peak_rss_mb ",
    ] {
        num(key);
    }
    assert_eq!(num("scaling_pairs "), 2.0);
    let hashes: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("flat threads "))
        .filter(|l| l.contains(" las_fnv1a "))
        .filter_map(|l| l.rsplit(' ').next())
        .collect();
    assert_eq!(hashes.len(), 4, "{text}");
    assert!(
        hashes.iter().all(|h| *h == hashes[0]),
        "thread counts must write the same LAS: {hashes:?}"
    );
    assert_eq!(value("identical_output "), "true");
    let _ = std::fs::remove_dir_all(&dir);
}
