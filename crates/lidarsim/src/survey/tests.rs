//! Reading and checking surveys: defaults, and problems reported at their
//! file, line and key.

use super::*;
use crate::message::edit_distance;

const MINIMAL: &str = r#"
[[flight_line]]
start_m = [0.0, -100.0, 500.0]
end_m = [0.0, 100.0, 500.0]
speed_mps = 50.0

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

#[test]
fn defaults_fill_a_minimal_survey() {
    let s = Survey::from_toml(MINIMAL, None).unwrap();
    assert_eq!(s.scanner.prf_hz, 100_000.0);
    assert_eq!(s.scanner.subrays, 19);
    assert_eq!(s.receiver.bin_s, 500e-12);
    assert_eq!(s.line_spec.straight.len(), 1);
    assert_eq!(s.scene_spec.polygons.len(), 1);
    assert!(s.output.formats.las && !s.output.formats.xyz);
}

fn diagnostics(text: &str) -> Vec<Diagnostic> {
    Survey::from_toml(text, Some(Path::new("s.toml")))
        .unwrap_err()
        .diagnostics
}

#[test]
fn problems_name_line_and_key() {
    let bad = MINIMAL.replace("speed_mps = 50.0", "speed_mps = -5.0");
    let d = diagnostics(&bad);
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].key, "flight_line[0].speed_mps");
    assert_eq!(d[0].line, 5);
    assert!(d[0].message.contains("greater than 0"));
    let text = d[0].to_string();
    assert_eq!(
        text,
        "key `flight_line[0].speed_mps`: must be greater than 0 m/s, got -5\n \
         --> s.toml:5:13\n  |\n5 | speed_mps = -5.0\n  |             ^^^^"
    );

    let unknown = format!("[scanner]\nprff_hz = 3\n{MINIMAL}");
    let d = diagnostics(&unknown);
    assert_eq!(d[0].line, 2);
    assert!(d[0].message.contains("prff_hz"), "{}", d[0].message);
    assert_eq!(d[0].help.as_deref(), Some("did you mean `prf_hz`?"));
    assert_eq!((d[0].column, d[0].width), (1, 7));
    let far = diagnostics(&format!("[scanner]\nbananas = 3\n{MINIMAL}"));
    let help = far[0].help.as_deref().unwrap();
    assert!(
        help.starts_with("valid keys here: preset, prf_hz, "),
        "{help}"
    );
    assert_eq!(edit_distance("scan_angel_deg", "scan_angle_deg"), 2);
    assert!(d[0].key.contains("scanner"), "{}", d[0].key);

    let wrong_type = format!("[scanner]\nprf_hz = \"fast\"\n{MINIMAL}");
    let d = diagnostics(&wrong_type);
    assert_eq!((d[0].line, d[0].key.as_str()), (2, "scanner.prf_hz"));

    let several = format!(
        "[scanner]\nprf_hz = 0\nsubrays = 0\n{}",
        MINIMAL.replace("\"grass\"\nclass", "\"gras\"\nclass")
    );
    let d = diagnostics(&several);
    let keys: Vec<&str> = d.iter().map(|d| d.key.as_str()).collect();
    assert_eq!(
        keys,
        ["scanner.prf_hz", "scanner.subrays", "polygon[0].material"]
    );
    assert!(d[2].message.contains("defined: grass"));
}

#[test]
fn edge_rays_name_a_grid_of_the_beam() {
    use crate::sensor::beam::Fineness;
    let with = |rays: &str| format!("[scanner]\nedge_rays = {rays}\n{MINIMAL}");
    let fineness = |text: &str| Survey::from_toml(text, None).unwrap().scanner.edge_fineness;
    assert_eq!(fineness(MINIMAL), Fineness::Rays16);
    assert_eq!(fineness(&with("64")), Fineness::Rays64);
    assert_eq!(fineness(&with("256")), Fineness::Rays256);
    for wrong in ["4", "17", "0", "-16", "1024"] {
        let d = diagnostics(&with(wrong));
        assert_eq!((d[0].line, d[0].key.as_str()), (2, "scanner.edge_rays"));
        assert!(d[0].message.contains("must be 16"), "{}", d[0].message);
    }
}

#[test]
fn unknown_keys_wrong_types_and_ranges_anywhere_are_reported_together() {
    // Five problems in four tables: two unknown keys, two wrong types
    // (one inside an array of tables), one value out of range.
    let text = "[scanner]\nprf_hz = \"fast\"\nscan_angel_deg = 10\nsubrays = 0\n\n\
                [[flight_line]]\nstart_m = [0.0, -500.0, 1000.0]\n\
                end_m = [0.0, 500.0, \"high\"]\nspeed_mps = 60.0\n\n\
                [materials.grass]\nreflectance = 0.4\ncolour = \"green\"\n\n\
                [[polygon]]\nmaterial = \"grass\"\nclass = \"ground\"\n\
                vertices_m = [[-600, -700, 0], [600, -700, 0], [600, 700, 0]]\n";
    let d = diagnostics(text);
    let got: Vec<(usize, usize, &str)> = d
        .iter()
        .map(|d| (d.line, d.column, d.key.as_str()))
        .collect();
    assert_eq!(
        got,
        [
            (2, 10, "scanner.prf_hz"),
            (3, 1, "scanner.scan_angel_deg"),
            (4, 11, "scanner.subrays"),
            (8, 22, "flight_line[0].end_m[2]"),
            (13, 1, "materials.grass.colour"),
        ],
        "{d:#?}"
    );
    assert_eq!(
        d[0].message,
        "invalid type: string \"fast\", expected a number"
    );
    assert_eq!(d[0].width, 6); // "fast" with its quotes
    assert_eq!(d[1].help.as_deref(), Some("did you mean `scan_angle_deg`?"));
    assert!(d[2].message.contains("from 1 to 10000"), "{}", d[2].message);
    assert!(d[4].help.as_deref().unwrap().contains("reflectance"));
    // A syntax error stops reading, with its place.
    let d = diagnostics("[scanner]\nprf_hz = = 3\n");
    assert_eq!((d.len(), d[0].line), (1, 2), "{d:#?}");
    assert!(d[0].to_string().contains("2 | prf_hz = = 3"), "{}", d[0]);
}

#[test]
fn trees_and_forests_are_validated_together() {
    let bad = format!(
        "{MINIMAL}\n[[tree]]\nposition_m = [0, 0, 0]\nspecies = \"oak\"\ndbh_m = -1\n\
         height_m = 200\ncrown_base_m = 20\n\n[[forest]]\nrectangle_m = [0, 0, -5, 5]\n\
         stems_per_ha = 100\nspecies = {{ elm = 1.0 }}\nheight_m = [1.0, 5.0]\n"
    );
    let d = diagnostics(&bad);
    let keys: Vec<&str> = d.iter().map(|d| d.key.as_str()).collect();
    assert_eq!(
        keys,
        [
            "tree[0].species",
            "tree[0].dbh_m",
            "tree[0].height_m",
            "forest[0].rectangle_m",
            "forest[0].species.elm",
            "forest[0].height_m"
        ],
        "{d:#?}"
    );
}

#[test]
fn bad_polygons_are_reported() {
    let empty = MINIMAL.replace(
        "vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]",
        "vertices_m = []",
    );
    let d = diagnostics(&empty);
    assert_eq!(d[0].key, "polygon[0].vertices_m");
    assert!(d[0].message.contains("at least 3"));
    let warped = MINIMAL.replace("[300, 300, 0]", "[300, 300, 5]");
    let d = diagnostics(&warped);
    assert!(d[0].message.contains("not planar"), "{}", d[0].message);
    assert_eq!(d[0].line, 13);
}

/// Deflector keys: those of another kind are named as such, and a polygon
/// without a field of view is refused.
#[test]
fn deflector_keys_belong_to_their_kind() {
    let d = diagnostics(&format!("[scanner]\nfacets = 6\n{MINIMAL}"));
    assert_eq!(d[0].key, "scanner.facets");
    assert!(
        d[0].message.contains("deflector = \"polygon\""),
        "{}",
        d[0].message
    );
    let d = diagnostics(&format!(
        "[scanner]\ndeflector = \"polygon\"\nscan_angle_deg = 0\n{MINIMAL}"
    ));
    assert_eq!(d[0].key, "scanner.scan_angle_deg");
    let d = diagnostics(&format!("[scanner]\ndeflector = \"risley\"\n{MINIMAL}"));
    assert_eq!(d[0].key, "scanner.prism_deviation_deg");
    let d = diagnostics(&format!(
        "[scanner]\ndeflector = \"risley\"\nscan_angle_deg = 30\nprism_deviation_deg = [10, 10]\n\
         rotor_frequency_hz = [100, -60]\n{MINIMAL}"
    ));
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].key, "scanner.scan_angle_deg");
    assert!(
        d[0].message.contains("prisms set the field of view"),
        "{}",
        d[0].message
    );
}

/// Channels take the scanner's divergence and wavelength unless they give
/// their own; their shares and a material's spectrum are checked.
#[test]
fn channels_and_spectra_are_checked() {
    let two = format!(
        "[scanner]\ndivergence_mrad = 0.5\nwavelength_nm = 1064\n\
         [[scanner.channels]]\nwavelength_nm = 532\npulses_per_cycle = 3\n\
         [[scanner.channels]]\ndivergence_along_mrad = 2.0\n{MINIMAL}"
    );
    let s = Survey::from_toml(&two, None).unwrap();
    let [a, b] = s.scanner.channels.as_slice() else {
        panic!("{:?}", s.scanner.channels)
    };
    assert_eq!((a.divergence_rad, a.divergence_along_rad), (0.5e-3, 0.5e-3));
    assert_eq!((a.wavelength_nm, a.pulses_per_cycle), (532.0, 3));
    assert_eq!((b.divergence_rad, b.divergence_along_rad), (0.5e-3, 2e-3));
    assert_eq!((b.wavelength_nm, b.pulses_per_cycle), (1064.0, 1));

    let d = diagnostics(&format!(
        "[scanner]\n[[scanner.channels]]\npulses_per_cycle = 0\n\
         [[scanner.channels]]\nwavelength_nm = -1\n{MINIMAL}"
    ));
    let keys: Vec<_> = d.iter().map(|d| d.key.as_str()).collect();
    assert_eq!(
        keys,
        [
            "scanner.channels[0].pulses_per_cycle",
            "scanner.channels[1].wavelength_nm"
        ]
    );
    let d = diagnostics(&format!(
        "[scanner]\n[[scanner.channels]]\npulses_per_cycle = 200\n\
         [[scanner.channels]]\npulses_per_cycle = 100\n{MINIMAL}"
    ));
    assert_eq!(d[0].key, "scanner.channels");
    assert!(d[0].message.contains("add up to 300"), "{}", d[0].message);

    let spectral = MINIMAL.replace(
        "reflectance = 0.4",
        "reflectance_spectrum = [[532, 0.1], [1064, 0.5]]",
    );
    let s = Survey::from_toml(&spectral, None).unwrap();
    let grass = &s.materials["grass"];
    assert_eq!(grass.spectrum, [(532.0, 0.1), (1064.0, 0.5)]);
    for (bad, key, says) in [
        (
            "reflectance = 0.4\nreflectance_spectrum = [[532, 0.1], [1064, 0.5]]",
            "materials.grass.reflectance_spectrum",
            "not both",
        ),
        (
            "reflectance_spectrum = [[1064, 0.5], [532, 0.1]]",
            "materials.grass.reflectance_spectrum[1]",
            "must increase",
        ),
        (
            "reflectance_spectrum = [[532, 0.1, 3], [1064, 1.5]]",
            "materials.grass.reflectance_spectrum[0]",
            "pair",
        ),
        (
            "reflectance_spectrum = [[532, 0.1]]",
            "materials.grass.reflectance_spectrum",
            "at least two",
        ),
    ] {
        let d = diagnostics(&MINIMAL.replace("reflectance = 0.4", bad));
        assert_eq!(d[0].key, key, "{bad}");
        assert!(d[0].message.contains(says), "{bad}: {}", d[0].message);
    }
}
