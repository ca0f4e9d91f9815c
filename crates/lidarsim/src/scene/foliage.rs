//! How plant area fills a crown's envelope: the physical model (a
//! foliated shell below the envelope, clump cells at branch scale) or the
//! specification's three factors, as settings, as a crown holds them and
//! as one height of a crown gives them to the marches. The densities
//! themselves are [`super::Crown::density_at`] and
//! [`super::CrownLevel::density`]; `docs/trees.md` gives the sources.

/// How plant area fills a crown's envelope.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FoliageModel {
    /// Needles or leaves and woody area as a random medium, denser
    /// towards the outer hull ([`shell`]), clumped in cells of
    /// branch scale (the default; `docs/trees.md`).
    #[default]
    Physical,
    /// The specification's `thetafactor × heightfactor × radiusfactor`.
    Specification,
}

impl FoliageModel {
    /// The model named `name` in a survey file.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "physical" => Some(Self::Physical),
            "specification" => Some(Self::Specification),
            _ => None,
        }
    }

    /// Its name in a survey file.
    pub fn name(self) -> &'static str {
        match self {
            Self::Physical => "physical",
            Self::Specification => "specification",
        }
    }
}

/// How a survey's crowns are filled (`[vegetation]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoliageSettings {
    /// The model.
    pub model: FoliageModel,
    /// Vertical distance between branch whorls (the specification's
    /// pattern turns at each), m.
    pub whorl_spacing_m: f64,
    /// Edge of the physical model's clump cells, m.
    pub clump_m: f64,
    /// Share of the clump cells that hold foliage.
    pub clump_fraction: f64,
    /// Depth of the foliated shell below the envelope, m (horizontally):
    /// the physical model's plant area lies within it.
    pub shell_m: f64,
}

impl FoliageSettings {
    /// The default settings with the specification's field.
    pub fn specification() -> Self {
        Self {
            model: FoliageModel::Specification,
            ..Self::default()
        }
    }
}

impl Default for FoliageSettings {
    /// The physical model, 0.3 m whorls, clump cells of 0.3 m half filled.
    fn default() -> Self {
        Self {
            model: FoliageModel::Physical,
            whorl_spacing_m: 0.3,
            clump_m: 0.3,
            clump_fraction: 0.5,
            shell_m: 1.0,
        }
    }
}

/// The physical model's foliated shell at a height where the envelope's
/// radius is `radius_m`: the relative distance from the stem `rc` from
/// which the shell of depth `shell_m` begins, and the density within it
/// that makes the level's mean 1 (its plant area that of a uniform
/// crown, held in the ring).
#[inline]
pub fn shell(radius_m: f64, shell_m: f64) -> (f64, f64) {
    let core = if radius_m > shell_m {
        1.0 - shell_m / radius_m
    } else {
        0.0
    };
    (core, 1.0 / (1.0 - core * core))
}

/// The hash of clump cell `(i, j)` at a level keyed `level_key`: a cell
/// holds foliage when it is below the crown's fraction of `2³²`. Integer
/// arithmetic only, so that the lanes' `f32` march and the crowns' `f64`
/// density agree on every cell.
#[inline(always)]
pub fn clump_hash(i: i32, j: i32, level_key: u32) -> u32 {
    let mut h =
        (i as u32).wrapping_mul(0x9E37_79B1) ^ (j as u32).wrapping_mul(0x85EB_CA77) ^ level_key;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297A_2D39);
    h ^ (h >> 15)
}

/// The key of the clump cells of crown `key` at vertical cell `m`.
#[inline]
pub(super) fn level_key(key: u32, m: i64) -> u32 {
    let h = (m as u32).wrapping_mul(0xC2B2_AE3D) ^ key;
    clump_hash(0, 0, h)
}

/// What fills a crown's envelope.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Field {
    /// A constant relative density.
    Uniform(f64),
    /// The specification's three factors, the branches turning by whorl.
    Specification(Whorls),
    /// The physical model: the foliated shell and the clump cells.
    Physical(Clumps),
}

/// The specification's whorls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Whorls {
    pub(super) spacing_m: f64,
    /// Rotation `f` of the top whorl.
    pub(super) phase: f64,
    /// `cos` and `sin` of `phase`, for [`CrownProfile::level`].
    pub(super) phase_cos: f64,
    pub(super) phase_sin: f64,
    /// Turn from one whorl to the next.
    pub(super) step: f64,
}

/// The physical model's clump cells: a lattice of cubes of edge `cell_m`
/// aligned to the stem and the top, each holding foliage with probability
/// `fraction` (then at `1/fraction` times the mean density), by a hash of
/// the cell and the crown's `key`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Clumps {
    pub(super) cell_m: f64,
    pub(super) fraction: f64,
    pub(super) key: u32,
    pub(super) shell_m: f64,
}

/// A crown's field at one height.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LevelField {
    /// A constant density.
    Uniform(f64),
    /// The specification's: the height factor and the whorl's rotation
    /// `f` (its `cos` and `sin`).
    Specification {
        /// The height factor.
        height_factor: f64,
        /// `cos f`.
        whorl_cos: f64,
        /// `sin f`.
        whorl_sin: f64,
    },
    /// The physical model's: the clump cells of this height.
    Physical {
        /// `1 / cell edge`, 1/m.
        inv_cell: f64,
        /// The cells' key at this height ([`clump_hash`]).
        key: u32,
        /// A cell holds foliage when its hash is below this.
        below: u32,
        /// The density of a cell of the shell that holds foliage.
        weight: f64,
        /// Relative distance from the stem where the shell begins.
        core_rc: f64,
    },
}
