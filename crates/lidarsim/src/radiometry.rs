//! How much of a sub-ray's energy comes back.
//!
//! Specification Eq. 2:
//! `Power_received = Power_transmitted / (R/Rn)² × Refl × f(incidence)`,
//! with `f(α) = cos(α)^a` ("we can test different models, where the
//! reflectance is proportional to cos(angle)**a"). `Rn` is a fixed
//! instrument constant (`reference_range_m`), so intensities of different
//! surveys compare. Speckle is multiplicative noise on each sub-ray's return
//! (specification, Fig. 6).

use crate::rng::Stream;
use rand_distr::{Distribution, Gamma};

/// Received power of one sub-ray from an opaque surface (Eq. 2), in units
/// of the pulse's transmitted power.
///
/// * `share` — the sub-ray's share of the transmitted power,
/// * `range_m` — distance to the surface,
/// * `reference_range_m` — `Rn`,
/// * `reflectance` — `Refl`, 0–1,
/// * `cos_incidence` — cosine of the angle between the ray and the normal,
/// * `incidence_exponent` — `a` of `cos(α)^a`.
#[inline]
pub fn surface_return(
    share: f64,
    range_m: f64,
    reference_range_m: f64,
    reflectance: f64,
    cos_incidence: f64,
    incidence_exponent: f64,
) -> f64 {
    let range_factor = (reference_range_m / range_m).powi(2);
    let incidence = if incidence_exponent == 1.0 {
        cos_incidence
    } else {
        cos_incidence.powf(incidence_exponent)
    };
    share * range_factor * reflectance * incidence
}

/// Multiplicative speckle: the intensity of fully developed speckle
/// averaged over `looks` independent speckle cells follows a Gamma
/// distribution with shape `looks` and mean 1 (Goodman, "Speckle Phenomena
/// in Optics", 2007, ch. 3 and 5). One look is the negative-exponential law
/// of a single speckle cell.
#[derive(Clone, Copy, Debug)]
pub struct Speckle {
    gamma: Gamma<f64>,
}

impl Speckle {
    /// Speckle averaged over `looks > 0` cells.
    pub fn new(looks: f64) -> Option<Self> {
        Gamma::new(looks, 1.0 / looks)
            .ok()
            .map(|gamma| Self { gamma })
    }

    /// One speckle factor (mean 1).
    #[inline]
    pub fn factor(&self, rng: &mut Stream) -> f64 {
        self.gamma.sample(rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Purpose;

    #[test]
    fn equation_2_scaling() {
        let base = surface_return(1.0, 1000.0, 1000.0, 0.5, 1.0, 1.0);
        assert!((base - 0.5).abs() < 1e-15);
        // Doubling the range quarters the power.
        let far = surface_return(1.0, 2000.0, 1000.0, 0.5, 1.0, 1.0);
        assert!((far / base - 0.25).abs() < 1e-15);
        // Lambertian: 60° incidence halves it; a = 2 quarters it.
        let tilted = surface_return(1.0, 1000.0, 1000.0, 0.5, 60f64.to_radians().cos(), 1.0);
        assert!((tilted / base - 0.5).abs() < 1e-12);
        let glossy = surface_return(1.0, 1000.0, 1000.0, 0.5, 60f64.to_radians().cos(), 2.0);
        assert!((glossy / base - 0.25).abs() < 1e-12);
        // The specification's example: Rn = 200 m, R = 250 m.
        let spec = surface_return(1.0, 250.0, 200.0, 1.0, 1.0, 1.0);
        assert!((spec - 1.0 / (250.0f64 / 200.0).powi(2)).abs() < 1e-15);
    }

    #[test]
    fn speckle_mean_one_variance_one_over_looks() {
        for looks in [1.0, 4.0] {
            let s = Speckle::new(looks).unwrap();
            let mut rng = Stream::new(3, 0, 0, Purpose::Test);
            let n = 100_000;
            let x: Vec<f64> = (0..n).map(|_| s.factor(&mut rng)).collect();
            let mean = x.iter().sum::<f64>() / n as f64;
            let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
            assert!((mean - 1.0).abs() < 0.02, "{mean}");
            assert!((var - 1.0 / looks).abs() < 0.05 / looks.sqrt(), "{var}");
        }
        assert!(Speckle::new(0.0).is_none());
    }
}
