//! `[output]`: the formats, the time base, the coordinate resolution and
//! reference system, the offset to projected coordinates.

use super::{Bounds, Checker};
use crate::geometry::DVec3;
use crate::survey::raw::RawOutput;
use crate::survey::{Formats, KeyPath, Layout, OutputSettings, RawSurvey};

/// Checks `[output]` (the LAS scale against the survey's extent is checked
/// once the scene and the lines are known, by [`crate::world`]).
pub(crate) fn output(c: &mut Checker, raw: &RawSurvey) -> OutputSettings {
    let root = KeyPath::root();
    let o = &raw.output;
    let op = root.key("output");
    let formats = formats(c, &o.formats, &op);
    let crs = crs(c, o, &op);
    let offset_m = match &o.offset_m {
        None => DVec3::ZERO,
        Some(v) => c
            .point(op.key("offset_m"), &Some(v.clone()))
            .unwrap_or(DVec3::ZERO),
    };
    if formats.las_waveform {
        check_waveform_bin(c, raw, &root);
    }
    // Inertial systems record at 50 to 2000 Hz; finer rows add bytes,
    // not information.
    let trajectory_interval_s = c.number(
        op.key("trajectory_interval_s"),
        o.trajectory_interval_s,
        0.001,
        Bounds::between(1e-4, 3600.0, " s"),
    );
    let gps_start_time_s = o.gps_start_time_s.map(|g| {
        c.number(
            op.key("gps_start_time_s"),
            Some(g),
            0.0,
            Bounds::between(0.0, 1e10, " s"),
        )
    });
    let las_scale_m = c.number(
        op.key("las_scale_m"),
        o.las_scale_m,
        0.001,
        Bounds::above(0.0, " m").at_most(1.0),
    );
    let layout = layout(c, o, &op, &formats);
    OutputSettings {
        formats,
        layout,
        trajectory_interval_s,
        gps_start_time_s,
        las_scale_m,
        extra_bytes: o.extra_bytes.unwrap_or(true),
        crs_wkt: crs.wkt,
        crs_epsg: crs.epsg,
        offset_m,
    }
}

/// `formats`: LAS alone when not given.
fn formats(c: &mut Checker, list: &Option<Vec<String>>, op: &KeyPath) -> Formats {
    let mut formats = Formats {
        las: false,
        las_waveform: false,
        laz: false,
        ply: false,
        xyz: false,
    };
    let Some(list) = list else {
        formats.las = true;
        return formats;
    };
    for (i, f) in list.iter().enumerate() {
        match f.as_str() {
            "las" if formats.las_waveform => c.err(
                op.key("formats").index(i),
                "\"las\" and \"las-waveform\" both write points.las; keep one",
            ),
            "las" => formats.las = true,
            "las-waveform" if formats.las && !formats.las_waveform => c.err(
                op.key("formats").index(i),
                "\"las\" and \"las-waveform\" both write points.las; keep one",
            ),
            "las-waveform" => {
                formats.las = true;
                formats.las_waveform = true;
            }
            "laz" => formats.laz = true,
            "ply" => formats.ply = true,
            "xyz" => formats.xyz = true,
            other => c.err(
                op.key("formats").index(i),
                format!(
                    "unknown format '{other}'; expected \"las\", \"las-waveform\", \
                     \"laz\", \"ply\" or \"xyz\""
                ),
            ),
        }
    }
    formats
}

/// The coordinate reference system of the output, if one is given.
#[derive(Default)]
struct Crs {
    /// OGC WKT.
    wkt: Option<String>,
    /// The EPSG code it was given by, if it was.
    epsg: Option<u32>,
}

/// `crs = "EPSG:code"` (from the built-in table) or `crs_wkt`, not both.
fn crs(c: &mut Checker, o: &RawOutput, op: &KeyPath) -> Crs {
    match (&o.crs, &o.crs_wkt) {
        (Some(_), Some(_)) => {
            c.err(
                op.key("crs_wkt"),
                "give the CRS once: `crs = \"EPSG:code\"` or `crs_wkt`, not both",
            );
            Crs::default()
        }
        (Some(text), None) => match crate::output::crs::parse_epsg(text) {
            None => {
                c.err(
                    op.key("crs"),
                    format!("must be \"EPSG:code\", got '{text}'"),
                );
                Crs::default()
            }
            Some(code) => match crate::output::crs::wkt_for_epsg(code) {
                Some(wkt) => Crs {
                    wkt: Some(wkt),
                    epsg: Some(code),
                },
                None => {
                    c.err(
                        op.key("crs"),
                        format!(
                            "EPSG:{code} is not in the built-in table (UTM zones on WGS 84 \
                             32601–32660/32701–32760, ETRS89 25828–25838, NAD83 \
                             26901–26923, ETRS-TM35FIN 3067); give its WKT with `crs_wkt` \
                             instead (e.g. from epsg.io or `projinfo EPSG:{code} -o WKT1_GDAL`)"
                        ),
                    );
                    Crs::default()
                }
            },
        },
        (None, Some(wkt)) => match crate::output::crs::check_wkt(wkt) {
            Ok(()) => Crs {
                wkt: Some(wkt.trim().to_string()),
                epsg: None,
            },
            Err(m) => {
                c.err(op.key("crs_wkt"), m);
                Crs::default()
            }
        },
        (None, None) => Crs::default(),
    }
}

/// The LAS waveform descriptor stores the sample spacing in whole
/// picoseconds: `[receiver] bin_ps` must be one.
fn check_waveform_bin(c: &mut Checker, raw: &RawSurvey, root: &KeyPath) {
    let bin_ps = raw.receiver.bin_ps.unwrap_or(500.0);
    if bin_ps.fract() != 0.0 || bin_ps > f64::from(u32::MAX) {
        c.err(
            root.key("receiver").key("bin_ps"),
            format!(
                "must be a whole number of picoseconds for \"las-waveform\" output (the \
                 LAS waveform descriptor stores the sample spacing in whole ps), got {bin_ps}"
            ),
        );
    }
}

/// `layout` (and `tile_m`, for tiles only): how LAS and LAZ points are
/// split into files.
fn layout(c: &mut Checker, o: &RawOutput, op: &KeyPath, formats: &Formats) -> Layout {
    match o.layout.as_deref() {
        None | Some("single") => {
            if o.tile_m.is_some() {
                c.err(
                    op.key("tile_m"),
                    "applies to layout = \"tiles\" only".to_string(),
                );
            }
            Layout::Single
        }
        Some(kind @ ("strips" | "tiles")) => {
            if formats.las_waveform || !(formats.las || formats.laz) {
                c.err(
                    op.key("layout"),
                    format!(
                        "\"{kind}\" lays out LAS and LAZ points without waveforms: use \
                         formats \"las\" or \"laz\" (not \"las-waveform\")"
                    ),
                );
            }
            if kind == "strips" {
                if o.tile_m.is_some() {
                    c.err(
                        op.key("tile_m"),
                        "applies to layout = \"tiles\" only".to_string(),
                    );
                }
                Layout::Strips
            } else {
                if o.tile_m.is_none() {
                    c.err(
                        op.key("tile_m"),
                        "is required with layout = \"tiles\"".to_string(),
                    );
                }
                Layout::Tiles(c.number(
                    op.key("tile_m"),
                    o.tile_m,
                    1000.0,
                    Bounds::between(1.0, 1e6, " m"),
                ))
            }
        }
        Some(other) => {
            c.err(
                op.key("layout"),
                format!("unknown layout \"{other}\": expected \"single\", \"strips\" or \"tiles\""),
            );
            Layout::Single
        }
    }
}
