//! A LAS or LAZ file, or a simulation's points, into a [`ScanCloud`].

use std::path::Path;

use super::{Progress, ScanCloud, ScanError, ScanFacts};
use crate::io::cloud::{describe_las_error, open_las};
use crate::output::PointRecord;

/// Points read per batch (and between two progress reports).
const BATCH: usize = 1 << 18;

/// Reads every point of a LAS or LAZ file, reporting the share read to
/// `progress` as `"reading"`. Points whose coordinates are not finite are
/// an error naming the point.
pub fn read_scan(path: &Path, progress: Progress<'_>) -> Result<ScanCloud, ScanError> {
    let fail = |reason: String| ScanError::Read {
        path: path.to_path_buf(),
        reason,
    };
    let mut reader = open_las(path).map_err(fail)?;
    let header = reader.header().clone();
    let total = header.number_of_points();
    let format = header.point_format();
    let mut cloud = ScanCloud {
        name: path.display().to_string(),
        facts: ScanFacts {
            version: format!("{}.{}", header.version().major, header.version().minor),
            point_format: format.to_u8().unwrap_or(0),
            has_gps_time: format.has_gps_time,
            scan_angle_step_deg: if format.is_extended { 0.006 } else { 1.0 },
            epsg: None,
            wkt: None,
        },
        ..ScanCloud::default()
    };
    (cloud.facts.epsg, cloud.facts.wkt) = crs_of(&header);
    progress("reading", 0.0);
    loop {
        let batch = reader
            .read_points(BATCH as u64)
            .map_err(|e| fail(describe_las_error(&e)))?;
        if batch.is_empty() {
            break;
        }
        for p in batch.points() {
            let p = p.map_err(|e| fail(describe_las_error(&e)))?;
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                return Err(fail(format!(
                    "point {} has a coordinate that is not a finite number (check the \
                     header's scale and offset)",
                    cloud.len() + 1
                )));
            }
            cloud.x.push(p.x);
            cloud.y.push(p.y);
            cloud.z.push(p.z);
            cloud.intensity.push(p.intensity);
            cloud.return_number.push(p.return_number);
            cloud.number_of_returns.push(p.number_of_returns);
            cloud.classification.push(u8::from(p.classification));
            cloud.gps_time.push(p.gps_time.unwrap_or(0.0));
            cloud.scan_angle_deg.push(p.scan_angle);
            cloud.point_source_id.push(p.point_source_id);
        }
        progress("reading", cloud.len() as f64 / total.max(1) as f64);
    }
    if cloud.is_empty() {
        return Err(ScanError::Empty {
            path: path.to_path_buf(),
            why: String::new(),
        });
    }
    Ok(cloud)
}

/// A simulation's points as a scan (LAS 1.4 point format 6, as the run
/// writes them), named `name`.
pub fn scan_from_records(name: &str, points: &[PointRecord]) -> ScanCloud {
    ScanCloud {
        name: name.to_string(),
        x: points.iter().map(|p| p.position_m.x).collect(),
        y: points.iter().map(|p| p.position_m.y).collect(),
        z: points.iter().map(|p| p.position_m.z).collect(),
        intensity: points.iter().map(|p| p.intensity).collect(),
        return_number: points.iter().map(|p| p.return_number).collect(),
        number_of_returns: points.iter().map(|p| p.number_of_returns).collect(),
        classification: points.iter().map(|p| p.classification).collect(),
        gps_time: points.iter().map(|p| p.gps_time_s).collect(),
        scan_angle_deg: points.iter().map(|p| p.scan_angle_deg as f32).collect(),
        point_source_id: points.iter().map(|p| p.point_source_id).collect(),
        facts: ScanFacts {
            version: "1.4".into(),
            point_format: 6,
            has_gps_time: true,
            scan_angle_step_deg: 0.006,
            epsg: None,
            wkt: None,
        },
    }
}

/// The file's CRS: an EPSG code (from the GeoTIFF keys' projected CRS, or
/// the WKT's last `AUTHORITY["EPSG","…"]` or `ID["EPSG",…]`) and the WKT
/// text.
fn crs_of(header: &las::Header) -> (Option<u32>, Option<String>) {
    let wkt = header
        .get_wkt_crs_bytes()
        .map(|b| {
            String::from_utf8_lossy(b)
                .trim_end_matches('\0')
                .to_string()
        })
        .filter(|w| !w.trim().is_empty());
    let from_keys = header
        .get_geotiff_crs()
        .ok()
        .flatten()
        .and_then(|c| c.get_projected_crs_geo_key_value())
        .filter(|&k| (1024..=32766).contains(&k))
        .map(u32::from);
    let from_wkt = wkt.as_deref().and_then(epsg_in_wkt);
    (from_keys.or(from_wkt), wkt)
}

/// The EPSG code a WKT text ends with (its outermost system's).
fn epsg_in_wkt(wkt: &str) -> Option<u32> {
    let at = wkt
        .rfind("AUTHORITY[\"EPSG\",")
        .map(|i| i + 17)
        .or_else(|| wkt.rfind("ID[\"EPSG\",").map(|i| i + 10))?;
    let digits: String = wkt[at..]
        .chars()
        .skip_while(|c| *c == '"' || c.is_whitespace())
        .take_while(char::is_ascii_digit)
        .collect();
    digits.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_epsg_code_of_a_wkt_is_its_outermost_one() {
        let wkt = r#"PROJCS["NAD83 / UTM zone 12N",GEOGCS["NAD83",AUTHORITY["EPSG","4269"]],UNIT["metre",1],AUTHORITY["EPSG","26912"]]"#;
        assert_eq!(epsg_in_wkt(wkt), Some(26912));
        assert_eq!(epsg_in_wkt(r#"PROJCRS["x",ID["EPSG",3067]]"#), Some(3067));
        assert_eq!(epsg_in_wkt("LOCAL_CS[\"x\"]"), None);
    }

    /// A file whose header is cut off is an error naming it, not a panic.
    #[test]
    fn a_broken_file_is_an_error_naming_it() {
        let d = std::env::temp_dir().join(format!("lidarsim-scan-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("cut.las");
        std::fs::write(&p, b"LASF\x00\x00").unwrap();
        let e = read_scan(&p, &super::super::no_progress).unwrap_err();
        assert!(e.to_string().contains("cut.las"), "{e}");
    }
}
