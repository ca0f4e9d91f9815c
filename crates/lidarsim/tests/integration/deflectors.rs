//! Each beam deflector flown over flat ground, its points compared with the
//! pattern that the scanner's geometry predicts on paper (not with the
//! deflector's own code): parallel one-way lines `v/f` apart for a polygon,
//! the ellipse of semi-axes `H·tan β` for a Palmer scanner, the rosette's
//! annulus for Risley prisms, fixed fibre angles for a fibre array.

use lidarsim::Survey;
use lidarsim::output::PointRecord;
use lidarsim::sim::simulate_world_to_memory;
use lidarsim::world::World;

/// Height of the flight over the ground, m.
const H: f64 = 200.0;
/// Ground speed, m/s (north, +y).
const V: f64 = 40.0;
/// Start of the line (y), m.
const Y0: f64 = -20.0;

/// Flies `scanner` (the `[scanner]` keys) north over flat ground for
/// `seconds` at `H` and `V`, time 0 at the start of the line.
fn fly(scanner: &str, seconds: f64) -> Vec<PointRecord> {
    let text = format!(
        r#"
seed = 7
[scanner]
{scanner}
divergence_mrad = 0.2
subrays = 1
max_returns = 1
[[flight_line]]
start_m = [0.0, {Y0}, {H}]
end_m = [0.0, {y1}, {H}]
speed_mps = {V}
[output]
gps_start_time_s = 0.0
[materials.grass]
reflectance = 0.3
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-400, -400, 0], [400, -400, 0], [400, 400, 0], [-400, 400, 0]]
"#,
        y1 = Y0 + V * seconds
    );
    let s = Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"));
    let w = World::build(&s).unwrap_or_else(|e| panic!("{e}"));
    let points = simulate_world_to_memory(&s, &w, 2);
    assert!(points.len() > 1000, "{} points", points.len());
    for p in &points {
        assert!(p.position_m.z.abs() < 0.01, "{p:?}");
    }
    points
}

/// The point's offset from the nadir point of the aircraft when its pulse
/// left (east, north), m.
fn offset(p: &PointRecord) -> (f64, f64) {
    (p.position_m.x, p.position_m.y - (Y0 + V * p.gps_time_s))
}

#[test]
fn polygon_draws_parallel_one_way_lines_v_over_f_apart() {
    let (facets, lines_per_s, half_deg) = (4, 150.0, 30.0);
    let points = fly(
        &format!(
            "deflector = \"polygon\"\nprf_hz = 60000\nscan_frequency_hz = {lines_per_s}\n\
         scan_angle_deg = {half_deg}\nfacets = {facets}"
        ),
        1.0,
    );
    // Swath 2H·tan θ_eff, and only the effective part of each facet's
    // 180° sweep fires: 60° of it, a third of the pulse slots.
    let half_swath = H * f64::to_radians(half_deg).tan();
    let max_x = points
        .iter()
        .map(|p| p.position_m.x.abs())
        .fold(0.0, f64::max);
    // (The last pulse of a line falls within one pulse step, 0.45°, of
    // the edge: 2.1 m at 30°.)
    assert!(
        max_x <= half_swath + 0.05 && max_x > half_swath - 2.5,
        "{max_x}"
    );
    let share = points.len() as f64 / 60_000.0;
    assert!((share - 60.0 / 180.0).abs() < 0.01, "{share}");
    // Group by scan line: a new line at every facet.
    let line_of = |p: &PointRecord| (p.gps_time_s * lines_per_s).floor() as i64;
    let mut by_line: std::collections::BTreeMap<i64, Vec<&PointRecord>> = Default::default();
    for p in &points {
        by_line.entry(line_of(p)).or_default().push(p);
    }
    assert!(by_line.len() >= 140);
    let mut crossings = Vec::new(); // y where each line crosses x = 0
    let mut slopes = Vec::new();
    for pts in by_line.values().filter(|p| p.len() > 100) {
        // One way: every line runs from the left of the flight (west) to
        // its right (east) as time goes on.
        for w in pts.windows(2) {
            assert!(w[1].position_m.x > w[0].position_m.x, "not one-way");
            assert!(w[0].scan_direction_positive);
        }
        let (a, b) = (pts[0].position_m, pts[pts.len() - 1].position_m);
        slopes.push((b.y - a.y) / (b.x - a.x));
        crossings.push(a.y + (0.0 - a.x) * (b.y - a.y) / (b.x - a.x));
        // The line's last pulse carries the edge flag.
        assert!(pts[pts.len() - 1].edge_of_flight_line);
        assert!(pts[..pts.len() - 1].iter().all(|p| !p.edge_of_flight_line));
    }
    // Parallel: the same slope (the aircraft moves v/PRF per pulse).
    let s0 = slopes[0];
    assert!(slopes.iter().all(|s| (s - s0).abs() < 1e-3), "{slopes:?}");
    // Spaced v / (N f_rot) = v / lines_per_s along the track.
    let spacing = V / lines_per_s;
    for w in crossings.windows(2) {
        assert!(
            ((w[1] - w[0]) - spacing).abs() < 0.01,
            "{} vs {spacing}",
            w[1] - w[0]
        );
    }
    // The LAS scan angle is the deflection: ±θ_eff at the ends.
    let max_angle = points
        .iter()
        .map(|p| p.scan_angle_deg.abs())
        .fold(0.0, f64::max);
    assert!((max_angle - half_deg).abs() < 0.5, "{max_angle}");
}

#[test]
fn palmer_footprints_lie_on_the_ellipse_and_are_seen_looking_both_ways() {
    let (across_deg, along_deg) = (20.0, 14.0);
    let points = fly(
        &format!(
            "deflector = \"palmer\"\nprf_hz = 50000\nscan_frequency_hz = 25\n\
         scan_angle_deg = {across_deg}\nscan_angle_along_deg = {along_deg}"
        ),
        3.0,
    );
    let (a, b) = (
        H * f64::to_radians(across_deg).tan(),
        H * f64::to_radians(along_deg).tan(),
    );
    for p in &points {
        let (dx, dy) = offset(p);
        let r = (dx / a).powi(2) + (dy / b).powi(2);
        // Within a few centimetres (the footprint is 4 cm) of the ellipse.
        assert!((r.sqrt() - 1.0).abs() < 0.05 / b, "{dx} {dy} {r}");
        // Forward look: ahead of the aircraft.
        if dy.abs() > 0.01 {
            assert_eq!(p.scan_direction_positive, dy > 0.0, "{dx} {dy}");
        }
    }
    // Over the middle of the line (the aircraft flies 120 m, the ellipse
    // reaches 50 m ahead and behind), every 4 m × 4 m cell of the swath's
    // inner part is hit by both the forward and the backward look.
    let mut cells: std::collections::HashMap<(i64, i64), (bool, bool)> = Default::default();
    for p in &points {
        let q = p.position_m;
        if q.x.abs() < 0.8 * a && (q.y - (Y0 + 1.5 * V)).abs() < 10.0 {
            let c = cells
                .entry(((q.x / 4.0).floor() as i64, (q.y / 4.0).floor() as i64))
                .or_default();
            if p.scan_direction_positive {
                c.0 = true;
            } else {
                c.1 = true;
            }
        }
    }
    assert!(cells.len() > 100, "{}", cells.len());
    let both = cells.values().filter(|(f, b)| *f && *b).count();
    assert!(
        both as f64 > 0.95 * cells.len() as f64,
        "{both} of {}",
        cells.len()
    );
}

#[test]
fn risley_rosette_fills_the_annulus_the_prisms_give() {
    // Unequal prisms: the beam stays between |δ1 − δ2| and δ1 + δ2 from
    // nadir, and reaches both.
    let (d1, d2) = (18.0f64, 12.0f64);
    let points = fly(
        "deflector = \"risley\"\nprf_hz = 50000\nprism_deviation_deg = [18.0, 12.0]\n\
         rotor_frequency_hz = [121.6, -77.7]",
        1.0,
    );
    let angles: Vec<f64> = points
        .iter()
        .map(|p| {
            let (dx, dy) = offset(p);
            dx.hypot(dy).atan2(H).to_degrees()
        })
        .collect();
    let lo = angles.iter().cloned().fold(f64::MAX, f64::min);
    let hi = angles.iter().cloned().fold(0.0, f64::max);
    assert!(lo >= (d1 - d2) - 0.01 && lo < (d1 - d2) + 0.1, "{lo}");
    assert!(hi <= d1 + d2 + 0.01 && hi > d1 + d2 - 0.1, "{hi}");
    // The swath across the track is 2H·tan(δ1 + δ2).
    let max_x = points
        .iter()
        .map(|p| p.position_m.x.abs())
        .fold(0.0, f64::max);
    assert!(
        (max_x - H * (d1 + d2).to_radians().tan()).abs() < 1.0,
        "{max_x}"
    );
}

#[test]
fn fibre_array_keeps_its_fibres_fixed_across_the_fan() {
    let (fibres, half_deg) = (16u32, 7.0f64);
    let points = fly(
        &format!(
            "deflector = \"fibre\"\nprf_hz = 32000\nscan_frequency_hz = 1000\n\
         fibres = {fibres}\nscan_angle_deg = {half_deg}"
        ),
        1.0,
    );
    let want: Vec<f64> = (0..fibres)
        .map(|j| half_deg * (1.0 - 2.0 * f64::from(j) / f64::from(fibres - 1)))
        .collect();
    let mut seen = vec![0usize; fibres as usize];
    for p in &points {
        // Across-track angle; the fibres look to the left (west) for
        // positive angles.
        let angle = (-p.position_m.x).atan2(H).to_degrees();
        let (j, err) = want
            .iter()
            .enumerate()
            .map(|(j, w)| (j, (w - angle).abs()))
            .fold((0, f64::MAX), |a, b| if b.1 < a.1 { b } else { a });
        assert!(err < 1e-3, "{angle}° is no fibre's direction");
        seen[j] += 1;
    }
    // Every fibre fires once per sweep: 32 000 / 16 = 2 000 each.
    assert!(seen.iter().all(|&n| n.abs_diff(2000) <= 1), "{seen:?}");
}

/// RIEGL VQ-1560i: two channels through one polygon, tilted 14° forward
/// and 14° backward, fire in turn. A beam `(sin θ, 0, cos θ)` tilted by α
/// about the across-track axis meets flat ground `H·tan α` ahead of (or
/// behind) the nadir point whatever θ, so each channel's points lie on
/// their own line across the track, and the LAS channel field tells them
/// apart.
#[test]
fn two_channels_look_forward_and_backward_in_turn() {
    let points = fly(
        "preset = \"riegl_vq_1560i\"\nprf_hz = 200000\nscan_frequency_hz = 100",
        1.0,
    );
    let ahead = H * 14f64.to_radians().tan();
    let mut count = [0usize; 2];
    for p in &points {
        let (_, dy) = offset(p);
        let want = if p.channel == 0 { ahead } else { -ahead };
        assert!(p.channel < 2);
        assert!(
            (dy - want).abs() < 0.01,
            "channel {}: {dy} against {want}",
            p.channel
        );
        count[p.channel as usize] += 1;
    }
    // Half each: a scan line's odd pulse count may favour one channel by
    // one pulse (100 lines).
    assert!(count[0].abs_diff(count[1]) <= 100, "{count:?}");
}
