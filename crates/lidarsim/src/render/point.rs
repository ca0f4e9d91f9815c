//! The point as a picture sees it: position and the attributes colours
//! can show, whatever file it was read from.

/// The attributes a picture can show of a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderPoint {
    /// Position, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Height, m.
    pub z: f64,
    /// LAS intensity.
    pub intensity: u16,
    /// ASPRS class.
    pub classification: u8,
    /// Return number (1-based).
    pub return_number: u8,
    /// Number of returns of the pulse.
    pub number_of_returns: u8,
    /// Point source ID (flight line).
    pub source: u16,
    /// GPS time, s (0 where the picture does not show it: the report's
    /// cross-section).
    pub gps_time_s: f64,
}
