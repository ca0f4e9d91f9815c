//! Load time, memory and ray rate of a large terrain.
//!
//! ```sh
//! cargo run --release -p lidarsim --example terrain_load -- [CELLS] [FILE]
//! ```
//! Generates a CELLS × CELLS fBm terrain of 1 m cells (default 4000; or
//! reads FILE, a GeoTIFF or ESRI ASCII grid), adds it to a scene as
//! height-field tiles, builds the BVH and casts 1 M rays from 500 m above,
//! printing the time of each step and the peak resident memory. With
//! `TERRAIN_AS_TRIANGLES=1` the cells become separate triangle primitives
//! instead, for comparison.

use std::time::Instant;

use lidarsim::accel::{Bvh, RayCaster};
use lidarsim::geometry::{DVec3, Ray};
use lidarsim::io::raster::read_raster;
use lidarsim::scene::terrain::{FbmSpec, add_terrain, generate_fbm};
use lidarsim::scene::{Scene, SurfaceClass};

fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cells: f64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(4000.0);
    let t = Instant::now();
    let grid = match args.get(2) {
        Some(file) => read_raster(std::path::Path::new(file)).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1)
        }),
        None => generate_fbm(&FbmSpec {
            extent_m: [0.0, 0.0, cells, cells],
            resolution_m: 1.0,
            relief_m: 80.0,
            wavelength_m: cells / 2.0,
            octaves: 8,
            seed: 1,
        })
        .unwrap(),
    };
    let read_s = t.elapsed().as_secs_f64();
    let (x0, y0) = (grid.origin_m[0], grid.origin_m[1]);
    let (w, h) = (
        (grid.cols - 1) as f64 * grid.spacing_m[0],
        (grid.rows - 1) as f64 * grid.spacing_m[1],
    );
    let nodes = grid.cols * grid.rows;
    let t = Instant::now();
    let mut scene = Scene::default();
    let as_triangles = std::env::var_os("TERRAIN_AS_TRIANGLES").is_some();
    let triangles = if as_triangles {
        // For comparison: every cell as two separate triangle primitives.
        for j in 0..grid.rows - 1 {
            for i in 0..grid.cols - 1 {
                let (a, b, c, d) = (
                    grid.node(i, j),
                    grid.node(i + 1, j),
                    grid.node(i + 1, j + 1),
                    grid.node(i, j + 1),
                );
                for [p, q, r] in [[a, b, c], [a, c, d]] {
                    if let Some(t) = lidarsim::scene::Triangle::new(p, q, r) {
                        scene.primitives.push(lidarsim::scene::Primitive {
                            shape: lidarsim::scene::Shape::Triangle(t),
                            material: 0,
                            class: SurfaceClass::Ground,
                            object: 0,
                        });
                    }
                }
            }
        }
        scene.primitives.len()
    } else {
        add_terrain(&mut scene, grid, 0, SurfaceClass::Ground, "terrain")
    };
    let tiles_s = t.elapsed().as_secs_f64();
    let tiles = scene.primitives.len();
    let t = Instant::now();
    let bvh = Bvh::build(scene);
    let bvh_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let n = 1_000_000u64;
    let mut hits = 0u64;
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut uniform = || {
        state = lidarsim::rng::mix64(state);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..n {
        let o = DVec3::new(x0 + w * uniform(), y0 + h * uniform(), 500.0);
        let d = DVec3::new(0.4 * (uniform() - 0.5), 0.4 * (uniform() - 0.5), -1.0);
        if bvh.closest_hit(&Ray::new(o, d), 0.0, 1e4).is_some() {
            hits += 1;
        }
    }
    let cast_s = t.elapsed().as_secs_f64();
    println!(
        "{nodes} nodes, {triangles} triangles in {tiles} tiles: read/generate {read_s:.2} s, \
         tiles {tiles_s:.2} s, BVH {bvh_s:.3} s; {n} rays ({hits} hits) in {cast_s:.2} s = \
         {:.2} M rays/s on one thread; peak RSS {:.0} MB",
        n as f64 / cast_s / 1e6,
        peak_rss_mb()
    );
}
