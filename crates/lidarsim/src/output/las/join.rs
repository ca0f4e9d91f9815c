//! The LAS files of a split run's parts joined into one: copied as they
//! are, one by one as they arrive ([`LasJoin`]), before the settings that
//! check them are known — while parts still run, or a merge still builds
//! the survey's scene — and then taken over by a writer of those settings
//! ([`LasWriter::adopt`]), which checks every part against them and writes
//! the file's own VLRs and, when finished, its header.

use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::{Body, HEADER_SIZE, LAS_WRITE_BYTES, LasSettings, LasWriter, RawHeader, tally};
use crate::output::{AtFile, AtomicFile, WriteCause, WriteError};

/// Part files joined by a [`LasJoin`], not yet checked: the first file whole,
/// then the point records of each later one.
#[derive(Debug)]
pub struct JoinedLas {
    file: AtomicFile,
    parts: Vec<Joined>,
    /// Bytes written.
    len: u64,
}

/// One part as it was joined.
#[derive(Debug)]
struct Joined {
    /// The part's file, as errors name it.
    named: PathBuf,
    /// Where its header is read: the part's file, or the joined file when
    /// the part's file was moved to become it.
    header: PathBuf,
    /// Bytes its file held.
    len: u64,
}

/// LAS files joined into `path` (as `path.partial` until the writer that
/// adopts it finishes), one at a time, as the parts of a split run
/// arrive: the first file as it is, then the records of each later one
/// (what follows its header and VLRs). Nothing but the LAS signature is
/// checked here; [`LasWriter::adopt`] checks the rest. A file already at
/// `path` is left for the caller to remove (the merge does once its
/// survey's world is built) or for the joined file to replace.
#[derive(Debug)]
pub struct LasJoin {
    /// The joined file's final name.
    path: PathBuf,
    /// The parts joined so far, in `joined`'s file.
    joined: Option<JoinedLas>,
}

impl LasJoin {
    /// A join into `path` (written as `path.partial`) of no part yet.
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            joined: None,
        }
    }

    /// The parts joined so far.
    pub fn parts(&self) -> usize {
        self.joined.as_ref().map_or(0, |j| j.parts.len())
    }

    /// Appends the LAS file `part`: whole if it is the first (moved into
    /// place with `take_first`, when the file system allows it: it is gone
    /// from its part then, and a failure later leaves the joined file
    /// behind under its `.partial` name), else its point records.
    pub fn append(&mut self, part: &Path, take_first: bool) -> Result<(), WriteError> {
        let Some(joined) = self.joined.as_mut() else {
            if take_first {
                signature(part)?;
                let partial = AtomicFile::partial_of(&self.path);
                if std::fs::rename(part, &partial).is_ok() {
                    let len = std::fs::metadata(&partial).at(&partial)?.len();
                    self.joined = Some(JoinedLas {
                        file: AtomicFile::reopen(&self.path, len)?,
                        parts: vec![Joined {
                            named: part.to_path_buf(),
                            header: partial,
                            len,
                        }],
                        len,
                    });
                    return Ok(());
                }
            }
            self.joined = Some(JoinedLas {
                file: AtomicFile::create_beside(&self.path)?,
                parts: Vec::new(),
                len: 0,
            });
            return self.append(part, false);
        };
        let (mut f, records) = signature(part)?;
        let start = if joined.parts.is_empty() { 0 } else { records };
        f.seek(SeekFrom::Start(start)).at(part)?;
        // An append reads one file and writes the other, and its error
        // does not say which: both are named.
        let appended = joined.file.append_rest_of(&mut f).map_err(|cause| {
            WriteError::new(
                part,
                WriteCause::Join {
                    into: AtomicFile::partial_of(joined.file.path()),
                    cause,
                },
            )
        })?;
        joined.len += appended;
        let copied = start + appended;
        joined.parts.push(Joined {
            named: part.to_path_buf(),
            header: part.to_path_buf(),
            len: copied,
        });
        Ok(())
    }

    /// The joined file, for [`LasWriter::adopt`]; an error if no part was
    /// appended.
    pub fn finish(self) -> Result<JoinedLas, WriteError> {
        self.joined.ok_or_else(|| {
            WriteError::new(
                &self.path,
                WriteCause::Unsupported("no LAS file to join".into()),
            )
        })
    }
}

/// `part` opened, once its first bytes are a LAS header's, with the
/// offset to its point records.
fn signature(part: &Path) -> Result<(std::fs::File, u64), WriteError> {
    let mut f = std::fs::File::open(part).at(part)?;
    let mut header = [0u8; HEADER_SIZE as usize];
    f.read_exact(&mut header).at(part)?;
    if &header[..4] != b"LASF" {
        return Err(WriteError::mismatch(part, "append", "it is not a LAS file"));
    }
    let header = RawHeader::parse(&header)
        .map_err(|e| WriteError::mismatch(part, "append", e.to_string()))?;
    Ok((f, u64::from(header.offset_to_points)))
}

impl LasWriter {
    /// Takes over `joined` as a plain LAS file of `settings` (no
    /// compression, no waveforms): every part must be a finished file of
    /// these settings holding as many bytes as its header counts points
    /// for, its counts, counts by return and bounds join this file's, and
    /// the file's VLRs are written from `settings`. Returns the writer, to
    /// be finished like one that wrote the points itself, and the points
    /// of each part. A part that fails is named in the error, and the
    /// joined file is removed (kept, under its `.partial` name, when the
    /// first part's file was moved to become it).
    pub fn adopt(joined: JoinedLas, settings: LasSettings) -> Result<(Self, Vec<u64>), WriteError> {
        let JoinedLas {
            mut file,
            parts,
            len,
        } = joined;
        if settings.compressed || settings.waveform.is_some() {
            return Err(WriteError::new(
                file.path(),
                WriteCause::Unsupported("only LAS files without waveforms are joined".into()),
            ));
        }
        let mut count = 0u64;
        let mut by_return = [0u64; 15];
        let (mut min, mut max) = ([i32::MAX; 3], [i32::MIN; 3]);
        let mut counts = Vec::with_capacity(parts.len());
        let mut offset_to_points = u64::from(HEADER_SIZE);
        for part in &parts {
            let t = tally::read(&part.header, &part.named, &settings, "append")?;
            let held = part.len;
            if t.file_len(&settings) != Some(held) {
                return Err(WriteError::mismatch(
                    &part.named,
                    "append",
                    format!(
                        "its header counts {} points but it holds {held} bytes",
                        t.count
                    ),
                ));
            }
            count += t.count;
            for (a, b) in by_return.iter_mut().zip(t.by_return) {
                *a += b;
            }
            if t.count > 0 {
                for a in 0..3 {
                    min[a] = min[a].min(t.min[a]);
                    max[a] = max[a].max(t.max[a]);
                }
            }
            offset_to_points = t.offset_to_points;
            counts.push(t.count);
        }
        let want = u64::from(settings.record_len())
            .checked_mul(count)
            .and_then(|b| b.checked_add(offset_to_points));
        if want != Some(len) {
            return Err(WriteError::mismatch(
                file.path(),
                "finish",
                format!(
                    "the parts joined into {len} bytes, not the {} their headers count: \
                     did a part change while it was joined?",
                    want.map_or_else(|| "overflowing".to_string(), |b| b.to_string())
                ),
            ));
        }
        let vlrs = settings
            .vlrs()
            .map_err(|cause| WriteError::new(file.path(), cause))?;
        let out = file.writer();
        let r = out
            .seek(SeekFrom::Start(u64::from(HEADER_SIZE)))
            .and_then(|_| out.write_all(&vlrs))
            .and_then(|()| out.seek(SeekFrom::End(0)).map(|_| ()));
        if let Err(e) = r {
            return Err(file.error(e));
        }
        let w = Self {
            file,
            settings,
            body: Body::Plain,
            wdp: None,
            count,
            by_return,
            min,
            max,
            buf: Vec::with_capacity(LAS_WRITE_BYTES + (1 << 16)),
        };
        Ok((w, counts))
    }
}
