//! `preset`, `[gnss]`, `[imu]`, `[boresight]` and `[ranging]`: the
//! navigation and measurement errors.

use super::{Bounds, Checker, axes, triple};
use crate::geometry::DVec3;
use crate::sensor::navigation::{ErrorModel, NavigationErrors};
use crate::survey::{KeyPath, MAX_ATTITUDE_ERROR_DEG, MAX_GNSS_ERROR_M, RawSurvey, raw};

/// Validates `preset`, `[gnss]`, `[imu]`, `[boresight]` and `[ranging]`.
pub(crate) fn check_navigation(c: &mut Checker, raw: &RawSurvey) -> NavigationErrors {
    let root = KeyPath::root();
    let lookup = |c: &mut Checker, path: KeyPath, name: &Option<String>| match name {
        None => None,
        Some(n) => crate::sensor::navigation::preset(n).or_else(|| {
            c.err(
                path,
                format!(
                    "unknown preset '{n}'; expected one of: {}",
                    crate::sensor::navigation::PRESETS.join(", ")
                ),
            );
            None
        }),
    };
    let top = lookup(c, root.key("preset"), &raw.preset);
    let deg = 1f64.to_radians();
    let group = |c: &mut Checker, key: &str, r: &raw::RawErrors, base: ErrorModel| {
        let p = root.key(key);
        let gnss = key == "gnss";
        let base = match lookup(c, p.key("preset"), &r.preset) {
            Some((g, i)) => {
                if gnss {
                    g
                } else {
                    i
                }
            }
            None => base,
        };
        // [gnss] takes metres, [imu] degrees: the other unit's keys exist in
        // the shared raw table but are errors here.
        // Bounds far beyond any navigation grade (a consumer GNSS errs by
        // metres, an IMU by fractions of a degree) that keep positions and
        // angles meaningful.
        let (bias, sigma, walk, unit) = if gnss {
            (
                &r.bias_m,
                &r.sigma_m,
                &r.random_walk_m,
                (1.0, MAX_GNSS_ERROR_M, " m"),
            )
        } else {
            (
                &r.bias_deg,
                &r.sigma_deg,
                &r.random_walk_deg,
                (deg, MAX_ATTITUDE_ERROR_DEG, "°"),
            )
        };
        let other_unit = if gnss {
            [
                ("bias_deg", r.bias_deg.is_some()),
                ("sigma_deg", r.sigma_deg.is_some()),
                ("random_walk_deg", r.random_walk_deg.is_some()),
            ]
        } else {
            [
                ("bias_m", r.bias_m.is_some()),
                ("sigma_m", r.sigma_m.is_some()),
                ("random_walk_m", r.random_walk_m.is_some()),
            ]
        };
        for (k, _) in other_unit.iter().filter(|(_, set)| *set) {
            let unit = if gnss {
                "metres (_m keys)"
            } else {
                "degrees (_deg keys)"
            };
            c.err(p.key(k), format!("[{key}] takes {unit}"));
        }
        let suffix = if gnss { "_m" } else { "_deg" };
        let mut m = base;
        if bias.is_some() {
            m.bias = triple(c, p.key(&format!("bias{suffix}")), bias, unit);
        }
        m.sigma = axes(c, p.key(&format!("sigma{suffix}")), sigma, m.sigma, unit);
        m.random_walk = axes(
            c,
            p.key(&format!("random_walk{suffix}")),
            walk,
            m.random_walk,
            unit,
        );
        if r.correlation_time_s.is_some() || m.correlation_time_s <= 0.0 {
            m.correlation_time_s = c.number(
                p.key("correlation_time_s"),
                r.correlation_time_s,
                if m.correlation_time_s > 0.0 {
                    m.correlation_time_s
                } else {
                    100.0
                },
                Bounds::above(0.0, " s").at_most(1e6),
            );
        }
        m
    };
    let (g0, i0) = top.unwrap_or_default();
    let gnss = group(c, "gnss", &raw.gnss, g0);
    let imu = group(c, "imu", &raw.imu, i0);
    let bp = root.key("boresight");
    let rp = root.key("ranging");
    NavigationErrors {
        gnss,
        imu,
        boresight_rad: triple(
            c,
            bp.key("angles_deg"),
            &raw.boresight.angles_deg,
            (deg, MAX_ATTITUDE_ERROR_DEG, "°"),
        ),
        lever_arm_m: {
            let [x, y, z] = triple(
                c,
                bp.key("lever_arm_m"),
                &raw.boresight.lever_arm_m,
                (1.0, 100.0, " m"),
            );
            DVec3::new(x, y, z)
        },
        range_sigma_m: c.number(
            rp.key("sigma_m"),
            raw.ranging.sigma_m,
            0.0,
            Bounds::between(0.0, 100.0, " m"),
        ),
        encoder_sigma_rad: c.number(
            rp.key("encoder_sigma_deg"),
            raw.ranging.encoder_sigma_deg,
            0.0,
            Bounds::between(0.0, 10.0, "°"),
        ) * deg,
    }
}
