//! Strips and tiles (`[output] layout`), read back by the `las` crate's
//! reader: the strips hold each flight line's points, in order, and
//! together the single file's; every tile holds the points within its
//! square, the tiles together the single file's, and the GeoJSON index
//! gives each tile's square, files and count.

use std::path::{Path, PathBuf};

use las::Reader;
use lidarsim::Survey;
use lidarsim::run::RunOptions;

use crate::kit::run_to_dir;

use crate::kit::fresh;

/// Three lines over a plane and a roof: 3 × 0.6 s at 20 kHz.
const SURVEY: &str = r#"seed = 41
[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 20
subrays = 7
[[flight_line]]
start_m = [0.0, -15.0, 200.0]
end_m = [0.0, 15.0, 200.0]
speed_mps = 50.0
[[flight_line]]
start_m = [60.0, 15.0, 200.0]
end_m = [60.0, -15.0, 200.0]
speed_mps = 50.0
[[flight_line]]
start_m = [-60.0, -15.0, 200.0]
end_m = [-60.0, 15.0, 200.0]
speed_mps = 50.0
[output]
offset_m = [500000.0, 6000000.0, 0.0]
[materials.grass]
reflectance = 0.35
[materials.roof]
reflectance = 0.2
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
[[polygon]]
material = "roof"
class = "roof"
vertices_m = [[-12, -8, 6], [10, -8, 6], [10, 8, 9], [-12, 8, 9]]
"#;

fn run(layout: &str, name: &str) -> PathBuf {
    let text = SURVEY.replace(
        "[output]\n",
        &format!("[output]\nformats = [\"las\", \"laz\"]\n{layout}\n"),
    );
    let s = Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"));
    let out = fresh(name);
    run_to_dir(&s, &out, &RunOptions::new(2, &|_| {})).unwrap();
    out
}

/// The points of a LAS or LAZ file: (x, y, z, gps time, return number,
/// point source id).
fn read(path: &Path) -> Vec<(f64, f64, f64, f64, u8, u16)> {
    let mut r = Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    r.read_all()
        .unwrap()
        .points()
        .map(|p| {
            let p = p.unwrap();
            (
                p.x,
                p.y,
                p.z,
                p.gps_time.unwrap(),
                p.return_number,
                p.point_source_id,
            )
        })
        .collect()
}

#[test]
fn strips_hold_each_lines_points_and_tiles_each_squares() {
    let single = run("", "single");
    let all = read(&single.join("points.las"));
    assert!(all.len() > 30_000, "{}", all.len());
    assert_eq!(read(&single.join("points.laz")), all);

    // Strips: line after line, each the single file's points of its line.
    let strips = run("layout = \"strips\"", "strips");
    assert!(!strips.join("points.las").exists());
    let mut joined = Vec::new();
    for line in 1..=3u16 {
        let las = read(&strips.join(format!("strips/line-{line:04}.las")));
        assert_eq!(
            read(&strips.join(format!("strips/line-{line:04}.laz"))),
            las
        );
        assert!(
            !las.is_empty() && las.iter().all(|p| p.5 == line),
            "line {line}"
        );
        joined.extend(las);
    }
    assert_eq!(joined, all);

    // Tiles of 50 m in output coordinates.
    let tiles = run("layout = \"tiles\"\ntile_m = 50", "tiles");
    let index: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tiles.join("tiles/index.geojson")).unwrap()).unwrap();
    let features = index["features"].as_array().unwrap();
    assert!(features.len() > 8, "{}", features.len());
    let mut gathered = Vec::new();
    for f in features {
        let ring = f["geometry"]["coordinates"][0].as_array().unwrap();
        let corner = |i: usize, a: usize| ring[i][a].as_f64().unwrap();
        let (x0, y0, x1, y1) = (corner(0, 0), corner(0, 1), corner(2, 0), corner(2, 1));
        assert_eq!((x1 - x0, y1 - y0), (50.0, 50.0));
        assert_eq!(x0 % 50.0, 0.0);
        let files = f["properties"]["files"].as_array().unwrap();
        let las = read(&tiles.join("tiles").join(files[0].as_str().unwrap()));
        assert_eq!(
            read(&tiles.join("tiles").join(files[1].as_str().unwrap())),
            las
        );
        assert_eq!(
            las.len() as u64,
            f["properties"]["points"].as_u64().unwrap()
        );
        // Every point in its square, to the LAS resolution.
        assert!(
            las.iter().all(|p| p.0 >= x0 - 1e-3
                && p.0 < x1 + 1e-3
                && p.1 >= y0 - 1e-3
                && p.1 < y1 + 1e-3),
            "a point outside {x0} {y0}"
        );
        // In pulse order within the tile.
        assert!(las.windows(2).all(|w| w[0].3 <= w[1].3 || w[0].5 != w[1].5));
        gathered.extend(las);
    }
    let key = |p: &(f64, f64, f64, f64, u8, u16)| (p.5, p.3.to_bits(), p.4);
    let mut want = all.clone();
    want.sort_by_key(key);
    gathered.sort_by_key(key);
    assert_eq!(gathered, want);
    for d in [single, strips, tiles] {
        std::fs::remove_dir_all(d).ok();
    }
}

#[test]
fn layouts_need_las_or_laz_points_and_tiles_an_edge() {
    let check = |output: &str| {
        let text = SURVEY.replace("[output]\n", &format!("[output]\n{output}\n"));
        Survey::from_toml(&text, None).unwrap_err().to_string()
    };
    let e = check("formats = [\"las-waveform\"]\nlayout = \"strips\"");
    assert!(
        e.contains("output.layout") && e.contains("waveforms"),
        "{e}"
    );
    let e = check("formats = [\"xyz\"]\nlayout = \"tiles\"\ntile_m = 100");
    assert!(e.contains("output.layout"), "{e}");
    let e = check("layout = \"tiles\"");
    assert!(e.contains("output.tile_m") && e.contains("required"), "{e}");
    let e = check("layout = \"strips\"\ntile_m = 100");
    assert!(e.contains("output.tile_m"), "{e}");
    let e = check("layout = \"mosaic\"");
    assert!(e.contains("unknown layout"), "{e}");
}
