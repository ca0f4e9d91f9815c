//! The other output formats read back by hand against their specifications:
//! LAS 1.4 point format 9 with the waveforms in `points.wdp` (LAS 1.4 R15,
//! Tables 3, 11, 13, 17, 21), LAZ header and LASzip VLR, PLY header and
//! record size, the WKT VLR, and the survey keys' errors. (The independent
//! reader of the same files is laspy: `scripts/check_outputs.py`.)

use std::path::PathBuf;

use lidarsim::Survey;
use lidarsim::run::RunOptions;

use crate::kit::run_to_dir;

use crate::kit::fresh;

const C: f64 = 299_792_458.0;
const H: f64 = 300.0;
const ROOF_M: f64 = 5.0;

/// Roof strips 0.25 m wide every 0.5 m, `ROOF_M` above the ground, under a
/// 3 mrad beam: two echoes per pulse.
fn two_planes(output: &str) -> String {
    let mut s = format!(
        r#"
seed = 4
[scanner]
prf_hz = 20000
scan_frequency_hz = 30
scan_angle_deg = 4
divergence_mrad = 3
subrays = 37
[receiver]
noise = 0.002
[output]
{output}
[[flight_line]]
start_m = [0.0, -0.6, {H}]
end_m = [0.0, 0.6, {H}]
speed_mps = 60.0
[materials.grass]
reflectance = 0.3
[materials.roof]
reflectance = 0.5
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]]
"#
    );
    for i in -50..50 {
        let x0 = f64::from(i) * 0.5;
        let x1 = x0 + 0.25;
        s.push_str(&format!(
            "[[polygon]]\nmaterial = \"roof\"\nclass = \"building\"\n\
             vertices_m = [[{x0}, -10, {ROOF_M}], [{x1}, -10, {ROOF_M}], [{x1}, 10, {ROOF_M}], [{x0}, 10, {ROOF_M}]]\n"
        ));
    }
    s
}

fn run(text: &str, name: &str) -> (PathBuf, lidarsim::run::Summary) {
    let dir = fresh(name);
    let survey = Survey::from_toml(text, None).unwrap();
    let summary = run_to_dir(&survey, &dir, &RunOptions::new(2, &|_| {})).unwrap();
    (dir, summary)
}

struct Bytes(Vec<u8>);

impl Bytes {
    fn u16(&self, o: usize) -> u16 {
        u16::from_le_bytes(self.0[o..o + 2].try_into().unwrap())
    }
    fn u32(&self, o: usize) -> u32 {
        u32::from_le_bytes(self.0[o..o + 4].try_into().unwrap())
    }
    fn u64(&self, o: usize) -> u64 {
        u64::from_le_bytes(self.0[o..o + 8].try_into().unwrap())
    }
    fn f32(&self, o: usize) -> f64 {
        f64::from(f32::from_le_bytes(self.0[o..o + 4].try_into().unwrap()))
    }
    fn f64(&self, o: usize) -> f64 {
        f64::from_le_bytes(self.0[o..o + 8].try_into().unwrap())
    }
    fn i32(&self, o: usize) -> i32 {
        i32::from_le_bytes(self.0[o..o + 4].try_into().unwrap())
    }
    /// The VLRs: (user ID, record ID, data offset, data length).
    fn vlrs(&self) -> Vec<(String, u16, usize, usize)> {
        let mut o = usize::from(self.u16(94));
        (0..self.u32(100))
            .map(|_| {
                let user = String::from_utf8_lossy(&self.0[o + 2..o + 18])
                    .trim_end_matches('\0')
                    .to_string();
                let id = self.u16(o + 18);
                let len = usize::from(self.u16(o + 20));
                let v = (user, id, o + 54, len);
                o += 54 + len;
                v
            })
            .collect()
    }
}

#[test]
fn point_format_9_waveforms_follow_las_1_4_and_the_two_plane_geometry() {
    let (dir, summary) = run(
        &two_planes(
            r#"formats = ["las-waveform", "laz"]
crs = "EPSG:32633""#,
        ),
        "wave",
    );
    let las = Bytes(std::fs::read(dir.join("points.las")).unwrap());
    let wdp = Bytes(std::fs::read(dir.join("points.wdp")).unwrap());
    // Header (Table 3): global encoding bits 2 (external waveforms) and 4
    // (WKT); point format 9; record length 59 + 20 extra bytes; start of
    // waveform data packet record 0 (external file).
    assert_eq!(las.u16(6), 0b1_0100);
    assert_eq!(las.0[104], 9);
    assert_eq!(las.u16(105), 79);
    assert_eq!(las.u64(227), 0);
    let vlrs = las.vlrs();
    assert_eq!(vlrs.len(), 1 + 255 + 1);
    // Waveform packet descriptors (Table 17), record ID 99 + index.
    for (k, (user, id, o, len)) in vlrs[1..256].iter().enumerate() {
        assert_eq!(
            (user.as_str(), *id, *len),
            ("LASF_Spec", 100 + k as u16, 26)
        );
        assert_eq!((las.0[*o], las.0[o + 1]), (16, 0)); // bits, compression
        assert_eq!(las.u32(o + 2), 16 * (k as u32 + 1)); // samples
        assert_eq!(las.u32(o + 6), 500); // spacing, ps
    }
    let (gain, offset) = (las.f64(vlrs[1].2 + 10), las.f64(vlrs[1].2 + 18));
    // Digitiser full scale: twice a white surface filling the beam at the
    // closest range (300 m flight, roofs at 5 m; reference range 1000 m),
    // counts from −full/16 to full.
    let full = 2.0 * (1000.0 / (H - ROOF_M)).powi(2);
    assert!((offset + full / 16.0).abs() < 1e-9, "{offset}");
    assert!((offset + gain * 65535.0 - full).abs() < 1e-9);
    // The WKT VLR: UTM zone 33N, central meridian 15° E.
    let (user, id, o, len) = &vlrs[256];
    assert_eq!((user.as_str(), *id), ("LASF_Projection", 2112));
    let wkt = String::from_utf8_lossy(&las.0[*o..o + len]);
    assert!(wkt.contains(r#"PARAMETER["central_meridian",15]"#) && wkt.ends_with("]]\0"));
    // The .wdp file starts with an EVLR header (Table 21): record 65535,
    // length of the packets after it.
    assert_eq!(&wdp.0[2..11], b"LASF_Spec");
    assert_eq!(wdp.u16(18), 65535);
    assert_eq!(wdp.u64(20), wdp.0.len() as u64 - 60);

    let first = las.u32(96) as usize;
    let n = summary.points as usize;
    assert_eq!(las.0.len(), first + 79 * n);
    assert!(summary.pulses > 300 && summary.points == 2 * summary.pulses);
    let scale = las.f64(131);
    let offs = [las.f64(155), las.f64(163), las.f64(171)];
    let mut worst_anchor = 0.0f64;
    let mut worst_gap = 0.0f64;
    for pulse in 0..n / 2 {
        let mut anchors = Vec::new();
        let mut locations = Vec::new();
        for e in 0..2 {
            let r = first + 79 * (2 * pulse + e);
            let p: Vec<f64> = (0..3)
                .map(|a| f64::from(las.i32(r + 4 * a)) * scale + offs[a])
                .collect();
            // Wave packet (Table 11) at +30: index, offset, size, location,
            // X(t), Y(t), Z(t).
            let index = usize::from(las.0[r + 30]);
            let off = las.u64(r + 31) as usize;
            let size = las.u32(r + 39) as usize;
            let loc = las.f32(r + 43);
            let v = [las.f32(r + 47), las.f32(r + 51), las.f32(r + 55)];
            assert!(index >= 1 && size == 2 * 16 * index && off >= 60);
            // (X(t), Y(t), Z(t)) points up to the scanner at c/2 per ps.
            let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!((norm - C / 2.0 * 1e-12).abs() < 1e-9 && v[2] > 0.99 * norm);
            // The sample nearest the location is within one sample of the
            // local maximum.
            let samples: Vec<f64> = (0..size / 2)
                .map(|s| offset + gain * f64::from(wdp.u16(off + 2 * s)))
                .collect();
            let j = (loc / 500.0).round() as usize;
            let (lo, hi) = (j.saturating_sub(3), (j + 4).min(samples.len()));
            let k = (lo..hi)
                .max_by(|&a, &b| samples[a].total_cmp(&samples[b]))
                .unwrap();
            assert!(
                (k as f64 - loc / 500.0).abs() <= 1.0,
                "{k} vs {}",
                loc / 500.0
            );
            anchors.push([0, 1, 2].map(|a| p[a] + loc * v[a]));
            locations.push((loc, p[2], off));
        }
        // Both echoes of the pulse share the packet and the anchor (the
        // first sample's position, LASlib's reading of X(t), Y(t), Z(t)).
        assert_eq!(locations[0].2, locations[1].2);
        let d = (0..3)
            .map(|a| (anchors[0][a] - anchors[1][a]).powi(2))
            .sum::<f64>()
            .sqrt();
        worst_anchor = worst_anchor.max(d);
        // Roof first, ground second: the locations differ by the two-way
        // time over the 5 m between the planes along the beam
        // (2 · 5 m / cos θ / c; θ ≤ 4°, so 1/cos θ < 1.0025).
        assert!((locations[0].1 - ROOF_M).abs() < 0.01 && locations[1].1.abs() < 0.01);
        let gap_ps = locations[1].0 - locations[0].0;
        let want = 2.0 * ROOF_M / C * 1e12;
        worst_gap = worst_gap.max((gap_ps / want - 1.0).abs());
        assert!(
            gap_ps > want - 70.0 && gap_ps < want * 1.0025 + 70.0,
            "{gap_ps} vs {want}"
        );
    }
    // The LAZ file beside it is point format 9 too (bit 7: compressed),
    // with the same header fields, and refers to the same points.wdp.
    let laz = Bytes(std::fs::read(dir.join("points.laz")).unwrap());
    assert_eq!((laz.0[104], laz.u16(105), laz.u16(6)), (0x89, 79, 0b1_0100));
    assert_eq!(laz.u64(247), summary.points);
    println!(
        "{} pulses: anchors of the two echoes agree within {:.2} mm; \
         location gap / (2·5 m / c) − 1 ≤ {worst_gap:.5}",
        n / 2,
        worst_anchor * 1000.0
    );
    assert!(worst_anchor < 0.01);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn laz_and_ply_headers_follow_their_specifications() {
    let (dir, summary) = run(
        &two_planes(
            r#"formats = ["las", "laz", "ply"]
offset_m = [400000.0, 5000000.0, 0.0]"#,
        ),
        "lazply",
    );
    let las = Bytes(std::fs::read(dir.join("points.las")).unwrap());
    let laz = Bytes(std::fs::read(dir.join("points.laz")).unwrap());
    // LAZ: point format 6 with bit 7 set, the uncompressed record length,
    // the LASzip VLR (user "laszip encoded", record 22204), and less than
    // half the size.
    assert_eq!(laz.0[104], 0x86);
    assert_eq!(laz.u16(105), 50);
    assert_eq!(laz.u64(247), summary.points);
    assert!(
        laz.vlrs()
            .iter()
            .any(|(u, id, _, _)| u == "laszip encoded" && *id == 22204)
    );
    assert!(
        laz.0.len() * 2 < las.0.len(),
        "{} vs {}",
        laz.0.len(),
        las.0.len()
    );
    // Bounds equal in both, and offset to projected coordinates.
    for o in (179..227).step_by(8) {
        assert_eq!(laz.f64(o), las.f64(o));
    }
    assert!((las.f64(187) - 400_000.0).abs() < 30.0); // min x
    assert!((las.f64(203) - 5_000_000.0).abs() < 30.0); // min y

    // PLY: header lines, vertex count, 64-byte records, x as a double in
    // projected coordinates.
    let ply = std::fs::read(dir.join("points.ply")).unwrap();
    let end = ply.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header = String::from_utf8(ply[..end].to_vec()).unwrap();
    let lines: Vec<&str> = header.lines().collect();
    assert_eq!(lines[..2], ["ply", "format binary_little_endian 1.0"]);
    assert!(lines.contains(&format!("element vertex {}", summary.points).as_str()));
    assert!(lines.contains(&"property double x") && lines.contains(&"property uint object_id"));
    assert_eq!((ply.len() - end) as u64, 64 * summary.points);
    let x0 = f64::from_le_bytes(ply[end..end + 8].try_into().unwrap());
    let lx0 = f64::from(las.i32(las.u32(96) as usize)) * las.f64(131) + las.f64(155);
    assert!((x0 - lx0).abs() <= 0.0005 + 1e-9);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn output_key_errors_name_the_key() {
    let err = |output: &str| {
        Survey::from_toml(&two_planes(output), Some(std::path::Path::new("s.toml")))
            .unwrap_err()
            .to_string()
    };
    let e = err(r#"crs = "EPSG:4326""#);
    assert!(
        e.contains("key `output.crs`") && e.contains("crs_wkt"),
        "{e}"
    );
    let e = err(r#"crs = "UTM32""#);
    assert!(
        e.contains("key `output.crs`") && e.contains("EPSG:code"),
        "{e}"
    );
    let e = err("crs = \"EPSG:25832\"\ncrs_wkt = 'PROJCS[\"x\"]'");
    assert!(
        e.contains("key `output.crs_wkt`") && e.contains("not both"),
        "{e}"
    );
    let e = err("crs_wkt = 'PROJCS[\"x\"'");
    assert!(e.contains("unbalanced"), "{e}");
    let e = err(r#"formats = ["las", "las-waveform"]"#);
    assert!(
        e.contains("key `output.formats[1]`") && e.contains("keep one"),
        "{e}"
    );
    let e = err(r#"formats = ["wdp"]"#);
    assert!(e.contains("unknown format 'wdp'"), "{e}");
    let e = err(r#"offset_m = [1.0, 2.0]"#);
    assert!(e.contains("key `output.offset_m`"), "{e}");
    let text = two_planes(r#"formats = ["las-waveform"]"#)
        .replace("[receiver]\n", "[receiver]\nbin_ps = 500.5\n");
    let e = Survey::from_toml(&text, None).unwrap_err().to_string();
    assert!(
        e.contains("key `receiver.bin_ps`") && e.contains("whole number"),
        "{e}"
    );
    // A WKT given verbatim is written as is.
    let wkt = lidarsim::output::crs::wkt_for_epsg(3067).unwrap();
    let s = Survey::from_toml(&two_planes(&format!("crs_wkt = '{wkt}'")), None).unwrap();
    assert_eq!(s.output.crs_wkt.as_deref(), Some(wkt.as_str()));
}

#[test]
fn the_waveform_example_survey_is_valid() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/waveform-utm.toml");
    let s = Survey::load(&path).unwrap();
    assert!(s.output.formats.las_waveform && s.output.formats.laz && s.output.formats.ply);
    assert_eq!(s.output.crs_epsg, Some(3067));
    assert_eq!(s.output.offset_m.to_array(), [385_000.0, 6_672_000.0, 10.0]);
}
