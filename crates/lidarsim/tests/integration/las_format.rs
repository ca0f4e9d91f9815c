//! The LAS file read back by an independent reader (the `las` crate) and by
//! hand against the LAS 1.4 R15 byte layout, checked against the geometry
//! of the survey, and against the text output written by the other sink.

use std::path::PathBuf;

use lidarsim::Survey;
use lidarsim::run::RunOptions;

use crate::kit::run_to_dir;

use crate::kit::fresh;

const H: f64 = 500.0;

/// Runs the flat survey (with `extra` in its `[output]` table or after it)
/// into a fresh directory named after `name`.
fn run_flat(extra: &str, name: &str, threads: usize) -> (PathBuf, lidarsim::run::Summary) {
    let dir = fresh(name);
    let summary = run_to_dir(
        &flat_survey(extra),
        &dir,
        &RunOptions::new(threads, &|_| {}),
    )
    .unwrap();
    (dir, summary)
}

fn flat_survey(extra: &str) -> Survey {
    let text = format!(
        r#"
seed = 5
[scanner]
prf_hz = 50000
scan_frequency_hz = 40
scan_angle_deg = 18
# Intensity from the echo's energy, Eq. 2 (a discrete receiver records the
# peak, lower on the stretched echoes of oblique pulses).
echo_detection = "waveform"
[output]
formats = ["las", "xyz"]
{extra}
[[flight_line]]
start_m = [1000.0, 2000.0, {H}]
end_m = [1000.0, 2060.0, {H}]
speed_mps = 60.0
[materials.grass]
reflectance = 0.3
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[0, 1000, 0], [2000, 1000, 0], [2000, 3000, 0], [0, 3000, 0]]
"#
    );
    Survey::from_toml(&text, None).unwrap()
}

#[test]
fn las_header_and_points_read_back_with_an_independent_reader() {
    let (dir, summary) = run_flat("", "las", 2);

    let mut reader = las::Reader::from_path(dir.join("points.las")).unwrap();
    let header = reader.header().clone();
    assert_eq!(header.version(), las::Version::new(1, 4));
    assert_eq!(header.point_format().to_u8().unwrap(), 6);
    assert_eq!(header.number_of_points(), summary.points);
    assert_eq!(header.number_of_points_by_return(1), Some(summary.points));
    assert_eq!(header.file_source_id(), 1);
    assert!(
        header.has_wkt_crs(),
        "WKT bit must be set for point format 6"
    );
    assert_eq!(header.gps_time_type(), las::GpsTimeType::Week);
    assert!(header.generating_software().starts_with("lidarsim"));

    let points: Vec<las::Point> = reader
        .read_all()
        .unwrap()
        .points()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(points.len() as u64, summary.points);
    assert_eq!(summary.points, summary.pulses); // one echo per pulse

    // Header bounds are the extremes of the points.
    let b = header.bounds();
    let min_x = points.iter().map(|p| p.x).fold(f64::MAX, f64::min);
    let max_x = points.iter().map(|p| p.x).fold(f64::MIN, f64::max);
    let max_y = points.iter().map(|p| p.y).fold(f64::MIN, f64::max);
    assert!((b.min.x - min_x).abs() < 1e-9 && (b.max.x - max_x).abs() < 1e-9);
    assert!((b.max.y - max_y).abs() < 1e-9);

    let half = 18f64.to_radians();
    let mut last_time = f64::MIN;
    for p in &points {
        // On the plane, within the swath, classified as ground.
        assert!(p.z.abs() < 0.01, "z = {}", p.z);
        assert!((p.x - 1000.0).abs() <= H * half.tan() + 0.01);
        assert_eq!(p.classification, las::point::Classification::Ground);
        assert_eq!((p.return_number, p.number_of_returns), (1, 1));
        assert_eq!(p.point_source_id, 1);
        // Scan angle: LAS counts counter-clockwise seen from behind as
        // positive, i.e. towards the right of the flight direction (east for
        // a northbound line): tan(angle) = Δx / H, quantised to 0.006°.
        let want = ((p.x - 1000.0) / H).atan().to_degrees();
        assert!(
            (f64::from(p.scan_angle) - want).abs() < 0.0031,
            "{} vs {want}",
            p.scan_angle
        );
        let t = p.gps_time.unwrap();
        assert!(t >= last_time);
        last_time = t;
    }
    // The last pulse leaves just before the end of the 1 s line.
    assert!(last_time < 1.0 && last_time > 0.999);
    // Both scan directions and some edge points are present.
    let l2r = points
        .iter()
        .filter(|p| p.scan_direction == las::point::ScanDirection::LeftToRight)
        .count();
    assert!(l2r > points.len() / 3 && l2r < 2 * points.len() / 3);
    let edges = points.iter().filter(|p| p.is_edge_of_flight_line).count();
    // Two scan lines per mirror cycle, 40 cycles in 1 s.
    assert!((79..=81).contains(&edges), "{edges}");
    // Moving left to right means the beam's x increases along the line.
    for w in points.windows(2) {
        if w[0].scan_direction == las::point::ScanDirection::LeftToRight
            && !w[0].is_edge_of_flight_line
        {
            assert!(w[1].x > w[0].x);
        }
    }

    // The text output holds the same points.
    let text = std::fs::read_to_string(dir.join("points.xyz")).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("x y z intensity"));
    let mut n = 0;
    for (line, p) in lines.zip(&points) {
        let cols: Vec<f64> = line
            .split_whitespace()
            .map(|c| c.parse().unwrap())
            .collect();
        assert!((cols[0] - p.x).abs() < 0.0006 && (cols[1] - p.y).abs() < 0.0006);
        assert!((cols[2] - p.z).abs() < 0.0006);
        assert_eq!(cols[3] as u16, p.intensity);
        n += 1;
    }
    assert_eq!(n, points.len());

    // Intensity follows Eq. 2 with the documented gain: ρ (Rn/R)² cos α
    // times 10 000 (the beam is at most 18° off nadir over level ground).
    for p in points.iter().step_by(97) {
        let angle = f64::from(p.scan_angle).to_radians();
        let range = H / angle.cos();
        let want = 10_000.0 * 0.3 * (1000.0 / range).powi(2) * angle.cos();
        assert!((f64::from(p.intensity) - want).abs() < 0.01 * want + 1.0);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn raw_header_bytes_follow_the_specification() {
    let (dir, summary) = run_flat("gps_start_time_s = 400000000.0", "raw", 1);
    let bytes = std::fs::read(dir.join("points.las")).unwrap();
    let u16_at = |o: usize| u16::from_le_bytes([bytes[o], bytes[o + 1]]);
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
    let f64_at = |o: usize| f64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
    // LAS 1.4 R15 Table 3 offsets.
    assert_eq!(&bytes[0..4], b"LASF");
    assert_eq!(u16_at(6), 0b1_0001); // adjusted standard GPS time + WKT
    assert_eq!((bytes[24], bytes[25]), (1, 4));
    assert_eq!(u16_at(94), 375); // header size
    // One VLR, the Extra Bytes VLR: 54-byte header + 5 descriptors of 192.
    let first = 375 + 54 + 5 * 192;
    assert_eq!(u32_at(96), first as u32); // offset to point data
    assert_eq!(u32_at(100), 1); // VLRs
    assert_eq!(bytes[104], 6); // point format
    // Format 6 (30 bytes) + amplitude, echo width, range, incidence angle
    // (f32) and object id (u32).
    assert_eq!(u16_at(105), 50); // record length
    assert_eq!(u32_at(107), 0); // legacy count is zero for format 6
    assert_eq!(f64_at(131), 0.001); // x scale
    assert_eq!(u64_at(247), summary.points); // number of point records
    assert_eq!(u64_at(255), summary.points); // first returns
    assert_eq!(bytes.len() as u64, first as u64 + 50 * summary.points);
    // VLR header (Table 13): user ID at +2, record ID 4 at +18, length at
    // +20; descriptor names at +4 of each 192-byte descriptor.
    assert_eq!(&bytes[375 + 2..375 + 11], b"LASF_Spec");
    assert_eq!(u16_at(375 + 18), 4);
    assert_eq!(u16_at(375 + 20), 5 * 192);
    let names: Vec<String> = (0..5)
        .map(|k| {
            let d = &bytes[375 + 54 + k * 192..];
            String::from_utf8_lossy(&d[4..36])
                .trim_end_matches('\0')
                .to_string()
        })
        .collect();
    assert_eq!(
        names,
        [
            "amplitude",
            "echo_width",
            "range",
            "incidence_angle",
            "object_id"
        ]
    );
    // First point record: GPS time at offset 22 within the 30 bytes, then
    // the extra bytes: range (m) at +38 equals the flying height over the
    // level ground divided by the cosine of the scan angle (i16 at +18, in
    // 0.006°), incidence angle at +42 equals that scan angle.
    let t0 = f64_at(first + 22);
    assert_eq!(t0, 400_000_000.0);
    for k in 0..summary.points as usize {
        let rec = first + 50 * k;
        let angle = f64::from(i16::from_le_bytes([bytes[rec + 18], bytes[rec + 19]])) * 0.006;
        let f32_at = |o: usize| f64::from(f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()));
        let range = f32_at(rec + 38);
        assert!(
            (range - H / angle.to_radians().cos()).abs() < 0.05,
            "{range}"
        );
        assert!((f32_at(rec + 42) - angle.abs()).abs() < 0.01);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn error_vectors_are_extra_bytes_with_a_descriptor() {
    let (dir, summary) = run_flat("[gnss]\nbias_m = [0.25, -0.5, 0.125]", "extra", 2);
    let mut reader = las::Reader::from_path(dir.join("points.las")).unwrap();
    let header = reader.header().clone();
    // Point format 6 with 20 bytes of echo attributes and 12 of error
    // vector, described by one Extra Bytes VLR (user ID LASF_Spec, record
    // ID 4) of eight 192-byte descriptors.
    assert_eq!(header.point_format().len(), 62);
    assert_eq!(header.point_format().extra_bytes, 32);
    let vlr = header
        .vlrs()
        .iter()
        .find(|v| v.user_id == "LASF_Spec" && v.record_id == 4)
        .expect("Extra Bytes VLR");
    assert_eq!(vlr.data.len(), 8 * 192);
    for (k, name) in ["error_x", "error_y", "error_z"].iter().enumerate() {
        let d = &vlr.data[(k + 5) * 192..(k + 6) * 192];
        assert_eq!(d[2], 9, "data type float");
        assert_eq!(&d[4..4 + name.len()], name.as_bytes());
    }
    let points: Vec<las::Point> = reader
        .read_all()
        .unwrap()
        .points()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(points.len() as u64, summary.points);
    for p in &points {
        let e: Vec<f32> = p.extra_bytes[20..]
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(e, [0.25, -0.5, 0.125]);
        // The bias moved the point: the ground is at z = 0.125.
        assert!((p.z - 0.125).abs() < 0.011);
    }
    std::fs::remove_dir_all(&dir).ok();
}
