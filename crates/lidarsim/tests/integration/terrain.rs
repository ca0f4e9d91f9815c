//! Terrain rasters read against the parameters they were written with by
//! an independent writer (rasterio / GDAL, `scripts/make_geotiff_fixtures.py`),
//! and terrain surveys flown end to end.

use std::path::{Path, PathBuf};

use lidarsim::Survey;
use lidarsim::io::raster::read_raster;
use lidarsim::scene::terrain::HeightGrid;
use lidarsim::sim::simulate_to_memory;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The height rasterio wrote for file pixel (col, row), row 0 north.
fn area_height(col: usize, row: usize) -> f64 {
    let (c, r) = (col as f64, row as f64);
    100.0 + 0.5 * c - 0.25 * r + 0.01 * c * r
}

#[test]
fn geotiff_pixel_is_area_tiled_deflate_float32() {
    let g = read_raster(&data("dem_area.tif")).unwrap();
    assert_eq!((g.cols, g.rows), (40, 24));
    // Upper-left corner (500000, 4200120), 10 m × 5 m pixels: the centre of
    // the south-west pixel (col 0, row 23) is half a pixel in.
    assert_eq!(g.spacing_m, [10.0, 5.0]);
    assert_eq!(g.origin_m, [500_005.0, 4_200_120.0 - 23.5 * 5.0]);
    for j in 0..g.rows {
        for i in 0..g.cols {
            let row = g.rows - 1 - j;
            let want = (i, row) != (7, 3);
            match g.height(i, j) {
                Some(h) => {
                    assert!(want, "({i}, {row}) is nodata");
                    let expect = area_height(i, row) as f32 as f64;
                    assert_eq!(h, expect, "pixel ({i}, {row})");
                }
                None => assert!(!want, "pixel ({i}, {row}) lost"),
            }
        }
    }
    // The world position of a node is its pixel centre.
    let p = g.node(3, 20);
    assert_eq!((p.x, p.y), (500_035.0, 4_200_120.0 - 3.5 * 5.0));
}

#[test]
fn geotiff_pixel_is_point_strips_lzw_int16() {
    let g = read_raster(&data("dem_point.tif")).unwrap();
    assert_eq!((g.cols, g.rows), (12, 9));
    assert_eq!(g.spacing_m, [2.0, 2.0]);
    // GDAL's corner-based transform is (-30, 50); PixelIsPoint puts the
    // tie point on the centre of pixel (0, 0): (-29, 49). The south-west
    // node is 8 rows further south.
    assert_eq!(g.origin_m, [-29.0, 49.0 - 8.0 * 2.0]);
    for j in 0..g.rows {
        for i in 0..g.cols {
            let row = (g.rows - 1 - j) as f64;
            assert_eq!(g.height(i, j), Some(7.0 * i as f64 - 3.0 * row + 20.0));
        }
    }
}

#[test]
fn raster_errors_name_the_file_and_reason() {
    let dir = std::env::temp_dir().join(format!("lidarsim-terrain-it-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let junk = dir.join("junk.tif");
    std::fs::write(&junk, b"not a tiff at all").unwrap();
    let e = read_raster(&junk).unwrap_err().to_string();
    assert!(
        e.contains("junk.tif") && e.contains("not a readable TIFF"),
        "{e}"
    );
    let e = read_raster(&dir.join("missing.asc"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing.asc") && e.contains("cannot read"),
        "{e}"
    );
    let e = read_raster(&dir.join("dem.xyz")).unwrap_err().to_string();
    assert!(e.contains("unknown raster format"), "{e}");
}

/// A survey of one north-bound line at `altitude` over `terrain`.
fn survey_text(terrain: &str, x: f64, y0: f64, y1: f64, altitude: f64) -> String {
    format!(
        r#"
seed = 3
[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15
subrays = 1
[[flight_line]]
start_m = [{x}, {y0}, {altitude}]
end_m = [{x}, {y1}, {altitude}]
speed_mps = 50
[materials.soil]
reflectance = 0.3
{terrain}
"#
    )
}

#[test]
fn points_over_a_geotiff_terrain_lie_on_it_with_the_offset() {
    // Shift the UTM raster near the origin: x − 500000, y − 4200000, z + 5.
    let terrain = format!(
        "[[terrain]]\nfile = '{}'\nmaterial = 'soil'\noffset_m = [-500000, -4200000, 5]\n",
        data("dem_area.tif").display()
    );
    let s = Survey::from_toml(&survey_text(&terrain, 100.0, 10.0, 110.0, 400.0), None)
        .unwrap_or_else(|e| panic!("{e}"));
    let pts = simulate_to_memory(&s, 2).unwrap();
    assert!(pts.len() > 1000, "{}", pts.len());
    let mut grid: HeightGrid = read_raster(&data("dem_area.tif")).unwrap();
    grid.shift(lidarsim::geometry::DVec3::new(
        -500_000.0,
        -4_200_000.0,
        5.0,
    ));
    let mut worst: f64 = 0.0;
    for p in &pts {
        let q = p.position_m;
        let z = grid
            .elevation_at(q.x, q.y)
            .unwrap_or_else(|| panic!("point {q} off the terrain"));
        worst = worst.max((q.z - z).abs());
        assert_eq!(p.classification, 2, "ground by default");
    }
    println!("{} points, worst height error {worst:.2e} m", pts.len());
    // Ranging precision of a noise-free pulse plus 1 mm LAS rounding.
    assert!(worst < 0.02, "{worst}");
    // Nodata pixel (7, 3) is grid node (7, 20): the triangles around it
    // are left out. Every point within 2 m of it would lie on one of them
    // (the nearest edge not touching the node is 4.47 m away); the ring
    // beyond is hit.
    let hole = grid.node(7, 20);
    let near = |r: f64| {
        pts.iter()
            .filter(|p| (p.position_m.truncate() - hole.truncate()).length() < r)
            .count()
    };
    println!(
        "points within 2 m of the nodata node: {}, within 15 m: {}",
        near(2.0),
        near(15.0)
    );
    assert_eq!(near(2.0), 0, "points in the nodata hole");
    assert!(near(15.0) > 100, "the hole's surroundings were not scanned");
}

#[test]
fn fbm_terrain_survey_is_reproducible_and_within_its_relief() {
    let terrain = "[[terrain]]\ngenerator = 'fbm'\nextent_m = [-150, -150, 150, 150]\n\
                   resolution_m = 2\nrelief_m = 30\nseed = 9\nmaterial = 'soil'\nclass = 'road'\n";
    let text = survey_text(terrain, 0.0, -60.0, 60.0, 500.0);
    let s = Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"));
    let world = lidarsim::world::World::build(&s).unwrap_or_else(|e| panic!("{e}"));
    let b = world.scene().bounds();
    assert_eq!(
        (b.min.x, b.min.y, b.max.x, b.max.y),
        (-150.0, -150.0, 150.0, 150.0)
    );
    assert_eq!(b.min.z, 0.0);
    assert!((b.max.z - 30.0).abs() < 1e-4, "{}", b.max.z);
    let pts = simulate_to_memory(&s, 1).unwrap();
    assert!(pts.iter().all(|p| p.classification == 11));
    assert!(pts.iter().all(|p| (-0.02..30.02).contains(&p.position_m.z)));
    let again = Survey::from_toml(&text, None).unwrap();
    assert_eq!(simulate_to_memory(&again, 2).unwrap().len(), pts.len());
}

#[test]
fn terrain_key_errors_name_the_key() {
    let cases = [
        (
            "[[terrain]]\nmaterial = 'soil'\n",
            "terrain[0].file",
            "is required",
        ),
        (
            "[[terrain]]\ngenerator = 'fbm'\nmaterial = 'soil'\n",
            "terrain[0].extent_m",
            "is required",
        ),
        (
            "[[terrain]]\ngenerator = 'perlin'\nmaterial = 'soil'\n",
            "terrain[0].generator",
            "unknown generator",
        ),
        (
            "[[terrain]]\nfile = 'x.asc'\ngenerator = 'fbm'\nmaterial = 'soil'\n",
            "terrain[0].generator",
            "not both",
        ),
        (
            "[[terrain]]\nfile = 'x.asc'\nrelief_m = 3\nmaterial = 'soil'\n",
            "terrain[0].relief_m",
            "belongs to",
        ),
        (
            "[[terrain]]\nfile = 'nope.asc'\nmaterial = 'soil'\n",
            "terrain[0].file",
            "cannot read",
        ),
        (
            "[[terrain]]\ngenerator = 'fbm'\nextent_m = [0, 0, 10, 10]\nmaterial = 'rock'\n",
            "terrain[0].material",
            "unknown material 'rock'",
        ),
        (
            "[[terrain]]\ngenerator = 'fbm'\nextent_m = [0, 0, 10, 10]\nmaterial = 'soil'\nclass = 'lava'\n",
            "terrain[0].class",
            "unknown class",
        ),
        (
            "[[terrain]]\ngenerator = 'fbm'\nextent_m = [0, 0, 10, 10]\nresolution_m = 20\nmaterial = 'soil'\n",
            "terrain[0].resolution_m",
            "fewer than 2",
        ),
    ];
    for (terrain, key, what) in cases {
        let text = survey_text(terrain, 0.0, 0.0, 10.0, 300.0);
        let e = lidarsim::world::from_toml(&text, Some(Path::new("s.toml"))).unwrap_err();
        // All problems of a file are reported, sorted by line: find ours.
        let d = e
            .diagnostics
            .iter()
            .find(|d| d.key == key)
            .unwrap_or_else(|| panic!("no problem at {key}: {e}"));
        assert!(d.message.contains(what), "{e}");
        assert!(d.line > 0, "{e}");
    }
}

/// A north-up GeoTIFF georeferenced by `ModelTransformationTag` (GeoTIFF
/// 1.1 §7.3.4: X = a·I + b·J + d, Y = e·I + f·J + h, row-major 4 × 4), with
/// PixelIsPoint, written with the `tiff` crate's encoder; and the same
/// with a rotation, which must be refused.
#[test]
fn geotiff_model_transformation_and_rotation() {
    use tiff::encoder::{TiffEncoder, colortype::Gray32Float};
    use tiff::tags::Tag;
    let dir = std::env::temp_dir().join(format!("lidarsim-terrain-mt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, b: f64| {
        let path = dir.join(name);
        let mut enc = TiffEncoder::new(std::fs::File::create(&path).unwrap()).unwrap();
        let mut img = enc.new_image::<Gray32Float>(4, 3).unwrap();
        // 2.5 m east per column, 1.5 m south per row, first pixel centre at
        // (1000, 2000).
        let m = [
            2.5, b, 0.0, 1000.0, //
            0.0, -1.5, 0.0, 2000.0, //
            0.0, 0.0, 0.0, 0.0, //
            0.0, 0.0, 0.0, 1.0,
        ];
        img.encoder()
            .write_tag(Tag::ModelTransformationTag, &m[..])
            .unwrap();
        // GeoKeyDirectory: version 1.1.0, 1 key; GTRasterTypeGeoKey (1025)
        // = RasterPixelIsPoint (2).
        let keys: [u16; 8] = [1, 1, 0, 1, 1025, 0, 1, 2];
        img.encoder()
            .write_tag(Tag::GeoKeyDirectoryTag, &keys[..])
            .unwrap();
        let data: Vec<f32> = (0..12).map(|k| k as f32 * 0.5).collect();
        img.write_data(&data).unwrap();
        path
    };
    let g = read_raster(&write("mt.tif", 0.0)).unwrap();
    assert_eq!((g.cols, g.rows), (4, 3));
    assert_eq!(g.spacing_m, [2.5, 1.5]);
    // South-west node: file row 2, column 0 → (1000, 2000 − 2·1.5).
    assert_eq!(g.origin_m, [1000.0, 1997.0]);
    // File pixel (col, row) holds 0.5·(4·row + col); grid row 0 is file row 2.
    assert_eq!(g.height(0, 0), Some(4.0));
    assert_eq!(g.height(3, 2), Some(1.5));
    let e = read_raster(&write("rot.tif", 0.3)).unwrap_err().to_string();
    assert!(e.contains("rotates or shears"), "{e}");
}

/// GeoTIFF heights that are no heights (1e300, infinity) are refused with
/// the pixel, instead of silently becoming holes; NaN stays nodata.
#[test]
fn geotiff_heights_beyond_any_terrain_are_refused() {
    use tiff::encoder::{TiffEncoder, colortype::Gray64Float};
    use tiff::tags::Tag;
    let dir = std::env::temp_dir().join(format!("lidarsim-terrain-big-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, bad: f64| {
        let path = dir.join(name);
        let mut enc = TiffEncoder::new(std::fs::File::create(&path).unwrap()).unwrap();
        let mut img = enc.new_image::<Gray64Float>(3, 2).unwrap();
        img.encoder()
            .write_tag(Tag::ModelPixelScaleTag, &[1.0, 1.0, 0.0][..])
            .unwrap();
        img.encoder()
            .write_tag(Tag::ModelTiepointTag, &[0.0, 0.0, 0.0, 0.0, 2.0, 0.0][..])
            .unwrap();
        let data = [1.0, 2.0, 3.0, 4.0, bad, 6.0];
        img.write_data(&data).unwrap();
        path
    };
    for bad in [1e300, f64::INFINITY, -1e6] {
        let e = read_raster(&write("bad.tif", bad)).unwrap_err().to_string();
        assert!(e.contains("row 2, column 2"), "{bad}: {e}");
        assert!(e.contains("GDAL_NODATA"), "{bad}: {e}");
    }
    let g = read_raster(&write("nan.tif", f64::NAN)).unwrap();
    assert_eq!(g.height(1, 0), None);
    assert_eq!(g.height(0, 0), Some(4.0));
    std::fs::remove_dir_all(&dir).ok();
}
