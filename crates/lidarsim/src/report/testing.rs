//! Points and areas for the tests of the report.

use crate::geometry::{Aabb, DVec3};
use crate::output::PointRecord;

/// A point of pulse `pulse` of line `line` (0-based) at `(x, y, z)`,
/// return `n` of `of`, with georeferencing error `error`.
pub(super) fn rec(
    (x, y, z): (f64, f64, f64),
    error: DVec3,
    (n, of): (u8, u8),
    (line, pulse): (u16, u64),
) -> PointRecord {
    PointRecord {
        position_m: DVec3::new(x, y, z),
        gps_time_s: 0.0,
        intensity: 100,
        amplitude: 0.0,
        echo_width_ns: 4.0,
        range_m: 100.0,
        beam_dir: -DVec3::Z,
        error_m: error,
        return_number: n,
        number_of_returns: of,
        scan_direction_positive: true,
        edge_of_flight_line: false,
        scan_angle_deg: 0.0,
        classification: 2,
        point_source_id: line + 1,
        pulse_index: pulse,
        object_id: None,
        component: Default::default(),
        channel: 0,
        incidence_angle_deg: Some(0.0),
        echo_time_ps: 0.0,
    }
}

pub(super) fn area(w: f64, h: f64) -> Aabb {
    Aabb {
        min: DVec3::new(0.0, 0.0, 0.0),
        max: DVec3::new(w, h, 0.0),
    }
}
