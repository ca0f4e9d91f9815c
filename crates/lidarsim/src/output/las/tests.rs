//! The writer's parts against the LAS specification's figures.

use super::*;
use crate::geometry::DVec3;

#[test]
fn digitizer_counts_span_minus_a_sixteenth_to_full_scale() {
    let d = Digitizer::with_full_scale(500, 32.0);
    assert_eq!(d.offset, -2.0);
    assert_eq!(d.count(-2.0), 0);
    assert_eq!(d.count(32.0), 65535);
    assert_eq!(d.count(1e9), 65535); // saturates
    assert_eq!(d.count(-1e9), 0);
    // Zero signal at 1/17 of the range; a count maps back within half a
    // count.
    assert_eq!(d.count(0.0), (65535.0f64 / 17.0).round() as u16);
    let v = 1.234_567;
    assert!((d.offset + d.gain * f64::from(d.count(v)) - v).abs() <= d.gain / 2.0);
    // A useless full scale falls back to 1.
    assert_eq!(
        Digitizer::with_full_scale(500, f64::NAN).offset,
        -1.0 / 16.0
    );
}

fn point(x: f64, t: f64) -> PointRecord {
    PointRecord {
        position_m: DVec3::new(x, 2.0, 3.0),
        gps_time_s: t,
        intensity: 7,
        amplitude: 1.0,
        echo_width_ns: 4.0,
        range_m: 500.0,
        beam_dir: DVec3::new(0.0, 0.0, -1.0),
        error_m: DVec3::ZERO,
        return_number: 1,
        number_of_returns: 1,
        scan_direction_positive: true,
        edge_of_flight_line: false,
        scan_angle_deg: 0.0,
        classification: 2,
        point_source_id: 1,
        pulse_index: 0,
        object_id: None,
        incidence_angle_deg: Some(0.0),
        echo_time_ps: 0.0,
        component: Default::default(),
        channel: 0,
    }
}

/// Records are gathered into megabyte writes across blocks, and a block
/// with a coordinate the file cannot hold is refused whole: the file
/// then holds exactly the points of the other blocks, in order, as the
/// `las` crate reads them back.
#[test]
fn gathered_blocks_and_a_refused_block() {
    let dir = std::env::temp_dir().join(format!("lidarsim-las-blocks-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("blocks.las");
    let settings = LasSettings {
        scale_m: 0.001,
        offset_m: [0.0; 3],
        origin_m: [0.0; 3],
        adjusted_standard_gps_time: false,
        file_source_id: 1,
        creation_day_year: (1, 2026),
        generating_software: "test".into(),
        attribute_extra_bytes: true,
        error_extra_bytes: false,
        crs_wkt: None,
        compressed: false,
        waveform: None,
        waveform_file_shared: false,
    };
    let mut w = LasWriter::create(&path, settings).unwrap();
    let len = usize::from(w.settings.record_len());
    // Blocks of 3 000 points, so that a few blocks fill a write.
    let per_block = 3000;
    let blocks = 2 * LAS_WRITE_BYTES / (per_block * len) + 2;
    let mut want = Vec::new();
    for b in 0..blocks {
        let block: Vec<PointRecord> = (0..per_block)
            .map(|i| point((b * per_block + i) as f64 * 0.01, b as f64))
            .collect();
        w.write(&block).unwrap();
        want.extend(block.iter().map(|p| p.position_m.x));
        if b == 1 {
            // 1e9 m / 1 mm does not fit an i32: the block is refused.
            let mut bad = block.clone();
            bad[per_block / 2].position_m.x = 1e9;
            assert!(w.write(&bad).is_err());
        }
    }
    Box::new(w).finish().unwrap();
    let mut reader = ::las::Reader::from_path(&path).unwrap();
    assert_eq!(reader.header().number_of_points(), want.len() as u64);
    let bounds = reader.header().bounds();
    assert!((bounds.max.x - want[want.len() - 1]).abs() < 1e-6);
    let got: Vec<f64> = reader
        .read_all()
        .unwrap()
        .points()
        .map(|p| p.unwrap().x)
        .collect();
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-6, "{g} vs {w}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn wdp_header_is_an_evlr_header() {
    let h = wdp_header(1234);
    assert_eq!(h.len() as u64, WDP_HEADER_LEN);
    assert_eq!(&h[2..11], b"LASF_Spec");
    assert_eq!(u16::from_le_bytes([h[18], h[19]]), 65535);
    assert_eq!(u64::from_le_bytes(h[20..28].try_into().unwrap()), 1234);
}
