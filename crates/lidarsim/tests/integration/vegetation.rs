//! Trees end to end (issue 3): multiple returns from one crown, Beer–Lambert
//! penetration, vegetation points inside crowns, opaque trunks, classes.

use lidarsim::Survey;
use lidarsim::accel::{BruteForce, Bvh, RayCaster};
use lidarsim::geometry::{DVec3, Ray};
use lidarsim::output::Component;
use lidarsim::output::PointRecord;
use lidarsim::scene::{Shape, Species};
use lidarsim::sim::simulate_world_to_memory;
use lidarsim::world::World;

/// A survey and its world.
struct Case {
    s: Survey,
    w: World,
}

impl Case {
    /// Pulses of the first line.
    fn pulses(&self) -> u64 {
        self.s.pulses_of(&self.w.lines[0])
    }
}

/// A survey with one northbound line at `x` from `y = -half` to `half`,
/// flown at `speed` m/s, 500 m above flat ground.
fn survey(scanner: &str, (x, half, speed): (f64, f64, f64), extra: &str) -> Case {
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
    let s = Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"));
    let w = World::build(&s).unwrap_or_else(|e| panic!("{e}"));
    Case { s, w }
}

fn simulate(c: &Case) -> Vec<PointRecord> {
    simulate_world_to_memory(&c.s, &c.w, 2)
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
        assert_eq!(p[0].component, Component::Foliage);
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
        let n = s.pulses() as f64;
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
    let trees: Vec<_> =
        s.w.scene()
            .primitives
            .iter()
            .filter_map(|p| match &p.shape {
                Shape::Crown(c) => Some(*c.clone()),
                _ => None,
            })
            .collect();
    assert_eq!(trees.len(), 384); // 0.64 ha × 600 /ha
    let points = simulate(&s);
    // Sub-rays reach 1.86 times the 1/e² radius (the Gaussian beam's tails
    // up to 99.9 % of its energy, beam.rs); a point lies on the beam axis.
    let footprint_radius = 1.87 * 0.5 * 500.0 * 0.5e-3;
    let mut foliage = 0;
    for p in &points {
        if p.component != Component::Foliage {
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
    let bvh = Bvh::build(s.w.scene().clone());
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
    assert_eq!(points.len() as u64, s.pulses());
    for p in &points {
        assert_eq!(p.component, Component::Trunk);
        assert_eq!(p.number_of_returns, 1);
        // The cone's radius is 0.5 m at 20 − 0.5/0.0802 = 13.8 m; the
        // 15 cm footprint spans about ±0.9 m of height on its steep side.
        assert!((12.5..15.0).contains(&p.position_m.z), "{}", p.position_m.z);
    }
}

/// A spruce with a uniform crown of relative density `rho` and
/// interception coefficient `k`, crown from 10 to 20 m, radius 2 m (flat
/// top 0.04 m: spruce's 2 %), its stem 2 cm thick so that it is never hit.
fn uniform_spruce(rho: f64, k: f64) -> String {
    format!(
        "[[tree]]\nposition_m = [0.0, 0.0, 0.0]\nspecies = \"spruce\"\ndbh_m = 0.02\n\
         height_m = 20.0\ncrown_base_m = 10.0\ncrown_radius_m = 2.0\nuniform_density = {rho}\n\
         extinction_per_m = {k}\n"
    )
}

/// Mean energy per pulse of the ground echoes and of the foliage echoes
/// (amplitudes, each scaled back to the reference range: × (R/Rn)²).
fn energies(s: &Case) -> (f64, f64) {
    let points = simulate(s);
    let n = s.pulses() as f64;
    let scaled = |p: &&PointRecord| p.amplitude * (p.range_m / 1000.0).powi(2);
    let ground: f64 = points
        .iter()
        .filter(|p| p.classification == 2)
        .map(|p| scaled(&p))
        .sum();
    let foliage: f64 = points
        .iter()
        .filter(|p| p.component == Component::Foliage)
        .map(|p| scaled(&p))
        .sum();
    (ground / n, foliage / n)
}

/// Energy through a crown (issue 23): the expected energy reaching the
/// ground is `exp(−τ)` of what a bare plane returns, for the optical depth
/// `τ = k·ρ·L` along the path (here the whole 10 m crown, the beams within
/// 3 cm of the axis, inside the flat top... of a cone whose radius grows
/// from 0.04 m: the path runs from near the top to the base); the foliage
/// returns the rest times leaf reflectance × 2/3, so the two add up to the
/// energy that entered; and splitting one τ between ρ and k differently
/// changes neither.
#[test]
fn energy_through_a_crown_is_conserved_and_follows_the_optical_depth() {
    // Nadir pulses 2 cm off the axis from 100 m (footprints of 3 cm), no
    // noise, a threshold low enough to see every foliage echo.
    // Waveform processing records each echo's energy, every echo apart.
    let scanner = "prf_hz = 20000\nscan_angle_deg = 0\ndivergence_mrad = 0.3\nmax_returns = 15\n\
                   echo_detection = \"waveform\"\n[receiver]\nmin_amplitude = 1e-6";
    let run = |tree: &str| {
        let mut s = survey(scanner, (0.02, 0.05, 0.1), tree);
        for l in &mut s.w.lines {
            l.start_m.z = 100.0;
            l.end_m.z = 100.0;
        }
        energies(&s)
    };
    let (bare, none) = run("");
    assert_eq!(none, 0.0);
    // A white plane returns 1 at the reference range: grass 0.3.
    assert!((bare - 0.3).abs() < 1e-3, "{bare}");
    // The crown's radius at depth χ is 0.04 + 1.96·χ^0.9 (Eq. 4): beams
    // 2 cm off the axis, inside the flat top, cross all of its 10 m.
    let leaf = 0.40 * 2.0 / 3.0; // spruce foliage reflectance × backscatter
    for tau in [1.0, 2.0] {
        let k = tau / 10.0;
        let (ground, foliage) = run(&uniform_spruce(1.0, k));
        let through = ground / bare;
        println!(
            "τ = {tau}: ground {through:.4} (exp(−τ) {:.4}), budget {:.3}",
            (-tau).exp(),
            through + foliage / leaf
        );
        assert!(
            (through / (-tau).exp() - 1.0).abs() < 0.15,
            "τ {tau}: {through}"
        );
        // Intercepted plus passed is what entered.
        assert!((through + foliage / leaf - 1.0).abs() < 0.05, "budget");
    }
    // One optical depth, two splits: (ρ 1, k 0.3) and (ρ 0.1, k 3).
    let (g1, f1) = run(&uniform_spruce(1.0, 0.3));
    let (g2, f2) = run(&uniform_spruce(0.1, 3.0));
    println!("τ = 3: foliage {f1:.4} vs {f2:.4}, ground {g1:.5} vs {g2:.5}");
    assert!((f1 / f2 - 1.0).abs() < 0.25, "{f1} vs {f2}");
    assert!((g1 / bare / (-3.0f64).exp() - 1.0).abs() < 0.25);
    // The specification's model counts the density again: the split with
    // ρ = 0.1 returns a tenth of the foliage energy.
    let spec = |tree: &str| {
        run(&format!(
            "[vegetation]\nreturn_model = \"specification\"\n{tree}"
        ))
    };
    let (s1, s2) = (
        spec(&uniform_spruce(1.0, 0.3)).1,
        spec(&uniform_spruce(0.1, 3.0)).1,
    );
    assert!(s1 / s2 > 5.0, "{s1} vs {s2}");
}

/// More echoes than the receiver records (issue 23): capped at 3 returns
/// under a deep crown, a pulse keeps its ground echo as the last return,
/// the same echo the uncapped run has; and no echo more than 0.5 m above
/// the ground is classed ground.
#[test]
fn capped_pulses_keep_the_ground_echo_and_foliage_is_not_ground() {
    let tree = uniform_spruce(1.0, 0.12);
    let run = |returns: u32| {
        let s = survey(
            &format!(
                "prf_hz = 20000\nscan_angle_deg = 0\nmax_returns = {returns}\n\
                 echo_detection = \"waveform\"\n[receiver]\nmin_amplitude = 1e-6"
            ),
            (0.3, 0.3, 1.0),
            &tree,
        );
        per_pulse(&simulate(&s))
            .into_iter()
            .map(|p| p.into_iter().copied().collect::<Vec<PointRecord>>())
            .collect::<Vec<_>>()
    };
    let (all, capped) = (run(15), run(3));
    let mut kept = 0;
    for (a, c) in all.iter().zip(&capped) {
        assert_eq!(a[0].pulse_index, c[0].pulse_index);
        for p in a.iter().chain(c) {
            if p.classification == 2 {
                assert!(p.position_m.z < 0.5, "ground at {:?}", p.position_m);
            }
        }
        let last = a.last().unwrap();
        if a.len() > 3 && last.classification == 2 {
            let l = c.last().unwrap();
            assert_eq!(c.len(), 3);
            assert_eq!(l.classification, 2, "{c:?}");
            assert!((l.position_m - last.position_m).length() < 1e-9);
            assert_eq!(l.return_number, 3);
            kept += 1;
        }
    }
    assert!(kept > 1000, "{kept} capped pulses with a ground echo");
}

/// First-return canopy cover does not collapse with flying height (issue
/// 23): with the receiver's noise off and a low threshold, a 600 stems/ha
/// stand flown at 2000 m gives a first-return cover within 25 % of the
/// one at 500 m, and at both heights at least 90 % of its trees give a
/// point. Both flights cover the stand with the same swath and density.
#[test]
fn first_return_cover_holds_from_500_to_2000_m() {
    let stand = "[[forest]]\nrectangle_m = [-30.0, -30.0, 30.0, 30.0]\nstems_per_ha = 600\n\
                 species = { pine = 0.5, spruce = 0.5 }\nheight_m = [15.0, 25.0]\nseed = 7\n";
    let flight = |h: f64| {
        // A 90 m swath at both heights, 12.5 pulses per m².
        let angle = (45.0f64 / h).atan().to_degrees();
        let mut s = survey(
            &format!(
                "prf_hz = 50000\nscan_frequency_hz = 100\nscan_angle_deg = {angle}\n\
                 max_returns = 5\n[receiver]\nmin_amplitude = 1e-5"
            ),
            (0.0, 40.0, 44.4),
            stand,
        );
        for l in &mut s.w.lines {
            l.start_m.z = h;
            l.end_m.z = h;
        }
        let trees: std::collections::BTreeSet<u32> =
            s.w.scene()
                .primitives
                .iter()
                .filter(|p| matches!(p.shape, Shape::Crown(_)))
                .map(|p| p.object)
                .collect();
        let points = simulate(&s);
        let inner = |p: &PointRecord| p.position_m.x.abs() < 25.0 && p.position_m.y.abs() < 25.0;
        let first: Vec<&PointRecord> = points
            .iter()
            .filter(|p| p.return_number == 1 && inner(p))
            .collect();
        let cover =
            first.iter().filter(|p| p.position_m.z > 2.0).count() as f64 / first.len() as f64;
        let seen: std::collections::BTreeSet<u32> = points
            .iter()
            .filter(|p| p.component != Component::Surface)
            .filter_map(|p| p.object_id)
            .collect();
        let share = trees.iter().filter(|t| seen.contains(t)).count() as f64 / trees.len() as f64;
        println!("H {h} m: first-return cover {cover:.3}, trees with a point {share:.3}");
        (cover, share)
    };
    let (low, high) = (flight(500.0), flight(2000.0));
    assert!((high.0 / low.0 - 1.0).abs() < 0.25, "{low:?} {high:?}");
    assert!(low.1 >= 0.9 && high.1 >= 0.9, "{low:?} {high:?}");
}
