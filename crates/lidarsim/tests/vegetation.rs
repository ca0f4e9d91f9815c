//! Trees end to end (issue 3): multiple returns from one crown, Beer–Lambert
//! penetration, vegetation points inside crowns, opaque trunks, classes.

use lidarsim::Survey;
use lidarsim::accel::{BruteForce, Bvh, RayCaster};
use lidarsim::geometry::{DVec3, Ray};
use lidarsim::output::PointRecord;
use lidarsim::scene::{Shape, Species};
use lidarsim::sim::{COMPONENT_FOLIAGE, COMPONENT_TRUNK, simulate_to_memory};

/// A survey with one northbound line at `x` from `y = -half` to `half`,
/// flown at `speed` m/s, 500 m above flat ground.
fn survey(scanner: &str, (x, half, speed): (f64, f64, f64), extra: &str) -> Survey {
    let text = format!(
        r#"
seed = 21
[scanner]
{scanner}
[[flight_line]]
start_m = [{x}, {y0}, 500.0]
end_m = [{x}, {half}, 500.0]
speed_mps = {speed}
[materials.grass]
reflectance = 0.3
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]]
{extra}
"#,
        y0 = -half
    );
    Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"))
}

fn simulate(s: &Survey) -> Vec<PointRecord> {
    simulate_to_memory(s, 2).unwrap()
}

/// Pulses grouped: (number of returns, classes) of each pulse.
fn per_pulse(points: &[PointRecord]) -> Vec<Vec<&PointRecord>> {
    let mut out: Vec<Vec<&PointRecord>> = Vec::new();
    for p in points {
        if p.return_number == 1 {
            out.push(Vec::new());
        }
        out.last_mut().unwrap().push(p);
    }
    out
}

const PINE: &str = r#"
[[tree]]
position_m = [0.0, 0.0, 0.0]
species = "pine"
dbh_m = 0.3
height_m = 20.0
crown_base_m = 10.0
"#;

#[test]
fn a_pulse_through_a_crown_gives_several_echoes() {
    // Nadir pulses (0.3 mrad, 19 sub-rays) over the crown centre, defaults.
    // A hovering platform (1 m/s) keeps the pulses within 5 cm of the spot.
    let s = survey("prf_hz = 20000\nscan_angle_deg = 0", (0.6, 0.05, 1.0), PINE);
    let points = simulate(&s);
    let pulses = per_pulse(&points);
    let multi = pulses.iter().filter(|p| p.len() > 1).count();
    assert!(
        multi as f64 > 0.6 * pulses.len() as f64,
        "{multi} of {} pulses with several echoes",
        pulses.len()
    );
    // The first echo comes from the crown, well above the ground.
    for p in &pulses {
        assert_eq!(p[0].component, COMPONENT_FOLIAGE);
        assert!(p[0].position_m.z > 10.0);
        assert_eq!(p[0].classification, 5); // high vegetation
    }
}

/// Path length of a vertical line at horizontal distance `d` from the stem
/// inside the envelope r(χ) = a + b χ^c of a crown of length `len`.
fn vertical_path(d: f64, a: f64, b: f64, c: f64, len: f64) -> f64 {
    let chi_min = if d <= a {
        0.0
    } else {
        ((d - a) / b).powf(1.0 / c)
    };
    (1.0 - chi_min.min(1.0)) * len
}

#[test]
fn ground_fraction_under_a_uniform_crown_is_beer_lambert() {
    // One sub-ray per pulse so that a pulse reaches the ground or not; no
    // energy loss on the way so that every pulse that gets through is seen.
    let (rho, radius, len, offset) = (0.4, 2.0, 10.0, 0.7);
    let p = Species::Spruce.preset();
    let (a, b) = (
        p.flat_top_fraction * radius,
        radius * (1.0 - p.flat_top_fraction),
    );
    let mut last = 1.0;
    for k in [0.1, 0.25, 0.5] {
        let tree = format!(
            "[[tree]]\nposition_m = [0.0, 0.0, 0.0]\n\
             species = \"spruce\"\ndbh_m = 0.3\nheight_m = 20.0\ncrown_base_m = 10.0\n\
             crown_radius_m = {radius}\nuniform_density = {rho}\nextinction_per_m = {k}\n"
        );
        let s = survey(
            "prf_hz = 50000\nscan_angle_deg = 0\nsubrays = 1",
            (offset, 0.05, 1.0),
            &tree,
        );
        let points = simulate(&s);
        let pulses = per_pulse(&points);
        let n = s.pulses_of(&s.lines[0]) as f64;
        let ground = pulses
            .iter()
            .filter(|p| p.last().unwrap().classification == 2)
            .count() as f64;
        // Pulses lie 0–5 cm off the line's x: average over their positions.
        let want = (0..100)
            .map(|i| {
                let d = offset.hypot(-0.05 + 0.1 * (i as f64 + 0.5) / 100.0);
                (-k * rho * vertical_path(d, a, b, p.shape_c, len)).exp()
            })
            .sum::<f64>()
            / 100.0;
        let got = ground / n;
        assert!(
            (got - want).abs() < 0.02 + 0.03 * want,
            "k={k}: {got} vs {want}"
        );
        assert!(got < last);
        last = got;
    }
}

#[test]
fn vegetation_points_lie_in_crowns_and_trunks_stop_the_beam() {
    let forest = r#"
[[forest]]
rectangle_m = [-40.0, -40.0, 40.0, 40.0]
stems_per_ha = 600
species = { pine = 0.5, spruce = 0.3, birch = 0.2 }
height_m = [12.0, 24.0]
seed = 4
"#;
    let s = survey(
        "prf_hz = 50000\nscan_angle_deg = 4\ndivergence_mrad = 0.5",
        (0.0, 30.0, 40.0),
        forest,
    );
    let trees: Vec<_> = s
        .scene
        .primitives
        .iter()
        .filter_map(|p| match &p.shape {
            Shape::Crown(c) => Some(*c.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(trees.len(), 384); // 0.64 ha × 600 /ha
    let points = simulate(&s);
    let footprint_radius = 0.5 * 500.0 * 0.5e-3;
    let mut foliage = 0;
    for p in &points {
        if p.component != COMPONENT_FOLIAGE {
            continue;
        }
        foliage += 1;
        // Distance outside the nearest crown envelope.
        let outside = trees
            .iter()
            .map(|c| {
                let (x, y) = c.axis();
                let (zb, zt) = c.z_range();
                let z = p.position_m.z.clamp(zb, zt);
                let chi = (zt - z) / (zt - zb);
                let d = (p.position_m.x - x).hypot(p.position_m.y - y);
                let dz = (p.position_m.z - z).abs();
                (d - c.radius_at_chi(chi)).max(0.0).hypot(dz)
            })
            .fold(f64::MAX, f64::min);
        assert!(
            outside <= footprint_radius + 0.05,
            "{:?} is {outside} m outside",
            p.position_m
        );
        assert!(matches!(p.classification, 3..=5));
    }
    assert!(foliage > 1000);
    // Trunks are opaque: a sub-ray that meets one returns from it and goes
    // no further (checked ray by ray against the brute-force reference).
    // The hierarchy puts the primitives in leaf order: the reference and
    // the loop work on the same order.
    let bvh = Bvh::build(s.scene.clone());
    let brute = BruteForce::new(bvh.scene().clone());
    let mut spans = Vec::new();
    let mut spans_ref = Vec::new();
    let mut trunk_hits = 0;
    for (i, prim) in bvh.scene().primitives.iter().enumerate() {
        let Shape::Trunk(t) = &prim.shape else {
            continue;
        };
        let b = t.bounds();
        let target = DVec3::new(b.center().x + 0.01, b.center().y, b.min.z + 3.0);
        let origin = target + DVec3::new(30.0, 5.0, 40.0);
        let ray = Ray::new(origin, target - origin);
        let hit = bvh.trace(&ray, 0.0, 1e4, &mut spans);
        let want = brute.trace(&ray, 0.0, 1e4, &mut spans_ref);
        assert_eq!(hit.map(|h| h.prim), want.map(|h| h.prim));
        assert_eq!(spans, spans_ref);
        if let Some(h) = hit {
            assert!(spans.iter().all(|sp| sp.t_out <= h.t));
            if h.prim == i as u32 {
                trunk_hits += 1;
            }
        }
    }
    assert!(trunk_hits > 100, "{trunk_hits}");
}

#[test]
fn a_broad_trunk_hides_the_ground() {
    // A 3 m thick stem under a tiny crown at the top: every sub-ray of a
    // nadir pulse 0.2 m off the axis meets the cone.
    let tree = "[[tree]]\nposition_m = [0.0, 0.0, 0.0]\nspecies = \"pine\"\ndbh_m = 3.0\n\
                height_m = 20.0\ncrown_base_m = 19.9\nuniform_density = 0.0\n";
    let s = survey(
        "prf_hz = 20000\nscan_angle_deg = 0\nsubrays = 37",
        (0.5, 0.05, 1.0),
        tree,
    );
    let points = simulate(&s);
    assert_eq!(points.len() as u64, s.pulses_of(&s.lines[0]));
    for p in &points {
        assert_eq!(p.component, COMPONENT_TRUNK);
        assert_eq!(p.number_of_returns, 1);
        // The cone's radius is 0.5 m at 20 − 0.5/0.0802 = 13.8 m; the
        // 15 cm footprint spans about ±0.9 m of height on its steep side.
        assert!((12.5..15.0).contains(&p.position_m.z), "{}", p.position_m.z);
    }
}
