//! Instrument presets: each preset's planning figures at a stated altitude
//! and speed against a hand calculation from its datasheet values (swath
//! `2H·tan θ`, density `PRF·duty / (v·W)`, line spacing `v / lines per
//! second`), a published survey's figures for the RIEGL VQ-780i and a
//! datasheet's for a ±20° Palmer scanner, and the warnings for settings
//! an instrument cannot fly.

use lidarsim::Survey;
use lidarsim::output::MemorySink;
use lidarsim::plan::plan;
use lidarsim::sim::Simulator;
use lidarsim::survey::preset::PRESETS;
use lidarsim::world::World;

/// A survey with only `scanner` keys, one line at `h` above flat ground at
/// `v` m/s, and the ground.
fn survey(scanner: &str, h: f64, v: f64) -> (Survey, World) {
    survey_along(scanner, h, v, 200.0)
}

/// As [`survey`], the line `length` metres long from y = −100 m.
fn survey_along(scanner: &str, h: f64, v: f64, length: f64) -> (Survey, World) {
    let y1 = -100.0 + length;
    let text = format!(
        r#"
[scanner]
{scanner}
[[flight_line]]
start_m = [0.0, -100.0, {h}]
end_m = [0.0, {y1}, {h}]
speed_mps = {v}
[materials.g]
reflectance = 0.3
[[polygon]]
material = "g"
class = "ground"
vertices_m = [[-5000, -5000, 0], [5000, -5000, 0], [5000, 5000, 0], [-5000, 5000, 0]]
"#
    );
    let s = Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"));
    let w = World::build(&s).unwrap_or_else(|e| panic!("{e}"));
    (s, w)
}

fn close(got: f64, want: f64, rel: f64, what: &str) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{what}: {got} against {want}"
    );
}

/// Datasheet figures of each preset, written out by hand: (id, PRF Hz,
/// scan half-angle °, share of pulse slots fired, scan lines per second,
/// channel tilt along the track °).
const HAND: &[(&str, f64, f64, f64, f64, f64)] = &[
    // Oscillating mirrors: two lines per mirror cycle.
    ("leica_als50_ii", 150_000.0, 20.0, 1.0, 2.0 * 40.0, 0.0),
    ("optech_galaxy", 550_000.0, 25.0, 1.0, 2.0 * 60.0, 0.0),
    // Polygons: 60° of a 90° sweep fire (2/3), one line per facet.
    ("riegl_lms_q780", 400_000.0, 30.0, 2.0 / 3.0, 100.0, 0.0),
    ("riegl_vq_780i", 1_000_000.0, 30.0, 2.0 / 3.0, 225.0, 0.0),
    // Its channels look 14° forward and backward: a beam (sin θ, 0, cos θ)
    // tilted by α meets the ground H·tan θ / cos α to the side.
    ("riegl_vq_1560i", 2_000_000.0, 30.0, 2.0 / 3.0, 400.0, 14.0),
    // Palmer: a ±20° circle, one forward and one backward arc per turn.
    ("riegl_vq_880_g", 550_000.0, 20.0, 1.0, 80.0, 0.0),
    // Risley: the rosette's lobes pass at |f1 − f2|.
    (
        "livox_mid_70",
        100_000.0,
        35.2,
        1.0,
        121.566667 + 77.733333,
        0.0,
    ),
    ("livox_avia", 240_000.0, 38.6, 1.0, 131.5463 + 40.8032, 0.0),
];

#[test]
fn every_preset_plans_as_its_datasheet_says() {
    let (h, v) = (300.0, 40.0);
    assert_eq!(
        HAND.len() + 1,
        PRESETS.len(),
        "a preset without a hand calculation"
    );
    for &(id, prf, half_deg, share, lines, tilt_deg) in HAND {
        let (s, w) = survey(&format!("preset = \"{id}\""), h, v);
        assert!(s.warnings.is_empty(), "{id}: {:?}", s.warnings);
        let p = plan(&s, &w);
        assert_eq!(p.lines[0].echo_limit_deg, None, "{id}");
        let swath = 2.0 * h * half_deg.to_radians().tan() / tilt_deg.to_radians().cos();
        close(p.swath_width_m, swath, 0.005, id);
        close(p.point_density_per_m2, prf * share / (v * swath), 0.005, id);
        close(p.lines[0].scan_line_spacing_m, v / lines, 1e-6, id);
    }
    // The VUX-1UAV: 330/360 of its pulse slots fire.
    let (s, _) = survey("preset = \"riegl_vux_1uav\"", 80.0, 8.0);
    close(
        s.scanner.deflector.emitted_share(),
        330.0 / 360.0,
        1e-12,
        "vux",
    );
}

/// The VUX-1UAV looks 165° to either side: over level ground its swath is
/// bounded by the ground's echo, not by the field of view. The plan's
/// swath and its share of pulses that give a point are those a simulated
/// flight gives (its points' extent across the track, and points per
/// emitted pulse).
#[test]
fn a_scanner_looking_to_the_horizon_plans_the_swath_its_echoes_give() {
    let (h, v) = (80.0, 8.0);
    let (s, w) = survey("preset = \"riegl_vux_1uav\"", h, v);
    let p = plan(&s, &w);
    let l = &p.lines[0];
    let limit = l.echo_limit_deg.expect("the echo bounds the swath");
    assert!((45.0..89.0).contains(&limit), "{limit}");
    close(
        l.swath_width_m,
        2.0 * h * limit.to_radians().tan(),
        1e-9,
        "edge",
    );

    // A short stretch of the line, simulated.
    let (short, world) = survey_along("preset = \"riegl_vux_1uav\"", h, v, 2.0);
    let mut sink = MemorySink::default();
    let counts = Simulator::new(&short, &world)
        .run(2, &mut [&mut sink], &|_| {})
        .unwrap();
    let points = sink.points;
    let (lo, hi) = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), q| {
        (lo.min(q.position_m.x), hi.max(q.position_m.x))
    });
    close(hi - lo, l.swath_width_m, 0.05, "simulated swath");
    let planned = l.point_density_per_m2 * v * l.swath_width_m
        / (s.scanner.prf_hz * s.scanner.deflector.emitted_share());
    close(
        points.len() as f64 / counts.pulses as f64,
        planned,
        0.03,
        "points per pulse",
    );
}

/// A VQ-780i survey flown at 1 MHz and 225 lines/s, 650 m above ground at
/// 51 m/s with 76 % side overlap, reported 70–78 pulses/m² and a point
/// spacing of about 28 cm (lidR forestry tutorial data, 2019 survey).
#[test]
fn vq_780i_matches_a_published_survey() {
    let (s, w) = survey("preset = \"riegl_vq_780i\"", 650.0, 51.0);
    let p = plan(&s, &w);
    let with_overlap = p.point_density_per_m2 / (1.0 - 0.76);
    assert!((70.0..=78.0).contains(&with_overlap), "{with_overlap}");
    let l = &p.lines[0];
    for spacing in [l.scan_line_spacing_m, l.across_track_spacing_m] {
        assert!((0.2..=0.3).contains(&spacing), "{spacing}");
    }
}

/// RIEGL's VQ-840-G datasheet: a ±20° Palmer scanner at 50 kHz gives
/// 92 points/m² from 75 m at 10 m/s and 18 points/m² from 150 m at 26 m/s.
#[test]
fn palmer_density_matches_a_datasheet_example() {
    for (h, v, want) in [(75.0, 10.0, 92.0), (150.0, 26.0, 18.0)] {
        let (s, w) = survey(
            "deflector = \"palmer\"\nprf_hz = 50000\nscan_frequency_hz = 69\nscan_angle_deg = 20",
            h,
            v,
        );
        close(plan(&s, &w).point_density_per_m2, want, 0.03, "palmer");
    }
}

#[test]
fn keys_override_the_preset_and_limits_are_warned() {
    let (s, _) = survey(
        "preset = \"riegl_vq_780i\"\nprf_hz = 400000\nscan_frequency_hz = 500\ndivergence_mrad = 0.5",
        650.0,
        51.0,
    );
    assert_eq!(s.scanner.prf_hz, 400_000.0);
    assert_eq!(s.scanner.divergence_rad, 0.5e-3);
    assert_eq!(s.scanner.divergence_along_rad, 0.5e-3);
    // The Livox beam is elliptical; setting the divergence makes it round.
    let (l, _) = survey("preset = \"livox_mid_70\"", 50.0, 5.0);
    close(l.scanner.divergence_rad, 0.89e-3, 1e-12, "across");
    close(l.scanner.divergence_along_rad, 8.3e-3, 1e-12, "along");
    let (l, _) = survey(
        "preset = \"livox_mid_70\"\ndivergence_mrad = 1.0",
        50.0,
        5.0,
    );
    close(l.scanner.divergence_along_rad, 1e-3, 1e-12, "round");
    let set = &s.preset.as_ref().unwrap().set;
    assert!(
        set.iter()
            .all(|k| !k.starts_with("prf_hz") && !k.starts_with("divergence"))
    );
    assert!(set.iter().any(|k| k == "facets = 8"), "{set:?}");
    let w = s.warnings.join("\n");
    assert!(w.contains("scanner.prf_hz") && w.contains("1000000"), "{w}");
    assert!(
        w.contains("scanner.scan_frequency_hz") && w.contains("20 to 300 Hz"),
        "{w}"
    );
    // A survey choosing its own deflector takes none of the preset's
    // deflector keys.
    let (s, _) = survey(
        "preset = \"riegl_vq_780i\"\ndeflector = \"oscillating\"\nscan_frequency_hz = 50",
        650.0,
        51.0,
    );
    assert_eq!(s.scanner.deflector.kind(), "oscillating");
    // Naming the preset's own kind keeps its deflector keys.
    let (s, _) = survey(
        "preset = \"riegl_vq_780i\"\ndeflector = \"polygon\"",
        650.0,
        51.0,
    );
    assert!(
        s.scanner
            .deflector
            .describe()
            .contains("8 facets, 225 lines/s")
    );
    // An unknown instrument is an error naming the key, with the nearest id.
    let e = Survey::from_toml("[scanner]\npreset = \"riegl_vq_780\"\n", None).unwrap_err();
    let e = e.to_string();
    assert!(
        e.contains("scanner.preset") && e.contains("riegl_vq_780i"),
        "{e}"
    );
}

/// `[platform] preset = "uav"`: the multicopter's sway and drift stay
/// within the figures of its sources (±1.9° roll and pitch, ±0.1 m off the
/// line, DJI's hovering accuracy with RTK) and reach a good part of them,
/// its turns take 7 s, and a line faster or higher than such a drone flies
/// is warned.
#[test]
fn the_uav_platform_sways_drifts_and_warns_within_its_sources() {
    let text = |v: f64, h: f64| {
        format!(
            r#"
[platform]
preset = "uav"
[[flight_line]]
start_m = [0.0, -100.0, {h}]
end_m = [0.0, 100.0, {h}]
speed_mps = {v}
[[flight_line]]
start_m = [20.0, 100.0, {h}]
end_m = [20.0, -100.0, {h}]
speed_mps = {v}
[materials.g]
reflectance = 0.3
[[polygon]]
material = "g"
class = "ground"
vertices_m = [[-500, -500, 0], [500, -500, 0], [500, 500, 0], [-500, 500, 0]]
"#
        )
    };
    let s = Survey::from_toml(&text(5.0, 60.0), None).unwrap();
    let w = World::build(&s).unwrap();
    let p = plan(&s, &w);
    close(
        p.flight_time_s,
        2.0 * 200.0 / 5.0 + 7.0,
        1e-9,
        "flight time",
    );
    assert!(lidarsim::plan::warnings(&s, &w, &p).is_empty());
    let line = &w.lines[0];
    let (mut max_roll, mut max_pitch, mut max_off) = (0.0f64, 0.0f64, 0.0f64);
    let n = 4000;
    for k in 0..=n {
        let t = line.duration_s() * f64::from(k) / f64::from(n);
        let pose = line.pose_at(t);
        max_roll = max_roll.max(pose.attitude.roll_rad.abs().to_degrees());
        max_pitch = max_pitch.max(pose.attitude.pitch_rad.abs().to_degrees());
        max_off = max_off
            .max(pose.position_m.x.abs())
            .max((pose.position_m.z - 60.0).abs());
    }
    assert!((0.5..=1.9 + 1e-9).contains(&max_roll), "roll {max_roll}");
    assert!((0.5..=1.9 + 1e-9).contains(&max_pitch), "pitch {max_pitch}");
    assert!(
        (0.02..=0.1 + 1e-9).contains(&max_off),
        "off the line {max_off}"
    );

    let s = Survey::from_toml(&text(30.0, 150.0), None).unwrap();
    let w = World::build(&s).unwrap();
    let warned = lidarsim::plan::warnings(&s, &w, &plan(&s, &w));
    for (want, line) in [
        ("30 m/s", 1),
        ("150.0 m above the ground", 1),
        ("30 m/s", 2),
    ] {
        assert!(
            warned
                .iter()
                .any(|m| m.contains(want) && m.contains(&format!("flight line {line}"))),
            "{want} on line {line}: {warned:?}"
        );
    }
}
