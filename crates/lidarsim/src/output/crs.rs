//! Coordinate reference systems for the LAS WKT VLR, without GDAL or PROJ.
//!
//! LAS 1.4 (R15, section 2.5) stores the CRS as OGC WKT in a VLR (user ID
//! `LASF_Projection`, record 2112). We generate the WKT of the projected
//! systems surveys use most — every UTM zone on WGS 84 (EPSG 32601–32660
//! north, 32701–32760 south), on ETRS89 (25828–25838) and on NAD83
//! (26901–26923), and ETRS-TM35FIN (3067) — from the zone number with the
//! EPSG parameters: Transverse Mercator, latitude of origin 0, central
//! meridian `6·zone − 183`°, scale 0.9996, false easting 500 000 m, false
//! northing 0 (north) or 10 000 000 m (south). Any other system can be
//! given verbatim as WKT (`[output] crs_wkt`).

/// The WKT of `EPSG:code`, or `None` when the code is not in the table.
pub fn wkt_for_epsg(code: u32) -> Option<String> {
    let (geog, name, zone, south) = match code {
        32601..=32660 => (WGS84, "WGS 84", code - 32600, false),
        32701..=32760 => (WGS84, "WGS 84", code - 32700, true),
        25828..=25838 => (ETRS89, "ETRS89", code - 25800, false),
        26901..=26923 => (NAD83, "NAD83", code - 26900, false),
        3067 => return Some(tm_wkt("ETRS89 / TM35FIN(E,N)", ETRS89, 27, false, 3067)),
        _ => return None,
    };
    let title = format!("{name} / UTM zone {zone}{}", if south { 'S' } else { 'N' });
    Some(tm_wkt(&title, geog, 6 * zone as i32 - 183, south, code))
}

/// Parses `EPSG:code` (case-insensitive) into the code.
pub fn parse_epsg(text: &str) -> Option<u32> {
    let (prefix, code) = text.trim().split_at_checked(5)?;
    if !prefix.eq_ignore_ascii_case("EPSG:") {
        return None;
    }
    code.trim().parse().ok()
}

/// A basic sanity check of user-supplied WKT: a keyword, brackets that
/// balance, no NUL byte. Returns what is wrong.
pub fn check_wkt(wkt: &str) -> Result<(), String> {
    let t = wkt.trim();
    if t.len() > MAX_WKT_BYTES {
        return Err(format!(
            "is {} bytes long; a LAS file's WKT record holds at most {MAX_WKT_BYTES} bytes",
            t.len()
        ));
    }
    let keyword: String = t
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect();
    const KNOWN: [&str; 8] = [
        "PROJCS",
        "PROJCRS",
        "COMPD_CS",
        "COMPOUNDCRS",
        "GEOGCS",
        "GEOGCRS",
        "GEOCCS",
        "VERT_CS",
    ];
    if !KNOWN.contains(&keyword.to_ascii_uppercase().as_str()) {
        return Err(format!(
            "must be OGC WKT starting with one of {}, got '{}'",
            KNOWN.join(", "),
            t.chars().take(20).collect::<String>()
        ));
    }
    if t.contains('\0') {
        return Err("must not contain a NUL character".to_string());
    }
    let mut depth = 0i64;
    let mut in_string = false;
    for c in t.chars() {
        match c {
            '"' => in_string = !in_string,
            '[' | '(' if !in_string => depth += 1,
            ']' | ')' if !in_string => {
                depth -= 1;
                if depth < 0 {
                    return Err("has a closing bracket without an opening one".to_string());
                }
            }
            _ => {}
        }
    }
    if depth != 0 || in_string {
        return Err("has unbalanced brackets or quotes".to_string());
    }
    Ok(())
}

const WGS84: &str = r#"GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],PRIMEM["Greenwich",0,AUTHORITY["EPSG","8901"]],UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],AUTHORITY["EPSG","4326"]]"#;
const ETRS89: &str = r#"GEOGCS["ETRS89",DATUM["European_Terrestrial_Reference_System_1989",SPHEROID["GRS 1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],AUTHORITY["EPSG","6258"]],PRIMEM["Greenwich",0,AUTHORITY["EPSG","8901"]],UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],AUTHORITY["EPSG","4258"]]"#;
const NAD83: &str = r#"GEOGCS["NAD83",DATUM["North_American_Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],AUTHORITY["EPSG","6269"]],PRIMEM["Greenwich",0,AUTHORITY["EPSG","8901"]],UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],AUTHORITY["EPSG","4269"]]"#;

/// Longest WKT a LAS 1.4 VLR can hold: its length field is 16 bits and
/// the text ends with a NUL (LAS 1.4 R15, Table 13).
pub const MAX_WKT_BYTES: usize = 65_534;

/// WKT 1 of a Transverse Mercator system with UTM parameters.
fn tm_wkt(title: &str, geog: &str, central_meridian: i32, south: bool, code: u32) -> String {
    format!(
        r#"PROJCS["{title}",{geog},PROJECTION["Transverse_Mercator"],PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",{central_meridian}],PARAMETER["scale_factor",0.9996],PARAMETER["false_easting",500000],PARAMETER["false_northing",{}],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AXIS["Easting",EAST],AXIS["Northing",NORTH],AUTHORITY["EPSG","{code}"]]"#,
        if south { 10_000_000 } else { 0 }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utm_zones_have_the_epsg_central_meridians() {
        // EPSG:32632 = WGS 84 / UTM zone 32N, central meridian 9° E;
        // EPSG:32718 = zone 18S, 75° W, false northing 10 000 km;
        // EPSG:25832 = ETRS89 / UTM zone 32N.
        let w = wkt_for_epsg(32632).unwrap();
        assert!(w.starts_with(r#"PROJCS["WGS 84 / UTM zone 32N""#));
        assert!(w.contains(r#"PARAMETER["central_meridian",9]"#));
        assert!(w.ends_with(r#"AUTHORITY["EPSG","32632"]]"#));
        let s = wkt_for_epsg(32718).unwrap();
        assert!(s.contains(r#"PARAMETER["central_meridian",-75]"#));
        assert!(s.contains(r#"PARAMETER["false_northing",10000000]"#));
        let e = wkt_for_epsg(25832).unwrap();
        assert!(e.contains(r#""ETRS89 / UTM zone 32N""#) && e.contains("GRS 1980"));
        assert!(
            wkt_for_epsg(3067)
                .unwrap()
                .contains(r#"central_meridian",27]"#)
        );
        assert!(wkt_for_epsg(4326).is_none());
        for code in [32601, 32660, 32701, 32760, 25828, 25838, 26901, 26923] {
            check_wkt(&wkt_for_epsg(code).unwrap()).unwrap();
        }
    }

    #[test]
    fn epsg_strings_and_wkt_checks() {
        assert_eq!(parse_epsg("EPSG:25832"), Some(25832));
        assert_eq!(parse_epsg("epsg: 3067"), Some(3067));
        assert_eq!(parse_epsg("25832"), None);
        assert_eq!(parse_epsg("EPSG:x"), None);
        assert!(check_wkt(r#"PROJCS["a",GEOGCS["b"]]"#).is_ok());
        assert!(check_wkt(r#"PROJCS["a",GEOGCS["b"]"#).is_err());
        assert!(check_wkt("hello").is_err());
    }
}
