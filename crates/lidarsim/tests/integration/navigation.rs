//! GNSS/IMU errors against analytic error propagation (issue 4): rays are
//! cast from the true pose, points computed from the observed one.

use lidarsim::Survey;
use lidarsim::output::PointRecord;
use lidarsim::sim::simulate_to_memory;
use lidarsim::survey::SurveyError;
use lidarsim::world::World;

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

/// The world of a survey in TOML text: its lines planned over its scene.
fn world(text: &str) -> Result<World, SurveyError> {
    World::build(&Survey::from_toml(text, None)?)
}

fn simulate(s: &Survey) -> Vec<PointRecord> {
    simulate_to_memory(s, 2).unwrap()
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
    let mut worst = 0.0f64;
    for (t, e) in pairs("[gnss]\nbias_m = [0.3, -0.2, 0.15]") {
        let d = e.position_m - t.position_m;
        worst = worst.max((d - lidarsim::geometry::DVec3::new(0.3, -0.2, 0.15)).length());
        assert!((d.x - 0.3).abs() < 1e-3 && (d.y + 0.2).abs() < 1e-3 && (d.z - 0.15).abs() < 1e-3);
        assert!((e.error_m - d).length() < 1e-9, "error vector = the shift");
    }
    eprintln!(
        "figure: GNSS bias (0.3, -0.2, 0.15) m: largest deviation of the shift {worst:.2e} m"
    );
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
    eprintln!(
        "figure: roll bias 0.2°: fitted across-track slope {slope:.6} (−tan δ = {:.6})",
        -delta.tan()
    );
    assert!((slope + delta.tan()).abs() < 0.01 * delta.tan(), "{slope}");
}

#[test]
fn pitch_bias_shifts_along_track() {
    let delta = 0.1f64.to_radians();
    let p = pairs("[imu]\nbias_deg = [0.0, 0.1, 0.0]");
    let mean = p
        .iter()
        .map(|(t, e)| e.position_m.y - t.position_m.y)
        .sum::<f64>()
        / p.len() as f64;
    eprintln!(
        "figure: pitch bias 0.1°: mean along-track shift {mean:.4} m (H tan δ = {:.4} m)",
        H * delta.tan()
    );
    for (t, e) in p {
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
    eprintln!("figure: GNSS height noise 0.05 m: RMS height error {got:.4} m");
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
    eprintln!("figure: roll noise 0.01°: RMS height error {got:.4} m (propagated {want:.4} m)");
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
    eprintln!("figure: range noise 0.03 m: RMS height error {got:.4} m (propagated {want:.4} m)");
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
        eprintln!("figure: no boresight error: roof residuals per strip {a:.4} / {b:.4} m");
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
        eprintln!(
            "figure: boresight roll 0.05°, {name} roof plane: strips {a:.3} / {b:.3} m, \
             discrepancy {:.3} m (expected {expected:.3} m)",
            (a - b).abs()
        );
        assert!(
            ((a - b).abs() - expected).abs() < 0.15 * expected,
            "{name}: {a} vs {b}"
        );
    }
    assert!((west[0] - west[1]) * (east[0] - east[1]) < 0.0);
}

fn run_dir(s: &Survey, name: &str) -> std::path::PathBuf {
    let dir = crate::kit::fresh(name);
    crate::kit::run_into(s, &dir, 2);
    dir
}

#[test]
fn a_written_trajectory_flies_again_the_same() {
    // Fly two swaying lines, then fly the trajectory file they wrote: the
    // 1 ms samples, slerped, reproduce the points within a millimetre.
    let lines = format!(
        "[platform]\nsway = true\nroll_amplitude_deg = 1.0\nturn_time_s = 5\n\
         [[flight_line]]\nstart_m = [0.0, -20.0, {H}]\nend_m = [0.0, 20.0, {H}]\nspeed_mps = 50.0\n\
         [[flight_line]]\nstart_m = [30.0, 20.0, {H}]\nend_m = [30.0, -20.0, {H}]\nspeed_mps = 50.0\n"
    );
    let ground = "[materials.grass]\nreflectance = 0.4\n[[polygon]]\nmaterial = \"grass\"\n\
                  class = \"ground\"\nvertices_m = [[-900, -900, 0], [900, -900, 0], [900, 900, 0], [-900, 900, 0]]\n";
    let scanner = "[scanner]\nprf_hz = 20000\nscan_angle_deg = 20\nsubrays = 1\n";
    let a = Survey::from_toml(&format!("seed = 4\n{scanner}{lines}{ground}"), None).unwrap();
    let dir = run_dir(&a, "traj");
    let traj = dir.join("trajectory_true.csv");
    let text = format!(
        "seed = 4\n{scanner}[platform]\ntrajectory_file = \"{}\"\ninterpolation = \"spline\"\n{ground}",
        traj.display()
    );
    let b = Survey::from_toml(&text, None).unwrap();
    let lines_a = World::build(&a).unwrap().lines;
    let lines_b = World::build(&b).unwrap().lines;
    assert_eq!(lines_b.len(), 2);
    assert!((lines_b[1].start_time_s - lines_a[1].start_time_s).abs() < 1e-9);
    let (pa, pb) = (simulate(&a), simulate(&b));
    // The file ends at the last whole millisecond: compare the pulses both
    // flights emitted.
    assert!(pb.len() as f64 > 0.99 * pa.len() as f64);
    let mut compared = 0;
    for q in &pb {
        let p = pa
            .iter()
            .find(|p| p.point_source_id == q.point_source_id && p.pulse_index == q.pulse_index)
            .unwrap();
        assert!((p.position_m - q.position_m).length() < 1e-3);
        compared += 1;
        if compared > 2000 {
            break;
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn observed_trajectory_file_carries_the_bias() {
    let s = survey(
        "[gnss]\nbias_m = [0.0, 0.0, 0.4]\n[imu]\nbias_deg = [0.1, 0.0, 0.0]",
        "",
    );
    let dir = run_dir(&s, "obs");
    let read = |name: &str| -> Vec<Vec<f64>> {
        std::fs::read_to_string(dir.join(name))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
            .collect()
    };
    let (t, o) = (read("trajectory_true.csv"), read("trajectory_observed.csv"));
    assert_eq!(t.len(), o.len());
    for (a, b) in t.iter().zip(&o) {
        assert!((b[3] - a[3] - 0.4).abs() < 1e-4); // z
        assert!((b[4] - a[4] - 0.1).abs() < 1e-6); // roll, degrees
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_plan_covers_its_area_with_the_requested_overlap() {
    let text = r#"
[scanner]
prf_hz = 10000
scan_angle_deg = 20
subrays = 1
[plan]
rectangle_m = [0.0, 0.0, 800.0, 300.0]
altitude_m = 400.0
heading_deg = 90.0
side_overlap = 0.3
speed_mps = 70.0
run_in_m = 50.0
[materials.grass]
reflectance = 0.4
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-900, -900, 20], [900, -900, 20], [900, 900, 20], [-900, 900, 20]]
"#;
    let s = world(text).unwrap();
    // Eastbound (compass 90°) lines spaced W·(1 − 0.3), W = 2·400·tan 20°,
    // over the 300 m north–south extent, 400 m above the ground at z = 20.
    let w = 2.0 * 400.0 * 20f64.to_radians().tan();
    let n = (300.0 / (w * 0.7)).ceil() as usize;
    assert_eq!(s.lines.len(), n);
    for (k, l) in s.lines.iter().enumerate() {
        assert!((l.start_m.z - 420.0).abs() < 1e-9);
        assert!((l.length_m() - 900.0).abs() < 1e-6);
        let east = l.end_m.x > l.start_m.x;
        assert_eq!(east, k % 2 == 0, "back and forth");
    }
    let spacing = (s.lines[1].start_m.y - s.lines[0].start_m.y).abs();
    assert!((spacing - 0.7 * w).abs() < 1e-6);
}

#[test]
fn presets_and_key_errors() {
    let s = survey("preset = \"survey-grade\"", "");
    assert!(s.navigation.gnss.random_walk[2] > 0.0 && s.navigation.imu.sigma[0] > 0.0);
    let uav = survey("[gnss]\npreset = \"uav\"", "");
    assert!(uav.navigation.gnss.random_walk[0] >= 1.0 && uav.navigation.imu.is_zero());
    let bad = |extra: &str| {
        let text = format!(
            "{extra}\n[[flight_line]]\nstart_m = [0, 0, 100]\nend_m = [0, 10, 100]\nspeed_mps = 5\n\
             [materials.a]\nreflectance = 0.2\n[[polygon]]\nmaterial = \"a\"\n\
             vertices_m = [[-9, -9, 0], [9, -9, 0], [9, 9, 0]]\n"
        );
        Survey::from_toml(&text, None).unwrap_err().diagnostics[0]
            .key
            .clone()
    };
    assert_eq!(bad("preset = \"military\""), "preset");
    assert_eq!(bad("[gnss]\nsigma_deg = 0.1"), "gnss.sigma_deg");
    assert_eq!(bad("[imu]\nbias_deg = [1, 2]"), "imu.bias_deg");
    assert_eq!(
        bad("[boresight]\nlever_arm_m = [0.1]"),
        "boresight.lever_arm_m"
    );
    assert_eq!(bad("[ranging]\nsigma_m = -1"), "ranging.sigma_m");
    assert_eq!(bad("[platform]\ndrift_m = [1]"), "platform.drift_m");
}

#[test]
fn drift_moves_the_flown_path_but_not_the_georeferencing() {
    // Drift is real motion (true and observed alike): points stay on the
    // ground plane while the swath wanders.
    let s = survey("[platform]\ndrift_m = [5.0, 3.0]\ndrift_period_s = 2.0", "");
    let pts = simulate(&s);
    assert!(pts.iter().all(|p| p.position_m.z.abs() < 0.01));
    let plain = simulate(&survey("", ""));
    let moved = pts
        .iter()
        .zip(&plain)
        .filter(|(a, b)| (a.position_m.x - b.position_m.x).abs() > 0.5)
        .count();
    assert!(moved > pts.len() / 2);
}

#[test]
fn trajectory_files_are_checked() {
    let dir = std::env::temp_dir().join(format!("lidarsim-trajbad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let header = "time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,line\n";
    let cases = [
        (
            "0,0,0,100,0,0,0,0\n1,0,10,100,0,0,0,0.0\n2,0,20,100,0,0,0,1\n3,0,30,100,0,0,0,1\n",
            None,
        ),
        (
            "0,0,0,100,0,0,0,0\n1,0,10,100,0,0,0,1\n2,0,20,100,0,0,0,0\n",
            Some("appears again"),
        ),
        (
            "5,0,0,100,0,0,0,0\n6,0,10,100,0,0,0,0\n4,0,20,100,0,0,0,1\n",
            Some("starts before"),
        ),
        (
            "0,0,0,100,0,0,0,0\n1,0,x,100,0,0,0,0\n",
            Some("line 3: `y_m` is 'x'"),
        ),
    ];
    for (k, (rows, want)) in cases.iter().enumerate() {
        let f = dir.join(format!("t{k}.csv"));
        std::fs::write(&f, format!("{header}{rows}")).unwrap();
        let text = format!(
            "[platform]\ntrajectory_file = \"{}\"\n[materials.a]\nreflectance = 0.3\n[[polygon]]\n\
             material = \"a\"\nvertices_m = [[-99, -99, 0], [99, -99, 0], [99, 99, 0]]\n",
            f.display()
        );
        match (world(&text), want) {
            (Ok(s), None) => assert_eq!(s.lines.len(), 2, "0 and 0.0 are one line"),
            (Err(e), Some(w)) => {
                let d = &e.diagnostics[0];
                assert_eq!(d.key, "platform.trajectory_file");
                assert!(d.message.contains(w), "{}", d.message);
            }
            (r, w) => panic!("case {k}: {:?} / {w:?}", r.map(|s| s.lines.len())),
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
