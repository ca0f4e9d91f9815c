//! Points and map sizes for the tests of the pictures.

use super::RenderPoint;

/// A single-return point of line 1 with intensity 100.
pub(super) fn pt(x: f64, y: f64, z: f64, class: u8) -> RenderPoint {
    RenderPoint {
        x,
        y,
        z,
        intensity: 100,
        classification: class,
        return_number: 1,
        number_of_returns: 1,
        source: 1,
        gps_time_s: 0.0,
    }
}

/// Map size at a pixel size, by the rule the module documents: one
/// pixel per started `res` plus one.
pub(super) fn map_px(len_m: f64, res: f64) -> f64 {
    (len_m / res).floor() + 1.0
}
