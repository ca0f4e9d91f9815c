//! The swath over level ground, channel by channel: each channel's beam at
//! the deflector's across-track edges (turned by the channel's mounting,
//! so a beam tilted `α` along the track meets the ground `H·tan θ / cos α`
//! to the side), cut where the ground's echo is lost. Ground seen at
//! off-nadir angle `φ` is `R = H / cos φ` away and returns the peak of
//! Eq. 2, `ρ (Rn/R)² cos^a φ`, lowered by the spread of ranges across the
//! footprint on the slanted ground, `σ_r = R (γ/4) tan φ` (γ/4 the
//! Gaussian beam's angular deviation), which widens the echo from the
//! pulse's `σ_p` to `√(σ_p² + σ_r²)` at equal energy. Beyond the angle
//! where that falls below the detection threshold, or `R` beyond
//! `scanner.max_range_m`, no ground point is recorded: a rotating mirror
//! that looks 165° to either side (RIEGL VUX-1UAV) has a swath bounded by
//! its echo, not by its field of view, and only the pulses inside it give
//! points.

use crate::geometry::{DVec3, SPEED_OF_LIGHT_MPS};
use crate::radiometry::surface_return;
use crate::scene::Material;
use crate::sensor::channel::{Channel, FiringOrder};
use crate::survey::Survey;

/// Deflector directions sampled, over one second, for the share of pulses
/// that reach the ground when the echo cuts the scan.
const SAMPLES: usize = 20_000;

/// A line's swath over level ground.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Swath {
    /// Width across the track, m.
    pub width_m: f64,
    /// Its edges across the track from nadir, m (x of the scanner frame,
    /// to the left positive): symmetric unless channels look to one side.
    pub edges_m: (f64, f64),
    /// Share of the emitted pulses that meet the ground inside it and
    /// return an echo (1 unless the echo cuts the scan or beams look at or
    /// above the horizon).
    pub landing_share: f64,
    /// Share of the emitted pulses whose beam looks at or above the
    /// horizon (never meeting level ground below the scanner).
    pub upward_share: f64,
    /// Off-nadir angle beyond which level ground returns no echo, rad,
    /// when that is inside the field of view of some channel.
    pub echo_limit_rad: Option<f64>,
}

/// The cosine of the off-nadir angle of a beam that counts as meeting
/// level ground: 89.9°, beyond which the ground is thousands of heights
/// away.
const HORIZON_COS: f64 = 1.75e-3;

/// The swath of `survey` at `h` metres above level ground of `ground`'s
/// material (`None`: the echo is not considered). Its edges are the
/// deflector's across-track edges tilted along the track by each
/// channel's mounting (exact for mirrors, polygons and the like); when a
/// channel is turned about the vertical or an edge beam looks at or above
/// the horizon, they come from the beams that land, sampled over one
/// second.
pub(crate) fn swath(survey: &Survey, h: f64, ground: Option<&Material>) -> Swath {
    let s = &survey.scanner;
    let theta = s.deflector.across_half_angle_rad();
    let mut cuts = false;
    let mut lowest_cos = 1.0f64;
    let mut skyward = false;
    let (mut left, mut right) = (f64::INFINITY, f64::NEG_INFINITY);
    // Per channel: the cosine of the widest off-nadir angle with an echo.
    let limits: Vec<f64> = s
        .channels
        .iter()
        .map(|ch| {
            let reach = ground.map_or(0.0, |m| echo_cos(survey, ch, h, m));
            let ca = ch.along_tilt_rad.cos();
            // The edge beam (sin φ, 0, cos φ) is cos φ · cos α off nadir
            // once tilted: the widest φ whose beam still returns an echo.
            let phi = if reach / ca >= 1.0 {
                0.0
            } else {
                (reach / ca).acos().min(theta)
            };
            if phi < theta {
                cuts = true;
                lowest_cos = lowest_cos.min(reach);
            }
            for side in [-1.0, 1.0] {
                let d = ch.mount() * DVec3::new(side * phi.sin(), 0.0, phi.cos());
                skyward |= d.z < HORIZON_COS;
                let x = h * d.x / d.z;
                left = left.min(x);
                right = right.max(x);
            }
            reach.max(HORIZON_COS)
        })
        .collect();
    // A channel turned about the vertical sweeps off the across-track
    // plane: its edges are where its beams are, not at ±θ.
    let turned = s.channels.iter().any(|ch| ch.yaw_rad != 0.0);
    // Sampled always: a conic or rosette pattern looks along the track
    // too, where a forward tilt can lift its beams past the horizon.
    let sm = sample(survey, h, &limits);
    if skyward || turned {
        (left, right) = sm.edges_m;
    }
    let width_m = if h > 0.0 && left <= right {
        right - left
    } else {
        0.0
    };
    Swath {
        width_m,
        edges_m: if left <= right {
            (left, right)
        } else {
            (0.0, 0.0)
        },
        landing_share: if cuts || skyward || turned || sm.upward_share > 0.0 {
            sm.landing_share
        } else {
            1.0
        },
        upward_share: sm.upward_share,
        echo_limit_rad: cuts.then(|| lowest_cos.acos()),
    }
}

/// The cosine of the largest off-nadir angle at which level ground of
/// `ground` `h` below returns an echo above the detection threshold and
/// within the range window, for channel `ch`: 1 when even nadir does not.
fn echo_cos(survey: &Survey, ch: &Channel, h: f64, ground: &Material) -> f64 {
    let s = &survey.scanner;
    let r = &survey.receiver;
    let floor = survey
        .detector
        .min_amplitude
        .max(survey.detector.threshold_sigma * r.noise_sigma);
    let rho = ground.reflectance_at(ch.wavelength_nm);
    // The pulse's deviation in range, m (FWHM / 2.355 of the round trip).
    let sigma_p = SPEED_OF_LIGHT_MPS * r.pulse.fwhm_s() / 2.0 / 2.354_82;
    let detected = |c: f64| {
        let range = h / c;
        if range > s.max_range_m || range < s.min_range_m {
            return false;
        }
        let tan = (1.0 - c * c).max(0.0).sqrt() / c;
        let sigma_r = range * 0.25 * ch.divergence_rad.max(ch.divergence_along_rad) * tan;
        let peak = surface_return(
            1.0,
            range,
            r.reference_range_m,
            rho,
            c,
            ground.incidence_exponent,
        ) * sigma_p
            / sigma_p.hypot(sigma_r);
        peak >= floor
    };
    if !detected(1.0) {
        return 1.0;
    }
    // Bisection on the cosine: the echo weakens monotonically away from
    // nadir.
    let (mut lo, mut hi) = (1e-6, 1.0);
    if detected(lo) {
        return lo;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if detected(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// The emitted pulses' beams sampled over one second: the share that
/// meet level ground within the echo limit `limits[c]` (cosine of the
/// off-nadir angle) of their channel, the share that look at or above the
/// horizon, and the edges across the track, at height `h`, of the beams
/// that land.
#[derive(Clone, Copy, Debug)]
struct Sampled {
    landing_share: f64,
    upward_share: f64,
    edges_m: (f64, f64),
}

fn sample(survey: &Survey, h: f64, limits: &[f64]) -> Sampled {
    let s = &survey.scanner;
    let mounts: Vec<_> = s.channels.iter().map(Channel::mount).collect();
    let firing = FiringOrder::new(&s.channels);
    let (mut emitted, mut landed, mut upward) = (0usize, 0usize, 0usize);
    let (mut left, mut right) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..SAMPLES {
        let t = (i as f64 + 0.5) / SAMPLES as f64;
        if !s.deflector.emits_at(t) {
            continue;
        }
        emitted += 1;
        let c = firing.channel_of(i as u64);
        let d = mounts[c] * s.deflector.direction_at(t);
        if d.z < HORIZON_COS {
            upward += 1;
        } else if d.z >= limits[c] {
            landed += 1;
            let x = h * d.x / d.z;
            left = left.min(x);
            right = right.max(x);
        }
    }
    let share = |n: usize| {
        if emitted == 0 {
            0.0
        } else {
            n as f64 / emitted as f64
        }
    };
    Sampled {
        landing_share: share(landed),
        upward_share: share(upward),
        edges_m: (left, right),
    }
}
