//! The twin round trip (issue 45): a known stand flown by lidarsim with
//! one setup is the "real" scan; `twin` reads it back — trees, ground,
//! acquisition — within stated tolerances; the twin's survey, flown
//! again, gives a cloud whose metrics agree with the first one's within
//! their sampling spread (`compare`'s paired cells).

use lidarsim::compare::{CompareOptions, compare};
use lidarsim::output::PointRecord;
use lidarsim::scan::{ScanCloud, scan_from_records};
use lidarsim::scene::Shape;
use lidarsim::sim::simulate_world_to_memory;
use lidarsim::twin::acquisition::combine::{Deflector, Flight};
use lidarsim::twin::{TwinOptions, twin, write::write_twin};
use lidarsim::{Survey, World};

/// The tile the "real" scan is cut to: the stand's core, m.
const TILE: [f64; 4] = [-45.0, -45.0, 45.0, 45.0];

/// The known setup: two lines 90 m apart flown in opposite directions
/// 450 m above a generated terrain (relief 6 m) with a pine stand.
const STAND: &str = r#"
seed = 45
[scanner]
prf_hz = 80000
scan_frequency_hz = 40
scan_angle_deg = 15
max_returns = 5
subrays = 7
[[flight_line]]
start_m = [-45.0, -160.0, 455.0]
end_m = [-45.0, 160.0, 455.0]
speed_mps = 60.0
[[flight_line]]
start_m = [45.0, 160.0, 455.0]
end_m = [45.0, -160.0, 455.0]
speed_mps = 60.0
[materials.ground]
reflectance = 0.25
[[terrain]]
generator = "fbm"
extent_m = [-120, -120, 120, 120]
resolution_m = 2
relief_m = 6
seed = 3
material = "ground"
[[forest]]
rectangle_m = [-60, -60, 60, 60]
stems_per_ha = 150
height_m = [12, 26]
min_spacing_m = 5
seed = 8
"#;

/// A tree of the known stand: stem base, height, crown base height and
/// radius.
#[derive(Debug)]
struct Truth {
    x: f64,
    y: f64,
    z_top: f64,
    height: f64,
    crown_base_z: f64,
    crown_radius: f64,
}

impl Truth {
    /// The crown envelope's radius at height `z` (pine: r(χ) = a + b·χ^0.6,
    /// a = 0.1 of the radius; `docs/survey.md`, "Trees and the beam").
    fn radius_at(&self, z: f64) -> f64 {
        if z > self.z_top || z < self.crown_base_z {
            return 0.0;
        }
        let chi = (self.z_top - z) / (self.z_top - self.crown_base_z);
        self.crown_radius * (0.1 + 0.9 * chi.powf(0.6))
    }

    /// Whether another tree's crown covers this one's top from above: no
    /// scan sees such a tree's top.
    fn overtopped(&self, all: &[Truth]) -> bool {
        all.iter().any(|o| {
            o.z_top > self.z_top && (o.x - self.x).hypot(o.y - self.y) < o.radius_at(self.z_top)
        })
    }
}

/// The stand's trees: each tree's trunk (its box spans the stem from its
/// base to the top) and crown (its box, the envelope) are the scene's
/// primitives of one object.
fn truth(world: &World) -> Vec<Truth> {
    let prims = &world.scene().primitives;
    let crown = |object| {
        prims
            .iter()
            .find(|p| p.object == object && matches!(p.shape, Shape::Crown(_)))
            .map(|p| p.bounds())
    };
    prims
        .iter()
        .filter(|p| matches!(p.shape, Shape::Trunk(_)))
        .filter_map(|p| {
            let (b, c) = (p.bounds(), crown(p.object)?);
            Some(Truth {
                x: 0.5 * (b.min.x + b.max.x),
                y: 0.5 * (b.min.y + b.max.y),
                z_top: b.max.z,
                height: b.max.z - b.min.z,
                crown_base_z: c.min.z,
                crown_radius: 0.5 * (c.max.x - c.min.x),
            })
        })
        .collect()
}

/// Within the tile, with `margin` m to spare.
fn inside(x: f64, y: f64, margin: f64) -> bool {
    x >= TILE[0] + margin && x <= TILE[2] - margin && y >= TILE[1] + margin && y <= TILE[3] - margin
}

/// A survey's points in the tile, as a scan.
fn fly(survey: &Survey, world: &World, name: &str) -> ScanCloud {
    let points: Vec<PointRecord> = simulate_world_to_memory(survey, world, 2)
        .into_iter()
        .filter(|p| inside(p.position_m.x, p.position_m.y, 0.0))
        .collect();
    scan_from_records(name, &points)
}

#[test]
fn a_known_stand_is_twinned_and_its_twin_flies_like_it() {
    let survey = Survey::from_toml(STAND, None).unwrap();
    let world = World::build(&survey).unwrap();
    let real = fly(&survey, &world, "stand");
    let made = twin(&real, &TwinOptions::default(), &|_, _| {}).unwrap();
    check_trees(&truth(&world), &made);
    check_acquisition(&real, &made);

    let dir = std::env::temp_dir().join(format!("lidarsim-twin-{}", std::process::id()));
    let path = write_twin(&made, &dir, false).unwrap();
    let again = Survey::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let again_world = World::build(&again).unwrap_or_else(|e| panic!("{e}"));
    // The twin's points are written with [output] offset_m added: shift
    // them back to the scan's coordinates.
    let mut twin_cloud = {
        let offset = again.output.offset_m;
        let mut points = simulate_world_to_memory(&again, &again_world, 2);
        points.iter_mut().for_each(|p| p.position_m += offset);
        points.retain(|p| inside(p.position_m.x, p.position_m.y, 0.0));
        scan_from_records("twin", &points)
    };
    twin_cloud.name = "twin".into();
    check_metrics(&real, &twin_cloud);
    std::fs::remove_dir_all(&dir).ok();
}

/// Tree count within 15 % of the stand's trees in the tile that no taller
/// crown covers; of those 5 m inside it, 85 % have a detected top within
/// 2 m; their heights biased by −1.5 to +0.3 m (the highest return lies
/// below the apex: `docs/validation.md`, section 1) with an RMS error
/// under 1.5 m; their crown radii a median 0.8 to 1.2 times the true ones;
/// their crown bases biased by −1 to +1.5 m (the lowest foliage is sparse
/// and returns little).
fn check_trees(all: &[Truth], made: &lidarsim::twin::Twin) {
    let truth: Vec<&Truth> = all.iter().filter(|t| !t.overtopped(all)).collect();
    let in_tile = truth.iter().filter(|t| inside(t.x, t.y, 0.0)).count();

    let found = made.trees.len();
    assert!(
        (found as f64 - in_tile as f64).abs() <= 0.15 * in_tile as f64,
        "{found} trees found, {in_tile} in the tile"
    );
    let core: Vec<&&Truth> = truth.iter().filter(|t| inside(t.x, t.y, 5.0)).collect();
    // Per matched tree: height error, crown radius over the true one,
    // crown base error.
    let errors: Vec<[f64; 3]> = core
        .iter()
        .filter_map(|t| {
            let nearest = made.trees.iter().min_by(|a, b| {
                let d = |m: &&lidarsim::twin::trees::TwinTree| (m.x_m - t.x).hypot(m.y_m - t.y);
                d(a).total_cmp(&d(b))
            })?;
            let base = t.crown_base_z - (t.z_top - t.height);
            ((nearest.x_m - t.x).hypot(nearest.y_m - t.y) <= 2.0).then(|| {
                [
                    nearest.height_m - t.height,
                    nearest.crown_radius_m / t.crown_radius,
                    nearest.crown_base_m - base,
                ]
            })
        })
        .collect();
    let matched = errors.len() as f64 / core.len() as f64;
    // The figures docs/validation.md quotes (`-- --nocapture`).
    eprintln!(
        "trees: {found} found, {in_tile} in the tile not overtopped; {} of {} core trees matched",
        errors.len(),
        core.len()
    );
    assert!(
        matched >= 0.85,
        "{} of {} core trees matched",
        errors.len(),
        core.len()
    );
    let heights: Vec<f64> = errors.iter().map(|e| e[0]).collect();
    let bias = heights.iter().sum::<f64>() / heights.len() as f64;
    let rms = (heights.iter().map(|e| e * e).sum::<f64>() / heights.len() as f64).sqrt();
    assert!((-1.5..=0.3).contains(&bias), "height bias {bias} m");
    assert!(rms < 1.5, "height RMS error {rms} m");
    let mut ratios: Vec<f64> = errors.iter().map(|e| e[1]).collect();
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    assert!(
        (0.8..=1.2).contains(&median),
        "crown radius over the true one: median {median}"
    );
    let base = errors.iter().map(|e| e[2]).sum::<f64>() / errors.len() as f64;
    eprintln!(
        "height bias {bias:.2} m, RMS {rms:.2} m; crown radius median {median:.2} of the truth; \
         crown base bias {base:.2} m"
    );
    assert!((-1.0..=1.5).contains(&base), "crown base bias {base} m");
}

/// The acquisition as flown: two lines, 0° and 180°, 60 m/s within 2 %,
/// 450 m above the ground within 3 % (the ground of the tile's ground
/// points), 40 Hz within 1 %, ±15° within 0.5°, an oscillating mirror,
/// 80 kHz within 6 % (the PRF comes from the density), the lines 90 m
/// apart within 2 m.
fn check_acquisition(real: &ScanCloud, made: &lidarsim::twin::Twin) {
    let a = &made.acquisition;
    let Flight::Lines(lines) = &a.flight else {
        panic!("lines planned, not read: {:?}", a.notes)
    };
    assert_eq!(lines.len(), 2, "{:?}", a.strips);
    let ground: Vec<f64> = (0..real.len())
        .filter(|&k| real.classification[k] == 2)
        .map(|k| real.z[k])
        .collect();
    let ground_z = ground.iter().sum::<f64>() / ground.len() as f64;
    let height = 455.0 - ground_z;
    for s in &a.strips {
        let t = s.track.as_ref().expect("a track");
        let heading = t.heading_deg.rem_euclid(180.0);
        assert!(
            heading.min(180.0 - heading) < 1.0,
            "heading {}",
            t.heading_deg
        );
        assert!(
            (t.speed_mps / 60.0 - 1.0).abs() < 0.02,
            "speed {}",
            t.speed_mps
        );
        assert!(
            (t.height_m / height - 1.0).abs() < 0.03,
            "height {} against {height}",
            t.height_m
        );
    }
    let sc = &a.scanner;
    eprintln!(
        "acquisition: {:?}; {} Hz, ±{} deg, PRF {} Hz; spacing {:?}",
        a.strips
            .iter()
            .map(|s| s.track.as_ref().map(|t| (
                t.heading_deg.round(),
                (t.speed_mps * 10.0).round() / 10.0,
                t.height_m.round()
            )))
            .collect::<Vec<_>>(),
        sc.scan_frequency_hz.value,
        sc.scan_angle_deg.value,
        sc.prf_hz.value.round(),
        a.line_spacing
            .iter()
            .map(|s| s.distance_m)
            .collect::<Vec<_>>()
    );
    assert_eq!(sc.deflector, Deflector::Oscillating);
    assert!(
        (sc.scan_frequency_hz.value / 40.0 - 1.0).abs() < 0.01,
        "{:?}",
        sc.scan_frequency_hz
    );
    assert!(
        (sc.scan_angle_deg.value - 15.0).abs() <= 0.5,
        "{:?}",
        sc.scan_angle_deg
    );
    assert!(
        (sc.prf_hz.value / 80_000.0 - 1.0).abs() < 0.06,
        "{:?}",
        sc.prf_hz
    );
    assert_eq!(a.line_spacing.len(), 1);
    assert!(
        (a.line_spacing[0].distance_m - 90.0).abs() < 2.0,
        "{:?}",
        a.line_spacing
    );
}

/// The twin's flight against the scan, cell by cell (15 m cells, 36 of
/// them). What the acquisition and the trees' positions, heights and
/// crown sizes decide agrees within a third of the cells' own spread
/// (the standard deviation of the scan's cell values): pulse density,
/// the share of first returns on the ground, canopy cover and the
/// first-return height percentiles P25 to P99 (the twin's crowns are
/// envelopes rebuilt from the canopy height model, their edges as opaque
/// as their middle: where the first returns of the lower canopy fall
/// depends on how well their radii and bases are read). How deep pulses go into the
/// crowns depends on the crowns' length and shape, which the twin rebuilds
/// only roughly (crown bases from the lowest returns, `docs/validation.md`):
/// returns per pulse within 0.25 and the share of canopy pulses reaching
/// the ground within 15 points.
fn check_metrics(real: &ScanCloud, twin: &ScanCloud) {
    let options = CompareOptions {
        cell_m: 15.0,
        ..CompareOptions::default()
    };
    let c = compare(real, twin, &options).unwrap();
    let report = lidarsim::compare::table::text(&c);
    eprintln!("{report}");
    assert!(c.cells.metrics[0].pairs >= 30, "{report}");
    for key in [
        "pulse_density_per_m2",
        "first_ground_share",
        "canopy_cover",
        "first_p25",
        "first_p50",
        "first_p75",
        "first_p95",
        "first_p99",
    ] {
        let m = c.cells.metrics.iter().find(|m| m.key == key).unwrap();
        let (d, sd) = (m.mean_difference.unwrap(), m.sd_a.unwrap());
        assert!(
            d.abs() < sd / 3.0,
            "{key}: mean difference {d} against the cells' sd {sd}\n{report}"
        );
    }
    let value = |side: usize, key: &str| {
        let m = lidarsim::compare::metrics::SCALARS
            .iter()
            .position(|s| s.key == key)
            .unwrap();
        c.values[side][m].unwrap()
    };
    for (key, margin) in [("returns_per_pulse", 0.25), ("canopy_ground_reach", 0.15)] {
        let (a, b) = (value(0, key), value(1, key));
        assert!((b - a).abs() <= margin, "{key}: {a} against {b}\n{report}");
    }
}
