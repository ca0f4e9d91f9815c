//! Terrain: height grids (read by [`crate::io::raster`] from GeoTIFF DEMs
//! and ESRI ASCII grids, or made by the procedural fBm generator here),
//! intersected as a height field.
//!
//! A [`HeightGrid`] holds one height per grid node, the nodes being the
//! pixel (cell) centres of the raster, south-west node first, rows running
//! north. The surface is the lattice TIN over the nodes: every square of
//! four nodes is split along its south-west → north-east diagonal into two
//! triangles; a triangle with a nodata corner is left out (a hole). The
//! surface therefore spans from the first to the last pixel centre, half a
//! pixel inside the raster's outer edges.
//!
//! The grid is shared (`Arc`) by [`TerrainTile`] primitives of
//! [`TILE_CELLS`]² cells each; the BVH culls tiles by their boxes and a tile
//! walks the cells its ray crosses in order (a 2-D DDA, Amanatides & Woo
//! 1987), testing the two triangles of each cell with the scene's one
//! ray–triangle test ([`Triangle::intersect`], watertight on the edges the
//! cells share). The first cell with a hit holds the closest hit. A
//! 4000 × 4000 DEM costs its heights as `f32` (64 MB) and 62 500 tiles,
//! where 32 M separate triangle primitives would take several gigabytes.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rayon::prelude::*;

use super::{MaterialId, ObjectId, Primitive, Scene, Shape, SurfaceClass, Triangle};
use crate::geometry::{Aabb, DVec3, Ray};

/// Largest height magnitude a terrain raster may hold, m (the deepest
/// ocean trench is 11 km deep, the highest summit 8.8 km high).
pub const MAX_HEIGHT_M: f64 = 100_000.0;
/// Cells along each side of a [`TerrainTile`].
pub const TILE_CELLS: u32 = 16;

/// Largest grid accepted, in nodes (400 MB of `f32` heights).
pub const MAX_NODES: usize = 100_000_000;

/// Why a terrain could not be read or generated.
#[derive(Debug, thiserror::Error)]
pub enum TerrainError {
    /// The file could not be read.
    #[error("cannot read '{path}': {source}")]
    Read {
        /// File that failed.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file's extension names no raster format we read.
    #[error(
        "'{path}': unknown raster format; expected .tif, .tiff (GeoTIFF) or .asc (ESRI ASCII grid)"
    )]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file breaks its format, at a line where that is meaningful
    /// (0 for binary files).
    #[error("'{path}'{}: {reason}", if *line > 0 { format!(" line {line}") } else { String::new() })]
    Format {
        /// The file.
        path: PathBuf,
        /// 1-based line of a text file, 0 when not meaningful.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The grid is too small or too large.
    #[error("'{path}': {reason}")]
    Size {
        /// The file (or `<fbm>`).
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// Heights on a regular grid of nodes (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct HeightGrid {
    /// Nodes per row (west → east), at least 2.
    pub cols: usize,
    /// Rows of nodes (south → north), at least 2.
    pub rows: usize,
    /// World position of the south-west node (x, y), m.
    pub origin_m: [f64; 2],
    /// Node spacing east and north, m (both > 0).
    pub spacing_m: [f64; 2],
    /// Added to every stored height, m.
    pub z_offset_m: f64,
    /// Row-major heights, row 0 southernmost; NaN is nodata.
    pub heights: Vec<f32>,
}

impl HeightGrid {
    /// Height of node `(col, row)` in world metres, `None` for nodata or
    /// outside the grid.
    #[inline]
    pub fn height(&self, col: usize, row: usize) -> Option<f64> {
        if col >= self.cols || row >= self.rows {
            return None;
        }
        let h = self.heights[row * self.cols + col];
        h.is_finite().then_some(h as f64 + self.z_offset_m)
    }

    /// World position of node `(col, row)` (NaN height for nodata).
    #[inline]
    pub fn node(&self, col: usize, row: usize) -> DVec3 {
        let h = self.heights[row * self.cols + col];
        DVec3::new(
            self.origin_m[0] + col as f64 * self.spacing_m[0],
            self.origin_m[1] + row as f64 * self.spacing_m[1],
            if h.is_finite() {
                h as f64 + self.z_offset_m
            } else {
                f64::NAN
            },
        )
    }

    /// Moves the grid by `offset` (x, y, z), m.
    pub fn shift(&mut self, offset: DVec3) {
        self.origin_m[0] += offset.x;
        self.origin_m[1] += offset.y;
        self.z_offset_m += offset.z;
    }

    /// Height of the surface at `(x, y)` (linear on the triangle there),
    /// `None` outside the grid or in a hole.
    pub fn elevation_at(&self, x: f64, y: f64) -> Option<f64> {
        let u = (x - self.origin_m[0]) / self.spacing_m[0];
        let v = (y - self.origin_m[1]) / self.spacing_m[1];
        if !(u >= 0.0 && v >= 0.0 && u <= (self.cols - 1) as f64 && v <= (self.rows - 1) as f64) {
            return None;
        }
        let i = (u.floor() as usize).min(self.cols - 2);
        let j = (v.floor() as usize).min(self.rows - 2);
        let (fu, fv) = (u - i as f64, v - j as f64);
        let a = self.height(i, j)?;
        let c = self.height(i + 1, j + 1)?;
        if fu >= fv {
            let b = self.height(i + 1, j)?;
            Some(a + fu * (b - a) + fv * (c - b))
        } else {
            let d = self.height(i, j + 1)?;
            Some(a + fv * (d - a) + fu * (c - d))
        }
    }

    /// Number of triangles with three valid corners.
    pub fn triangle_count(&self) -> usize {
        (0..self.rows - 1)
            .into_par_iter()
            .map(|j| {
                (0..self.cols - 1)
                    .map(|i| {
                        let [a, b, c, d] = self.cell_valid(i, j);
                        usize::from(a && b && c) + usize::from(a && c && d)
                    })
                    .sum::<usize>()
            })
            .sum()
    }

    fn cell_valid(&self, i: usize, j: usize) -> [bool; 4] {
        let ok = |c: usize, r: usize| self.heights[r * self.cols + c].is_finite();
        [ok(i, j), ok(i + 1, j), ok(i + 1, j + 1), ok(i, j + 1)]
    }

    pub(crate) fn check_size(&self, path: &Path) -> Result<(), TerrainError> {
        let size = |reason: String| TerrainError::Size {
            path: path.to_path_buf(),
            reason,
        };
        if self.cols < 2 || self.rows < 2 {
            return Err(size(format!(
                "a terrain needs at least 2 × 2 cells, got {} × {}",
                self.cols, self.rows
            )));
        }
        if self.cols.saturating_mul(self.rows) > MAX_NODES {
            return Err(size(format!(
                "{} × {} cells exceed the limit of {MAX_NODES} cells",
                self.cols, self.rows
            )));
        }
        if !(self.spacing_m.iter().all(|s| s.is_finite() && *s > 0.0)
            && self.origin_m.iter().all(|o| o.is_finite()))
        {
            return Err(size(format!(
                "the pixel grid is not usable: origin {:?}, pixel size {:?}",
                self.origin_m, self.spacing_m
            )));
        }
        if !self.heights.iter().any(|h| h.is_finite()) {
            return Err(size("every cell is nodata".to_string()));
        }
        Ok(())
    }
}

/// A block of up to [`TILE_CELLS`]² cells of a shared [`HeightGrid`]: one
/// primitive of the scene.
#[derive(Clone, Debug)]
pub struct TerrainTile {
    grid: Arc<HeightGrid>,
    /// First cell column and row.
    col0: u32,
    row0: u32,
    /// Cells across and up.
    ncols: u32,
    nrows: u32,
    bounds: Aabb,
}

impl TerrainTile {
    /// Bounding box of the tile's valid triangles.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The grid the tile belongs to.
    pub fn grid(&self) -> &HeightGrid {
        &self.grid
    }

    /// Closest intersection within `(t_min, t_max)`.
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let (t0, t1) = self.bounds.ray_interval(ray, t_min, t_max)?;
        let g = &*self.grid;
        let [dx, dy] = g.spacing_m;
        let [x0, y0] = g.origin_m;
        let (lo_i, hi_i) = (self.col0 as i64, (self.col0 + self.ncols - 1) as i64);
        let (lo_j, hi_j) = (self.row0 as i64, (self.row0 + self.nrows - 1) as i64);
        let p = ray.at(t0);
        let mut i = (((p.x - x0) / dx).floor() as i64).clamp(lo_i, hi_i);
        let mut j = (((p.y - y0) / dy).floor() as i64).clamp(lo_j, hi_j);
        let axis = |d: f64, o: f64, origin: f64, step: f64, cell: i64| -> (i64, f64, f64) {
            if d > 0.0 {
                let edge = origin + (cell + 1) as f64 * step;
                (1, (edge - o) / d, step / d)
            } else if d < 0.0 {
                let edge = origin + cell as f64 * step;
                (-1, (edge - o) / d, -step / d)
            } else {
                (0, f64::INFINITY, f64::INFINITY)
            }
        };
        let (si, mut next_x, delta_x) = axis(ray.dir.x, ray.origin.x, x0, dx, i);
        let (sj, mut next_y, delta_y) = axis(ray.dir.y, ray.origin.y, y0, dy, j);
        loop {
            if let Some(t) = cell_hit(g, i as usize, j as usize, ray, t_min, t_max) {
                return Some(t);
            }
            if next_x < next_y {
                if next_x > t1 {
                    return None;
                }
                i += si;
                if i < lo_i || i > hi_i {
                    return None;
                }
                next_x += delta_x;
            } else {
                if next_y > t1 {
                    return None;
                }
                j += sj;
                if j < lo_j || j > hi_j {
                    return None;
                }
                next_y += delta_y;
            }
        }
    }

    /// Unit normal (upward) of the triangle under the point `p`.
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        let g = &*self.grid;
        let u = (p.x - g.origin_m[0]) / g.spacing_m[0];
        let v = (p.y - g.origin_m[1]) / g.spacing_m[1];
        let i = (u.floor() as i64).clamp(self.col0 as i64, (self.col0 + self.ncols - 1) as i64);
        let j = (v.floor() as i64).clamp(self.row0 as i64, (self.row0 + self.nrows - 1) as i64);
        let (i, j) = (i as usize, j as usize);
        let (fu, fv) = (u - i as f64, v - j as f64);
        let [a, b, c, d] = [
            g.node(i, j),
            g.node(i + 1, j),
            g.node(i + 1, j + 1),
            g.node(i, j + 1),
        ];
        let lower = (b - a).cross(c - a);
        let upper = (c - a).cross(d - a);
        let n = if (fu >= fv && lower.is_finite()) || !upper.is_finite() {
            lower
        } else {
            upper
        };
        n.try_normalize().unwrap_or(DVec3::Z)
    }
}

/// Closest hit on the two triangles of cell `(i, j)`.
#[inline]
fn cell_hit(g: &HeightGrid, i: usize, j: usize, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
    let a = g.node(i, j);
    let c = g.node(i + 1, j + 1);
    if a.z.is_nan() || c.z.is_nan() {
        return None;
    }
    let b = g.node(i + 1, j);
    let d = g.node(i, j + 1);
    let t_lower = if b.z.is_nan() {
        None
    } else {
        Triangle::from_corners(a, b, c).intersect(ray, t_min, t_max)
    };
    let t_upper = if d.z.is_nan() {
        None
    } else {
        Triangle::from_corners(a, c, d).intersect(ray, t_min, t_max.min(t_lower.unwrap_or(t_max)))
    };
    t_upper.or(t_lower)
}

/// Adds `grid` to `scene` as tiles of one new object; returns the number of
/// triangles (valid cells' halves) it holds. A grid of fewer than 2 × 2
/// nodes, or whose `heights` do not hold `cols × rows` values, adds
/// nothing (the readers never return one).
pub fn add_terrain(
    scene: &mut Scene,
    grid: HeightGrid,
    material: MaterialId,
    class: SurfaceClass,
    name: impl Into<String>,
) -> usize {
    if grid.cols < 2 || grid.rows < 2 || grid.heights.len() != grid.cols * grid.rows {
        return 0;
    }
    let object: ObjectId = scene.add_object(name);
    let triangles = grid.triangle_count();
    let grid = Arc::new(grid);
    let cells = [(grid.cols - 1) as u32, (grid.rows - 1) as u32];
    let tiles_x = cells[0].div_ceil(TILE_CELLS);
    let tiles_y = cells[1].div_ceil(TILE_CELLS);
    let tiles: Vec<Primitive> = (0..tiles_y)
        .into_par_iter()
        .flat_map_iter(|ty| {
            let grid = Arc::clone(&grid);
            (0..tiles_x).filter_map(move |tx| {
                let col0 = tx * TILE_CELLS;
                let row0 = ty * TILE_CELLS;
                let ncols = TILE_CELLS.min(cells[0] - col0);
                let nrows = TILE_CELLS.min(cells[1] - row0);
                let mut bounds = Aabb::EMPTY;
                for j in row0..row0 + nrows {
                    for i in col0..col0 + ncols {
                        let [a, b, c, d] = grid.cell_valid(i as usize, j as usize);
                        if a && c && (b || d) {
                            let (i, j) = (i as usize, j as usize);
                            for (ok, (ci, cj)) in [
                                (a, (i, j)),
                                (b, (i + 1, j)),
                                (c, (i + 1, j + 1)),
                                (d, (i, j + 1)),
                            ] {
                                if ok {
                                    bounds = bounds.union_point(grid.node(ci, cj));
                                }
                            }
                        }
                    }
                }
                (!bounds.is_empty()).then(|| Primitive {
                    shape: Shape::Terrain(TerrainTile {
                        grid: Arc::clone(&grid),
                        col0,
                        row0,
                        ncols,
                        nrows,
                        bounds,
                    }),
                    material,
                    class,
                    object,
                })
            })
        })
        .collect();
    scene.primitives.extend(tiles);
    triangles
}

/// A procedural terrain: fractional Brownian motion of gradient noise.
#[derive(Clone, Debug, PartialEq)]
pub struct FbmSpec {
    /// `[xmin, ymin, xmax, ymax]`, m.
    pub extent_m: [f64; 4],
    /// Node spacing, m.
    pub resolution_m: f64,
    /// Difference between the highest and the lowest node, m.
    pub relief_m: f64,
    /// Wavelength of the first (largest) octave, m.
    pub wavelength_m: f64,
    /// Octaves, each of half the wavelength and half the amplitude of the
    /// one before.
    pub octaves: u32,
    /// Seed of the gradients.
    pub seed: u64,
}

impl FbmSpec {
    /// Nodes across and up: `floor(width / resolution) + 1` (the grid
    /// starts at the extent's south-west corner and never leaves it).
    pub fn nodes(&self) -> (usize, usize) {
        let [x0, y0, x1, y1] = self.extent_m;
        let n = |w: f64| (w / self.resolution_m + 1e-9).floor() as usize + 1;
        (n(x1 - x0), n(y1 - y0))
    }
}

/// Generates an fBm terrain: heights from 0 (lowest node) to `relief_m`
/// (highest), reproducible from the seed.
pub fn generate_fbm(spec: &FbmSpec) -> Result<HeightGrid, TerrainError> {
    let (cols, rows) = spec.nodes();
    let path = Path::new("<fbm>");
    if cols.saturating_mul(rows) > MAX_NODES {
        return Err(TerrainError::Size {
            path: path.to_path_buf(),
            reason: format!("{cols} × {rows} cells exceed the limit of {MAX_NODES} cells"),
        });
    }
    let mut heights = vec![0f32; cols * rows];
    let [x0, y0, _, _] = spec.extent_m;
    heights
        .par_chunks_mut(cols)
        .enumerate()
        .for_each(|(j, row)| {
            let y = j as f64 * spec.resolution_m;
            let mut sum = vec![0.0f64; row.len()];
            let mut amp = 1.0;
            let mut freq = 1.0 / spec.wavelength_m;
            for o in 0..spec.octaves {
                let noise = GradientNoise {
                    key: crate::rng::mix64(spec.seed ^ (o as u64).wrapping_mul(0x9E37_79B9)),
                };
                // Along a row the lattice cell changes rarely: its four
                // gradients are hashed once per cell.
                let (yy, mut cell, mut grads) = (y * freq, i64::MIN, [(0.0, 0.0); 4]);
                for (i, s) in sum.iter_mut().enumerate() {
                    let xx = i as f64 * spec.resolution_m * freq;
                    let ix = xx.floor() as i64;
                    if ix != cell {
                        cell = ix;
                        grads = noise.corners(ix, yy.floor() as i64);
                    }
                    *s += amp * noise.eval(&grads, xx, yy);
                }
                amp *= 0.5;
                freq *= 2.0;
            }
            for (h, s) in row.iter_mut().zip(&sum) {
                *h = *s as f32;
            }
        });
    let (lo, hi) = heights
        .par_iter()
        .fold(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |(lo, hi), &h| (lo.min(h), hi.max(h)),
        )
        .reduce(
            || (f32::INFINITY, f32::NEG_INFINITY),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    let span = (hi - lo) as f64;
    let k = if span > 0.0 {
        spec.relief_m / span
    } else {
        0.0
    };
    heights
        .par_iter_mut()
        .for_each(|h| *h = (((*h - lo) as f64) * k) as f32);
    let grid = HeightGrid {
        cols,
        rows,
        origin_m: [x0, y0],
        spacing_m: [spec.resolution_m; 2],
        z_offset_m: 0.0,
        heights,
    };
    grid.check_size(path)?;
    Ok(grid)
}

/// 2-D gradient noise (Perlin 2002, "Improving noise": quintic fade,
/// gradients from a hashed lattice), roughly in [-1, 1].
struct GradientNoise {
    key: u64,
}

impl GradientNoise {
    const DIRS: [(f64, f64); 8] = [
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, -1.0),
        (
            std::f64::consts::FRAC_1_SQRT_2,
            std::f64::consts::FRAC_1_SQRT_2,
        ),
        (
            -std::f64::consts::FRAC_1_SQRT_2,
            std::f64::consts::FRAC_1_SQRT_2,
        ),
        (
            std::f64::consts::FRAC_1_SQRT_2,
            -std::f64::consts::FRAC_1_SQRT_2,
        ),
        (
            -std::f64::consts::FRAC_1_SQRT_2,
            -std::f64::consts::FRAC_1_SQRT_2,
        ),
    ];

    /// Gradient at lattice point `(cx, cy)`.
    fn gradient(&self, cx: i64, cy: i64) -> (f64, f64) {
        let h = crate::rng::mix64(
            self.key ^ crate::rng::mix64((cx as u64) ^ (cy as u64).rotate_left(32)),
        );
        Self::DIRS[(h >> 61) as usize]
    }

    /// Gradients at the corners (0,0), (1,0), (0,1), (1,1) of lattice cell
    /// `(ix, iy)`.
    fn corners(&self, ix: i64, iy: i64) -> [(f64, f64); 4] {
        [
            self.gradient(ix, iy),
            self.gradient(ix + 1, iy),
            self.gradient(ix, iy + 1),
            self.gradient(ix + 1, iy + 1),
        ]
    }

    /// Noise at `(x, y)` given the gradients of its lattice cell.
    fn eval(&self, g: &[(f64, f64); 4], x: f64, y: f64) -> f64 {
        let (fx, fy) = (x - x.floor(), y - y.floor());
        let dot = |g: (f64, f64), dx: f64, dy: f64| g.0 * dx + g.1 * dy;
        let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let (u, v) = (fade(fx), fade(fy));
        let n00 = dot(g[0], fx, fy);
        let n10 = dot(g[1], fx - 1.0, fy);
        let n01 = dot(g[2], fx, fy - 1.0);
        let n11 = dot(g[3], fx - 1.0, fy - 1.0);
        let a = n00 + u * (n10 - n00);
        let b = n01 + u * (n11 - n01);
        (a + v * (b - a)) * std::f64::consts::SQRT_2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{BruteForce, Bvh, RayCaster};

    #[test]
    fn fbm_is_reproducible_spans_the_relief_and_honours_the_resolution() {
        let spec = FbmSpec {
            extent_m: [-100.0, 50.0, 100.0, 150.0],
            resolution_m: 2.5,
            relief_m: 40.0,
            wavelength_m: 80.0,
            octaves: 5,
            seed: 7,
        };
        let a = generate_fbm(&spec).unwrap();
        let b = generate_fbm(&spec).unwrap();
        assert_eq!(a, b);
        assert_eq!((a.cols, a.rows), (81, 41));
        assert_eq!(a.origin_m, [-100.0, 50.0]);
        assert_eq!(a.spacing_m, [2.5, 2.5]);
        assert_eq!(a.node(80, 40).truncate(), glam::DVec2::new(100.0, 150.0));
        let lo = a.heights.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = a.heights.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
        assert_eq!(lo, 0.0);
        assert!((hi as f64 - 40.0).abs() < 1e-4, "{hi}");
        let c = generate_fbm(&FbmSpec {
            seed: 8,
            ..spec.clone()
        })
        .unwrap();
        assert_ne!(a.heights, c.heights);
        // Neighbouring nodes differ far less than the relief: a surface,
        // not white noise.
        let mean_step = a
            .heights
            .windows(2)
            .map(|w| (w[1] - w[0]).abs() as f64)
            .sum::<f64>()
            / (a.heights.len() - 1) as f64;
        assert!(mean_step < 0.1 * 40.0, "{mean_step}");
    }

    #[test]
    fn tiles_hit_where_the_interpolated_surface_is_and_match_brute_force_triangles() {
        let spec = FbmSpec {
            extent_m: [0.0, 0.0, 90.0, 70.0],
            resolution_m: 1.5,
            relief_m: 12.0,
            wavelength_m: 30.0,
            octaves: 4,
            seed: 3,
        };
        let mut grid = generate_fbm(&spec).unwrap();
        // A hole of nodata.
        for j in 10..14 {
            for i in 20..25 {
                grid.heights[j * grid.cols + i] = f32::NAN;
            }
        }
        grid.shift(DVec3::new(500.0, -200.0, 30.0));
        let g2 = grid.clone();
        // Reference: every valid triangle as a separate scene triangle.
        let mut reference = Scene::default();
        for j in 0..g2.rows - 1 {
            for i in 0..g2.cols - 1 {
                let (a, b, c, d) = (
                    g2.node(i, j),
                    g2.node(i + 1, j),
                    g2.node(i + 1, j + 1),
                    g2.node(i, j + 1),
                );
                for tri in [[a, b, c], [a, c, d]] {
                    if let Some(t) = crate::scene::Triangle::new(tri[0], tri[1], tri[2]) {
                        reference.primitives.push(Primitive {
                            shape: Shape::Triangle(t),
                            material: 0,
                            class: SurfaceClass::Ground,
                            object: 0,
                        });
                    }
                }
            }
        }
        let mut scene = Scene::default();
        let n = add_terrain(&mut scene, grid, 0, SurfaceClass::Ground, "t");
        assert_eq!(n, reference.primitives.len());
        let tiles = scene.primitives.len();
        assert_eq!(
            tiles,
            4 * 3,
            "60 × 46 cells in 16-cell tiles: ceil(60/16) × ceil(46/16)"
        );
        let bvh = Bvh::build(scene);
        let brute = BruteForce::new(reference);
        let mut rng = crate::rng::Stream::new(5, 0, 0, crate::rng::Purpose::Speckle);
        let (mut hits, mut holes) = (0, 0);
        for _ in 0..3000 {
            let o = DVec3::new(
                490.0 + 110.0 * rng.uniform(),
                -210.0 + 90.0 * rng.uniform(),
                120.0,
            );
            let d = DVec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, -1.0);
            let ray = Ray::new(o, d);
            let a = bvh.closest_hit(&ray, 0.0, 1e4);
            let b = brute.closest_hit(&ray, 0.0, 1e4);
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert!((a.t - b.t).abs() < 1e-9, "{} vs {}", a.t, b.t);
                    assert!(a.normal.dot(b.normal) > 1.0 - 1e-9 || (a.t - b.t).abs() < 1e-9);
                    let p = ray.at(a.t);
                    let z = g2.elevation_at(p.x, p.y).unwrap();
                    assert!((z - p.z).abs() < 1e-6, "{z} vs {}", p.z);
                    hits += 1;
                }
                (None, None) => holes += 1,
                (a, b) => panic!("tile {a:?} vs triangles {b:?} for {ray:?}"),
            }
        }
        assert!(hits > 1000 && holes > 10, "{hits} hits, {holes} misses");
        // Straight down into the middle of the hole: nothing.
        let into_hole = Ray::new(DVec3::new(533.0, -182.0, 200.0), -DVec3::Z);
        assert!(bvh.closest_hit(&into_hole, 0.0, 1e4).is_none());
        // A vertical ray exactly on a node line and on a tile boundary.
        let x = 500.0 + 16.0 * 1.5;
        let ray = Ray::new(DVec3::new(x, -180.0, 200.0), -DVec3::Z);
        let h = bvh.closest_hit(&ray, 0.0, 1e4).unwrap();
        let z = g2.elevation_at(x, -180.0).unwrap();
        assert!((ray.at(h.t).z - z).abs() < 1e-9);
    }
}
