//! What a survey is expected to give, computed without simulating.
//!
//! Textbook ALS planning formulas (e.g. Baltsavias 1999, "Airborne laser
//! scanning: basic relations and formulas", ISPRS J. 54): over level ground
//! at height `H` below the sensor, the swath is `W = 2·H·tan θ` for scan
//! half-angle θ across the track, the mean point density of one line is
//! `PRF·s / (v·W)` (`s` the share of pulse slots that fire: less than 1
//! for a polygon mirror), the distance between scan lines along track is
//! `v / n_lines` (`n_lines` scan lines per second: `2·f_scan` for an
//! oscillating mirror, one per facet for a polygon,
//! [`crate::sensor::deflector::Deflector::lines_per_s`]), and the
//! footprint diameter at nadir is `H·γ` for full divergence γ.

mod swath;

use serde::Serialize;

use crate::accel::RayCaster;
use crate::geometry::{Aabb, DVec3, Ray, SPEED_OF_LIGHT_MPS};
use crate::message::{fixed, num};
use crate::survey::Survey;
use crate::world::World;

/// Expected figures of one flight line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LinePlan {
    /// Flight line number, 1 for the first (the LAS point source ID).
    pub line: u32,
    /// Pulses emitted (a polygon's ticks in its dead time emit none).
    pub pulses: u64,
    /// Duration, s.
    pub duration_s: f64,
    /// Height of the sensor above the ground under the middle of the line, m.
    pub height_above_ground_m: f64,
    /// Swath width `2·H·tan θ` (`/ cos α` for channels tilted `α` along
    /// the track), or less where the ground's echo is lost, m.
    pub swath_width_m: f64,
    /// The swath's edges across the track from the ground below the
    /// scanner, m, positive to the left of the flight direction (channels
    /// that look to one side move them).
    pub swath_edges_m: [f64; 2],
    /// Share of the pulses whose beam looks at or above the horizon: they
    /// cannot reach the ground.
    pub upward_share: f64,
    /// Off-nadir angle beyond which the ground under the line returns no
    /// echo, degrees, when that cuts the scan (a scanner looking to the
    /// horizon).
    pub echo_limit_deg: Option<f64>,
    /// Mean point density `PRF / (v·W)`, points per m² (one return per pulse).
    pub point_density_per_m2: f64,
    /// Footprint diameter at nadir `H·γ`, m.
    pub footprint_diameter_m: f64,
    /// Distance between scan lines along track at nadir, m.
    pub scan_line_spacing_m: f64,
    /// Distance between neighbouring footprints across track at nadir, m.
    pub across_track_spacing_m: f64,
}

/// Expected figures of a survey.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Plan {
    /// Per flight line.
    pub lines: Vec<LinePlan>,
    /// Total pulses.
    pub pulses: u64,
    /// Pulse-weighted mean swath width, m.
    pub swath_width_m: f64,
    /// Pulse-weighted mean point density of a single line, per m².
    pub point_density_per_m2: f64,
    /// Pulse-weighted mean nadir footprint diameter, m.
    pub footprint_diameter_m: f64,
    /// Flight time including turns, s.
    pub flight_time_s: f64,
}

/// A place along `line` where ground (ground, road or water) lies above
/// the sensor, and how far above: sampled at 17 points along the line.
fn ground_above(
    caster: &dyn RayCaster,
    line: &crate::sensor::platform::FlightLine,
) -> Option<(DVec3, f64)> {
    let ground = |prim: &crate::scene::Primitive| prim.class.is_ground();
    (0..=16).find_map(|k| {
        let p = line
            .pose_at(line.duration_s() * f64::from(k) / 16.0)
            .position_m;
        let up = Ray {
            origin: p,
            dir: DVec3::Z,
        };
        caster
            .closest_hit_where(&up, 0.0, f64::INFINITY, &ground)
            .map(|h| (p, h.t))
    })
}

/// The material of the ground straight below `p` (ground, road or water
/// first, else any surface).
fn ground_material(caster: &dyn RayCaster, p: DVec3) -> Option<&crate::scene::Material> {
    let down = Ray {
        origin: p,
        dir: -DVec3::Z,
    };
    let ground = |prim: &crate::scene::Primitive| prim.class.is_ground();
    let hit = caster
        .closest_hit_where(&down, 0.0, f64::INFINITY, &ground)
        .or_else(|| caster.closest_hit(&down, 0.0, f64::INFINITY))?;
    let scene = caster.scene();
    let prim = &scene.primitives[hit.prim as usize];
    scene.materials.get(prim.material as usize)
}

/// Computes the plan of `survey` over its world.
pub fn plan(survey: &Survey, world: &World) -> Plan {
    let caster = world.index();
    let s = &survey.scanner;
    let mut lines = Vec::new();
    for line in &world.lines {
        let mid = (line.start_m + line.end_m) * 0.5;
        let h = (mid.z - crate::accel::ground_below(caster, mid)).max(0.0);
        let sw = swath::swath(survey, h, ground_material(caster, mid));
        let w = sw.width_m;
        // The pulses that fire, counted as the simulation tests them.
        let pulses = s
            .deflector
            .emitted_slots(line.start_time_s, s.prf_hz, survey.pulses_of(line));
        let step_rad = s.deflector.pulse_step_rad(s.prf_hz);
        let prf = s.prf_hz * s.deflector.emitted_share() * sw.landing_share;
        // A profiler's (or a narrow fan's) pulses cover at least their
        // footprint.
        let covered = w.max(h * s.divergence_rad);
        lines.push(LinePlan {
            line: line.index + 1,
            pulses,
            duration_s: line.duration_s(),
            height_above_ground_m: h,
            swath_width_m: w,
            swath_edges_m: [sw.edges_m.0, sw.edges_m.1],
            upward_share: sw.upward_share,
            echo_limit_deg: sw.echo_limit_rad.map(f64::to_degrees),
            point_density_per_m2: if covered > 0.0 && sw.landing_share > 0.0 {
                prf / (line.speed_mps * covered)
            } else {
                0.0
            },
            footprint_diameter_m: h * s.divergence_rad,
            scan_line_spacing_m: match s.deflector.lines_per_s() {
                n if n > 0.0 => line.speed_mps / n,
                _ => 0.0,
            },
            across_track_spacing_m: h * step_rad,
        });
    }
    let pulses: u64 = lines.iter().map(|l| l.pulses).sum();
    let weighted = |f: fn(&LinePlan) -> f64| {
        if pulses == 0 {
            0.0
        } else {
            lines.iter().map(|l| f(l) * l.pulses as f64).sum::<f64>() / pulses as f64
        }
    };
    let flight_time_s = world
        .lines
        .last()
        .map_or(0.0, |l| l.start_time_s + l.duration_s());
    Plan {
        swath_width_m: weighted(|l| l.swath_width_m),
        point_density_per_m2: weighted(|l| l.point_density_per_m2),
        footprint_diameter_m: weighted(|l| l.footprint_diameter_m),
        flight_time_s,
        pulses,
        lines,
    }
}

/// Settings that are possible but physically suspicious for this scene,
/// each with its reason and numbers:
///
/// * the ground nearer than `scanner.min_range_m` (no echo recorded) or
///   farther than `scanner.max_range_m` (none either), or swath edges beyond
///   `max_range_m`;
/// * multiple pulses in the air: the round trip `2R/c` to the farthest
///   expected range (the swath edge, at most `max_range_m`) longer than the
///   time `1/PRF` between pulses, so that a real receiver could not tell
///   which pulse an echo belongs to without multiple-time-around processing;
/// * swaths that miss the scene's bounding box (no pulse of that line can
///   hit anything), for some lines or for all of them;
/// * with a platform preset, lines faster or higher above the ground than
///   that aircraft flies.
pub fn warnings(survey: &Survey, world: &World, plan: &Plan) -> Vec<String> {
    let caster = world.index();
    let s = &survey.scanner;
    let theta = s.deflector.max_off_nadir_rad();
    let mut out = Vec::new();
    let mut farthest: Option<(f64, u32)> = None;
    let scene = caster.scene_bounds();
    let mut missing = Vec::new();
    let mut swaths = Aabb::EMPTY;
    for (line, lp) in world.lines.iter().zip(&plan.lines) {
        let n = lp.line;
        if let Some((p, above)) = ground_above(caster, line) {
            out.push(format!(
                "flight line {n} flies below the ground: at x {} m, y {} m the ground is {} m \
                 above the scanner, whose pulses point down and cannot reach the scene; raise \
                 the line (its z or altitude_m)",
                fixed(p.x, 1),
                fixed(p.y, 1),
                fixed(above, 1)
            ));
            continue;
        }
        let h = lp.height_above_ground_m;
        if let Some(u) = &survey.platform_preset {
            out.extend(crate::survey::platform_preset::limits(
                u.preset,
                n as usize,
                line.speed_mps,
                h,
            ));
        }
        let edge = h / theta.cos();
        if h > 0.0 && h < s.min_range_m {
            out.push(format!(
                "flight line {n}: the ground is {} m below the scanner, nearer than \
                 scanner.min_range_m = {} m: no echo from it will be recorded",
                fixed(h, 1),
                num(s.min_range_m)
            ));
        } else if h > s.max_range_m {
            out.push(format!(
                "flight line {n}: the ground is {} m below the scanner, beyond \
                 scanner.max_range_m = {} m: no echo from it will be recorded",
                fixed(h, 1),
                num(s.max_range_m)
            ));
        } else if edge > s.max_range_m {
            out.push(format!(
                "flight line {n}: at the swath edges (scan angle {}°) the ground is {} m away, \
                 beyond scanner.max_range_m = {} m: pulses near the edges record no ground echo",
                fixed(theta.to_degrees(), 1),
                fixed(edge, 1),
                num(s.max_range_m)
            ));
        }
        // The farthest ground with an echo: the scan's edge, or nearer
        // where the echo is lost first.
        let widest = lp.echo_limit_deg.map_or(theta, f64::to_radians);
        let r = (h / widest.cos()).min(edge).min(s.max_range_m);
        if farthest.is_none_or(|(f, _)| r > f) {
            farthest = Some((r, n));
        }
        // The area the line's pulses can reach: its path (sampled, for
        // curved tracks) with the swath's edges to either side, widened by
        // the footprint.
        let reach = lp.footprint_diameter_m + 1.0;
        let along = (line.end_m - line.start_m).truncate().normalize_or_zero();
        let left = DVec3::new(-along.y, along.x, 0.0);
        let mut area = Aabb::EMPTY;
        let samples = 64;
        for k in 0..=samples {
            let p = line.pose_at(line.duration_s() * f64::from(k) / f64::from(samples));
            for e in lp.swath_edges_m {
                area = area.union_point(p.position_m + left * e);
            }
        }
        let grow = DVec3::new(reach, reach, 0.0);
        let (lo, hi) = (area.min - grow, area.max + grow);
        swaths = swaths.union_point(lo).union_point(hi);
        let overlaps = !scene.is_empty()
            && lo.x <= scene.max.x
            && hi.x >= scene.min.x
            && lo.y <= scene.max.y
            && hi.y >= scene.min.y;
        if !overlaps {
            missing.push(n);
        }
    }
    out.extend(upward_warning(plan));
    if let Some((r, n)) = farthest {
        let round_trip_s = 2.0 * r / SPEED_OF_LIGHT_MPS;
        let period_s = 1.0 / s.prf_hz;
        if r > 0.0 && round_trip_s > period_s {
            out.push(format!(
                "multiple pulses in the air: on flight line {n} the echo from {} m away \
                 returns after 2R/c = {} µs, but pulses leave every 1/PRF = {} µs \
                 (scanner.prf_hz = {}); a real receiver would need multiple-time-around \
                 processing to assign such echoes, the simulation assigns each echo to its own \
                 pulse",
                fixed(r, 1),
                fixed(round_trip_s * 1e6, 2),
                fixed(period_s * 1e6, 2),
                num(s.prf_hz)
            ));
        }
    }
    if !missing.is_empty() && !world.lines.is_empty() {
        let scene_text = if scene.is_empty() {
            "the scene is empty".to_string()
        } else {
            format!(
                "the scene spans x {} to {} m, y {} to {} m",
                fixed(scene.min.x, 1),
                fixed(scene.max.x, 1),
                fixed(scene.min.y, 1),
                fixed(scene.max.y, 1)
            )
        };
        if missing.len() == world.lines.len() {
            out.push(format!(
                "no pulse can hit the scene: the swaths of the flight lines cover x {} to {} m, \
                 y {} to {} m, but {scene_text}",
                fixed(swaths.min.x, 1),
                fixed(swaths.max.x, 1),
                fixed(swaths.min.y, 1),
                fixed(swaths.max.y, 1)
            ));
        } else {
            let list: Vec<String> = missing.iter().map(u32::to_string).collect();
            out.push(format!(
                "flight line(s) {}: the swath misses the scene ({scene_text}): those pulses hit \
                 nothing",
                list.join(", ")
            ));
        }
    }
    out
}

/// The warning for beams that look at or above the horizon (channels
/// tilted past it, or a deflector that sweeps beyond it), if any do.
fn upward_warning(plan: &Plan) -> Option<String> {
    let share = plan.lines.first()?.upward_share;
    if share >= 1.0 {
        Some(
            "no pulse looks below the horizon (the channels' tilts and the deflector's \
             angles point every beam level or upwards): no pulse can reach the ground or \
             the scene below the aircraft"
                .to_string(),
        )
    } else if share > 0.0 {
        Some(format!(
            "{:.1} % of the pulses look at or above the horizon (the channels' tilts and \
             the deflector's angles): those pulses cannot reach the ground",
            share * 100.0
        ))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warnings_of(scanner: &str, line_x_m: f64, height_m: f64) -> Vec<String> {
        let text = format!(
            "[scanner]\n{scanner}\n[[flight_line]]\nstart_m = [{line_x_m}, -100.0, {height_m}]\n\
             end_m = [{line_x_m}, 100.0, {height_m}]\nspeed_mps = 50.0\n\
             [materials.grass]\nreflectance = 0.4\n[[polygon]]\nmaterial = \"grass\"\n\
             class = \"ground\"\nvertices_m = [[-500, -500, 0], [500, -500, 0], [500, 500, 0], \
             [-500, 500, 0]]\n"
        );
        let survey = Survey::from_toml(&text, None).unwrap();
        let world = World::build(&survey).unwrap();
        let p = plan(&survey, &world);
        warnings(&survey, &world, &p)
    }

    #[test]
    fn multiple_pulses_in_the_air_when_the_round_trip_exceeds_the_pulse_period() {
        // H = 1000 m, θ = 20°: edge range 1000 / cos 20° = 1064.18 m, round
        // trip 2R/c = 7.0995 µs. At 200 kHz pulses leave every 5 µs.
        let w = warnings_of("prf_hz = 200000\nscan_angle_deg = 20", 0.0, 1000.0);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("multiple pulses in the air"), "{}", w[0]);
        assert!(
            w[0].contains("1064.2 m") && w[0].contains("7.10 µs"),
            "{}",
            w[0]
        );
        assert!(w[0].contains("5.00 µs"), "{}", w[0]);
        // At 100 kHz (10 µs) one pulse is in the air at a time.
        assert!(warnings_of("prf_hz = 100000\nscan_angle_deg = 20", 0.0, 1000.0).is_empty());
    }

    #[test]
    fn ground_outside_the_receiver_window() {
        let w = warnings_of("prf_hz = 50000\nmin_range_m = 600", 0.0, 500.0);
        assert!(
            w[0].contains("nearer than scanner.min_range_m = 600 m"),
            "{w:?}"
        );
        let w = warnings_of("prf_hz = 50000\nmax_range_m = 400", 0.0, 500.0);
        assert!(w[0].contains("beyond scanner.max_range_m = 400 m"), "{w:?}");
        // 500 / cos 20° = 532.1 m at the edges, beyond 520 m.
        let w = warnings_of(
            "prf_hz = 50000\nscan_angle_deg = 20\nmax_range_m = 520",
            0.0,
            500.0,
        );
        assert!(
            w[0].contains("swath edges") && w[0].contains("532.1 m"),
            "{w:?}"
        );
        assert!(warnings_of("prf_hz = 50000\nscan_angle_deg = 20", 0.0, 500.0).is_empty());
    }

    #[test]
    fn swaths_that_miss_the_scene() {
        // 500 m up at 20°: swath 364 m; a line at x = 2000 m is 1500 m
        // beyond the scene's edge at x = 500 m.
        let w = warnings_of("prf_hz = 50000\nscan_angle_deg = 20", 2000.0, 500.0);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("no pulse can hit the scene"), "{}", w[0]);
        assert!(w[0].contains("x -500.0 to 500.0 m"), "{}", w[0]);
        // At x = 600 m the swath (half width 182 m) reaches the scene.
        assert!(warnings_of("prf_hz = 50000\nscan_angle_deg = 20", 600.0, 500.0).is_empty());
    }
}
