//! `[scanner]`'s beam keys: the divergence of the beam, and the channels
//! of `[[scanner.channels]]`, each with its mounting, divergence,
//! wavelength and share of the pulses.

use super::{Bounds, Checker};
use crate::sensor::channel::{Channel, MAX_CYCLE};
use crate::survey::KeyPath;
use crate::survey::raw::RawScanner;

/// Widest divergence accepted, mrad.
const MAX_DIVERGENCE_MRAD: f64 = 100.0;

/// Narrowest divergence above 0 accepted, mrad: 1 µrad, below the
/// diffraction limit `λ/(π·w₀)` of any airborne scanner's beam (3.4 µrad
/// at 1064 nm from a 10 cm waist). 0 is an ideal pencil beam.
const MIN_DIVERGENCE_MRAD: f64 = 1e-3;

/// Most an elliptical beam's two divergences may differ, as a ratio: the
/// flattest beams of laser diodes are about 10 to 1 (Livox Mid-70, 0.28°
/// by 0.03°).
const MAX_ELLIPTICITY: f64 = 100.0;

/// Refuses a divergence above 0 but narrower than [`MIN_DIVERGENCE_MRAD`].
fn check_narrowest(c: &mut Checker, key: KeyPath, mrad: f64) {
    if mrad > 0.0 && mrad < MIN_DIVERGENCE_MRAD {
        c.err(
            key,
            format!(
                "must be 0 (a pencil beam) or at least {MIN_DIVERGENCE_MRAD} mrad, got {}: no \
                 laser beam diverges less than its diffraction limit (3.4 µrad at 1064 nm from a \
                 10 cm waist)",
                crate::message::num(mrad)
            ),
        );
    }
}

/// The full divergence across and along the track, mrad, from the keys
/// `divergence_mrad` and `divergence_along_mrad` of `path` (defaults:
/// `default`, and the across value for along).
pub(crate) fn divergence(
    c: &mut Checker,
    path: &KeyPath,
    across: Option<f64>,
    along: Option<f64>,
    default: (f64, f64),
) -> (f64, f64) {
    let across_mrad = c.number(
        path.key("divergence_mrad"),
        across,
        default.0,
        Bounds::between(0.0, MAX_DIVERGENCE_MRAD, " mrad"),
    );
    let along_mrad = match (along, across) {
        (None, None) => default.1,
        (None, Some(_)) => across_mrad,
        (given, _) => {
            let v = c.number(
                path.key("divergence_along_mrad"),
                given,
                across_mrad,
                Bounds::between(0.0, MAX_DIVERGENCE_MRAD, " mrad"),
            );
            if across_mrad == 0.0 && v > 0.0 {
                c.err(
                    path.key("divergence_along_mrad"),
                    "an elliptical beam needs divergence_mrad (across) above 0 as well",
                );
            }
            let ratio = (v / across_mrad).max(across_mrad / v);
            if across_mrad > 0.0 && v > 0.0 && ratio > MAX_ELLIPTICITY {
                c.err(
                    path.key("divergence_along_mrad"),
                    format!(
                        "is {} times divergence_mrad ({} mrad against {} mrad); an elliptical \
                         beam's two divergences may differ at most {MAX_ELLIPTICITY} times \
                         (laser diodes' beams differ about 10 times)",
                        crate::message::num((ratio * 10.0).round() / 10.0),
                        crate::message::num(v),
                        crate::message::num(across_mrad)
                    ),
                );
            }
            v
        }
    };
    check_narrowest(c, path.key("divergence_mrad"), across_mrad);
    if along.is_some() {
        check_narrowest(c, path.key("divergence_along_mrad"), along_mrad);
    }
    (across_mrad, along_mrad)
}

/// The channels of `[[scanner.channels]]`: one to four (the LAS scanner
/// channel field has two bits), tilts within ±45°, each channel's
/// divergence and wavelength defaulting to the scanner's (`beam`: across
/// and along divergence, rad, and wavelength, nm), its firing cycle at most
/// [`MAX_CYCLE`] pulses; one straight channel when none is given.
pub(crate) fn channels(
    c: &mut Checker,
    s: &RawScanner,
    sp: &KeyPath,
    beam: (f64, f64, f64),
) -> Vec<Channel> {
    let (across_rad, along_rad, wavelength_nm) = beam;
    let straight = Channel::straight(across_rad, along_rad, wavelength_nm);
    let Some(raw) = &s.channels else {
        return vec![straight];
    };
    let key = sp.key("channels");
    if raw.is_empty() || raw.len() > 4 {
        c.err(
            key,
            format!(
                "give one to four channels (the LAS scanner channel field has two bits), got {}",
                raw.len()
            ),
        );
        return vec![straight];
    }
    let channels: Vec<Channel> = raw
        .iter()
        .enumerate()
        .map(|(i, ch)| {
            let k = key.index(i);
            let tilt = c.number(
                k.key("along_tilt_deg"),
                ch.along_tilt_deg,
                0.0,
                Bounds::between(-45.0, 45.0, "°"),
            );
            let yaw = c.number(
                k.key("yaw_deg"),
                ch.yaw_deg,
                0.0,
                Bounds::between(-180.0, 180.0, "°"),
            );
            let (across_mrad, along_mrad) = divergence(
                c,
                &k,
                ch.divergence_mrad,
                ch.divergence_along_mrad,
                (across_rad * 1e3, along_rad * 1e3),
            );
            let wavelength_nm = c.positive(
                k.key("wavelength_nm"),
                ch.wavelength_nm,
                wavelength_nm,
                " nm",
            );
            let pulses = c.count(
                k.key("pulses_per_cycle"),
                ch.pulses_per_cycle,
                1,
                1,
                i64::from(MAX_CYCLE),
            ) as u32;
            Channel {
                along_tilt_rad: tilt.to_radians(),
                yaw_rad: yaw.to_radians(),
                divergence_rad: across_mrad * 1e-3,
                divergence_along_rad: along_mrad * 1e-3,
                wavelength_nm,
                pulses_per_cycle: pulses,
            }
        })
        .collect();
    let cycle: u32 = channels.iter().map(|ch| ch.pulses_per_cycle).sum();
    if cycle > MAX_CYCLE {
        c.err(
            key,
            format!(
                "the channels' pulses_per_cycle add up to {cycle}; at most {MAX_CYCLE} (give \
                 the shares as the smallest whole numbers in their ratio)"
            ),
        );
    }
    channels
}
