//! Generated forest stands: trees placed reproducibly from a seed.
//!
//! Stem positions are uniform over the stand's area with a minimum distance
//! between stems (a hard-core point process, the usual null model of stem
//! maps), species drawn from the mix, heights uniform in the range, dbh from
//! the species' height curve and the crown base from its live crown ratio
//! (±15 %). A stand's trees go into the scene on all threads
//! ([`Scene::add_stand`]).

use super::foliage::FoliageSettings;
use super::tree::TreeSpec;
use super::{MaterialId, Scene, SceneObject, Species, tree_part};
use crate::geometry::DVec3;
use crate::rng::{Purpose, Stream};
use rayon::prelude::*;
use std::sync::OnceLock;

/// A stand to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct ForestSpec {
    /// Outline of the stand (x, y), any simple polygon.
    pub area: Vec<[f64; 2]>,
    /// Stem density, trees per hectare.
    pub stems_per_ha: f64,
    /// Species and their relative weights.
    pub mix: Vec<(Species, f64)>,
    /// Smallest and largest tree height, m.
    pub height_range_m: (f64, f64),
    /// Smallest distance between two stems, m.
    pub min_spacing_m: f64,
    /// Seed of the placement.
    pub seed: u64,
}

/// Area of a simple polygon (shoelace formula), m².
pub fn polygon_area(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let [x0, y0] = poly[i];
            let [x1, y1] = poly[(i + 1) % n];
            x0 * y1 - x1 * y0
        })
        .sum::<f64>()
        .abs()
        * 0.5
}

/// Even-odd point-in-polygon test in the plane.
pub fn inside(poly: &[[f64; 2]], x: f64, y: f64) -> bool {
    let mut c = false;
    let n = poly.len();
    let mut j = n - 1;
    for i in 0..n {
        let ([xi, yi], [xj, yj]) = (poly[i], poly[j]);
        if (yi > y) != (yj > y) && x < xi + (y - yi) * (xj - xi) / (yj - yi) {
            c = !c;
        }
        j = i;
    }
    c
}

/// The trees of a stand; `ground_z(x, y)` gives the height of the ground
/// at a stem. Fewer trees than asked are returned when the minimum spacing
/// cannot be kept (the caller can compare with the requested count).
///
/// The stems are placed one after another (each must keep its distance
/// from those before it); each accepted stem then takes the next
/// four numbers of the stream for its attributes, which are worked out
/// from the stream's position at that stem: the same trees as drawing
/// them in turn. The attributes of every 32 768 stems are worked out by a
/// task of their own while the placement goes on, so that the other
/// threads work while placement keeps one busy.
pub fn generate(spec: &ForestSpec, ground_z: &(dyn Fn(f64, f64) -> f64 + Sync)) -> Vec<TreeSpec> {
    let area = polygon_area(&spec.area);
    let wanted = (area / 10_000.0 * spec.stems_per_ha).round() as usize;
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for [x, y] in &spec.area {
        x0 = x0.min(*x);
        y0 = y0.min(*y);
        x1 = x1.max(*x);
        y1 = y1.max(*y);
    }
    let mut rng = Stream::new(spec.seed, 0, 0, Purpose::Forest);
    let mut grid = SpacingGrid::new(spec.min_spacing_m, [x0, y0, x1, y1]);
    let mut stems: Vec<[f64; 2]> = crate::memory::huge_vec(wanted);
    // The trees of chunk `c`, set by its task.
    let chunks: Vec<OnceLock<Vec<TreeSpec>>> = (0..wanted.div_ceil(ATTRIBUTE_CHUNK))
        .map(|_| OnceLock::new())
        .collect();
    let chunks_ref = &chunks;
    rayon::scope(|scope| {
        // A chunk's stems and streams, handed to a task of its own.
        let spawn = |c: usize, stems: Vec<[f64; 2]>, mut draws: Vec<Stream>| {
            scope.spawn(move |_| {
                let mut trees = Vec::with_capacity(stems.len());
                trees.extend(
                    stems
                        .chunks(TREE_BATCH)
                        .zip(draws.chunks_mut(TREE_BATCH))
                        .flat_map(|(stems, draws)| trees_at(spec, stems, draws, ground_z)),
                );
                // Each chunk is set once, by its only task.
                let _ = chunks_ref[c].set(trees);
            });
        };
        let mut draws: Vec<Stream> = Vec::with_capacity(ATTRIBUTE_CHUNK);
        let mut attempts = 0usize;
        while stems.len() < wanted && attempts < 50 * wanted + 1000 {
            attempts += 1;
            let x = x0 + rng.uniform() * (x1 - x0);
            let y = y0 + rng.uniform() * (y1 - y0);
            if !inside(&spec.area, x, y) {
                continue;
            }
            if let Some(grid) = &mut grid {
                let near = grid.any_near(x, y, |i| {
                    let [px, py] = stems[i as usize];
                    (px - x).hypot(py - y) < spec.min_spacing_m
                });
                if near {
                    continue;
                }
                grid.insert(x, y, stems.len() as u32);
            }
            stems.push([x, y]);
            draws.push(rng.clone());
            rng.skip(DRAWS_PER_TREE);
            if draws.len() == ATTRIBUTE_CHUNK {
                let start = stems.len() - ATTRIBUTE_CHUNK;
                let full = std::mem::replace(&mut draws, Vec::with_capacity(ATTRIBUTE_CHUNK));
                spawn(start / ATTRIBUTE_CHUNK, stems[start..].to_vec(), full);
            }
        }
        if !draws.is_empty() {
            let start = stems.len() - draws.len();
            spawn(start / ATTRIBUTE_CHUNK, stems[start..].to_vec(), draws);
        }
        drop(grid);
    });
    let mut trees = Vec::with_capacity(stems.len());
    for chunk in chunks {
        trees.extend(chunk.into_inner().unwrap_or_default());
    }
    trees
}

impl Scene {
    /// Adds the trees of `[[forest]]` entry `forest`, each as
    /// [`Scene::add_tree`] would (a trunk, then a crown, one object per
    /// tree) but built on all threads and named by number
    /// ([`SceneObject::StandTree`]).
    pub fn add_stand(&mut self, forest: usize, trees: &[TreeSpec], foliage: &FoliageSettings) {
        self.add_trees(trees, foliage, |tree| SceneObject::StandTree {
            forest: forest as u32,
            tree,
        });
    }

    /// Adds `trees` as [`Scene::add_stand`] does, tree `k` named
    /// `object(k)`.
    pub fn add_trees(
        &mut self,
        trees: &[TreeSpec],
        foliage: &FoliageSettings,
        object: impl Fn(u32) -> SceneObject,
    ) {
        // The materials, in the order add_tree would add them; a stand has
        // a few, shared by its trees: looked up again only when a tree's
        // differ from the last one's.
        let mut materials: Vec<(MaterialId, MaterialId)> = Vec::with_capacity(trees.len());
        let mut last: Option<(&TreeSpec, (MaterialId, MaterialId))> = None;
        for t in trees {
            let ids = match last {
                Some((l, ids))
                    if (l.species, l.bark_reflectance, l.foliage_reflectance)
                        == (t.species, t.bark_reflectance, t.foliage_reflectance) =>
                {
                    ids
                }
                _ => self.tree_materials(t, foliage),
            };
            last = Some((t, ids));
            materials.push(ids);
        }
        let first_object = self.objects.len();
        self.objects
            .extend((0..trees.len()).map(|tree| object(tree as u32)));
        let stand = (0..2 * trees.len()).into_par_iter().map(|k| {
            let object = (first_object + k / 2) as u32;
            tree_part(&trees[k / 2], k % 2 == 1, materials[k / 2], object, foliage)
        });
        self.primitives.par_extend(stand);
    }
}

/// Numbers of the stream each tree's attributes take (species, height,
/// crown ratio, seed).
const DRAWS_PER_TREE: u64 = 4;

/// Trees whose attributes are worked out together: their dbh bisections
/// run side by side ([`Species::dbh_from_heights_m`]).
const TREE_BATCH: usize = 16;

/// Stems whose attributes one task works out while placement goes on
/// ([`generate`]): a multiple of [`TREE_BATCH`], a few milliseconds of
/// work.
const ATTRIBUTE_CHUNK: usize = 2048 * TREE_BATCH;

/// The trees whose stems stand at `stems` (at most [`TREE_BATCH`]), each
/// with its attributes drawn from its stream in `draws`
/// ([`DRAWS_PER_TREE`] numbers): species, height, crown ratio, seed.
fn trees_at<'a>(
    spec: &'a ForestSpec,
    stems: &'a [[f64; 2]],
    draws: &'a mut [Stream],
    ground_z: &'a (dyn Fn(f64, f64) -> f64 + Sync),
) -> impl Iterator<Item = TreeSpec> + 'a {
    let n = stems.len();
    let mut drawn = [(spec.mix[0].0, 0.0); TREE_BATCH];
    for (d, rng) in drawn.iter_mut().zip(draws.iter_mut()) {
        *d = species_and_height(spec, rng);
    }
    // Lanes past `n` repeat the first tree; their answers are dropped.
    for k in n..TREE_BATCH {
        drawn[k] = drawn[0];
    }
    let dbh = Species::dbh_from_heights_m(drawn);
    (0..n).map(move |k| {
        let [x, y] = stems[k];
        let (species, height) = drawn[k];
        // Heights beyond what the height curve gives over its dbh range
        // take the nearest end of that range.
        let (d_lo, d_hi) = Species::DBH_RANGE_M;
        let dbh = dbh[k].unwrap_or(if height < species.height_from_dbh_m(d_lo) {
            d_lo
        } else {
            d_hi
        });
        let rng = &mut draws[k];
        let ratio = species.preset().crown_ratio * (0.85 + 0.3 * rng.uniform());
        let crown_base = height * (1.0 - ratio.min(0.95));
        let base = DVec3::new(x, y, ground_z(x, y));
        let mut tree = TreeSpec::new(base, species, dbh, height, crown_base);
        tree.seed = rng.next_u64();
        tree
    })
}

/// A tree's species, by the mix's weights, and its height: the first two
/// numbers of its stream.
fn species_and_height(spec: &ForestSpec, rng: &mut Stream) -> (Species, f64) {
    let total_weight: f64 = spec.mix.iter().map(|(_, w)| w).sum();
    let mut pick = rng.uniform() * total_weight;
    let mut species = spec.mix[0].0;
    for (s, w) in &spec.mix {
        species = *s;
        if pick < *w {
            break;
        }
        pick -= w;
    }
    let (h0, h1) = spec.height_range_m;
    (species, h0 + rng.uniform() * (h1 - h0))
}

/// The stems placed so far, by cells whose diagonal is the minimum spacing:
/// a cell holds at most one stem, and every stem closer than the spacing to
/// a point lies in the 5 × 5 cells around it.
struct SpacingGrid {
    origin: [f64; 2],
    inv_cell: f64,
    nx: usize,
    ny: usize,
    cells: Cells,
}

/// A flat array of cells where that takes at most [`SpacingGrid::FLAT_MAX`]
/// cells, a map of the occupied ones otherwise.
enum Cells {
    Flat(Vec<u32>),
    Sparse(std::collections::HashMap<usize, u32>),
}

impl SpacingGrid {
    /// Largest flat grid: 64 M cells, 256 MB.
    const FLAT_MAX: usize = 1 << 26;
    const EMPTY: u32 = u32::MAX;

    /// The grid over the box `[x0, y0, x1, y1]`, `None` without a spacing.
    fn new(spacing_m: f64, [x0, y0, x1, y1]: [f64; 4]) -> Option<Self> {
        if spacing_m.is_nan() || spacing_m <= 0.0 {
            return None;
        }
        let cell = spacing_m / std::f64::consts::SQRT_2;
        // One cell more than the box needs: a stem rounded onto the far
        // edge still has a cell of its own.
        let nx = ((x1 - x0) / cell).ceil().clamp(0.0, 1e15) as usize + 1;
        let ny = ((y1 - y0) / cell).ceil().clamp(0.0, 1e15) as usize + 1;
        let cells = match nx.checked_mul(ny) {
            Some(n) if n <= Self::FLAT_MAX => {
                let mut v = crate::memory::huge_vec(n);
                v.resize(n, Self::EMPTY);
                Cells::Flat(v)
            }
            _ => Cells::Sparse(Default::default()),
        };
        Some(Self {
            origin: [x0, y0],
            inv_cell: 1.0 / cell,
            nx,
            ny,
            cells,
        })
    }

    fn cell_of(&self, x: f64, y: f64) -> (usize, usize) {
        let cx = ((x - self.origin[0]) * self.inv_cell) as usize;
        let cy = ((y - self.origin[1]) * self.inv_cell) as usize;
        (cx.min(self.nx - 1), cy.min(self.ny - 1))
    }

    /// Whether `hit` holds for a stem in the 5 × 5 cells around `(x, y)`.
    fn any_near(&self, x: f64, y: f64, mut hit: impl FnMut(u32) -> bool) -> bool {
        let (cx, cy) = self.cell_of(x, y);
        let (gx0, gx1) = (cx.saturating_sub(2), (cx + 2).min(self.nx - 1));
        for gy in cy.saturating_sub(2)..=(cy + 2).min(self.ny - 1) {
            let row = gy * self.nx;
            let found = match &self.cells {
                Cells::Flat(v) => v[row + gx0..=row + gx1]
                    .iter()
                    .any(|&i| i != Self::EMPTY && hit(i)),
                Cells::Sparse(m) => {
                    (gx0..=gx1).any(|gx| m.get(&(row + gx)).is_some_and(|&i| hit(i)))
                }
            };
            if found {
                return true;
            }
        }
        false
    }

    fn insert(&mut self, x: f64, y: f64, stem: u32) {
        let (cx, cy) = self.cell_of(x, y);
        let cell = cy * self.nx + cx;
        match &mut self.cells {
            Cells::Flat(v) => v[cell] = stem,
            Cells::Sparse(m) => {
                m.insert(cell, stem);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stand(seed: u64) -> ForestSpec {
        ForestSpec {
            area: vec![[0.0, 0.0], [100.0, 0.0], [100.0, 50.0], [0.0, 50.0]],
            stems_per_ha: 800.0,
            mix: vec![(Species::Pine, 0.7), (Species::Birch, 0.3)],
            height_range_m: (12.0, 22.0),
            min_spacing_m: 1.5,
            seed,
        }
    }

    #[test]
    fn density_mix_spacing_and_reproducibility() {
        let trees = generate(&stand(4), &|_, _| 2.0);
        assert_eq!(trees.len(), 400); // 0.5 ha × 800 /ha
        assert_eq!(trees, generate(&stand(4), &|_, _| 2.0));
        assert_ne!(trees, generate(&stand(5), &|_, _| 2.0));
        let pines = trees.iter().filter(|t| t.species == Species::Pine).count() as f64;
        assert!((pines / 400.0 - 0.7).abs() < 0.08);
        for (i, a) in trees.iter().enumerate() {
            assert!(inside(&stand(4).area, a.base_m.x, a.base_m.y));
            assert_eq!(a.base_m.z, 2.0);
            assert!((12.0..22.0).contains(&a.height_m));
            assert!(a.crown_base_m > 0.0 && a.crown_base_m < a.height_m);
            assert!(a.dbh_m >= 0.03 && a.dbh_m <= 0.8);
            for b in &trees[i + 1..] {
                let d = (a.base_m.x - b.base_m.x).hypot(a.base_m.y - b.base_m.y);
                assert!(d >= 1.5);
            }
        }
    }

    /// A stand of several attribute chunks, worked out while it is placed,
    /// has the trees that placing the stems and drawing each accepted
    /// tree's attributes in turn from the one stream gives.
    #[test]
    fn a_stand_of_many_chunks_is_the_stand_drawn_in_turn() {
        let mut spec = stand(8);
        spec.area = vec![[0.0, 0.0], [1000.0, 0.0], [1000.0, 600.0], [0.0, 600.0]];
        let ground = |x: f64, y: f64| 0.01 * x - 0.02 * y;
        let trees = generate(&spec, &ground);
        assert_eq!(trees.len(), 48_000); // 60 ha × 800 /ha
        assert!(trees.len() > ATTRIBUTE_CHUNK + TREE_BATCH + 1);

        let mut rng = Stream::new(spec.seed, 0, 0, Purpose::Forest);
        let mut grid = SpacingGrid::new(spec.min_spacing_m, [0.0, 0.0, 1000.0, 600.0]).unwrap();
        let mut want: Vec<TreeSpec> = Vec::new();
        while want.len() < trees.len() {
            let (x, y) = (1000.0 * rng.uniform(), 600.0 * rng.uniform());
            let near = grid.any_near(x, y, |i| {
                let b = want[i as usize].base_m;
                (b.x - x).hypot(b.y - y) < spec.min_spacing_m
            });
            if near {
                continue;
            }
            grid.insert(x, y, want.len() as u32);
            let (species, height) = species_and_height(&spec, &mut rng);
            let dbh = species
                .dbh_from_height_m(height)
                .expect("heights on the curve");
            let ratio = species.preset().crown_ratio * (0.85 + 0.3 * rng.uniform());
            let base = DVec3::new(x, y, ground(x, y));
            let mut tree = TreeSpec::new(base, species, dbh, height, height * (1.0 - ratio));
            tree.seed = rng.next_u64();
            want.push(tree);
        }
        assert!(trees == want, "the first tree that differs: {:?}", {
            let k = (0..want.len()).find(|&k| trees[k] != want[k]);
            k.map(|k| (k, &trees[k], &want[k]))
        });
    }

    #[test]
    fn heights_outside_the_height_curve_keep_sane_diameters() {
        let mut spec = stand(1);
        spec.height_range_m = (1.9, 45.0);
        spec.mix = vec![(Species::Pine, 1.0), (Species::Birch, 1.0)];
        for t in generate(&spec, &|_, _| 0.0) {
            assert!((0.03..=0.8).contains(&t.dbh_m), "{t:?}");
            assert!(t.crown_radius_m <= t.species.crown_radius_m(0.8), "{t:?}");
        }
    }

    /// The flat and the sparse grid find the same stems near a point: all
    /// those closer than the spacing (brute force), perhaps a few more.
    #[test]
    fn spacing_grid_finds_every_close_stem() {
        let spacing = 2.0;
        let mut flat = SpacingGrid::new(spacing, [0.0, 0.0, 40.0, 30.0]).unwrap();
        let mut sparse = SpacingGrid::new(spacing, [0.0, 0.0, 40.0, 30.0]).unwrap();
        sparse.cells = Cells::Sparse(Default::default());
        let mut rng = Stream::new(1, 0, 0, Purpose::Forest);
        let mut stems: Vec<[f64; 2]> = Vec::new();
        for _ in 0..3000 {
            let (x, y) = (40.0 * rng.uniform(), 30.0 * rng.uniform());
            let close = |grid: &SpacingGrid| {
                grid.any_near(x, y, |i| {
                    let [px, py] = stems[i as usize];
                    (px - x).hypot(py - y) < spacing
                })
            };
            let brute = stems
                .iter()
                .any(|[px, py]| (px - x).hypot(py - y) < spacing);
            assert_eq!(close(&flat), brute);
            assert_eq!(close(&sparse), brute);
            if !brute {
                flat.insert(x, y, stems.len() as u32);
                sparse.insert(x, y, stems.len() as u32);
                stems.push([x, y]);
            }
        }
        assert!(stems.len() > 100);
    }

    /// A stand added on all threads is the scene that adding its trees one
    /// by one gives, but for how the objects hold their names.
    #[test]
    fn add_stand_is_add_tree_in_turn() {
        let spec = stand(11);
        let trees = generate(&spec, &|x, y| 0.01 * x - 0.02 * y);
        assert!(trees.len() > 100);
        let mut one_by_one = Scene::default();
        one_by_one.add_object("polygon[0]");
        let mut stand_scene = one_by_one.clone();
        for (j, t) in trees.iter().enumerate() {
            one_by_one.add_tree(
                t,
                &FoliageSettings::default(),
                format!("forest[2].tree[{j}]"),
            );
        }
        stand_scene.add_stand(2, &trees, &FoliageSettings::default());
        assert_eq!(stand_scene.materials, one_by_one.materials);
        let names = |s: &Scene| s.objects.iter().map(|o| o.to_string()).collect::<Vec<_>>();
        assert_eq!(names(&stand_scene), names(&one_by_one));
        assert_eq!(stand_scene.primitives.len(), one_by_one.primitives.len());
        for (a, b) in stand_scene.primitives.iter().zip(&one_by_one.primitives) {
            assert_eq!(
                (a.material, a.class, a.object),
                (b.material, b.class, b.object)
            );
            assert_eq!(format!("{:?}", a.shape), format!("{:?}", b.shape));
        }
    }

    #[test]
    fn polygon_area_and_inside() {
        let l = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 1.0],
            [1.0, 1.0],
            [1.0, 3.0],
            [0.0, 3.0],
        ];
        assert!((polygon_area(&l) - 6.0).abs() < 1e-12);
        assert!(inside(&l, 0.5, 2.0) && !inside(&l, 2.0, 2.0));
    }
}
