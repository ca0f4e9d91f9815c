//! Beam deflectors: where the beam points, in the scanner frame, at each
//! instant. A closed set, one module per kind, each a pure function of time:
//!
//! * [`oscillating`] — the specification's mirror swinging across the track
//!   (triangle or sine), zig-zag scan lines;
//! * [`polygon`] — a rotating polygon mirror: parallel, unidirectional scan
//!   lines, pulses only while the facet looks into the field of view;
//! * [`palmer`] — a mirror tilted on a shaft about the nadir axis (conic
//!   scan): a circle or an ellipse on the ground, each spot seen looking
//!   forward and again looking backward;
//! * [`risley`] — two or three rotating wedge prisms: a rosette;
//! * [`fibre`] — a fixed fan of fibres, each pulse down the next one.
//!
//! The scanner frame is the specification's (Fig. 8): `x` to the left of
//! the flight direction, `y` along it, `z` down; a beam along `+z` points
//! at nadir.

pub mod fibre;
pub mod oscillating;
pub mod palmer;
pub mod polygon;
pub mod risley;

pub use fibre::Fibre;
pub use oscillating::{Mirror, MirrorProfile};
pub use palmer::Palmer;
pub use polygon::Polygon;
pub use risley::Risley;

use crate::geometry::{DMat3, DVec3};

/// A beam deflector.
#[derive(Clone, Debug, PartialEq)]
pub enum Deflector {
    /// Oscillating mirror.
    Oscillating(Mirror),
    /// Rotating polygon mirror.
    Polygon(Polygon),
    /// Palmer (conic) scanner.
    Palmer(Palmer),
    /// Risley prisms.
    Risley(Risley),
    /// Fibre array.
    Fibre(Fibre),
}

impl Deflector {
    /// The kind's name as the survey spells it (`[scanner] deflector`).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Oscillating(_) => "oscillating",
            Self::Polygon(_) => "polygon",
            Self::Palmer(_) => "palmer",
            Self::Risley(_) => "risley",
            Self::Fibre(_) => "fibre",
        }
    }

    /// Unit beam direction in the scanner frame at time `t_s`.
    pub fn direction_at(&self, t_s: f64) -> DVec3 {
        match self {
            Self::Oscillating(m) => Mirror::beam_direction(m.angle_at(t_s)),
            Self::Polygon(p) => Mirror::beam_direction(p.angle_at(t_s)),
            Self::Palmer(p) => p.direction_at(t_s),
            Self::Risley(r) => r.direction_at(t_s),
            Self::Fibre(f) => Mirror::beam_direction(f.angle_at(t_s)),
        }
    }

    /// The rotation from the beam frame (beam along `+z`) to the scanner
    /// frame at `t_s`: its third column is [`Deflector::direction_at`].
    /// Mirrors that swing across the track turn the beam about the
    /// along-track axis ([`crate::sensor::beam::deflection`]); the others by
    /// the shortest rotation from nadir ([`shortest_rotation`]).
    pub fn beam_frame(&self, t_s: f64) -> DMat3 {
        use crate::sensor::beam::deflection;
        match self {
            Self::Oscillating(m) => deflection(m.angle_at(t_s)),
            Self::Polygon(p) => deflection(p.angle_at(t_s)),
            Self::Fibre(f) => deflection(f.angle_at(t_s)),
            Self::Palmer(_) | Self::Risley(_) => shortest_rotation(self.direction_at(t_s)),
        }
    }

    /// The direction an angle encoder reports when it is off by
    /// `error_rad`: the deflection angle of a mirror scanning across the
    /// track, and a turn of the beam about the along-track axis for the
    /// rotating scanners.
    pub fn observed_direction(&self, t_s: f64, error_rad: f64) -> DVec3 {
        match self {
            Self::Oscillating(m) => Mirror::beam_direction(m.angle_at(t_s) + error_rad),
            Self::Polygon(p) => Mirror::beam_direction(p.angle_at(t_s) + error_rad),
            Self::Fibre(f) => Mirror::beam_direction(f.angle_at(t_s) + error_rad),
            Self::Palmer(_) | Self::Risley(_) => {
                let d = self.direction_at(t_s);
                let (s, c) = error_rad.sin_cos();
                DVec3::new(c * d.x + s * d.z, d.y, c * d.z - s * d.x)
            }
        }
    }

    /// Whether a pulse leaves at `t_s`: a polygon's facet looks outside the
    /// field of view for part of its turn, and the laser is idle then.
    pub fn emits_at(&self, t_s: f64) -> bool {
        match self {
            Self::Polygon(p) => p.emits_at(t_s),
            _ => true,
        }
    }

    /// How many of the pulse slots `t_k = t0_s + k / prf_hz`,
    /// `k = 0 … slots − 1`, fire: all but a polygon's while its facet looks
    /// outside the field of view ([`Polygon::emitted_slots`]).
    pub fn emitted_slots(&self, t0_s: f64, prf_hz: f64, slots: u64) -> u64 {
        match self {
            Self::Polygon(p) => p.emitted_slots(t0_s, prf_hz, slots),
            _ => slots,
        }
    }

    /// Share of the pulses that leave (the polygon's duty cycle; 1 for the
    /// others).
    pub fn emitted_share(&self) -> f64 {
        match self {
            Self::Polygon(p) => p.emitted_share(),
            _ => 1.0,
        }
    }

    /// The LAS scan direction flag at `t_s`, set while the beam moves from
    /// left to right: the mirror's swing to the right (oscillating), always
    /// for the one-way scanners (polygon and fibre sweep from left to
    /// right; the Risley rosette has no direction), and — for want of a
    /// left and right — while looking forward (Palmer).
    pub fn scan_direction_positive(&self, t_s: f64) -> bool {
        match self {
            Self::Oscillating(m) => !m.moving_left_at(t_s),
            Self::Palmer(p) => p.looking_forward_at(t_s),
            Self::Polygon(_) | Self::Risley(_) | Self::Fibre(_) => true,
        }
    }

    /// Whether a scan line ends between `t_s` and `t_next_s` (the LAS
    /// edge-of-flight-line flag of the pulse at `t_s`): the mirror turns,
    /// the polygon's facet leaves the field of view or the fibre sweep
    /// ends, the Palmer scanner
    /// turns from its forward to its backward look or back. A Risley
    /// rosette has no lines.
    pub fn line_ends_between(&self, t_s: f64, t_next_s: f64) -> bool {
        match self {
            Self::Oscillating(m) => m.moving_left_at(t_s) != m.moving_left_at(t_next_s),
            // The next pulse slot already looks outside the field of view.
            Self::Polygon(p) => !p.emits_at(t_next_s) || p.line_at(t_s) != p.line_at(t_next_s),
            Self::Fibre(f) => f.sweep_at(t_s) != f.sweep_at(t_next_s),
            Self::Palmer(p) => p.looking_forward_at(t_s) != p.looking_forward_at(t_next_s),
            Self::Risley(_) => false,
        }
    }

    /// Largest angle from nadir across the track, rad: the swath is
    /// `2H·tan` of it over flat ground. A polygon looking sideways or up
    /// (beyond 89°) counts as 89°: its swath over flat ground is bounded by
    /// the range, not the angle.
    pub fn across_half_angle_rad(&self) -> f64 {
        match self {
            Self::Oscillating(m) => m.scan_half_angle_rad,
            Self::Polygon(p) => p.scan_half_angle_rad.min(89f64.to_radians()),
            Self::Palmer(p) => p.across_half_angle_rad,
            Self::Risley(r) => r.half_field_of_view_rad(),
            Self::Fibre(f) => f.scan_half_angle_rad,
        }
    }

    /// Largest angle of the beam from nadir in any direction, rad.
    pub fn max_off_nadir_rad(&self) -> f64 {
        match self {
            Self::Palmer(p) => p.across_half_angle_rad.max(p.along_half_angle_rad),
            _ => self.across_half_angle_rad(),
        }
    }

    /// Scan lines per second: an oscillating mirror draws two per cycle, a
    /// polygon one per facet, a fibre array one per sweep, a Palmer
    /// scanner one forward and one backward arc per turn (each look's
    /// arcs follow each other at the turn rate); a Risley rosette's lobes
    /// pass a fixed direction at the difference of its first two rotor
    /// frequencies.
    pub fn lines_per_s(&self) -> f64 {
        match self {
            Self::Oscillating(m) => 2.0 * m.scan_frequency_hz,
            Self::Polygon(p) => p.line_rate_hz,
            Self::Palmer(p) => p.rotation_hz,
            Self::Risley(r) => r.lobe_rate_hz(),
            Self::Fibre(f) => f.sweep_rate_hz,
        }
    }

    /// Angle between the beams of successive pulses near nadir, rad, at
    /// `prf_hz`: `4θf/PRF` for a triangle mirror, `2πθf/PRF` for a sine
    /// one, `Θf/PRF` for a polygon sweeping `Θ` per line, the fan's step
    /// for a fibre array; for the Palmer and Risley patterns the mean angle
    /// between successive beams over one second of the pattern.
    pub fn pulse_step_rad(&self, prf_hz: f64) -> f64 {
        match self {
            Self::Oscillating(m) => {
                let omega = match m.profile {
                    MirrorProfile::Triangle => 4.0,
                    MirrorProfile::Sine => std::f64::consts::TAU,
                };
                omega * m.scan_half_angle_rad * m.scan_frequency_hz / prf_hz
            }
            Self::Polygon(p) => p.sweep_rad() * p.line_rate_hz / prf_hz,
            Self::Fibre(f) => f.step_rad(),
            Self::Palmer(_) | Self::Risley(_) => {
                let n = 20_000usize;
                let dt = 1.0 / prf_hz;
                let stride = (prf_hz / n as f64).max(1.0).floor();
                let total: f64 = (0..n)
                    .map(|i| {
                        let t = i as f64 * stride * dt;
                        self.direction_at(t)
                            .angle_between(self.direction_at(t + dt))
                    })
                    .sum();
                total / n as f64
            }
        }
    }

    /// Words for the report and `lidarsim check`.
    pub fn describe(&self) -> String {
        let deg = f64::to_degrees;
        match self {
            Self::Oscillating(m) => format!(
                "oscillating mirror, {}, {} Hz, ±{:.2}°",
                match m.profile {
                    MirrorProfile::Triangle => "triangle (constant angular speed)",
                    MirrorProfile::Sine => "sine",
                },
                m.scan_frequency_hz,
                deg(m.scan_half_angle_rad)
            ),
            Self::Polygon(p) => format!(
                "rotating polygon, {} facets, {} lines/s, ±{:.2}° of a {:.1}° facet sweep",
                p.facets,
                p.line_rate_hz,
                deg(p.scan_half_angle_rad),
                deg(p.sweep_rad())
            ),
            Self::Palmer(p) => format!(
                "Palmer (conic), {} turns/s, ±{:.2}° across × ±{:.2}° along",
                p.rotation_hz,
                deg(p.across_half_angle_rad),
                deg(p.along_half_angle_rad)
            ),
            Self::Risley(r) => format!(
                "Risley prisms, deviations {} °, rotors {} Hz, field of view ±{:.2}°",
                r.prisms
                    .iter()
                    .map(|p| format!("{:.2}", deg(p.deviation_rad)))
                    .collect::<Vec<_>>()
                    .join(" / "),
                r.prisms
                    .iter()
                    .map(|p| format!("{}", p.frequency_hz))
                    .collect::<Vec<_>>()
                    .join(" / "),
                deg(r.half_field_of_view_rad())
            ),
            Self::Fibre(f) => format!(
                "fibre array, {} fibres over ±{:.2}°, {} sweeps/s",
                f.fibres,
                deg(f.scan_half_angle_rad),
                f.sweep_rate_hz
            ),
        }
    }
}

/// The shortest rotation that turns `+z` into the unit vector `d`
/// (Rodrigues' formula about `z × d`); the identity at nadir.
pub fn shortest_rotation(d: DVec3) -> DMat3 {
    let c = d.z;
    if c <= -1.0 + 1e-12 {
        // Straight up: any half turn about a horizontal axis.
        return DMat3::from_cols(DVec3::X, -DVec3::Y, -DVec3::Z);
    }
    // v = z × d = (−d.y, d.x, 0); R = I + [v]× + [v]×² / (1 + c).
    let (vx, vy) = (-d.y, d.x);
    let k = 1.0 / (1.0 + c);
    DMat3::from_cols(
        DVec3::new(1.0 - vy * vy * k, vx * vy * k, -vy),
        DVec3::new(vx * vy * k, 1.0 - vx * vx * k, vx),
        DVec3::new(vy, -vx, c),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shortest_rotation_is_a_rotation_to_the_direction() {
        for d in [
            DVec3::new(0.3, -0.2, 0.9).normalize(),
            DVec3::new(-0.5, 0.1, 0.2).normalize(),
            DVec3::Z,
            -DVec3::Z,
        ] {
            let r = shortest_rotation(d);
            assert!((r * DVec3::Z - d).length() < 1e-12, "{d}");
            assert!((r.determinant() - 1.0).abs() < 1e-12);
            assert!((r * r.transpose()).abs_diff_eq(DMat3::IDENTITY, 1e-12));
            // The rotation axis is perpendicular to z and d: a vector
            // along z × d stays.
            let axis = DVec3::Z.cross(d);
            if axis.length() > 1e-9 {
                assert!((r * axis - axis).length() < 1e-12);
            }
        }
        // Across-track deflection: the same as the mirror's rotation.
        let m = crate::sensor::beam::deflection(0.3);
        assert!(shortest_rotation(m.z_axis).abs_diff_eq(m, 1e-12));
    }

    #[test]
    fn encoder_error_turns_the_beam_by_that_angle() {
        let p = Deflector::Palmer(Palmer {
            rotation_hz: 20.0,
            across_half_angle_rad: 0.3,
            along_half_angle_rad: 0.3,
        });
        let t = 0.0123;
        let a = p
            .direction_at(t)
            .angle_between(p.observed_direction(t, 1e-3));
        assert!(a <= 1e-3 + 1e-12 && a > 0.0);
    }
}
