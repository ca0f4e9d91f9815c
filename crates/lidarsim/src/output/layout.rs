//! LAS and LAZ points laid out as deliveries are: a file per flight line
//! (strips, [`StripWriter`]) or per square tile ([`TileWriter`], with a
//! GeoJSON index of the tiles' extents and counts). Each file is a whole
//! LAS or LAZ file of the run's settings, its points in pulse order.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use super::part::{RECORD_BYTES, decode, encode};
use super::{AtFile, PointRecord, PointSink, WriteError, write_atomic};
use super::{LasSettings, LasWriter};

/// The file name of flight line `line` (from 1) in a strips directory.
pub fn strip_name(line: u16, ext: &str) -> String {
    format!("line-{line:04}.{ext}")
}

/// Writes a file per flight line into a directory: `line-NNNN.las` (or
/// `.laz`), one open at a time (the points come line after line).
pub struct StripWriter {
    dir: PathBuf,
    settings: LasSettings,
    ext: &'static str,
    current: Option<(u16, Box<LasWriter>)>,
}

impl StripWriter {
    /// Strips into `dir` (created), LAZ when `settings.compressed`.
    pub fn create(dir: &Path, settings: LasSettings) -> Result<Self, WriteError> {
        std::fs::create_dir_all(dir).at(dir)?;
        let ext = if settings.compressed { "laz" } else { "las" };
        Ok(Self {
            dir: dir.to_path_buf(),
            settings,
            ext,
            current: None,
        })
    }
}

impl PointSink for StripWriter {
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        for run in points.chunk_by(|a, b| a.point_source_id == b.point_source_id) {
            let line = run[0].point_source_id;
            if self.current.as_ref().map(|(l, _)| *l) != Some(line) {
                if let Some((_, w)) = self.current.take() {
                    w.finish()?;
                }
                let path = self.dir.join(strip_name(line, self.ext));
                let w = LasWriter::create(&path, self.settings.clone())?;
                self.current = Some((line, Box::new(w)));
            }
            if let Some((_, w)) = self.current.as_mut() {
                w.write(run)?;
            }
        }
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<(), WriteError> {
        match self.current.take() {
            Some((_, w)) => w.finish(),
            None => Ok(()),
        }
    }

    /// The lines done are whole strips; the one being written keeps its
    /// `.partial` name.
    fn suspend(mut self: Box<Self>) -> Result<(), WriteError> {
        match self.current.take() {
            Some((_, w)) => w.suspend(),
            None => Ok(()),
        }
    }

    fn discard(mut self: Box<Self>) {
        if let Some((_, w)) = self.current.take() {
            w.discard();
        }
    }
}

/// The directory of the tiles' spill files.
pub const SPILL_DIR: &str = ".spill";

/// Bytes of points held in memory before they are appended to the tiles'
/// spill files.
const SPILL_BYTES: usize = 64 << 20;

/// What the index says of a tile.
#[derive(Clone, Copy, Debug)]
struct TileStats {
    points: u64,
    z: (f64, f64),
}

/// Writes a file per square tile of edge `tile_m` and format into a
/// directory, `tile_X_Y.las` and `.laz` named by the tile's south-west
/// corner in output coordinates, and `index.geojson`. Points are gathered
/// per tile (in memory, then in spill files under `.spill/`) and each tile
/// written at the end, its points in pulse order.
pub struct TileWriter {
    dir: PathBuf,
    /// The settings of each format (LAZ when compressed).
    settings: Vec<LasSettings>,
    tile_m: f64,
    origin_m: [f64; 3],
    held: BTreeMap<(i64, i64), Vec<u8>>,
    held_bytes: usize,
    stats: BTreeMap<(i64, i64), TileStats>,
}

impl TileWriter {
    /// Tiles of `tile_m` into `dir` (created), a file for each of
    /// `settings` (LAZ when compressed); `origin_m` is added to the
    /// positions (the output's offset).
    pub fn create(
        dir: &Path,
        settings: Vec<LasSettings>,
        tile_m: f64,
        origin_m: [f64; 3],
    ) -> Result<Self, WriteError> {
        std::fs::create_dir_all(dir.join(SPILL_DIR)).at(dir)?;
        Ok(Self {
            dir: dir.to_path_buf(),
            settings,
            tile_m,
            origin_m,
            held: BTreeMap::new(),
            held_bytes: 0,
            stats: BTreeMap::new(),
        })
    }

    fn spill_path(&self, key: (i64, i64)) -> PathBuf {
        self.dir
            .join(SPILL_DIR)
            .join(format!("{}_{}", key.0, key.1))
    }

    /// Appends the points held to the tiles' spill files.
    fn spill(&mut self) -> Result<(), WriteError> {
        for (key, bytes) in std::mem::take(&mut self.held) {
            let path = self.spill_path(key);
            let mut f = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(&path)
                .at(&path)?;
            f.write_all(&bytes).at(&path)?;
        }
        self.held_bytes = 0;
        Ok(())
    }

    /// The corner of tile `key` in output coordinates.
    fn corner(&self, key: (i64, i64)) -> (f64, f64) {
        (key.0 as f64 * self.tile_m, key.1 as f64 * self.tile_m)
    }

    /// The file name of tile `key` in the format of `settings`.
    fn name(&self, key: (i64, i64), settings: &LasSettings) -> String {
        let (x, y) = self.corner(key);
        let ext = if settings.compressed { "laz" } else { "las" };
        format!("tile_{x}_{y}.{ext}")
    }

    /// The GeoJSON index: each tile's square, file and counts.
    fn index(&self) -> String {
        let t = self.tile_m;
        let features: Vec<String> = self
            .stats
            .iter()
            .map(|(&key, s)| {
                let (x0, y0) = self.corner(key);
                let (x1, y1) = (x0 + t, y0 + t);
                format!(
                    "{{\"type\":\"Feature\",\"geometry\":{{\"type\":\"Polygon\",\
                     \"coordinates\":[[[{x0},{y0}],[{x1},{y0}],[{x1},{y1}],[{x0},{y1}],\
                     [{x0},{y0}]]]}},\"properties\":{{\"files\":[{}],\"points\":{},\
                     \"z_min\":{},\"z_max\":{}}}}}",
                    self.settings
                        .iter()
                        .map(|st| format!("\"{}\"", self.name(key, st)))
                        .collect::<Vec<_>>()
                        .join(","),
                    s.points,
                    s.z.0,
                    s.z.1
                )
            })
            .collect();
        format!(
            "{{\"type\":\"FeatureCollection\",\"tile_m\":{t},\"features\":[\n{}\n]}}\n",
            features.join(",\n")
        )
    }
}

impl PointSink for TileWriter {
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        let (t, o) = (self.tile_m, self.origin_m);
        for p in points {
            let (x, y, z) = (
                p.position_m.x + o[0],
                p.position_m.y + o[1],
                p.position_m.z + o[2],
            );
            let key = ((x / t).floor() as i64, (y / t).floor() as i64);
            encode(p, self.held.entry(key).or_default());
            let s = self.stats.entry(key).or_insert(TileStats {
                points: 0,
                z: (f64::INFINITY, f64::NEG_INFINITY),
            });
            s.points += 1;
            s.z = (s.z.0.min(z), s.z.1.max(z));
        }
        self.held_bytes += points.len() * RECORD_BYTES;
        if self.held_bytes > SPILL_BYTES {
            self.spill()?;
        }
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<(), WriteError> {
        self.spill()?;
        let keys: Vec<(i64, i64)> = self.stats.keys().copied().collect();
        // A tile's points are read back a slice at a time.
        let mut buf = vec![0u8; (1 << 16) * RECORD_BYTES];
        let mut points = Vec::new();
        for key in keys {
            let spill = self.spill_path(key);
            let mut f = std::fs::File::open(&spill).at(&spill)?;
            let mut writers = Vec::new();
            for st in &self.settings {
                let path = self.dir.join(self.name(key, st));
                writers.push(Box::new(LasWriter::create(&path, st.clone())?));
            }
            loop {
                let mut filled = 0;
                while filled < buf.len() {
                    match f.read(&mut buf[filled..]).at(&spill)? {
                        0 => break,
                        n => filled += n,
                    }
                }
                points.clear();
                points.extend(buf[..filled].chunks_exact(RECORD_BYTES).map(decode));
                for w in writers.iter_mut() {
                    w.write(&points)?;
                }
                if filled < buf.len() {
                    break;
                }
            }
            for w in writers {
                w.finish()?;
            }
            std::fs::remove_file(&spill).at(&spill)?;
        }
        let spill = self.dir.join(SPILL_DIR);
        std::fs::remove_dir(&spill).at(&spill)?;
        let index = self.dir.join("index.geojson");
        write_atomic(&index, self.index().as_bytes())
    }

    /// No tile is written for an interrupted run.
    fn suspend(self: Box<Self>) -> Result<(), WriteError> {
        self.discard();
        Ok(())
    }

    fn discard(self: Box<Self>) {
        let _ = std::fs::remove_dir_all(self.dir.join(SPILL_DIR));
    }
}
