//! A sub-ray's way through tree crowns.
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

use crate::accel::VolumeSpan;
use crate::geometry::Ray;
use crate::rng::Stream;
use crate::scene::{Scene, Shape};

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
}

impl Default for CanopyConfig {
    fn default() -> Self {
        Self {
            step_m: 0.3,
            partial_blocking: 0.0,
            return_model: ReturnModel::Physical,
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

/// Follows `ray` through the crowns of `spans` (sorted by entry, clipped to
/// the closest surface). Random numbers come from `rng`: one for the phase
/// of the steps, one per step with foliage.
pub fn march(
    scene: &Scene,
    ray: &Ray,
    spans: &[VolumeSpan],
    config: &CanopyConfig,
    rng: &mut Stream,
) -> Fate {
    let mut transmission = 1.0;
    if spans.is_empty() {
        return Fate::Passed { transmission };
    }
    let step = config.step_m;
    // Steps at t0 + (j + u)·Δs with one random phase u for the sub-ray, so
    // the step positions are unbiased whatever the crown geometry.
    let t0 = spans[0].t_in;
    let phase = rng.uniform();
    let t_end = spans.iter().map(|s| s.t_out).fold(f64::MIN, f64::max);
    let mut j = 0u64;
    let mut first_open = 0usize;
    loop {
        let t = t0 + (j as f64 + phase) * step;
        if t >= t_end {
            return Fate::Passed { transmission };
        }
        j += 1;
        // Spans are sorted by entry: skip those already left behind.
        while first_open < spans.len() && spans[first_open].t_out <= t {
            first_open += 1;
        }
        let Some(next) = spans.get(first_open) else {
            return Fate::Passed { transmission };
        };
        if t < next.t_in {
            // A gap between crowns: jump to the first step inside the next.
            j = ((next.t_in - t0) / step - phase).ceil().max(j as f64) as u64;
            continue;
        }
        let p = ray.at(t);
        let open = || {
            spans[first_open..]
                .iter()
                .filter(move |s| s.t_in <= t && t < s.t_out)
                .filter_map(|s| match &scene.primitives[s.prim as usize].shape {
                    Shape::Crown(c) => {
                        let rho = c.density_at(p);
                        (rho > 0.0).then_some((s.prim, rho, c.extinction_per_m * rho * step))
                    }
                    _ => None,
                })
        };
        let total: f64 = open().map(|(_, _, tau)| tau).sum();
        if total <= 0.0 {
            continue;
        }
        let p_hit = 1.0 - (-total).exp();
        if rng.uniform() < p_hit {
            // Which crown: in proportion to its share of the optical depth
            // (the densities are evaluated again; this happens once).
            let mut pick = rng.uniform() * total;
            let mut chosen = (0, 0.0);
            for (prim, rho, tau) in open() {
                chosen = (prim, rho);
                if pick < tau {
                    break;
                }
                pick -= tau;
            }
            return Fate::Intercepted {
                t,
                prim: chosen.0,
                density: chosen.1,
                transmission,
            };
        }
        if config.partial_blocking > 0.0 {
            transmission *= (-config.partial_blocking * total).exp();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Bvh, RayCaster};
    use crate::geometry::DVec3;
    use crate::rng::Purpose;
    use crate::scene::{Material, Primitive, Species, SurfaceClass, TreeSpec};

    fn one_tree(uniform: Option<f64>, k: f64) -> Bvh {
        let mut scene = Scene::default();
        let foliage = scene.add_material(Material {
            name: "f".into(),
            reflectance: 0.4,
            incidence_exponent: 0.0,
        });
        let obj = scene.add_object("tree");
        let mut spec = TreeSpec::new(DVec3::ZERO, Species::Spruce, 0.3, 20.0, 6.0);
        spec.uniform_density = uniform;
        spec.extinction_per_m = k;
        scene.primitives.push(Primitive {
            shape: Shape::Crown(Box::new(spec.crown(0.3))),
            material: foliage,
            class: SurfaceClass::Vegetation,
            object: obj,
        });
        Bvh::build(scene)
    }

    /// Fraction of vertical rays at horizontal offset `x` that cross the
    /// crown, and the analytic `exp(−k ∫ρ ds)`.
    fn crossing(bvh: &Bvh, x: f64, k: f64, rho: f64) -> (f64, f64) {
        let ray = Ray::new(DVec3::new(x, 0.0, 100.0), -DVec3::Z);
        let mut spans = Vec::new();
        bvh.trace(&ray, 0.0, 1e9, &mut spans);
        let Shape::Crown(c) = &bvh.scene().primitives[0].shape else {
            unreachable!()
        };
        // Path length inside the envelope along the vertical line, by fine
        // sampling of the envelope test.
        let inside = (0..200_000)
            .filter(|i| c.contains(DVec3::new(x, 0.0, 6.0 + *i as f64 * 1e-4)))
            .count() as f64
            * 1e-4;
        let n = 20_000;
        let passed = (0..n)
            .filter(|&i| {
                let mut rng = Stream::new(1, 0, i, Purpose::Canopy);
                matches!(
                    march(
                        bvh.scene(),
                        &ray,
                        &spans,
                        &CanopyConfig::default(),
                        &mut rng
                    ),
                    Fate::Passed { .. }
                )
            })
            .count() as f64
            / n as f64;
        (passed, (-k * rho * inside).exp())
    }

    #[test]
    fn crossing_probability_is_beer_lambert() {
        for (k, rho) in [(0.3, 0.5), (0.6, 0.5), (0.6, 0.9)] {
            let bvh = one_tree(Some(rho), k);
            for x in [0.0, 0.8] {
                let (got, want) = crossing(&bvh, x, k, rho);
                assert!(
                    (got - want).abs() < 0.02 + 0.05 * want,
                    "k={k} ρ={rho} x={x}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn interceptions_lie_inside_the_envelope_and_depths_vary() {
        let bvh = one_tree(None, 0.9);
        let Shape::Crown(c) = &bvh.scene().primitives[0].shape else {
            unreachable!()
        };
        let ray = Ray::new(DVec3::new(0.4, 0.3, 100.0), -DVec3::Z);
        let mut spans = Vec::new();
        bvh.trace(&ray, 0.0, 1e9, &mut spans);
        let mut depths = Vec::new();
        for i in 0..2000 {
            let mut rng = Stream::new(2, 0, i, Purpose::Canopy);
            if let Fate::Intercepted {
                t,
                density,
                transmission,
                ..
            } = march(
                bvh.scene(),
                &ray,
                &spans,
                &CanopyConfig::default(),
                &mut rng,
            ) {
                let p = ray.at(t);
                assert!(c.contains(p));
                assert!((c.density_at(p) - density).abs() < 1e-12 && density > 0.0);
                assert!(transmission > 0.0 && transmission <= 1.0);
                depths.push(t);
            }
        }
        assert!(depths.len() > 1000);
        let lo = depths.iter().cloned().fold(f64::MAX, f64::min);
        let hi = depths.iter().cloned().fold(f64::MIN, f64::max);
        assert!(hi - lo > 5.0, "interceptions spread over the crown depth");
    }
}
