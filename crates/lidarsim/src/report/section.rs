//! Where the report's cross-section runs: west to east through the row of
//! the mapped area that crosses the most building surfaces and, of those
//! rows, the most tree parts — through what the scene holds, not through a street that
//! happens to lie in the middle. A scene of neither keeps the middle row.

use crate::geometry::Aabb;
use crate::scene::{Shape, SurfaceClass};
use crate::world::World;

/// Rows of the area tried, at most (every metre of smaller areas).
const ROWS: usize = 400;

/// Half the width of the cross-section's band, m (as `ReportSink` keeps).
const HALF_BAND_M: f64 = 1.0;

/// What an object is to the choice of the section.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Building,
    Tree,
}

/// The north coordinate of the west–east cross-section through `area`,
/// m: the row (of at most 400, at least 1 m apart) whose 2 m band
/// crosses the most roof planes and walls, then the most crowns and trunks, then lies nearest the
/// middle.
pub fn section_y(world: &World, area: Aabb) -> f64 {
    let middle = area.center().y;
    // In plan only: a run's covered area may have its heights crossed
    // (the flight's above the scene's).
    if area.min.x > area.max.x || area.extent().y <= 2.0 * HALF_BAND_M {
        return middle;
    }
    let rows = (area.extent().y.ceil() as usize).clamp(1, ROWS);
    let step = area.extent().y / rows as f64;
    let row_y = |k: usize| area.min.y + (k as f64 + 0.5) * step;
    // Per kind, +1 where an object's band starts and −1 after it ends.
    let mut starts = [vec![0i64; rows + 1], vec![0i64; rows + 1]];
    for (kind, b) in objects(world, area) {
        let first = ((b.min.y - HALF_BAND_M - area.min.y) / step - 0.5)
            .ceil()
            .max(0.0) as usize;
        let last = ((b.max.y + HALF_BAND_M - area.min.y) / step - 0.5).floor();
        if last < 0.0 || first >= rows {
            continue;
        }
        let last = (last as usize).min(rows - 1);
        if first <= last {
            let k = usize::from(kind == Kind::Tree);
            starts[k][first] += 1;
            starts[k][last + 1] -= 1;
        }
    }
    let (mut buildings, mut trees, mut best) = (0i64, 0i64, (i64::MIN, i64::MIN, f64::MIN, middle));
    for (k, (b, t)) in starts[0].iter().zip(&starts[1]).take(rows).enumerate() {
        buildings += b;
        trees += t;
        let y = row_y(k);
        let score = (buildings, trees, -(y - middle).abs(), y);
        if (score.0, score.1, score.2) > (best.0, best.1, best.2) {
            best = score;
        }
    }
    if (best.0, best.1) == (0, 0) {
        return middle;
    }
    best.3
}

/// The building surfaces (roof planes and walls) and tree parts (crowns
/// and trunks) of the scene over `area`, each with its box. Counted one by
/// one rather than per object: a scene file's polygons may all be one
/// object, whose box would cross every row.
fn objects(world: &World, area: Aabb) -> Vec<(Kind, Aabb)> {
    world
        .scene()
        .primitives
        .iter()
        .filter_map(|p| {
            let kind = match (&p.shape, p.class) {
                (_, SurfaceClass::Roof | SurfaceClass::Wall) => Kind::Building,
                (Shape::Crown(_) | Shape::Trunk(_), _) => Kind::Tree,
                _ => return None,
            };
            let b = p.bounds();
            (b.max.x >= area.min.x && b.min.x <= area.max.x).then_some((kind, b))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::survey::Survey;

    /// Issue 49: the demo's cross-section ran along the east–west street
    /// through the middle, where no house stands. Chosen by what the scene
    /// holds, its band crosses a roof and a crown.
    #[test]
    fn the_demo_section_cuts_a_house_and_trees() {
        let s = Survey::from_raw(crate::demo::demo_survey(), None).unwrap();
        let world = World::build(&s).unwrap();
        let area = world.scene_bounds();
        let y = section_y(&world, area);
        // A run's covered area has the flight's height as its bottom,
        // above the scene's top: the choice is made in plan.
        let mut crossed = area;
        crossed.min.z = area.max.z + 100.0;
        assert_eq!(section_y(&world, crossed), y);
        let crosses = |class: fn(&crate::scene::Primitive) -> bool| {
            world
                .scene()
                .primitives
                .iter()
                .filter(|p| class(p))
                .any(|p| {
                    let b = p.bounds();
                    b.min.y <= y + HALF_BAND_M && b.max.y >= y - HALF_BAND_M
                })
        };
        assert!(crosses(|p| p.class == SurfaceClass::Roof), "y = {y}");
        assert!(crosses(|p| matches!(p.shape, Shape::Crown(_))), "y = {y}");
        // Not the middle row, the street.
        assert!((y - area.center().y).abs() > 5.0, "y = {y}");
    }

    /// A scene without buildings or trees keeps the middle row.
    #[test]
    fn a_bare_scene_keeps_the_middle() {
        let s = Survey::from_toml(
            "[[flight_line]]\nstart_m = [0, -50, 300]\nend_m = [0, 50, 300]\nspeed_mps = 50\n\
             [materials.grass]\nreflectance = 0.4\n[[polygon]]\nmaterial = \"grass\"\n\
             class = \"ground\"\nvertices_m = [[-100, -80, 0], [100, -80, 0], [100, 60, 0], \
             [-100, 60, 0]]\n",
            None,
        )
        .unwrap();
        let world = World::build(&s).unwrap();
        let area = world.scene_bounds();
        assert_eq!(section_y(&world, area), area.center().y);
    }
}
