//! GNSS/IMU errors against analytic error propagation (issue 4): rays are
//! cast from the true pose, points computed from the observed one.

use lidarsim::Survey;
use lidarsim::accel::Bvh;
use lidarsim::output::{MemorySink, PointRecord};
use lidarsim::sim::Simulator;

const H: f64 = 500.0;

fn survey(extra: &str, scanner: &str) -> Survey {
    let text = format!(
        r#"
seed = 9
{extra}
[scanner]
prf_hz = 20000
scan_angle_deg = 20
subrays = 1
{scanner}
[[flight_line]]
start_m = [0.0, -30.0, {H}]
end_m = [0.0, 30.0, {H}]
speed_mps = 50.0
[materials.grass]
reflectance = 0.4
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-1000, -1000, 0], [1000, -1000, 0], [1000, 1000, 0], [-1000, 1000, 0]]
"#
    );
    Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"))
}

fn simulate(s: &Survey) -> Vec<PointRecord> {
    let bvh = Bvh::build(s.scene.clone());
    let sim = Simulator::new(s, &bvh);
    let mut sink = MemorySink::default();
    sim.run(2, &mut [&mut sink], &|_| {}).unwrap();
    sink.points
}

/// Points of the error-free survey and of the one with `extra`, pulse by
/// pulse (the rays are the same: they come from the true pose).
fn pairs(extra: &str) -> Vec<(PointRecord, PointRecord)> {
    let a = simulate(&survey("", ""));
    let b = simulate(&survey(extra, ""));
    assert_eq!(a.len(), b.len());
    a.into_iter().zip(b).collect()
}

#[test]
fn gnss_bias_shifts_the_cloud_by_the_bias() {
    for (t, e) in pairs("[gnss]\nbias_m = [0.3, -0.2, 0.15]") {
        let d = e.position_m - t.position_m;
        assert!((d.x - 0.3).abs() < 1e-3 && (d.y + 0.2).abs() < 1e-3 && (d.z - 0.15).abs() < 1e-3);
        assert!((e.error_m - d).length() < 1e-9, "error vector = the shift");
    }
}

#[test]
fn roll_bias_tilts_the_cloud_across_track() {
    let delta = 0.2f64.to_radians();
    let (mut sxx, mut sxz, mut sx, mut sz, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (t, e) in pairs("[imu]\nbias_deg = [0.2, 0.0, 0.0]") {
        let alpha = (t.position_m.x / H).atan(); // to the right (east) positive
        let range = H / alpha.cos();
        // Rolling right wing down turns the beam to the left by δ about the
        // sensor: the point moves along the circle of radius `range`.
        let want = range * ((alpha - delta).sin() - alpha.sin());
        let dx = e.position_m.x - t.position_m.x;
        assert!((dx - want).abs() < 1e-3, "{dx} vs {want}");
        // The issue's first-order picture: about H (tan(θ+δ) − tan θ).
        let first_order = H * ((alpha - delta).tan() - alpha.tan());
        assert!((dx - first_order).abs() < 0.15 * first_order.abs());
        let (x, z) = (e.position_m.x, e.position_m.z);
        sxx += x * x;
        sxz += x * z;
        sx += x;
        sz += z;
        n += 1.0;
    }
    // The level ground comes out as a plane tilted by δ across track
    // (rotated about the sensor: the right side comes out lower).
    let slope = (n * sxz - sx * sz) / (n * sxx - sx * sx);
    assert!((slope + delta.tan()).abs() < 0.01 * delta.tan(), "{slope}");
}

#[test]
fn pitch_bias_shifts_along_track() {
    let delta = 0.1f64.to_radians();
    for (t, e) in pairs("[imu]\nbias_deg = [0.0, 0.1, 0.0]") {
        let dy = e.position_m.y - t.position_m.y;
        // Nose up turns the beam forwards: Δy = H sin δ exactly for a level
        // plane below, ≈ H tan δ.
        assert!((dy - H * delta.sin()).abs() < 1e-3, "{dy}");
        assert!((dy - H * delta.tan()).abs() < 0.01 * H * delta.tan());
    }
}

fn rms_dz(extra: &str) -> f64 {
    let p = pairs(extra);
    let sum: f64 = p
        .iter()
        .map(|(t, e)| (e.position_m.z - t.position_m.z).powi(2))
        .sum();
    (sum / p.len() as f64).sqrt()
}

#[test]
fn white_noise_propagates_to_the_heights() {
    // GNSS height noise goes straight into the heights.
    let got = rms_dz("[gnss]\nsigma_m = [0.0, 0.0, 0.05]");
    assert!((got - 0.05).abs() < 0.1 * 0.05, "{got}");
    // Roll noise ε moves a point at angle α by R(cos α − cos(α − ε)) ≈
    // H tan α · ε vertically: RMS = H σ √(mean tan² α) over the swath.
    let sigma = 0.01f64.to_radians();
    let s = survey("", "");
    let pts = simulate(&s);
    let mean_tan2 = pts
        .iter()
        .map(|p| (p.position_m.x / H).powi(2))
        .sum::<f64>()
        / pts.len() as f64;
    let want = H * sigma * mean_tan2.sqrt();
    let got = rms_dz("[imu]\nsigma_deg = [0.01, 0.0, 0.0]");
    assert!((got - want).abs() < 0.1 * want, "{got} vs {want}");
    // Ranging noise: a range error moves the point along the beam,
    // vertically by σ cos α.
    let got = rms_dz("[ranging]\nsigma_m = 0.03");
    let mean_cos2 = pts
        .iter()
        .map(|p| 1.0 / (1.0 + (p.position_m.x / H).powi(2)))
        .sum::<f64>()
        / pts.len() as f64;
    let want = 0.03 * mean_cos2.sqrt();
    assert!((got - want).abs() < 0.1 * want, "{got} vs {want}");
}

/// Mean height residual of roof points against the true gabled roof, per
/// roof plane (west-, east-facing) and flight line (northbound, southbound).
fn roof_residuals(extra: &str) -> [[f64; 2]; 2] {
    // A gabled roof: ridge along y at x = 0, z = 12, eaves at x = ±10, z = 6.
    let text = format!(
        r#"
seed = 2
{extra}
[scanner]
prf_hz = 50000
scan_angle_deg = 15
subrays = 1
[[flight_line]]
start_m = [-60.0, -40.0, {H}]
end_m = [-60.0, 40.0, {H}]
speed_mps = 60.0
[[flight_line]]
start_m = [60.0, 40.0, {H}]
end_m = [60.0, -40.0, {H}]
speed_mps = 60.0
[materials.tiles]
reflectance = 0.3
[materials.grass]
reflectance = 0.4
[[polygon]]
material = "tiles"
class = "roof"
vertices_m = [[-10, -20, 6], [0, -20, 12], [0, 20, 12], [-10, 20, 6]]
[[polygon]]
material = "tiles"
class = "roof"
vertices_m = [[10, -20, 6], [0, -20, 12], [0, 20, 12], [10, 20, 6]]
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-500, -500, 0], [500, -500, 0], [500, 500, 0], [-500, 500, 0]]
"#
    );
    let s = Survey::from_toml(&text, None).unwrap();
    let pts = simulate(&s);
    let roof = |x: f64| 12.0 - 0.6 * x.abs();
    let mut sums = [[(0.0, 0.0); 2]; 2];
    for p in pts.iter().filter(|p| p.classification == 6) {
        // Stay clear of the ridge and the eaves.
        let x = p.position_m.x;
        if !(1.5..8.5).contains(&x.abs()) || p.position_m.y.abs() > 15.0 {
            continue;
        }
        let plane = usize::from(x > 0.0);
        let line = usize::from(p.point_source_id) - 1;
        sums[plane][line].0 += p.position_m.z - roof(x);
        sums[plane][line].1 += 1.0;
    }
    sums.map(|plane| {
        plane.map(|(sum, n)| {
            assert!(n > 500.0, "{n} roof points");
            sum / n
        })
    })
}

#[test]
fn boresight_error_shows_as_a_strip_discrepancy_on_a_roof() {
    for [a, b] in roof_residuals("") {
        assert!((a - b).abs() < 0.005, "no boresight: {a} vs {b}");
        assert!(a.abs() < 0.005 && b.abs() < 0.005);
    }
    // A 0.05° roll misalignment: opposite flight directions push the two
    // strips apart across track by about 2 H δ = 0.87 m; on roof planes
    // sloping 0.6 that is a height discrepancy of about 0.6 × 0.87 = 0.52 m
    // between the strips, of opposite sign on the two roof planes.
    let [west, east] = roof_residuals("[boresight]\nangles_deg = [0.05, 0.0, 0.0]");
    let expected = 0.6 * 2.0 * H * 0.05f64.to_radians();
    for (name, [a, b]) in [("west", west), ("east", east)] {
        assert!(
            ((a - b).abs() - expected).abs() < 0.15 * expected,
            "{name}: {a} vs {b}"
        );
    }
    assert!((west[0] - west[1]) * (east[0] - east[1]) < 0.0);
}
