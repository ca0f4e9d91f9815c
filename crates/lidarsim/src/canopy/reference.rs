//! The reference march: each sub-ray on its own, in steps of `Δs` with a
//! lottery at every step (specification, "LiDAR pulse in vegetation",
//! steps 1–7), as the module documentation of [`crate::canopy`] describes.

use super::{CanopyConfig, Fate};
use crate::accel::VolumeSpan;
use crate::geometry::Ray;
use crate::rng::Stream;
use crate::scene::{Scene, Shape};

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
