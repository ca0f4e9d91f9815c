//! Trees: a conical trunk and a volumetric crown (specification, "LiDAR
//! pulse in vegetation").
//!
//! A tree is described by its stem base, species, dbh, height and
//! crown-base height. It becomes two scene primitives: an opaque
//! [`Trunk`] (a cone, "the stem is a cone (c==1)") and a [`Crown`], the
//! envelope `r(χ) = a + b·χ^c` (specification Eq. 4, χ = 0 at the top and 1
//! at the crown base) filled with a relative density `ρ` of plant area
//! ([`FoliageModel`]): by default the physical one — needles or leaves and
//! woody area spread through the envelope as a random medium, denser
//! towards the outer hull and clumped in cells at branch scale — or the
//! specification's `thetafactor × heightfactor × radiusfactor` (its
//! Fig. 15 and the three factors that follow it). Sub-rays march through
//! crowns and are intercepted by a lottery (see [`crate::canopy`]); sources
//! of every parameter are in `docs/trees.md`.

use super::foliage::{
    Clumps, Field, FoliageModel, FoliageSettings, LevelField, Whorls, clump_hash, level_key, shell,
};
use super::species::Species;
use crate::geometry::{Aabb, DVec3, Ray, VerticalCylinder};

/// The rotation of the branch pattern from one whorl to the next: the
/// golden angle `π(3 − √5)`, so that no two whorls line up.
pub const GOLDEN_ANGLE: f64 = 0.763_932_022_500_210_2 * std::f64::consts::PI;

/// Height at which dbh is measured, m.
pub const BREAST_HEIGHT_M: f64 = 1.3;

/// Shortest tree accepted, m (the trunk tapers from breast height, 1.3 m,
/// to the top, so a tree must be clearly taller than that).
pub const MIN_TREE_HEIGHT_M: f64 = 2.0;

/// A tree as described in a survey.
#[derive(Clone, Debug, PartialEq)]
pub struct TreeSpec {
    /// Stem base (ground level at the stem), m.
    pub base_m: DVec3,
    /// Species.
    pub species: Species,
    /// Diameter at breast height (1.3 m), m.
    pub dbh_m: f64,
    /// Tree height, m.
    pub height_m: f64,
    /// Height of the base of the living crown above the stem base, m.
    pub crown_base_m: f64,
    /// Foliage reflectance (default: species preset).
    pub foliage_reflectance: f64,
    /// Bark reflectance (default: species preset).
    pub bark_reflectance: f64,
    /// Maximum crown radius `a + b`, m (default: species allometry).
    pub crown_radius_m: f64,
    /// Interception coefficient `k`, 1/m (`None`: the species preset's
    /// for the survey's foliage model).
    pub extinction_per_m: Option<f64>,
    /// When set, a constant relative foliage density inside the envelope
    /// replaces the three-factor model (for tests and simple crowns).
    pub uniform_density: Option<f64>,
    /// Seed of the whorl rotation of this tree.
    pub seed: u64,
}

impl TreeSpec {
    /// A tree with species defaults for everything not given.
    pub fn new(
        base_m: DVec3,
        species: Species,
        dbh_m: f64,
        height_m: f64,
        crown_base_m: f64,
    ) -> Self {
        let p = species.preset();
        Self {
            base_m,
            species,
            dbh_m,
            height_m,
            crown_base_m,
            foliage_reflectance: p.foliage_reflectance,
            bark_reflectance: p.bark_reflectance,
            crown_radius_m: species.crown_radius_m(dbh_m),
            extinction_per_m: None,
            uniform_density: None,
            seed: 0,
        }
    }

    /// The trunk cone.
    pub fn trunk(&self) -> Trunk {
        Trunk::new(self.base_m, self.dbh_m, self.height_m)
    }

    /// The crown, filled as `foliage` says.
    pub fn crown(&self, foliage: &FoliageSettings) -> Crown {
        let p = self.species.preset();
        let a = p.flat_top_fraction * self.crown_radius_m;
        let field = match (self.uniform_density, foliage.model) {
            (Some(rho), _) => Field::Uniform(rho),
            (None, FoliageModel::Specification) => {
                let whorl_phase = (crate::rng::mix64(self.seed) >> 11) as f64 / (1u64 << 53) as f64
                    * std::f64::consts::TAU;
                let (phase_sin, phase_cos) = whorl_phase.sin_cos();
                Field::Specification(Whorls {
                    spacing_m: foliage.whorl_spacing_m,
                    phase: whorl_phase,
                    phase_cos,
                    phase_sin,
                    step: GOLDEN_ANGLE,
                })
            }
            (None, FoliageModel::Physical) => Field::Physical(Clumps {
                cell_m: foliage.clump_m,
                fraction: foliage.clump_fraction,
                key: (crate::rng::mix64(self.seed ^ 0x636c_756d_7073) >> 32) as u32,
                shell_m: foliage.shell_m,
            }),
        };
        let default_k = match foliage.model {
            FoliageModel::Physical => p.extinction_per_m,
            FoliageModel::Specification => p.specification_extinction_per_m,
        };
        Crown {
            axis_x: self.base_m.x,
            axis_y: self.base_m.y,
            z_top: self.base_m.z + self.height_m,
            z_base: self.base_m.z + self.crown_base_m,
            a,
            b: self.crown_radius_m - a,
            c: p.shape_c,
            extinction_per_m: self.extinction_per_m.unwrap_or(default_k),
            field,
        }
    }

    /// The reflectance of the crown's plant area in `foliage`'s model:
    /// the physical model's includes the woody area (bark reflectance
    /// weighted by the species' branch-to-leaf area), the specification's
    /// is the foliage's.
    pub fn crown_reflectance(&self, foliage: &FoliageSettings) -> f64 {
        let w = self.species.preset().woody_ratio;
        match (foliage.model, self.uniform_density) {
            (FoliageModel::Physical, None) => {
                (self.foliage_reflectance + w * self.bark_reflectance) / (1.0 + w)
            }
            _ => self.foliage_reflectance,
        }
    }
}

/// The stem: a cone with its apex at the tree top and radius
/// `dbh/2 · (H − h)/(H − 1.3)` at height `h` above the base (so the radius is
/// dbh/2 at breast height and "slightly (linearly) larger" at the base).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trunk {
    axis_x: f64,
    axis_y: f64,
    z_base: f64,
    z_top: f64,
    /// Radius per metre below the top.
    slope: f64,
}

impl Trunk {
    /// The trunk of a tree of height `height_m` and dbh `dbh_m` at `base_m`.
    pub fn new(base_m: DVec3, dbh_m: f64, height_m: f64) -> Self {
        Self {
            axis_x: base_m.x,
            axis_y: base_m.y,
            z_base: base_m.z,
            z_top: base_m.z + height_m,
            slope: 0.5 * dbh_m / (height_m - BREAST_HEIGHT_M),
        }
    }

    /// Radius at world height `z`, m (0 outside the stem).
    pub fn radius_at(&self, z: f64) -> f64 {
        if z < self.z_base || z > self.z_top {
            0.0
        } else {
            self.slope * (self.z_top - z)
        }
    }

    /// The stem's bounding cylinder (its radius at the base).
    pub fn bounds_cylinder(&self) -> VerticalCylinder {
        VerticalCylinder {
            axis: (self.axis_x, self.axis_y),
            radius: self.radius_at(self.z_base),
            z: (self.z_base, self.z_top),
        }
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        let r = self.radius_at(self.z_base);
        Aabb {
            min: DVec3::new(self.axis_x - r, self.axis_y - r, self.z_base),
            max: DVec3::new(self.axis_x + r, self.axis_y + r, self.z_top),
        }
    }

    /// Outward unit normal of the cone's side at the point `p`.
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        DVec3::new(
            p.x - self.axis_x,
            p.y - self.axis_y,
            self.slope * self.slope * (self.z_top - p.z),
        )
        .normalize_or(DVec3::Z)
    }

    /// First intersection with the cone's side within `(t_min, t_max)` and
    /// the outward normal there.
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
        // (x−x0)² + (y−y0)² = m² (z_top − z)², z_base ≤ z ≤ z_top.
        let m2 = self.slope * self.slope;
        let o = ray.origin - DVec3::new(self.axis_x, self.axis_y, self.z_top);
        let d = ray.dir;
        let a = d.x * d.x + d.y * d.y - m2 * d.z * d.z;
        let b = 2.0 * (o.x * d.x + o.y * d.y - m2 * o.z * d.z);
        let c = o.x * o.x + o.y * o.y - m2 * o.z * o.z;
        let roots: [f64; 2] = if a.abs() < 1e-15 {
            if b.abs() < 1e-15 {
                return None;
            }
            [-c / b, f64::NAN]
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            // Numerically stable pair of roots.
            let q = -0.5 * (b + b.signum() * sq);
            let (r1, r2) = (q / a, if q != 0.0 { c / q } else { f64::NAN });
            if r1 <= r2 { [r1, r2] } else { [r2, r1] }
        };
        for t in roots {
            if !(t > t_min && t < t_max) {
                continue;
            }
            let p = ray.at(t);
            // The cone equation also holds on the mirrored cone above the
            // apex: keep the stem part.
            if p.z < self.z_base || p.z > self.z_top {
                continue;
            }
            return Some((t, self.normal_at(p)));
        }
        None
    }
}

/// A crown envelope with its foliage density field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crown {
    axis_x: f64,
    axis_y: f64,
    z_top: f64,
    z_base: f64,
    a: f64,
    b: f64,
    c: f64,
    /// Interception coefficient `k`, 1/m.
    pub extinction_per_m: f64,
    /// How the envelope is filled.
    field: Field,
}

/// What a crown's foliage density depends on at one height (the envelope
/// radius and the field's factors there), computed once for all sub-rays
/// of a pulse that cross that height: only the horizontal offset from the
/// stem is left to each sub-ray ([`CrownLevel::density`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrownLevel {
    /// Envelope radius squared, m².
    pub radius_sq: f64,
    /// Envelope radius, m.
    pub radius: f64,
    /// `1 / radius` (0 for a zero radius), 1/m.
    pub inv_radius: f64,
    /// The field at this level.
    pub field: LevelField,
}

impl CrownLevel {
    /// Relative density at horizontal offset `(dx, dy)` from the stem
    /// axis, as [`Crown::density_at`] gives it; the specification's
    /// `cos(6φ + f)` as `Re((dx + i·dy)⁶ e^{if}) / d⁶` (no division per
    /// factor, no branch on the data, so that a loop over sub-rays
    /// vectorises).
    #[inline(always)]
    pub fn density(&self, dx: f64, dy: f64) -> f64 {
        let d2 = dx * dx + dy * dy;
        let rc = d2.sqrt() * self.inv_radius;
        let rho = match self.field {
            LevelField::Uniform(rho) => rho,
            LevelField::Specification {
                height_factor,
                whorl_cos,
                whorl_sin,
            } => {
                let (x2, y2) = (dx * dx - dy * dy, 2.0 * dx * dy);
                let (x3, y3) = (x2 * dx - y2 * dy, x2 * dy + y2 * dx);
                let (x6, y6) = (x3 * x3 - y3 * y3, 2.0 * x3 * y3);
                let d6 = d2 * d2 * d2;
                // On the axis φ = 0, as in `density_at`.
                let theta = if d2 > 1e-24 {
                    (x6 * whorl_cos - y6 * whorl_sin).abs() / d6
                } else {
                    whorl_cos.abs()
                };
                theta * height_factor * (1.0 - rc)
            }
            LevelField::Physical {
                inv_cell,
                key,
                below,
                weight,
                core_rc,
            } => {
                let (i, j) = (
                    (dx * inv_cell).floor() as i32,
                    (dy * inv_cell).floor() as i32,
                );
                let held = clump_hash(i, j, key) < below;
                if held && rc >= core_rc { weight } else { 0.0 }
            }
        };
        if d2 <= self.radius_sq { rho } else { 0.0 }
    }
}

/// Number of cells of the tables of `χ^c` ([`ShapeFactor`]).
const SHAPE_CELLS: usize = 1024;

/// How `χ^c` is computed for one crown: exactly for `c` = 1 and 0.5, from
/// a table with linear interpolation for the species presets' other
/// exponents (the foliage density it gives differs from `powf`'s by less
/// than 1e-4 below the top 0.1 % of the crown, where the envelope is the
/// flat top `a` within a few millimetres), and `powf` otherwise.
#[derive(Clone, Copy, Debug)]
enum ShapeFactor {
    Linear,
    Sqrt,
    Table(&'static [f64]),
    Pow(f64),
}

impl ShapeFactor {
    fn of(c: f64) -> Self {
        use std::sync::OnceLock;
        static TABLES: OnceLock<[(f64, Box<[f64]>); 2]> = OnceLock::new();
        if c == 1.0 {
            return Self::Linear;
        }
        if c == 0.5 {
            return Self::Sqrt;
        }
        let tables = TABLES.get_or_init(|| {
            [0.6, 0.9].map(|e: f64| {
                let t = (0..=SHAPE_CELLS)
                    .map(|i| (i as f64 / SHAPE_CELLS as f64).powf(e))
                    .collect();
                (e, t)
            })
        });
        match tables.iter().find(|(e, _)| *e == c) {
            Some((_, t)) => Self::Table(t),
            None => Self::Pow(c),
        }
    }

    /// `χ^c` for `χ` in [0, 1].
    #[inline]
    fn at(self, chi: f64) -> f64 {
        match self {
            Self::Linear => chi,
            Self::Sqrt => chi.sqrt(),
            Self::Table(t) => {
                let x = chi.clamp(0.0, 1.0) * SHAPE_CELLS as f64;
                // Through i32, a cheaper conversion than to usize: x is
                // within [0, SHAPE_CELLS].
                let i = ((x as i32) as usize).min(SHAPE_CELLS - 1);
                let f = x - i as f64;
                t[i] + (t[i + 1] - t[i]) * f
            }
            Self::Pow(c) => chi.powf(c),
        }
    }
}

/// `cos` and `sin` of `w` times the golden angle for the first whorls.
fn whorl_rotations() -> &'static [(f64, f64)] {
    use std::sync::OnceLock;
    const WHORLS: usize = 1024;
    static TABLE: OnceLock<Box<[(f64, f64)]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..WHORLS)
            .map(|w| {
                let (s, c) = (w as f64 * GOLDEN_ANGLE).sin_cos();
                (c, s)
            })
            .collect()
    })
}

/// A crown with its tables looked up, for [`CrownProfile::level`] at many
/// heights ([`Crown::profile`]).
#[derive(Clone, Copy, Debug)]
pub struct CrownProfile {
    crown: Crown,
    shape: ShapeFactor,
    /// The whorl rotations by the golden angle, when the crown turns by it.
    rotations: Option<&'static [(f64, f64)]>,
}

impl CrownProfile {
    /// The crown.
    pub fn crown(&self) -> &Crown {
        &self.crown
    }

    /// What the density depends on at world height `z`, for
    /// [`CrownLevel::density`]; `None` above or below the crown. The
    /// envelope radius comes from a table of `χ^c` and the whorl's rotation
    /// from the stored phase turned by a tabulated multiple of the golden
    /// angle, so that no `powf` or `sin_cos` is left per step.
    #[inline]
    pub fn level(&self, z: f64) -> Option<CrownLevel> {
        self.envelope(z).map(|e| self.level_within(e))
    }

    /// The envelope at world height `z` (`None` above or below the crown):
    /// the first half of [`CrownProfile::level`], enough to tell whether a
    /// pulse reaches the crown there before the rest is worked out.
    #[inline]
    pub fn envelope(&self, z: f64) -> Option<Envelope> {
        let c = &self.crown;
        if z > c.z_top || z < c.z_base {
            return None;
        }
        let chi = (c.z_top - z) / (c.z_top - c.z_base);
        Some(Envelope {
            z,
            chi,
            radius: c.a + c.b * self.shape.at(chi),
        })
    }

    /// [`CrownProfile::level`] where the envelope is `e`.
    #[inline]
    pub fn level_within(&self, e: Envelope) -> CrownLevel {
        let c = &self.crown;
        let Envelope { z, chi, radius } = e;
        let field = match c.field {
            Field::Uniform(rho) => LevelField::Uniform(rho),
            Field::Specification(w) => self.whorl_level(&w, z, chi),
            Field::Physical(p) => {
                let m = ((c.z_top - z) / p.cell_m).floor() as i64;
                let (core_rc, ring) = shell(radius, p.shell_m);
                LevelField::Physical {
                    inv_cell: 1.0 / p.cell_m,
                    key: level_key(p.key, m),
                    below: (p.fraction * 4_294_967_296.0).min(4_294_967_295.0) as u32,
                    weight: ring / p.fraction,
                    core_rc,
                }
            }
        };
        CrownLevel {
            radius_sq: radius * radius,
            radius,
            inv_radius: if radius > 0.0 { 1.0 / radius } else { 0.0 },
            field,
        }
    }

    /// The specification's field at world height `z`, depth `chi`: the
    /// height factor and the whorl's rotation from the stored phase turned
    /// by a tabulated multiple of the golden angle.
    #[inline]
    fn whorl_level(&self, w: &Whorls, z: f64, chi: f64) -> LevelField {
        let whorl = ((self.crown.z_top - z) / w.spacing_m).floor();
        // The whorl's number through i64: a cheaper conversion than to
        // usize, the same for the table's range (and out of it otherwise).
        let rotation = self.rotations.and_then(|t| {
            let n = whorl as i64;
            if (0..t.len() as i64).contains(&n) {
                Some(&t[n as usize])
            } else {
                None
            }
        });
        let (whorl_cos, whorl_sin) = match rotation {
            Some(&(rc, rs)) => (
                w.phase_cos * rc - w.phase_sin * rs,
                w.phase_sin * rc + w.phase_cos * rs,
            ),
            None => {
                let (s, co) = (w.phase + whorl * w.step).sin_cos();
                (co, s)
            }
        };
        LevelField::Specification {
            height_factor: if chi <= 0.5 { 1.0 } else { 2.0 * (1.0 - chi) },
            whorl_cos,
            whorl_sin,
        }
    }
}

/// A crown's envelope at one height ([`CrownProfile::envelope`]).
#[derive(Clone, Copy, Debug)]
pub struct Envelope {
    /// World height, m.
    pub z: f64,
    /// Relative depth in the crown `χ` (0 at the top, 1 at the base).
    pub chi: f64,
    /// Envelope radius `r(χ)`, m.
    pub radius: f64,
}

impl Crown {
    /// Envelope radius at relative crown depth χ (Eq. 4).
    #[inline]
    pub fn radius_at_chi(&self, chi: f64) -> f64 {
        let shape = if self.c == 1.0 {
            chi
        } else if self.c == 0.5 {
            chi.sqrt()
        } else {
            chi.powf(self.c)
        };
        self.a + self.b * shape
    }

    /// Largest radius of the envelope, `a + b`, m.
    pub fn max_radius_m(&self) -> f64 {
        self.a + self.b
    }

    /// Top and bottom of the crown, world z.
    pub fn z_range(&self) -> (f64, f64) {
        (self.z_base, self.z_top)
    }

    /// Horizontal position of the stem axis.
    pub fn axis(&self) -> (f64, f64) {
        (self.axis_x, self.axis_y)
    }

    /// Bounding box (a vertical cylinder's).
    pub fn bounds(&self) -> Aabb {
        let r = self.max_radius_m();
        Aabb {
            min: DVec3::new(self.axis_x - r, self.axis_y - r, self.z_base),
            max: DVec3::new(self.axis_x + r, self.axis_y + r, self.z_top),
        }
    }

    /// Whether `p` lies inside the envelope: its horizontal distance to the
    /// stem is at most `r(χ)` at its height (specification Fig. 16).
    pub fn contains(&self, p: DVec3) -> bool {
        self.coordinates(p).is_some()
    }

    /// The crown coordinates `(χ, rc, φ)` of a point inside the envelope
    /// ("A point inside the envelope will be defined by coordinates
    /// (χ, rc, φ)").
    pub fn coordinates(&self, p: DVec3) -> Option<(f64, f64, f64)> {
        if p.z > self.z_top || p.z < self.z_base {
            return None;
        }
        let chi = (self.z_top - p.z) / (self.z_top - self.z_base);
        let (dx, dy) = (p.x - self.axis_x, p.y - self.axis_y);
        let d = dx.hypot(dy);
        let r = self.radius_at_chi(chi);
        (d <= r).then(|| (chi, if r > 0.0 { d / r } else { 0.0 }, dy.atan2(dx)))
    }

    /// The crown with its tables looked up, for levels at many heights.
    pub fn profile(&self) -> CrownProfile {
        CrownProfile {
            crown: *self,
            shape: ShapeFactor::of(self.c),
            rotations: match self.field {
                Field::Specification(w) if w.step == GOLDEN_ANGLE => Some(whorl_rotations()),
                _ => None,
            },
        }
    }

    /// What the density depends on at world height `z`, for
    /// [`CrownLevel::density`]; `None` above or below the crown
    /// ([`CrownProfile::level`]).
    #[inline]
    pub fn level(&self, z: f64) -> Option<CrownLevel> {
        self.profile().level(z)
    }

    /// Relative density at `p`, 0 outside the envelope, as the crown's
    /// field gives it: a constant; the physical model's radial profile
    /// `(3 + 6·rc)/7` times `1/fraction` in a clump cell that holds
    /// foliage (0 in one that does not); or the specification's
    /// thetafactor `|cos(6φ + f)|` with `f` rotated every whorl,
    /// heightfactor 1 down to χ = 0.5 then falling linearly to 0 at χ = 1
    /// (the specification writes "1−2χ", which is not continuous at 0.5;
    /// `2(1 − χ)` is the line it describes), radiusfactor `1 − rc`.
    pub fn density_at(&self, p: DVec3) -> f64 {
        if p.z > self.z_top || p.z < self.z_base {
            return 0.0;
        }
        let chi = (self.z_top - p.z) / (self.z_top - self.z_base);
        let (dx, dy) = (p.x - self.axis_x, p.y - self.axis_y);
        let d2 = dx * dx + dy * dy;
        let r = self.radius_at_chi(chi);
        if d2 > r * r {
            return 0.0;
        }
        let d = d2.sqrt();
        let rc = if r > 0.0 { d / r } else { 0.0 };
        match self.field {
            Field::Uniform(rho) => rho,
            Field::Physical(c) => {
                let cell = |v: f64| (v / c.cell_m).floor() as i64;
                let key = level_key(c.key, cell(self.z_top - p.z));
                let below = (c.fraction * 4_294_967_296.0).min(4_294_967_295.0) as u32;
                let (core_rc, ring) = shell(r, c.shell_m);
                if clump_hash(cell(dx) as i32, cell(dy) as i32, key) < below && rc >= core_rc {
                    ring / c.fraction
                } else {
                    0.0
                }
            }
            Field::Specification(w) => {
                // cos(6φ + f) without trigonometry of φ: (cos φ + i sin φ)⁶
                // by complex squaring and multiplication.
                let (c1, s1) = if d > 0.0 {
                    (dx / d, dy / d)
                } else {
                    (1.0, 0.0)
                };
                let (c2, s2) = (c1 * c1 - s1 * s1, 2.0 * c1 * s1);
                let (c3, s3) = (c2 * c1 - s2 * s1, c2 * s1 + s2 * c1);
                let (c6, s6) = (c3 * c3 - s3 * s3, 2.0 * c3 * s3);
                let whorl = ((self.z_top - p.z) / w.spacing_m).floor();
                let (sf, cf) = (w.phase + whorl * w.step).sin_cos();
                let theta = (c6 * cf - s6 * sf).abs();
                let height = if chi <= 0.5 { 1.0 } else { 2.0 * (1.0 - chi) };
                theta * height * (1.0 - rc)
            }
        }
    }

    /// The crown's bounding cylinder (radius `a + b`, base to top).
    pub fn bounds_cylinder(&self) -> VerticalCylinder {
        VerticalCylinder {
            axis: (self.axis_x, self.axis_y),
            radius: self.max_radius_m(),
            z: (self.z_base, self.z_top),
        }
    }

    /// The interval of `ray` inside the crown's bounding cylinder, within
    /// `(t_min, t_max)`.
    pub fn span(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
        self.bounds_cylinder().span(ray, t_min, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pine() -> TreeSpec {
        TreeSpec::new(DVec3::new(10.0, 20.0, 5.0), Species::Pine, 0.25, 18.0, 8.0)
    }

    #[test]
    fn envelope_follows_equation_4() {
        let crown = pine().crown(&FoliageSettings::specification());
        let (zb, zt) = crown.z_range();
        assert_eq!((zb, zt), (13.0, 23.0));
        for chi in [0.0, 0.25, 0.5, 0.9, 1.0] {
            let r = crown.radius_at_chi(chi);
            let want = crown.a + crown.b * chi.powf(crown.c);
            assert!((r - want).abs() < 1e-12);
            let z = zt - chi * (zt - zb);
            // Just inside and just outside the envelope at that height.
            assert!(crown.contains(DVec3::new(10.0 + r - 1e-6, 20.0, z)));
            assert!(!crown.contains(DVec3::new(10.0, 20.0 + r + 1e-6, z)));
        }
        assert!((crown.max_radius_m() - Species::Pine.crown_radius_m(0.25)).abs() < 1e-12);
    }

    #[test]
    fn density_factors() {
        let crown = pine().crown(&FoliageSettings::specification());
        let (zb, zt) = crown.z_range();
        // On the stem axis rc = 0 and φ = 0.
        let at = |chi: f64, rc: f64, phi: f64| {
            let z = zt - chi * (zt - zb);
            let r = crown.radius_at_chi(chi) * rc;
            crown.density_at(DVec3::new(10.0 + r * phi.cos(), 20.0 + r * phi.sin(), z))
        };
        // Six branches per whorl: density repeats every 60°.
        for phi in [0.1, 0.7, 2.0] {
            let d1 = at(0.3, 0.4, phi);
            let d2 = at(0.3, 0.4, phi + std::f64::consts::PI / 3.0);
            assert!((d1 - d2).abs() < 1e-9);
        }
        // Height factor: flat to χ = 0.5, then linear to 0 at χ = 1 —
        // compare the best branch direction at each height.
        let best = |chi: f64| {
            (0..3600)
                .map(|i| at(chi, 0.5, i as f64 * 0.1f64.to_radians()))
                .fold(0.0, f64::max)
        };
        assert!((best(0.2) - 0.5).abs() < 1e-3);
        assert!((best(0.45) - 0.5).abs() < 1e-3);
        assert!((best(0.75) - 0.25).abs() < 1e-3);
        // Radius factor 1 − rc.
        let b = |rc: f64| {
            (0..3600)
                .map(|i| at(0.3, rc, i as f64 * 0.1f64.to_radians()))
                .fold(0.0, f64::max)
        };
        assert!((b(0.001) - 0.999).abs() < 1e-3 && (b(0.8) - 0.2).abs() < 1e-3);
        // The whorl pattern rotates between whorls 0.3 m apart.
        let z1 = zt - 1.0;
        let z2 = z1 - 0.3;
        let p = |z: f64| crown.density_at(DVec3::new(10.5, 20.2, z));
        assert!((p(z1) - p(z2)).abs() > 1e-6);
    }

    #[test]
    fn trunk_cone_radius_and_intersection() {
        let t = pine().trunk();
        assert!((t.radius_at(5.0 + 1.3) - 0.125).abs() < 1e-12);
        assert!(t.radius_at(5.0) > 0.125);
        assert_eq!(t.radius_at(23.0), 0.0);
        // A horizontal ray at breast height hits the stem at dbh/2.
        let ray = Ray::new(DVec3::new(0.0, 20.0, 6.3), DVec3::X);
        let (d, n) = t.intersect(&ray, 0.0, 100.0).unwrap();
        assert!((d - (10.0 - 0.125)).abs() < 1e-9);
        assert!(n.x < -0.99);
        // A vertical ray beside the stem misses it; one onto the axis hits
        // the apex region.
        let miss = Ray::new(DVec3::new(10.3, 20.0, 50.0), -DVec3::Z);
        assert!(t.intersect(&miss, 0.0, 100.0).is_none());
        let down = Ray::new(DVec3::new(10.05, 20.0, 50.0), -DVec3::Z);
        let (d, _) = t.intersect(&down, 0.0, 100.0).unwrap();
        let z = 50.0 - d;
        assert!((t.radius_at(z) - 0.05).abs() < 1e-9);
    }

    #[test]
    fn crown_span_is_the_cylinder_interval() {
        let crown = pine().crown(&FoliageSettings::specification());
        let r = crown.max_radius_m();
        let ray = Ray::new(DVec3::new(10.0, 20.0, 100.0), -DVec3::Z);
        let (a, b) = crown.span(&ray, 0.0, 1e9).unwrap();
        assert!((a - 77.0).abs() < 1e-9 && (b - 87.0).abs() < 1e-9);
        let side = Ray::new(DVec3::new(-50.0, 20.0, 15.0), DVec3::X);
        let (a, b) = crown.span(&side, 0.0, 1e9).unwrap();
        assert!((a - (60.0 - r)).abs() < 1e-9 && (b - (60.0 + r)).abs() < 1e-9);
        let off = Ray::new(DVec3::new(10.0 + r + 0.1, 20.0, 100.0), -DVec3::Z);
        assert!(crown.span(&off, 0.0, 1e9).is_none());
    }
}
