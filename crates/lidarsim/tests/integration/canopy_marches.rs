//! The pulse march against the reference march (issue 25): over one stand,
//! flown twice with independent random numbers, the statistics a forestry
//! user takes from a point cloud agree within sampling error — the
//! return-number distribution (χ² test of homogeneity), first-return canopy
//! cover and the share of pulses under canopy that reach the ground
//! (two-proportion z-tests) and the heights of the first vegetation echo
//! (two-sample Kolmogorov–Smirnov test), each at the 0.1 % level.

use lidarsim::Survey;
use lidarsim::output::{Component, PointRecord};
use lidarsim::sim::simulate_world_to_memory;
use lidarsim::world::World;

/// LAS class of ground points (LAS 1.4 R15, Table 17).
const GROUND: u8 = 2;

/// Points of the test stand flown with `march` and survey seed `seed`.
fn fly(march: &str, seed: u64) -> Vec<PointRecord> {
    let text = format!(
        r#"
seed = {seed}
[scanner]
prf_hz = 50000
scan_frequency_hz = 100
scan_angle_deg = 4.0
divergence_mrad = 0.5
subrays = 19
max_returns = 5
[vegetation]
march = "{march}"
[[flight_line]]
start_m = [0.0, -30.0, 500.0]
end_m = [0.0, 30.0, 500.0]
speed_mps = 50.0
[materials.grass]
reflectance = 0.3
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]]
[[forest]]
rectangle_m = [-60.0, -60.0, 60.0, 60.0]
stems_per_ha = 600
species = {{ pine = 0.5, spruce = 0.3, birch = 0.2 }}
height_m = [12.0, 26.0]
min_spacing_m = 2.0
seed = 3
"#
    );
    let s = Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"));
    let w = World::build(&s).unwrap_or_else(|e| panic!("{e}"));
    simulate_world_to_memory(&s, &w, 2)
}

/// What is compared, from one flight.
struct Figures {
    /// Pulses with 1, 2, 3, 4 and 5 returns.
    returns: [u64; 5],
    /// First returns, and those more than 2 m above the (flat) ground.
    first: (u64, u64),
    /// Pulses whose first return is vegetation, and those of them with a
    /// ground return.
    under_canopy: (u64, u64),
    /// Heights of the first return of pulses whose first return is
    /// vegetation.
    heights: Vec<f64>,
}

fn figures(points: &[PointRecord]) -> Figures {
    let mut f = Figures {
        returns: [0; 5],
        first: (0, 0),
        under_canopy: (0, 0),
        heights: Vec::new(),
    };
    let mut pulse: Vec<&PointRecord> = Vec::new();
    let close = |pulse: &[&PointRecord], f: &mut Figures| {
        let Some(first) = pulse.first() else { return };
        f.returns[pulse.len().min(5) - 1] += 1;
        f.first.0 += 1;
        if first.position_m.z > 2.0 {
            f.first.1 += 1;
        }
        if first.component != Component::Surface && first.classification != GROUND {
            f.under_canopy.0 += 1;
            if pulse.iter().any(|p| p.classification == GROUND) {
                f.under_canopy.1 += 1;
            }
            f.heights.push(first.position_m.z);
        }
    };
    for p in points {
        if p.return_number == 1 {
            close(&pulse, &mut f);
            pulse.clear();
        }
        pulse.push(p);
    }
    close(&pulse, &mut f);
    f
}

/// χ² statistic of homogeneity of two rows of counts (columns with no
/// count in either row left out) and its degrees of freedom.
fn chi_square(a: &[u64], b: &[u64]) -> (f64, usize) {
    let (na, nb) = (a.iter().sum::<u64>() as f64, b.iter().sum::<u64>() as f64);
    let mut chi = 0.0;
    let mut cols = 0;
    for (&x, &y) in a.iter().zip(b) {
        let col = (x + y) as f64;
        if col == 0.0 {
            continue;
        }
        cols += 1;
        for (obs, n) in [(x as f64, na), (y as f64, nb)] {
            let expected = col * n / (na + nb);
            chi += (obs - expected).powi(2) / expected;
        }
    }
    (chi, cols - 1)
}

/// Upper 0.1 % points of χ² for 1 to 4 degrees of freedom.
const CHI2_999: [f64; 4] = [10.828, 13.816, 16.266, 18.467];

/// z statistic of two proportions `(n, k)` (pooled standard error).
fn two_proportions((n1, k1): (u64, u64), (n2, k2): (u64, u64)) -> f64 {
    let (p1, p2) = (k1 as f64 / n1 as f64, k2 as f64 / n2 as f64);
    let p = (k1 + k2) as f64 / (n1 + n2) as f64;
    (p1 - p2) / (p * (1.0 - p) * (1.0 / n1 as f64 + 1.0 / n2 as f64)).sqrt()
}

/// Two-sided 0.1 % point of the normal distribution.
const Z_999: f64 = 3.291;

/// Kolmogorov–Smirnov statistic of two samples.
fn ks(a: &[f64], b: &[f64]) -> f64 {
    let (mut a, mut b) = (a.to_vec(), b.to_vec());
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    let (mut i, mut j, mut d) = (0, 0, 0.0f64);
    while i < a.len() && j < b.len() {
        let x = a[i].min(b[j]);
        while i < a.len() && a[i] <= x {
            i += 1;
        }
        while j < b.len() && b[j] <= x {
            j += 1;
        }
        d = d.max((i as f64 / a.len() as f64 - j as f64 / b.len() as f64).abs());
    }
    d
}

/// Critical KS distance at the 0.1 % level: `1.949 √((n + m)/(n m))`.
fn ks_critical(n: usize, m: usize) -> f64 {
    1.949 * ((n + m) as f64 / (n * m) as f64).sqrt()
}

fn percentile(v: &[f64], q: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

#[test]
fn the_statistical_tests_tell_different_samples_apart() {
    // The tests below can fail: a return-number shift of 3 % of pulses
    // between 1 and 2 returns, a 2 % change of cover and a 0.3 m shift of
    // heights are all detected at these sample sizes.
    let a = [30_000, 12_000, 5_000, 2_000, 1_000];
    let b = [28_500, 13_500, 5_000, 2_000, 1_000];
    let (chi, df) = chi_square(&a, &b);
    assert!(chi > CHI2_999[df - 1], "χ² {chi}");
    assert!(two_proportions((50_000, 30_000), (50_000, 31_000)).abs() > Z_999);
    let h: Vec<f64> = (0..20_000)
        .map(|i| 10.0 + (i % 1000) as f64 * 0.01)
        .collect();
    let shifted: Vec<f64> = h.iter().map(|x| x + 0.3).collect();
    assert!(ks(&h, &shifted) > ks_critical(h.len(), shifted.len()));
    assert!(ks(&h, &h) < 1e-12);
}

#[test]
fn the_pulse_march_keeps_the_reference_statistics() {
    let reference = figures(&fly("sub-ray", 21));
    let pulse = figures(&fly("pulse", 22));
    let cover = |f: &Figures| f.first.1 as f64 / f.first.0 as f64;
    let ground = |f: &Figures| f.under_canopy.1 as f64 / f.under_canopy.0 as f64;
    println!(
        "returns per pulse: reference {:?}, pulse {:?}",
        reference.returns, pulse.returns
    );
    println!(
        "first-return cover {:.4} / {:.4}; ground under canopy {:.4} / {:.4}",
        cover(&reference),
        cover(&pulse),
        ground(&reference),
        ground(&pulse)
    );
    for q in [0.05, 0.25, 0.5, 0.75, 0.95] {
        println!(
            "first vegetation echo height p{:.0}: {:.2} / {:.2} m",
            q * 100.0,
            percentile(&reference.heights, q),
            percentile(&pulse.heights, q)
        );
    }
    assert!(reference.first.0 > 20_000 && reference.under_canopy.0 > 10_000);
    let (chi, df) = chi_square(&reference.returns, &pulse.returns);
    assert!(
        chi < CHI2_999[df - 1],
        "return numbers: χ² {chi} on {df} df"
    );
    let z = two_proportions(reference.first, pulse.first);
    assert!(z.abs() < Z_999, "first-return cover: z = {z}");
    let z = two_proportions(reference.under_canopy, pulse.under_canopy);
    assert!(z.abs() < Z_999, "ground under canopy: z = {z}");
    let (n, m) = (reference.heights.len(), pulse.heights.len());
    let d = ks(&reference.heights, &pulse.heights);
    assert!(d < ks_critical(n, m), "heights: KS {d} over {n} and {m}");
}
