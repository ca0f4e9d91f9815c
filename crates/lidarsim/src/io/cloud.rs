//! Point clouds — LAS/LAZ and XYZ text files, or points given as data —
//! made into scene voxels (see [`crate::scene::cloud`] for what a voxel
//! is), and the LAS reader's errors in words.

use std::path::{Path, PathBuf};

use crate::geometry::{Aabb, DVec3};
use crate::message::num;
use crate::output::{HEADER_SIZE_14, RawHeader};
use crate::scene::cloud::{CloudPlacement, MAX_VOXELS, Voxel};
use crate::scene::{Primitive, Scene, Shape, SurfaceClass};

/// Why a point cloud could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum CloudError {
    /// The LAS/LAZ reader failed.
    #[error("cannot read point cloud '{path}': {reason}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The reader's message.
        reason: String,
    },
    /// The file holds no point.
    #[error("'{path}' holds no point")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// Too many voxels for memory.
    #[error(
        "'{path}' gives {voxels} voxels of {voxel_m} m, more than the limit of {limit}; use a \
         larger voxel_m"
    )]
    TooMany {
        /// The file.
        path: PathBuf,
        /// Voxels found.
        voxels: usize,
        /// Edge length, m.
        voxel_m: f64,
        /// The limit.
        limit: usize,
    },
}

/// A LAS reader error in words: a truncated file, a header pointing
/// outside the file, or the reader's own message.
pub fn describe_las_error(e: &las::Error) -> String {
    match e {
        las::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends early: it is truncated or not a LAS file".to_string()
        }
        las::Error::Io(io) if io.kind() == std::io::ErrorKind::InvalidInput => {
            "its header points outside the file (point count or offsets too large)".to_string()
        }
        _ => e.to_string(),
    }
}

/// Opens a LAS or LAZ file for reading once its layout is checked
/// ([`check_layout`]): a header that promises more than the file holds, a
/// LAZ chunk table that points outside the file or counts more chunks
/// than it could hold, a version other than 1.0–1.4 or an unusable scale
/// is refused before the reader allocates anything by them. Errors say
/// what is wrong, without the path.
pub fn open_las(path: &Path) -> Result<las::Reader, String> {
    let raw = check_layout(path)?;
    let reader = las::Reader::from_path(path).map_err(|e| describe_las_error(&e))?;
    // The reader sizes its reads by its own reading of the header (its
    // point format's record length, the 64- or 32-bit count): check that
    // reading too against the file.
    let header = reader.header();
    let count = header.number_of_points();
    let record = u64::from(header.point_format().len());
    let size = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
    match count.checked_mul(record) {
        Some(bytes) if bytes <= size || raw.compressed() || header.point_format().is_compressed => {
            Ok(reader)
        }
        _ => Err(format!(
            "the header counts {count} points of {record} bytes, more than the file's {size} \
             bytes hold: it is truncated or its header is wrong"
        )),
    }
}

/// The header of the LAS or LAZ file at `path`, once the layout it
/// declares fits the file (see [`open_las`]).
pub fn check_layout(path: &Path) -> Result<RawHeader, String> {
    use std::io::Read;
    let size = crate::io::input::check_input(path, crate::io::input::MAX_INPUT_BYTES)
        .map_err(|e| e.to_string())?;
    let mut file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut head = Vec::with_capacity(usize::from(HEADER_SIZE_14));
    (&mut file)
        .take(u64::from(HEADER_SIZE_14))
        .read_to_end(&mut head)
        .map_err(|e| e.to_string())?;
    let header = RawHeader::parse(&head).map_err(|e| e.to_string())?;
    for (axis, (scale, offset)) in ["x", "y", "z"]
        .iter()
        .zip(header.scale.iter().zip(header.offset))
    {
        if !(scale.is_finite() && *scale != 0.0 && offset.is_finite()) {
            return Err(format!(
                "the header's {axis} scale factor is {} and offset {}: coordinates are stored as \
                 integers times a non-zero scale plus the offset (LAS 1.4 R15, Table 4)",
                num(*scale),
                num(offset)
            ));
        }
    }
    let start = u64::from(header.offset_to_points);
    if start < u64::from(header.header_size) || start > size {
        return Err(if start > size {
            format!(
                "the file ends early: its header puts the points at byte {start}, beyond its \
                 {size} bytes (truncated, or the header is wrong)"
            )
        } else {
            format!(
                "its header puts the points at byte {start}, inside its own {} bytes: the \
                 header is wrong",
                header.header_size
            )
        });
    }
    let compressed = header.compressed()
        || path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("laz"));
    if compressed {
        check_chunk_table(&mut file, &header, size)?;
    } else {
        check_records(&header, size)?;
    }
    Ok(header)
}

/// Refuses an uncompressed file whose header counts more records than
/// follow it, or none where records follow.
fn check_records(header: &RawHeader, size: u64) -> Result<(), String> {
    let start = u64::from(header.offset_to_points);
    // Records end where extended VLRs or waveform packets stored in the
    // file begin, else at its end.
    let end = [header.start_of_first_evlr, header.start_of_waveform_data]
        .into_iter()
        .filter(|&at| at > start && at <= size)
        .min()
        .unwrap_or(size);
    let record = u64::from(header.record_len).max(1);
    let count = header.points();
    let held = (end - start) / record;
    if count
        .checked_mul(record)
        .is_none_or(|bytes| bytes > end - start)
    {
        return Err(format!(
            "the header counts {count} points of {record} bytes, more than the file's {size} \
             bytes hold: it is truncated or its header is wrong"
        ));
    }
    if count == 0 && held > 0 {
        return Err(format!(
            "the header counts no point, but {held} records of {record} bytes follow it: its \
             header is wrong (a file being written, or not finished?)"
        ));
    }
    Ok(())
}

/// Refuses a LAZ file whose chunk table (LASzip: its offset in the first
/// 8 bytes of the point data; there, a version and the number of chunks)
/// lies outside the file or counts more chunks than the compressed data
/// could hold (each chunk takes at least one byte and one point).
fn check_chunk_table(
    file: &mut std::fs::File,
    header: &RawHeader,
    size: u64,
) -> Result<(), String> {
    use std::io::{Read, Seek, SeekFrom};
    let start = u64::from(header.offset_to_points);
    let mut read_u64_at = |at: u64| -> Result<[u8; 8], String> {
        let mut b = [0u8; 8];
        file.seek(SeekFrom::Start(at))
            .and_then(|_| file.read_exact(&mut b))
            .map_err(|_| "the file ends early: it is truncated or not a LAZ file".to_string())?;
        Ok(b)
    };
    let mut table = i64::from_le_bytes(read_u64_at(start)?);
    if table == -1 {
        // Written by a streaming compressor: the offset is in the last 8
        // bytes.
        table = i64::from_le_bytes(read_u64_at(size.saturating_sub(8))?);
    }
    let data = start + 8;
    let Some(table) = u64::try_from(table)
        .ok()
        .filter(|&t| t >= data && t + 8 <= size)
    else {
        return Err(format!(
            "its LAZ chunk table is said to be at byte {table}, outside the compressed points \
             (bytes {data} to {size}): it is truncated or damaged"
        ));
    };
    let b = read_u64_at(table)?;
    let chunks = u64::from(u32::from_le_bytes([b[4], b[5], b[6], b[7]]));
    let most = (table - data).min(header.points().max(1));
    if chunks > most {
        return Err(format!(
            "its LAZ chunk table counts {chunks} chunks, more than its {} bytes of compressed \
             points for {} points could hold: it is damaged",
            table - data,
            header.points()
        ));
    }
    Ok(())
}

/// Loads a LAS, LAZ or XYZ text file (`.xyz`, `.txt`: `x y z [class]` a
/// line) into `scene` as voxels of one new object; returns (points read,
/// voxels added).
pub fn load_point_cloud(
    path: &Path,
    placement: &CloudPlacement,
    scene: &mut Scene,
) -> Result<(u64, usize), CloudError> {
    let mut cells = Voxels::new(path, placement);
    let text = matches!(
        path.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("xyz" | "txt")
    );
    if text {
        read_xyz(path, &mut cells)?;
    } else {
        read_las(path, &mut cells)?;
    }
    cells.add_to(scene, format!("point_cloud:{}", path.display()))
}

/// Adds points given as data (`classes`: an ASPRS code per point, or
/// empty) to `scene` as voxels of one new object `name`; returns (points,
/// voxels added). `name` stands for the file in messages.
pub fn add_point_data(
    positions: &[DVec3],
    classes: &[u8],
    placement: &CloudPlacement,
    name: &str,
    scene: &mut Scene,
) -> Result<(u64, usize), CloudError> {
    let path = Path::new(name);
    let mut cells = Voxels::new(path, placement);
    for (i, p) in positions.iter().enumerate() {
        cells
            .add(*p, classes.get(i).copied().unwrap_or(1))
            .map_err(|why| CloudError::Read {
                path: path.to_path_buf(),
                reason: format!("point {}: {why}", i + 1),
            })?;
    }
    cells.add_to(scene, name.to_string())
}

/// The points of a cloud gathered by voxel: `(voxel index, class code)`
/// of every point, sorted and grouped at the end (no hash map of
/// counters).
struct Voxels<'a> {
    path: &'a Path,
    placement: &'a CloudPlacement,
    cells: Vec<([i64; 3], u8)>,
    read: u64,
}

impl<'a> Voxels<'a> {
    fn new(path: &'a Path, placement: &'a CloudPlacement) -> Self {
        Self {
            path,
            placement,
            cells: Vec::new(),
            read: 0,
        }
    }

    /// One point at `p` (before the offset) of class `code`; an error says
    /// why it cannot be placed (without the file, which callers name with
    /// the line or point).
    fn add(&mut self, p: DVec3, code: u8) -> Result<(), String> {
        self.read += 1;
        let v = self.placement.voxel_m;
        let q = p + self.placement.offset_m;
        if !q.is_finite() {
            return Err(format!(
                "the point at ({}, {}, {}) m (with offset_m) is not finite",
                num(q.x),
                num(q.y),
                num(q.z)
            ));
        }
        let cell = (q / v).floor();
        // Beyond 2^52 cells the indices would no longer be exact.
        if cell.abs().max_element() > 4.5e15 {
            return Err(format!(
                "the point at ({}, {}, {}) m is more than 2^52 voxels of {} m from the origin: \
                 use a larger voxel_m, or an offset_m that brings the cloud near the origin",
                num(q.x),
                num(q.y),
                num(q.z),
                num(v)
            ));
        }
        self.cells
            .push(([cell.x as i64, cell.y as i64, cell.z as i64], code));
        Ok(())
    }

    /// The voxels, each of the class most of its points have (the lowest
    /// code of equals), as one new object `name`; (points, voxels).
    fn add_to(mut self, scene: &mut Scene, name: String) -> Result<(u64, usize), CloudError> {
        let path = self.path.to_path_buf();
        if self.cells.is_empty() {
            return Err(CloudError::Empty { path });
        }
        let (cells, placement, v) = (&mut self.cells, self.placement, self.placement.voxel_m);
        cells.sort_unstable();
        let object = scene.add_object(name);
        let mut added = 0usize;
        let mut start = 0;
        while start < cells.len() {
            let key = cells[start].0;
            let mut end = start;
            // Within a voxel the entries are sorted by code: count runs.
            let (mut best, mut best_n) = (cells[start].1, 0usize);
            while end < cells.len() && cells[end].0 == key {
                let code = cells[end].1;
                let run_start = end;
                while end < cells.len() && cells[end].0 == key && cells[end].1 == code {
                    end += 1;
                }
                if end - run_start > best_n {
                    (best, best_n) = (code, end - run_start);
                }
            }
            start = end;
            added += 1;
            if added > MAX_VOXELS {
                return Err(CloudError::TooMany {
                    path,
                    voxels: added,
                    voxel_m: v,
                    limit: MAX_VOXELS,
                });
            }
            let min = DVec3::new(key[0] as f64, key[1] as f64, key[2] as f64) * v;
            scene.primitives.push(Primitive {
                shape: Shape::Voxel(Voxel {
                    bounds: Aabb {
                        min,
                        max: min + DVec3::splat(v),
                    },
                }),
                material: placement.material,
                class: placement
                    .class
                    .unwrap_or_else(|| SurfaceClass::from_asprs(best)),
                object,
            });
        }
        Ok((self.read, added))
    }
}

/// The points of a LAS or LAZ file into `cells`.
fn read_las(path: &Path, cells: &mut Voxels<'_>) -> Result<(), CloudError> {
    let bad = |e: las::Error| CloudError::Read {
        path: path.to_path_buf(),
        reason: describe_las_error(&e),
    };
    let mut reader = open_las(path).map_err(|reason| CloudError::Read {
        path: path.to_path_buf(),
        reason,
    })?;
    loop {
        let batch = reader.read_points(1 << 20).map_err(bad)?;
        if batch.is_empty() {
            return Ok(());
        }
        for p in batch.points() {
            let p = p.map_err(bad)?;
            let n = cells.read + 1;
            cells
                .add(DVec3::new(p.x, p.y, p.z), u8::from(p.classification))
                .map_err(|why| CloudError::Read {
                    path: path.to_path_buf(),
                    reason: format!("point {n}: {why}"),
                })?;
        }
    }
}

/// The points of an XYZ text file into `cells`: per line `x y z` and
/// optionally an ASPRS class code (1, unclassified, without), separated by
/// blanks or commas; blank lines and lines starting with `#` are skipped.
fn read_xyz(path: &Path, cells: &mut Voxels<'_>) -> Result<(), CloudError> {
    let read_err = |reason: String| CloudError::Read {
        path: path.to_path_buf(),
        reason,
    };
    let text = crate::io::input::read_text(path, crate::io::input::MAX_INPUT_BYTES)
        .map_err(|e| read_err(e.to_string()))?;
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |why: String| CloudError::Read {
            path: path.to_path_buf(),
            reason: format!("line {}: {why}", n + 1),
        };
        let fields: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|f| !f.is_empty())
            .collect();
        if !(3..=4).contains(&fields.len()) {
            return Err(bad(format!(
                "expected x y z and an optional class, got {} values",
                fields.len()
            )));
        }
        let mut xyz = [0.0f64; 3];
        for (a, f) in xyz.iter_mut().zip(&fields) {
            *a = f
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("'{f}' is not a finite number")))?;
        }
        let code = match fields.get(3) {
            None => 1,
            Some(f) => f
                .parse::<u8>()
                .map_err(|_| bad(format!("class '{f}' is not a code from 0 to 255")))?,
        };
        cells.add(DVec3::from_array(xyz), code).map_err(bad)?;
    }
    Ok(())
}
