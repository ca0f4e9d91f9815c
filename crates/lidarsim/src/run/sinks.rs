//! The point files of a run, opened: one writer per file of `[output]
//! formats` and `layout`, created afresh, continued where an interrupted
//! run left them, or — a merge's `points.las` — a writer holding its
//! parts' points already.

use std::path::Path;

use super::names::SUMMARY;
use super::resume::Interrupted;
use crate::error::{Error, PathError};
use crate::files::{digitizer, layout_dir};
use crate::flight::Flight;
use crate::output::layout::{StripWriter, TileWriter};
use crate::output::{FileSink, LasSettings, LasWriter, PlyWriter, XyzWriter};
use crate::survey::Layout;

/// How the point files are opened.
pub(super) enum Opening<'a> {
    /// Created afresh.
    Fresh,
    /// Continued after the bytes the interrupted run recorded.
    Continued(&'a Interrupted),
    /// Created afresh but `points.las`, whose writer holds a merge's
    /// points.
    Joined(Box<LasWriter>),
}

/// Opens the point files of `flight` in `out_dir`, in the order the
/// summary lists them (strips or tiles first).
pub(super) fn open(
    flight: &Flight,
    out_dir: &Path,
    opening: Opening<'_>,
) -> Result<Vec<Box<FileSink>>, Error> {
    let mut sinks = layout_sinks(flight, out_dir)?;
    if flight.survey().output.layout == Layout::Single {
        sinks.extend(single_files(flight, out_dir, opening)?);
    }
    Ok(sinks)
}

/// The writers of the strips or tiles directory, if the survey has one.
fn layout_sinks(flight: &Flight, out_dir: &Path) -> Result<Vec<Box<FileSink>>, Error> {
    let survey = flight.survey();
    let Some(dir) = layout_dir(survey) else {
        return Ok(Vec::new());
    };
    let dir = out_dir.join(dir);
    let formats = &survey.output.formats;
    let settings: Vec<LasSettings> = [(formats.las, false), (formats.laz, true)]
        .into_iter()
        .filter(|(on, _)| *on)
        .map(|(_, compressed)| LasSettings {
            compressed,
            ..flight.las_settings()
        })
        .collect();
    let origin = survey.output.offset_m.to_array();
    let mut sinks: Vec<Box<FileSink>> = Vec::new();
    if let Layout::Tiles(tile_m) = survey.output.layout {
        sinks.push(Box::new(TileWriter::create(
            &dir, settings, tile_m, origin,
        )?));
    } else {
        for s in settings {
            sinks.push(Box::new(StripWriter::create(&dir, s)?));
        }
    }
    Ok(sinks)
}

/// The writers of the single point files: `points.las`, `points.laz`,
/// `points.ply`, `points.xyz`.
fn single_files(
    flight: &Flight,
    out_dir: &Path,
    opening: Opening<'_>,
) -> Result<Vec<Box<FileSink>>, Error> {
    let survey = flight.survey();
    let formats = &survey.output.formats;
    let origin = survey.output.offset_m.to_array();
    let (continued, joined) = match opening {
        Opening::Fresh => (None, None),
        Opening::Continued(prev) => (Some(prev), None),
        Opening::Joined(writer) => (None, Some(writer)),
    };
    // The length the interrupted run recorded of file `name`.
    let len = |name: &str| -> Result<u64, Error> {
        continued.and_then(|p| p.file_len(name)).ok_or_else(|| {
            Error::Resume(PathError::new(
                &out_dir.join(SUMMARY),
                format!("the interrupted run recorded no length of {name}"),
            ))
        })
    };
    let mut sinks: Vec<Box<FileSink>> = Vec::new();
    if formats.las {
        let path = out_dir.join("points.las");
        let mut settings = flight.las_settings();
        if formats.las_waveform {
            settings.waveform = Some(digitizer(survey, flight.world()));
        }
        sinks.push(match (continued, joined) {
            (_, Some(joined)) => joined,
            (None, None) => Box::new(LasWriter::create(&path, settings)?),
            (Some(_), None) => {
                let wdp = formats
                    .las_waveform
                    .then(|| len("points.wdp"))
                    .transpose()?;
                Box::new(LasWriter::resume(&path, settings, len("points.las")?, wdp)?)
            }
        });
    }
    if formats.laz {
        // With "las-waveform" too, the LAZ points are format 9 and refer to
        // the points.wdp the LAS writer writes (same base name, same
        // packets).
        let settings = LasSettings {
            compressed: true,
            waveform: formats
                .las_waveform
                .then(|| digitizer(survey, flight.world())),
            waveform_file_shared: true,
            ..flight.las_settings()
        };
        sinks.push(Box::new(LasWriter::create(
            &out_dir.join("points.laz"),
            settings,
        )?));
    }
    if formats.ply {
        let path = out_dir.join("points.ply");
        sinks.push(match continued {
            None => Box::new(PlyWriter::create(&path, origin)?),
            Some(_) => Box::new(PlyWriter::resume(&path, len("points.ply")?, origin)?),
        });
    }
    if formats.xyz {
        let path = out_dir.join("points.xyz");
        sinks.push(match continued {
            None => Box::new(XyzWriter::create(&path, origin)?),
            Some(_) => Box::new(XyzWriter::resume(&path, len("points.xyz")?, origin)?),
        });
    }
    Ok(sinks)
}
