//! The built-in demo: a small town block and a forest stand beside it,
//! flown by three overlapping lines.
//!
//! The town is a 300 m × 300 m block: a north–south street and an
//! east–west street (asphalt), four lawns, eight houses with walls and
//! roofs — gabled roofs (pentagonal gable walls), a hipped roof (trapezoids
//! and triangles) and two flat roofs — and street and garden trees. East of
//! it lies a 120 m × 300 m mixed stand of pine, spruce and birch generated
//! by a `[[forest]]` entry. It is built as a [`RawSurvey`], the
//! same form a survey file takes, so `lidarsim demo --export-survey FILE`
//! writes a survey file that reproduces the demo exactly.

use std::collections::BTreeMap;

use crate::survey::raw::{
    RawFlightLine, RawForest, RawMaterial, RawOutput, RawPlatform, RawPolygon, RawReceiver,
    RawScanner, RawSurvey, RawTree,
};

/// Half the side of the block, m.
const HALF: f64 = 150.0;
/// Half the width of a street, m.
const STREET: f64 = 5.0;

fn material(reflectance: f64, incidence_exponent: f64) -> RawMaterial {
    RawMaterial {
        reflectance: Some(reflectance),
        incidence_exponent: Some(incidence_exponent),
        reflectance_spectrum: None,
    }
}

fn poly(material: &str, class: &str, vertices: &[[f64; 3]]) -> RawPolygon {
    RawPolygon {
        material: Some(material.to_string()),
        class: Some(class.to_string()),
        vertices_m: Some(vertices.iter().map(|v| v.to_vec()).collect()),
    }
}

fn rect_xy(material: &str, class: &str, x0: f64, x1: f64, y0: f64, y1: f64) -> RawPolygon {
    poly(
        material,
        class,
        &[[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]],
    )
}

/// Roof kind of a demo house.
#[derive(Clone, Copy)]
enum Roof {
    /// Gable roof with the ridge along x at the given ridge height.
    GableX(f64),
    /// Gable roof with the ridge along y.
    GableY(f64),
    /// Hipped roof: ridge along x, shortened by the half depth at each end.
    Hip(f64),
    /// Flat roof.
    Flat,
}

/// Walls and roof planes of a house with footprint `[x0, x1] × [y0, y1]`
/// and eaves height `h`.
fn house(out: &mut Vec<RawPolygon>, x0: f64, x1: f64, y0: f64, y1: f64, h: f64, roof: Roof) {
    let wall = |v: &[[f64; 3]]| poly("plaster", "wall", v);
    let roof_poly = |v: &[[f64; 3]]| poly("tiles", "roof", v);
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    match roof {
        Roof::GableX(r) => {
            // Long walls (south, north) are rectangles; gable ends pentagons.
            out.push(wall(&[
                [x0, y0, 0.0],
                [x1, y0, 0.0],
                [x1, y0, h],
                [x0, y0, h],
            ]));
            out.push(wall(&[
                [x1, y1, 0.0],
                [x0, y1, 0.0],
                [x0, y1, h],
                [x1, y1, h],
            ]));
            out.push(wall(&[
                [x0, y1, 0.0],
                [x0, y0, 0.0],
                [x0, y0, h],
                [x0, ym, r],
                [x0, y1, h],
            ]));
            out.push(wall(&[
                [x1, y0, 0.0],
                [x1, y1, 0.0],
                [x1, y1, h],
                [x1, ym, r],
                [x1, y0, h],
            ]));
            out.push(roof_poly(&[
                [x0, y0, h],
                [x1, y0, h],
                [x1, ym, r],
                [x0, ym, r],
            ]));
            out.push(roof_poly(&[
                [x1, y1, h],
                [x0, y1, h],
                [x0, ym, r],
                [x1, ym, r],
            ]));
        }
        Roof::GableY(r) => {
            out.push(wall(&[
                [x0, y1, 0.0],
                [x0, y0, 0.0],
                [x0, y0, h],
                [x0, y1, h],
            ]));
            out.push(wall(&[
                [x1, y0, 0.0],
                [x1, y1, 0.0],
                [x1, y1, h],
                [x1, y0, h],
            ]));
            out.push(wall(&[
                [x0, y0, 0.0],
                [x1, y0, 0.0],
                [x1, y0, h],
                [xm, y0, r],
                [x0, y0, h],
            ]));
            out.push(wall(&[
                [x1, y1, 0.0],
                [x0, y1, 0.0],
                [x0, y1, h],
                [xm, y1, r],
                [x1, y1, h],
            ]));
            out.push(roof_poly(&[
                [x0, y0, h],
                [xm, y0, r],
                [xm, y1, r],
                [x0, y1, h],
            ]));
            out.push(roof_poly(&[
                [x1, y1, h],
                [xm, y1, r],
                [xm, y0, r],
                [x1, y0, h],
            ]));
        }
        Roof::Hip(r) => {
            let half_depth = 0.5 * (y1 - y0);
            let (ra, rb) = (x0 + half_depth, x1 - half_depth);
            for v in [
                [[x0, y0, 0.0], [x1, y0, 0.0], [x1, y0, h], [x0, y0, h]],
                [[x1, y1, 0.0], [x0, y1, 0.0], [x0, y1, h], [x1, y1, h]],
                [[x0, y1, 0.0], [x0, y0, 0.0], [x0, y0, h], [x0, y1, h]],
                [[x1, y0, 0.0], [x1, y1, 0.0], [x1, y1, h], [x1, y0, h]],
            ] {
                out.push(wall(&v));
            }
            out.push(roof_poly(&[
                [x0, y0, h],
                [x1, y0, h],
                [rb, ym, r],
                [ra, ym, r],
            ]));
            out.push(roof_poly(&[
                [x1, y1, h],
                [x0, y1, h],
                [ra, ym, r],
                [rb, ym, r],
            ]));
            out.push(roof_poly(&[[x0, y1, h], [x0, y0, h], [ra, ym, r]]));
            out.push(roof_poly(&[[x1, y0, h], [x1, y1, h], [rb, ym, r]]));
        }
        Roof::Flat => {
            for v in [
                [[x0, y0, 0.0], [x1, y0, 0.0], [x1, y0, h], [x0, y0, h]],
                [[x1, y1, 0.0], [x0, y1, 0.0], [x0, y1, h], [x1, y1, h]],
                [[x0, y1, 0.0], [x0, y0, 0.0], [x0, y0, h], [x0, y1, h]],
                [[x1, y0, 0.0], [x1, y1, 0.0], [x1, y1, h], [x1, y0, h]],
            ] {
                out.push(wall(&v));
            }
            out.push(poly(
                "gravel",
                "roof",
                &[[x0, y0, h], [x1, y0, h], [x1, y1, h], [x0, y1, h]],
            ));
        }
    }
}

/// The demo survey.
pub fn demo_survey() -> RawSurvey {
    let mut materials = BTreeMap::new();
    materials.insert("grass".to_string(), material(0.45, 1.0));
    materials.insert("asphalt".to_string(), material(0.12, 1.0));
    materials.insert("plaster".to_string(), material(0.55, 1.0));
    materials.insert("tiles".to_string(), material(0.25, 1.2));
    materials.insert("gravel".to_string(), material(0.3, 1.0));

    let (h, s) = (HALF, STREET);
    let mut polygons = vec![
        // Streets: the north–south one whole, the east–west one in two
        // halves so that no two ground polygons overlap.
        rect_xy("asphalt", "road", -s, s, -h, h),
        rect_xy("asphalt", "road", -h, -s, -s, s),
        rect_xy("asphalt", "road", s, h, -s, s),
        // Lawns in the four quadrants.
        rect_xy("grass", "ground", -h, -s, -h, -s),
        rect_xy("grass", "ground", s, h, -h, -s),
        rect_xy("grass", "ground", -h, -s, s, h),
        rect_xy("grass", "ground", s, h, s, h),
    ];
    let houses = [
        (-60.0, -40.0, -50.0, -38.0, 6.0, Roof::GableX(10.0)),
        (-110.0, -90.0, -60.0, -45.0, 5.0, Roof::GableY(9.0)),
        (20.0, 50.0, -70.0, -50.0, 7.0, Roof::Hip(11.0)),
        (80.0, 110.0, -40.0, -20.0, 12.0, Roof::Flat),
        (-70.0, -30.0, 40.0, 60.0, 9.0, Roof::Flat),
        (-120.0, -104.0, 90.0, 102.0, 5.5, Roof::GableX(9.5)),
        (30.0, 42.0, 30.0, 48.0, 6.0, Roof::GableY(10.5)),
        (70.0, 96.0, 80.0, 100.0, 6.5, Roof::Hip(10.0)),
    ];
    for (x0, x1, y0, y1, eaves, roof) in houses {
        house(&mut polygons, x0, x1, y0, y1, eaves, roof);
    }

    // The forest floor east of the block.
    polygons.push(rect_xy("litter", "ground", h, h + 120.0, -h, h));
    materials.insert("litter".to_string(), material(0.25, 1.0));

    // Birches along the north–south street, pines and spruces in gardens.
    let tree = |x: f64, y: f64, species: &str, dbh: f64, height: f64, crown_base: f64| RawTree {
        position_m: Some(vec![x, y, 0.0]),
        species: Some(species.to_string()),
        dbh_m: Some(dbh),
        height_m: Some(height),
        crown_base_m: Some(crown_base),
        ..Default::default()
    };
    let mut trees = Vec::new();
    for k in 0..8 {
        let y = -130.0 + 20.0 * k as f64 + if k >= 4 { 20.0 } else { 0.0 };
        let side = if k % 2 == 0 { -9.0 } else { 9.0 };
        trees.push(tree(side, y, "birch", 0.22, 13.0, 4.0));
    }
    trees.push(tree(-80.0, -100.0, "pine", 0.35, 17.0, 8.0));
    trees.push(tree(-25.0, -110.0, "spruce", 0.3, 15.0, 2.0));
    trees.push(tree(60.0, -110.0, "pine", 0.28, 14.0, 7.0));
    trees.push(tree(120.0, 10.0, "birch", 0.3, 16.0, 5.0));
    trees.push(tree(-100.0, 30.0, "spruce", 0.25, 13.0, 1.5));
    trees.push(tree(60.0, 60.0, "pine", 0.32, 16.0, 8.0));
    let forest = RawForest {
        rectangle_m: Some(vec![h + 2.0, -h + 2.0, h + 118.0, h - 2.0]),
        stems_per_ha: Some(500.0),
        species: Some(BTreeMap::from([
            ("pine".to_string(), 0.5),
            ("spruce".to_string(), 0.3),
            ("birch".to_string(), 0.2),
        ])),
        height_m: Some(vec![14.0, 24.0]),
        min_spacing_m: Some(2.0),
        seed: Some(11),
        area_m: None,
    };

    let line = |x: f64, y0: f64, y1: f64| RawFlightLine {
        start_m: Some(vec![x, y0, 400.0]),
        end_m: Some(vec![x, y1, 400.0]),
        altitude_m: None,
        speed_mps: Some(60.0),
    };
    RawSurvey {
        seed: Some(7),
        scanner: RawScanner {
            prf_hz: Some(100_000.0),
            scan_frequency_hz: Some(50.0),
            scan_angle_deg: Some(20.0),
            mirror: Some("triangle".into()),
            divergence_mrad: Some(0.3),
            subrays: Some(19),
            pulse_fwhm_ns: Some(4.0),
            max_returns: Some(5),
            ..Default::default()
        },
        receiver: RawReceiver {
            bin_ps: Some(500.0),
            noise: Some(0.005),
            atmosphere: Some(0.005),
            speckle: Some(true),
            speckle_looks: Some(4.0),
            ..Default::default()
        },
        platform: RawPlatform {
            sway: Some(true),
            roll_amplitude_deg: Some(0.3),
            pitch_amplitude_deg: Some(0.2),
            yaw_amplitude_deg: Some(0.1),
            ..Default::default()
        },
        output: RawOutput {
            formats: Some(vec!["las".into(), "xyz".into()]),
            ..Default::default()
        },
        flight_lines: vec![
            line(-40.0, -150.0, 150.0),
            line(40.0, 150.0, -150.0),
            line(180.0, -150.0, 150.0),
        ],
        materials,
        polygons,
        meshes: Vec::new(),
        trees,
        forests: vec![forest],
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::survey::Survey;
    use crate::world::World;

    #[test]
    fn demo_is_valid_and_round_trips_through_toml() {
        let raw = demo_survey();
        let s = Survey::from_raw(raw.clone(), None).unwrap();
        let w = World::build(&s).unwrap();
        assert!(w.scene().primitives.len() > 50);
        let text = toml::to_string(&raw).unwrap();
        let again = World::build(&Survey::from_toml(&text, None).unwrap()).unwrap();
        assert_eq!(again.scene().primitives.len(), w.scene().primitives.len());
        assert_eq!(again.lines, w.lines);
    }
}
