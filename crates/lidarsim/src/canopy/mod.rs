//! A sub-ray's way through tree crowns.
//!
//! Two marches do what this page describes: the reference march
//! (`reference.rs`, [`march`]), sub-ray by sub-ray with a lottery at every
//! step as the specification describes it, and the pulse march
//! (`pulse.rs`, [`PulseMarch`], the default), which takes all sub-rays of
//! a pulse through the same heights at once and draws one exponential
//! threshold per sub-ray instead of one lottery per step — the same
//! probabilities, at a fraction of the cost ([`Marching`]).
//!
//! Specification, "LiDAR pulse in vegetation", steps 1–7: the sub-ray is
//! followed in steps of about 0.3 m; at every step inside a crown envelope
//! the foliage density there decides, by a lottery, whether the sub-ray is
//! intercepted ("trigger an echo and stop here"); otherwise it continues
//! with the losses the foliage caused ("reduce the previous low density – as
//! it has caused losses") to the next crown, the trunk or the ground.
//!
//! The lottery is Beer–Lambert: over a step `Δs` at relative density `ρ`
//! the sub-ray is intercepted with probability `1 − exp(−k·ρ·Δs)`, so that
//! the probability of crossing a path is `exp(−k ∫ρ ds)`. Where crowns
//! overlap their densities add and the interception is attributed to one of
//! them in proportion to `k·ρ`.
//!
//! What an intercepted sub-ray returns is the [`ReturnModel`]'s:
//!
//! * `Physical` (the default): its energy times the foliage's backscatter,
//!   `share · (Rn/R)² · refl · 2/3`, the 2/3 being the mean cosine between
//!   the beam and the normals of randomly (spherically) oriented leaves that
//!   intercept it (docs/trees.md). The lottery has already decided where
//!   the sub-ray met foliage, so the density does not enter again, and a
//!   sub-ray that passes keeps all its energy: on average `exp(−τ)` of the
//!   energy reaches what lies beyond the crowns and `1 − exp(−τ)` is
//!   intercepted, for optical depth `τ = k ∫ρ ds` however it is split
//!   between `k` and `ρ`.
//! * `Specification`: the specification's
//!   `photons = foliagedensity × reflectance × rangebias`, i.e.
//!   `share · T · (Rn/R)² · refl · ρ`, with a surviving sub-ray keeping the
//!   fraction `exp(−β·k·ρ·Δs)` of its energy at every step ("reduce the
//!   previous low density – as it has caused losses", `β` =
//!   `partial_blocking`). It counts the density twice and loses energy
//!   twice; it is kept to compare with.
//!
//! Either way there is no incidence term ("the foliage is randomly
//! oriented").

mod pulse;
mod reference;

pub use pulse::{MIN_STEEPNESS, PulseMarch};
pub use reference::march;

/// Mean cosine between the beam and the normal of a leaf that intercepts
/// it, for leaves oriented at random (a spherical leaf angle
/// distribution): `E[cos²θ] / E[cos θ] = (1/3) / (1/2)` over the sphere,
/// interception being proportional to the leaf's projected area `cos θ`.
/// A Lambertian leaf returns this fraction of what a Lambertian plane
/// facing the beam returns for the same intercepted energy.
pub const SPHERICAL_LEAF_BACKSCATTER: f64 = 2.0 / 3.0;

/// How foliage that intercepts a sub-ray returns it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReturnModel {
    /// Energy times backscatter; energy conserved through the crowns.
    #[default]
    Physical,
    /// The specification's `foliagedensity × reflectance × rangebias`,
    /// with partial blocking of surviving sub-rays.
    Specification,
}

impl ReturnModel {
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

    /// Power returned by foliage that intercepted a sub-ray of energy
    /// `share` after transmission `transmission`, at range `range_m`, of
    /// reflectance `reflectance` and relative density `density` there.
    pub fn foliage_return(
        self,
        share: f64,
        transmission: f64,
        range_m: f64,
        reference_range_m: f64,
        reflectance: f64,
        density: f64,
    ) -> f64 {
        let rangebias = (reference_range_m / range_m).powi(2);
        match self {
            Self::Physical => {
                share * transmission * rangebias * reflectance * SPHERICAL_LEAF_BACKSCATTER
            }
            Self::Specification => share * transmission * rangebias * reflectance * density,
        }
    }
}

/// How sub-rays are taken through the crowns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Marching {
    /// All sub-rays of a pulse through shared heights, one threshold each
    /// (`pulse.rs`).
    #[default]
    Pulse,
    /// Each sub-ray on its own with a lottery at every step, as the
    /// specification describes it (`reference.rs`).
    SubRay,
}

impl Marching {
    /// The march named `name` in a survey file.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "pulse" => Some(Self::Pulse),
            "sub-ray" => Some(Self::SubRay),
            _ => None,
        }
    }

    /// Its name in a survey file.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pulse => "pulse",
            Self::SubRay => "sub-ray",
        }
    }
}

/// Settings of the march through crowns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CanopyConfig {
    /// Step length along the sub-ray, m.
    pub step_m: f64,
    /// Share β of the interception optical depth that a surviving sub-ray
    /// loses as energy (0 in the physical model).
    pub partial_blocking: f64,
    /// What intercepted sub-rays return.
    pub return_model: ReturnModel,
    /// Which march takes the sub-rays through the crowns.
    pub marching: Marching,
}

impl Default for CanopyConfig {
    fn default() -> Self {
        Self {
            step_m: 0.3,
            partial_blocking: 0.0,
            return_model: ReturnModel::Physical,
            marching: Marching::Pulse,
        }
    }
}

/// What happened to a sub-ray in the crowns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fate {
    /// Intercepted by foliage.
    Intercepted {
        /// Distance along the sub-ray, m.
        t: f64,
        /// The crown primitive.
        prim: u32,
        /// Relative foliage density of that crown at the interception.
        density: f64,
        /// Energy fraction left when it got there.
        transmission: f64,
    },
    /// Passed through all crowns on its way.
    Passed {
        /// Energy fraction left after the crowns.
        transmission: f64,
    },
}

#[cfg(test)]
mod tests;
