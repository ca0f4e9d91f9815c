//! Points and trajectories as the bytes of NumPy structured arrays. The
//! values are those the LAS file stores — coordinates quantized with the
//! file's scale and offset and read back as laspy reads them, the scan
//! angle in the LAS field's 0.006° units, extra bytes as `f32` — using the
//! library's own encoders, so an array and the file agree to the bit.

use lidarsim::files::TrajectoryRow;
use lidarsim::output::{
    LasSettings, PointRecord, PointSink, WriteCause, return_numbers, scan_angle_units,
};

/// The fields of a point, in order: (name, NumPy type). Names are laspy's
/// dimension names where it has one, else the LAS file's extra-byte names;
/// `pulse_index` (the pulse within its line) is not in the LAS file.
pub const FIELDS: [(&str, &str); 23] = [
    ("x", "<f8"),
    ("y", "<f8"),
    ("z", "<f8"),
    ("intensity", "<u2"),
    ("return_number", "u1"),
    ("number_of_returns", "u1"),
    ("scan_direction_flag", "u1"),
    ("edge_of_flight_line", "u1"),
    ("scanner_channel", "u1"),
    ("classification", "u1"),
    ("user_data", "u1"),
    ("scan_angle", "<i2"),
    ("point_source_id", "<u2"),
    ("gps_time", "<f8"),
    ("amplitude", "<f4"),
    ("echo_width", "<f4"),
    ("range", "<f4"),
    ("incidence_angle", "<f4"),
    ("object_id", "<u4"),
    ("error_x", "<f4"),
    ("error_y", "<f4"),
    ("error_z", "<f4"),
    ("pulse_index", "<u8"),
];

/// Bytes of one packed point.
pub const RECORD_BYTES: usize = 85;

/// The fields of a trajectory row.
pub const TRAJECTORY_FIELDS: [(&str, &str); 8] = [
    ("gps_time", "<f8"),
    ("x", "<f8"),
    ("y", "<f8"),
    ("z", "<f8"),
    ("roll", "<f8"),
    ("pitch", "<f8"),
    ("yaw", "<f8"),
    ("line", "<u4"),
];

/// Appends the packed bytes of `p` to `out`.
pub fn pack(settings: &LasSettings, p: &PointRecord, out: &mut Vec<u8>) -> Result<(), WriteCause> {
    let q = settings.quantize_point(p.position_m)?;
    for (a, qa) in q.iter().enumerate() {
        let v = f64::from(*qa) * settings.scale_m + settings.offset_m[a];
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&p.intensity.to_le_bytes());
    let (rn, nr) = return_numbers(p);
    out.extend_from_slice(&[
        rn,
        nr,
        u8::from(p.scan_direction_positive),
        u8::from(p.edge_of_flight_line),
        p.channel & 3,
        p.classification,
        p.component.code(),
    ]);
    out.extend_from_slice(&scan_angle_units(p.scan_angle_deg).to_le_bytes());
    out.extend_from_slice(&p.point_source_id.to_le_bytes());
    out.extend_from_slice(&p.gps_time_s.to_le_bytes());
    for v in [
        p.amplitude,
        p.echo_width_ns,
        p.range_m,
        p.incidence_angle_deg.unwrap_or(f64::NAN),
    ] {
        out.extend_from_slice(&(v as f32).to_le_bytes());
    }
    out.extend_from_slice(&p.object_code().to_le_bytes());
    for e in [p.error_m.x, p.error_m.y, p.error_m.z] {
        out.extend_from_slice(&(e as f32).to_le_bytes());
    }
    out.extend_from_slice(&p.pulse_index.to_le_bytes());
    Ok(())
}

/// The packed bytes of trajectory rows.
pub fn pack_trajectory(rows: &[TrajectoryRow]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rows.len() * 60);
    for r in rows {
        out.extend_from_slice(&r.gps_time_s.to_le_bytes());
        for v in r.position_m.to_array().into_iter().chain(r.attitude_deg) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&r.line.to_le_bytes());
    }
    out
}

/// A sink that packs every point it is given.
pub struct PackSink {
    /// The LAS file's quantization.
    pub settings: LasSettings,
    /// The packed points.
    pub bytes: Vec<u8>,
}

impl PointSink for PackSink {
    /// A point the LAS scale and offset cannot store.
    type Error = WriteCause;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteCause> {
        self.bytes.reserve(points.len() * RECORD_BYTES);
        for p in points {
            pack(&self.settings, p, &mut self.bytes)?;
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), WriteCause> {
        Ok(())
    }

    fn discard(self: Box<Self>) {}
}
