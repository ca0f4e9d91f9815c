//! A twin as files: `survey.toml` (in a local frame near the origin,
//! `[output] offset_m` putting the points back in the scan's coordinates),
//! `trees.csv` (its `[[tree_table]]`, in the scan's coordinates),
//! `dtm.tif` (its `[[terrain]]`, in the scan's coordinates; a flat ground
//! is a `[[polygon]]` instead) and `twin.json` (what was inferred and how
//! sure it is).
//!
//! The directory must be new, empty or one a twin wrote (it holds [`OWN`]'s
//! marker); any other is refused unless `overwrite`, which replaces only
//! the twin's own files ([`crate::owned`]). Every file is written as
//! `NAME.partial` and renamed when whole; the marker comes last.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::acquisition::combine::{Deflector, Flight};
use super::{Twin, TwinError};
use crate::output::{AtFile, AtomicFile, WriteCause, WriteError, write_atomic};
use crate::owned::OwnFiles;
use crate::survey::raw::{
    RawFlightLine, RawMaterial, RawOutput, RawPlan, RawPolygon, RawScanner, RawSurvey, RawTerrain,
    RawTreeTable,
};

/// The files a twin writes.
pub const TWIN_FILES: [&str; 4] = ["survey.toml", "trees.csv", "dtm.tif", "twin.json"];

/// The files a twin writes and the marker of its directory.
pub const OWN: OwnFiles = OwnFiles {
    command: "twin",
    files: &TWIN_FILES,
    marker: ".lidarsim-twin",
};

/// Reflectance of the ground at 1064 nm (forest floor, litter and soil:
/// the value of the validation's ground, `docs/validation.md`).
pub const GROUND_REFLECTANCE: f64 = 0.25;

/// `twin.json`.
#[derive(Serialize)]
struct TwinJson<'a> {
    lidarsim_version: &'static str,
    scan: &'a super::ScanSummary,
    frame: Frame,
    terrain: TerrainJson,
    trees: &'a super::TreeReport,
    acquisition: &'a super::Acquisition,
    instrument: Option<&'a str>,
    files: Vec<&'static str>,
    not_modelled: Vec<&'static str>,
}

/// The local frame of `survey.toml`.
#[derive(Serialize)]
struct Frame {
    origin_m: [f64; 3],
    note: &'static str,
}

/// The terrain, for `twin.json`.
#[derive(Serialize)]
struct TerrainJson {
    kind: &'static str,
    description: String,
    relief_m: f64,
    cell_m: Option<f64>,
    reflectance: f64,
}

/// What a twin leaves out, in words.
pub const NOT_MODELLED: [&str; 5] = [
    "buildings and other objects that are not vegetation: whatever stands above the ground is \
     taken for a tree (a scan of a town gives trees where its houses are)",
    "understorey and shrubs under the crowns, and tree species (every tree is of the species \
     given, pine by default)",
    "the aircraft's attitude (roll, pitch, crab) and curved tracks: straight, level lines",
    "the footprint, the receiver's noise and the intensity scale: the instrument preset's or \
     the simulator's defaults",
    "reflectances: the ground 0.25, the foliage and bark the species'",
];

/// The origin of the local frame of `twin`: its south-west corner rounded
/// down to whole kilometres.
pub fn origin_of(twin: &Twin) -> [f64; 3] {
    let b = twin.scan.bounds_m;
    [
        (b[0] / 1000.0).floor() * 1000.0,
        (b[1] / 1000.0).floor() * 1000.0,
        0.0,
    ]
}

/// Writes `twin`'s files into `dir`; returns the survey's path.
pub fn write_twin(twin: &Twin, dir: &Path, overwrite: bool) -> Result<PathBuf, TwinError> {
    OWN.claim(dir, overwrite)?;
    let origin = origin_of(twin);
    let flat = twin.ground.flat;
    let survey = survey_text(twin, origin)?;
    let survey_path = dir.join("survey.toml");
    crate::Survey::from_toml(&survey, Some(&survey_path))?;
    if !flat {
        let path = dir.join("dtm.tif");
        let partial = AtomicFile::partial_of(&path);
        crate::io::export::write_geotiff(&partial, &twin.ground.dtm.to_height_grid())
            .and_then(|()| std::fs::rename(&partial, &path))
            .at(&path)?;
    }
    write_atomic(&dir.join("trees.csv"), trees_csv(twin).as_bytes())?;
    write_atomic(&survey_path, survey.as_bytes())?;
    write_atomic(&dir.join("twin.json"), report_json(twin, origin).as_bytes())?;
    OWN.mark(dir)?;
    Ok(survey_path)
}

/// `survey.toml`.
fn survey_text(twin: &Twin, origin: [f64; 3]) -> Result<String, TwinError> {
    let raw = raw_survey(twin, origin);
    let body = toml::to_string(&raw).map_err(|e| {
        WriteError::new(
            Path::new("survey.toml"),
            WriteCause::Unsupported(e.to_string()),
        )
    })?;
    Ok(format!(
        "# The twin of {}, written by lidarsim twin {}.\n# What was read from the scan, and \
         how sure it is: twin.json beside this file.\n# The survey is in a local frame: the \
         scan's coordinates less [{}, {}, {}] m\n# ([output] offset_m adds them back to the \
         points; trees.csv and dtm.tif are in the scan's coordinates).\n\n{body}",
        twin.scan.file,
        env!("CARGO_PKG_VERSION"),
        origin[0],
        origin[1],
        origin[2],
    ))
}

/// The survey as its raw form.
fn raw_survey(twin: &Twin, origin: [f64; 3]) -> RawSurvey {
    let acq = &twin.acquisition;
    let local = |p: [f64; 3]| {
        (0..3)
            .map(|i| round(p[i] - origin[i], 3))
            .collect::<Vec<f64>>()
    };
    let shift = Some(vec![-origin[0], -origin[1], -origin[2]]);
    let mut raw = RawSurvey {
        seed: Some(1),
        scanner: scanner(twin),
        output: output(twin, origin),
        ..RawSurvey::default()
    };
    match &acq.flight {
        Flight::Lines(lines) => {
            raw.flight_lines = lines
                .iter()
                .map(|l| RawFlightLine {
                    start_m: Some(local(l.start_m)),
                    end_m: Some(local(l.end_m)),
                    altitude_m: None,
                    speed_mps: Some(round(l.speed_mps, 3)),
                })
                .collect();
        }
        Flight::Plan(p) => {
            let b = twin.scan.bounds_m;
            raw.plan = Some(RawPlan {
                rectangle_m: Some(vec![
                    b[0] - origin[0],
                    b[1] - origin[1],
                    b[2] - origin[0],
                    b[3] - origin[1],
                ]),
                altitude_m: Some(round(p.altitude_m, 2)),
                heading_deg: Some(p.heading_deg),
                line_spacing_m: Some(round(p.line_spacing_m, 2)),
                speed_mps: Some(round(p.speed_mps, 3)),
                ..RawPlan::default()
            });
        }
    }
    raw.materials.insert(
        "ground".into(),
        RawMaterial {
            reflectance: Some(GROUND_REFLECTANCE),
            ..RawMaterial::default()
        },
    );
    if twin.ground.flat {
        let b = crate::scan::ground::expand(twin.scan.bounds_m, 50.0);
        let z = twin.ground.flat_z_m - origin[2];
        raw.polygons.push(RawPolygon {
            material: Some("ground".into()),
            class: Some("ground".into()),
            vertices_m: Some(
                [[b[0], b[1]], [b[2], b[1]], [b[2], b[3]], [b[0], b[3]]]
                    .iter()
                    .map(|c| local([c[0], c[1], z + origin[2]]))
                    .collect(),
            ),
        });
    } else {
        raw.terrains.push(RawTerrain {
            file: Some("dtm.tif".into()),
            material: Some("ground".into()),
            offset_m: shift.clone(),
            ..RawTerrain::default()
        });
    }
    if !twin.trees.is_empty() {
        raw.tree_tables.push(RawTreeTable {
            file: Some("trees.csv".into()),
            offset_m: shift,
            species: Some(twin.options.trees.species.name().into()),
        });
    }
    raw
}

/// `[scanner]`: the instrument preset if one was named, and what was read.
fn scanner(twin: &Twin) -> RawScanner {
    let s = &twin.acquisition.scanner;
    let mut raw = RawScanner {
        preset: twin.options.instrument.clone(),
        prf_hz: Some(s.prf_hz.value.round().max(1.0)),
        scan_frequency_hz: Some(round(s.scan_frequency_hz.value, 3)),
        scan_angle_deg: Some(round(s.scan_angle_deg.value, 2)),
        ..RawScanner::default()
    };
    if twin.options.instrument.is_none() {
        raw.max_returns = Some(i64::from(s.max_returns));
        match s.deflector {
            Deflector::Oscillating => {
                raw.deflector = Some("oscillating".into());
                raw.mirror = Some("triangle".into());
            }
            Deflector::Polygon { facets } => {
                raw.deflector = Some("polygon".into());
                raw.facets = Some(i64::from(facets));
            }
        }
    }
    raw
}

/// `[output]`: LAS in the scan's coordinates and CRS: its EPSG code when
/// the LAS writer knows it, else its WKT when the file has one.
fn output(twin: &Twin, origin: [f64; 3]) -> RawOutput {
    use crate::output::crs::{check_wkt, wkt_for_epsg};
    let crs = twin
        .scan
        .crs
        .as_deref()
        .and_then(crate::output::crs::parse_epsg)
        .filter(|&e| wkt_for_epsg(e).is_some())
        .map(|e| format!("EPSG:{e}"));
    let crs_wkt = match (&crs, &twin.scan_wkt) {
        (None, Some(w)) if check_wkt(w).is_ok() => Some(w.clone()),
        _ => None,
    };
    RawOutput {
        formats: Some(vec!["las".into()]),
        offset_m: Some(origin.to_vec()),
        crs,
        crs_wkt,
        ..RawOutput::default()
    }
}

/// `trees.csv`: a comment saying how the trees were found, the header and
/// a row per tree, in the scan's coordinates.
fn trees_csv(twin: &Twin) -> String {
    let r = &twin.tree_report;
    let mut out = format!(
        "# The trees of the twin of {}: tops where no return within half a window of\n# \
         {} + {}·h + {}·h² m is higher (lidR's lmf), crowns from the canopy height model\n# \
         (silva2016), radius of the disc holding {} % of a crown's cells, crown base the\n# 5th \
         percentile of its returns' heights. Edit freely: see docs/survey.md, [[tree_table]].\n\
         id,x_m,y_m,z_m,height_m,crown_base_m,crown_radius_m,dbh_m\n",
        twin.scan.file,
        r.window.a_m,
        r.window.b,
        r.window.c_per_m,
        super::trees::COVER_SHARE * 100.0,
    );
    for (i, t) in twin.trees.iter().enumerate() {
        let _ = writeln!(
            out,
            "{},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.3}",
            i + 1,
            t.x_m,
            t.y_m,
            t.z_m,
            t.height_m.max(crate::scene::tree::MIN_TREE_HEIGHT_M),
            t.crown_base_m,
            t.crown_radius_m,
            t.dbh_m
        );
    }
    out
}

/// `twin.json`.
fn report_json(twin: &Twin, origin: [f64; 3]) -> String {
    let g = &twin.ground;
    let json = TwinJson {
        lidarsim_version: env!("CARGO_PKG_VERSION"),
        scan: &twin.scan,
        frame: Frame {
            origin_m: origin,
            note: "survey.toml is in the scan's coordinates less origin_m; its points are \
                   written back in the scan's ([output] offset_m)",
        },
        terrain: TerrainJson {
            kind: if g.flat { "flat" } else { "dtm" },
            description: g.describe(),
            relief_m: g.relief_m,
            cell_m: (!g.flat).then_some(g.dtm.cell_m),
            reflectance: GROUND_REFLECTANCE,
        },
        trees: &twin.tree_report,
        acquisition: &twin.acquisition,
        instrument: twin.options.instrument.as_deref(),
        files: TWIN_FILES
            .iter()
            .copied()
            .filter(|f| *f != "dtm.tif" || !g.flat)
            .collect(),
        not_modelled: NOT_MODELLED.to_vec(),
    };
    serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"
}

/// `v` rounded to `digits` decimals.
fn round(v: f64, digits: i32) -> f64 {
    let f = 10f64.powi(digits);
    (v * f).round() / f
}
