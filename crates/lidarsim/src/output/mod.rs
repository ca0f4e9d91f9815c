//! Where the points go.
//!
//! The simulator hands every detected echo, in pulse order, to one or more
//! [`PointSink`]s: the LAS 1.4 / LAZ writer ([`LasWriter`], with full
//! waveforms in a `.wdp` file when asked), the PLY writer ([`PlyWriter`]),
//! the text writer ([`XyzWriter`]) and an in-memory sink ([`MemorySink`])
//! for tests and library users. [`crs`] knows the WKT of common EPSG codes. File sinks write under a temporary name
//! (`NAME.partial`) and rename to the final name only when complete, so an
//! interrupted or failed run never leaves a file that looks finished.

pub mod checksum;
pub mod crs;
#[cfg(target_os = "linux")]
mod direct;
mod error;
mod las;
pub mod layout;
pub mod own;
pub mod part;
mod ply;
mod record;
pub mod text;
mod xyz;

pub use error::{AtFile, WriteCause, WriteError};
pub use las::{
    Digitizer, HEADER_SIZE_14, HeaderError, JoinedLas, LasJoin, LasSettings, LasWriter,
    POINT_FORMAT_6_LEN, POINT_FORMAT_9_LEN, RawHeader, WAVEFORM_BITS, WAVEFORM_DESCRIPTORS,
    WAVEFORM_SAMPLES_STEP, WDP_HEADER_LEN, return_numbers, scan_angle_units,
};
pub use ply::{PLY_PROPERTIES, PLY_RECORD_LEN, PlyWriter};
pub use record::{Component, NO_OBJECT, PointRecord, WaveformBlock, WaveformPacket};
pub use xyz::XyzWriter;

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Receives the points of a survey in pulse order (as ripgrep's searcher
/// hands its matches to a `Sink`): its error is its own type, which the
/// run reports as it is.
pub trait PointSink: Send {
    /// Why the sink could not take the points: [`WriteError`] for the file
    /// writers, whose errors name their file.
    type Error;
    /// Appends points.
    fn write(&mut self, points: &[PointRecord]) -> Result<(), Self::Error>;
    /// Appends points together with the waveforms of their pulses (empty
    /// unless the simulator was asked to record waveforms). Sinks that do
    /// not store waveforms keep the default, which writes the points only.
    fn write_block(
        &mut self,
        points: &[PointRecord],
        waveforms: &WaveformBlock,
    ) -> Result<(), Self::Error> {
        let _ = waveforms;
        self.write(points)
    }
    /// Completes the output (headers, renaming).
    fn finish(self: Box<Self>) -> Result<(), Self::Error>;
    /// Completes the output for the points written so far but leaves it
    /// under its temporary name: the files of an interrupted run, which a
    /// resumed run continues. Sinks without files finish.
    fn suspend(self: Box<Self>) -> Result<(), Self::Error> {
        self.finish()
    }
    /// Abandons the output, removing anything partial.
    fn discard(self: Box<Self>);
}

/// A sink of the file writers' kind, as a run holds its sinks.
pub type FileSink = dyn PointSink<Error = WriteError>;

/// Keeps all points in memory.
#[derive(Debug, Default)]
pub struct MemorySink {
    /// Points received so far.
    pub points: Vec<PointRecord>,
}

impl PointSink for MemorySink {
    /// Memory that is there never fails.
    type Error = std::convert::Infallible;
    fn write(&mut self, points: &[PointRecord]) -> Result<(), Self::Error> {
        self.points.extend_from_slice(points);
        Ok(())
    }
    fn finish(self: Box<Self>) -> Result<(), Self::Error> {
        Ok(())
    }
    fn discard(self: Box<Self>) {}
}

/// Bytes written between two requests to start writing a file's data to
/// its device ([`OutFile`]). Under `AtomicFile`'s 1 MiB buffer this is a
/// request after every flush of the buffer: the sync at commit then waits
/// for at most the last flush: 0.3–0.7 ms for the 25 MB benchmark LAS,
/// against 2.3–2.7 ms with a request every 4 MiB, while both cores stand
/// idle. The writer's CPU time stays the same.
const WRITEBACK_BYTES: u64 = 256 << 10;

/// The file under an [`AtomicFile`]'s buffer. Every 256 KiB written
/// (`WRITEBACK_BYTES`), it asks the kernel to start writing those bytes to the device
/// without waiting for them (Linux `sync_file_range` with
/// `SYNC_FILE_RANGE_WRITE`; elsewhere nothing), so that the device works
/// while the simulation goes on and the sync at [`AtomicFile::commit`] has
/// only the last bytes left to wait for (without it, all of a large file's
/// data waits in the page cache until then). The request is only advice:
/// its failure changes nothing, and the sync at commit reports any error.
#[derive(Debug)]
pub struct OutFile {
    file: File,
    /// Position of the next write.
    pos: u64,
    /// End of the range last handed to writeback.
    started: u64,
}

impl OutFile {
    /// `file`, whose next write goes to `pos`.
    fn new(file: File, pos: u64) -> Self {
        Self {
            file,
            pos,
            started: pos,
        }
    }

    /// Starts writeback of the bytes written since the last start.
    #[cfg(target_os = "linux")]
    fn start_writeback(&mut self) {
        use std::os::fd::AsRawFd;
        let (Ok(from), Ok(len)) = (
            i64::try_from(self.started),
            i64::try_from(self.pos - self.started),
        ) else {
            return;
        };
        // SAFETY: a system call on this file's own open descriptor, with
        // plain integer arguments; it touches no memory of this process.
        unsafe {
            libc::sync_file_range(
                self.file.as_raw_fd(),
                from,
                len,
                libc::SYNC_FILE_RANGE_WRITE,
            );
        }
        self.started = self.pos;
    }

    /// Writeback is left to the operating system.
    #[cfg(not(target_os = "linux"))]
    fn start_writeback(&mut self) {
        self.started = self.pos;
    }
}

impl Write for OutFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.file.write(buf)?;
        self.pos += n as u64;
        if self.pos >= self.started + WRITEBACK_BYTES {
            self.start_writeback();
        }
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl OutFile {
    /// The file, for reading back what was written (the position moves:
    /// seek back before writing again).
    pub fn file_mut(&mut self) -> &mut File {
        &mut self.file
    }

    /// Copies what `from` holds after its position to this file's end,
    /// writeback started as for any write. Returns the bytes copied.
    fn copy_rest(&mut self, from: &mut File) -> io::Result<u64> {
        let mut copied = 0;
        #[cfg(target_os = "linux")]
        loop {
            match self.copy_in_kernel(from) {
                Ok(0) => return Ok(copied),
                Ok(n) => copied += n,
                // A file system (or kernel) that cannot copy between these
                // two files: the bytes go through this process instead.
                Err(e) if copied == 0 && cannot_copy_in_kernel(&e) => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        let mut buf = vec![0u8; COPY_BYTES];
        loop {
            let n = read_full(from, &mut buf)?;
            self.write_all(&buf[..n])?;
            copied += n as u64;
            if n < buf.len() {
                return Ok(copied);
            }
        }
    }

    /// Up to `COPY_BYTES` of `from`, from its position, copied to this
    /// file's end by the kernel (Linux `copy_file_range`): the bytes do
    /// not pass through this process, and a file system that shares
    /// blocks between files (XFS, Btrfs) shares them rather than copying.
    #[cfg(target_os = "linux")]
    fn copy_in_kernel(&mut self, from: &mut File) -> io::Result<u64> {
        use std::os::fd::AsRawFd;
        // SAFETY: a system call on two open descriptors this process owns,
        // with null offsets (each file's own position is used and moved);
        // it touches no memory of this process.
        let n = unsafe {
            libc::copy_file_range(
                from.as_raw_fd(),
                std::ptr::null_mut(),
                self.file.as_raw_fd(),
                std::ptr::null_mut(),
                COPY_BYTES,
                0,
            )
        };
        let n = u64::try_from(n).map_err(|_| io::Error::last_os_error())?;
        self.pos += n;
        if self.pos >= self.started + WRITEBACK_BYTES {
            self.start_writeback();
        }
        Ok(n)
    }
}

/// Bytes copied at a time by [`OutFile::copy_rest`] and `direct.rs`.
const COPY_BYTES: usize = 1 << 20;

/// Fills `buf` from `from`, short only at its end; returns the bytes read.
fn read_full(from: &mut File, buf: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match std::io::Read::read(from, &mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

/// Whether `e`, from `copy_file_range` before any byte was copied, says
/// that these files cannot be copied by the kernel (other file systems on
/// an older kernel, a file system without the call, a special file).
#[cfg(target_os = "linux")]
fn cannot_copy_in_kernel(e: &io::Error) -> bool {
    matches!(
        e.raw_os_error(),
        Some(libc::EXDEV | libc::ENOSYS | libc::EOPNOTSUPP | libc::EINVAL | libc::EPERM)
    )
}

impl Seek for OutFile {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        self.pos = self.file.seek(to)?;
        // Writes after a seek back (a header rewritten) are left to commit.
        self.started = self.started.max(self.pos);
        Ok(self.pos)
    }
}

/// A file written under `NAME.partial` and renamed to `NAME` on
/// [`AtomicFile::commit`]; dropped uncommitted, the partial file is removed.
#[derive(Debug)]
pub struct AtomicFile {
    writer: Option<BufWriter<OutFile>>,
    partial: PathBuf,
    target: PathBuf,
    committed: bool,
    /// A reopened file is not removed when dropped uncommitted.
    keep_on_drop: bool,
}

impl AtomicFile {
    /// Creates `target.partial` for writing (any stale final file with the
    /// same name is removed first so it cannot be mistaken for this run's).
    /// The partial file is created anew and exclusively: a file or a
    /// symbolic link already under that name is removed (the link, never
    /// what it points to), so that nothing outside the output is written.
    pub fn create(target: &Path) -> Result<Self, WriteError> {
        remove_if_present(target)?;
        Self::create_beside(target)
    }

    /// [`AtomicFile::create`] that leaves a final file already at `target`
    /// until this one is committed over it: for a caller that removes that
    /// file itself, once it knows its run will go ahead.
    pub fn create_beside(target: &Path) -> Result<Self, WriteError> {
        let partial = Self::partial_of(target);
        remove_if_present(&partial)?;
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&partial)
            .at(&partial)?;
        Ok(Self {
            writer: Some(BufWriter::with_capacity(1 << 20, OutFile::new(file, 0))),
            partial,
            target: target.to_path_buf(),
            committed: false,
            keep_on_drop: false,
        })
    }

    /// Continues a file that an interrupted run finished early and left
    /// as `target.partial` ([`AtomicFile::suspend`]): cut to `len` bytes
    /// and opened for writing at its end. The file must be a regular file
    /// (a symbolic link is refused, not followed). Dropped uncommitted, the
    /// partial file is kept, so that the run can be resumed again.
    pub fn reopen(target: &Path, len: u64) -> Result<Self, WriteError> {
        let partial = Self::partial_of(target);
        let refuse = |reason: String| {
            WriteError::new(
                &partial,
                WriteCause::Mismatch {
                    action: "continue",
                    reason,
                },
            )
        };
        let meta = std::fs::symlink_metadata(&partial).at(&partial)?;
        if !meta.file_type().is_file() {
            return Err(refuse(
                "it is not a regular file (an interrupted run leaves its files as regular files)"
                    .into(),
            ));
        }
        let have = meta.len();
        if have < len {
            return Err(refuse(format!(
                "it has {have} bytes, fewer than the {len} the interrupted run wrote"
            )));
        }
        let mut file = open_no_follow(&partial).at(&partial)?;
        file.set_len(len).at(&partial)?;
        let end = file.seek(SeekFrom::End(0)).at(&partial)?;
        Ok(Self {
            writer: Some(BufWriter::with_capacity(1 << 20, OutFile::new(file, end))),
            partial,
            target: target.to_path_buf(),
            committed: false,
            keep_on_drop: true,
        })
    }

    /// A handle on no file yet (for a writer under construction): it must
    /// be replaced before it is written; dropping it does nothing.
    pub(crate) fn unopened(target: &Path) -> Self {
        Self {
            writer: None,
            partial: Self::partial_of(target),
            target: target.to_path_buf(),
            committed: false,
            keep_on_drop: true,
        }
    }

    /// `target.partial`.
    pub fn partial_of(target: &Path) -> PathBuf {
        let mut partial = target.as_os_str().to_owned();
        partial.push(".partial");
        PathBuf::from(partial)
    }

    /// The final name of the file.
    pub fn path(&self) -> &Path {
        &self.target
    }

    /// `e` as an error that names this file.
    pub fn error(&self, e: io::Error) -> WriteError {
        WriteError::io(&self.target, e)
    }

    /// The buffered writer.
    pub fn writer(&mut self) -> &mut BufWriter<OutFile> {
        self.writer.as_mut().expect("writer present until commit")
    }

    /// Writes bytes the caller has gathered into large pieces itself (a
    /// megabyte of point records): what the buffer holds goes first, then
    /// the bytes go to the file directly, without being copied into the
    /// buffer on the way.
    pub fn write_unbuffered(&mut self, bytes: &[u8]) -> io::Result<()> {
        let w = self.writer();
        w.flush()?;
        w.get_mut().write_all(bytes)
    }

    /// Appends what `from` holds after its position (the rest of another
    /// file): on Linux written direct to the device, past the page cache
    /// (`direct.rs`), else copied by the kernel where it can
    /// ([`OutFile`]); returns the bytes appended.
    pub fn append_rest_of(&mut self, from: &mut File) -> io::Result<u64> {
        let w = self.writer.as_mut().expect("writer present until commit");
        w.flush()?;
        #[cfg(target_os = "linux")]
        if let Some(n) = direct::append(&self.partial, w.get_mut(), from)? {
            return Ok(n);
        }
        w.get_mut().copy_rest(from)
    }

    /// Lends the buffered writer out (to a compressor that owns its output);
    /// give it back with [`AtomicFile::put_writer`] before committing. The
    /// partial file is still removed if `self` is dropped meanwhile.
    pub fn take_writer(&mut self) -> BufWriter<OutFile> {
        self.writer.take().expect("writer present until commit")
    }

    /// Returns the writer lent by [`AtomicFile::take_writer`].
    pub fn put_writer(&mut self, writer: BufWriter<OutFile>) {
        self.writer = Some(writer);
    }

    /// Flushes and syncs the file but keeps it as `target.partial`: the
    /// output of an interrupted run, complete for what it holds, which a
    /// resumed run continues ([`AtomicFile::reopen`]) and only a complete
    /// run renames. Errors name the file.
    pub fn suspend(mut self) -> Result<(), WriteError> {
        let partial = self.partial.clone();
        let w = self.writer.take().expect("writer present until commit");
        let file = w
            .into_inner()
            .map_err(|e| e.into_error())
            .at(&partial)?
            .file;
        file.sync_all().at(&partial)?;
        self.committed = true;
        Ok(())
    }

    /// Flushes, syncs and renames to the final name. Errors name the file.
    pub fn commit(mut self) -> Result<(), WriteError> {
        let target = self.target.clone();
        let named = |e: io::Error| WriteError::io(&target, e);
        let w = self.writer.take().expect("writer present until commit");
        let file = match w.into_inner() {
            Ok(f) => f.file,
            Err(e) => {
                if !self.keep_on_drop {
                    let _ = std::fs::remove_file(&self.partial);
                }
                return Err(named(e.into_error()));
            }
        };
        if let Err(e) = file.sync_all() {
            drop(file);
            if !self.keep_on_drop {
                let _ = std::fs::remove_file(&self.partial);
            }
            return Err(named(e));
        }
        drop(file);
        std::fs::rename(&self.partial, &self.target).map_err(named)?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed && !self.keep_on_drop {
            drop(self.writer.take());
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

/// Removes the file or symbolic link `path` (never what a link points
/// to); a missing one is fine.
fn remove_if_present(path: &Path) -> Result<(), WriteError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(WriteError::io(path, e)),
        _ => Ok(()),
    }
}

/// Opens `path` for reading and writing without following a symbolic link
/// in its last component.
fn open_no_follow(path: &Path) -> io::Result<File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true).write(true);
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NOFOLLOW);
    }
    options.open(path)
}

/// Writes a whole small file atomically.
pub fn write_atomic(target: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let mut f = AtomicFile::create(target)?;
    f.writer().write_all(bytes).at(target)?;
    f.commit()
}

/// Day of year (1-based) and year of a Unix time, UTC (for the LAS header).
pub fn day_of_year(unix_s: i64) -> (u16, u16) {
    let days = unix_s.div_euclid(86_400);
    // Civil-from-days (H. Hinnant, "chrono-compatible low-level date
    // algorithms").
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy_mar = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy_mar + 2) / 153;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    let jan1 = days_from_civil(year, 1, 1);
    ((days - jan1 + 1) as u16, year as u16)
}

fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = if m > 2 { m - 3 } else { m + 9 };
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn day_of_year_known_dates() {
        assert_eq!(day_of_year(0), (1, 1970));
        // 2024-03-01 is day 61 of a leap year.
        assert_eq!(day_of_year(1_709_251_200), (61, 2024));
        // 2026-12-31.
        assert_eq!(day_of_year(1_798_675_200), (365, 2026));
    }

    #[test]
    fn atomic_file_is_invisible_until_commit() {
        let dir = std::env::temp_dir().join(format!("lidarsim-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("a.txt");
        {
            let mut f = AtomicFile::create(&target).unwrap();
            f.writer().write_all(b"half").unwrap();
            assert!(!target.exists());
        } // dropped: partial removed
        assert!(!target.exists());
        assert!(!dir.join("a.txt.partial").exists());
        write_atomic(&target, b"whole").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Other files' rests appended after buffered bytes — past the page
    /// cache (from an unaligned end, over several chunks; from a pipe;
    /// ending on a block boundary and starting on one) and by the kernel's
    /// copy — leave exactly those bytes, in order, and later writes go
    /// after them.
    #[test]
    #[cfg(unix)]
    fn appended_files_follow_the_bytes_written() {
        let dir = std::env::temp_dir().join(format!("lidarsim-append-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let pattern = |len: usize, k: usize| -> Vec<u8> {
            (0..len).map(|i| (i * k + i / 509) as u8).collect()
        };
        let source = |name: &str, bytes: &[u8]| {
            let path = dir.join(name);
            std::fs::write(&path, bytes).unwrap();
            File::open(path).unwrap()
        };
        let target = dir.join("joined.bin");
        let mut f = AtomicFile::create(&target).unwrap();
        f.writer().write_all(b"head").unwrap();
        let mut want = b"head".to_vec();
        let big = pattern(2 * COPY_BYTES + 4321, 13);
        let mut from = source("big.bin", &big);
        from.seek(SeekFrom::Start(100)).unwrap();
        assert_eq!(
            f.append_rest_of(&mut from).unwrap(),
            (big.len() - 100) as u64
        );
        want.extend_from_slice(&big[100..]);
        let (reader, mut writer) = std::io::pipe().unwrap();
        let feeding = std::thread::spawn(move || writer.write_all(b"from a pipe").unwrap());
        let mut pipe = File::from(std::os::fd::OwnedFd::from(reader));
        assert_eq!(f.append_rest_of(&mut pipe).unwrap(), 11);
        feeding.join().unwrap();
        want.extend_from_slice(b"from a pipe");
        // The kernel's copy, as where the page cache cannot be bypassed.
        let small = pattern(70_000, 7);
        f.writer().flush().unwrap();
        let copied = f
            .writer()
            .get_mut()
            .copy_rest(&mut source("small.bin", &small));
        assert_eq!(copied.unwrap(), small.len() as u64);
        want.extend_from_slice(&small);
        // To a block boundary, then from one.
        let to_boundary = pattern(4096 - want.len() % 4096 + 8192, 3);
        f.append_rest_of(&mut source("edge.bin", &to_boundary))
            .unwrap();
        want.extend_from_slice(&to_boundary);
        assert_eq!(want.len() % 4096, 0);
        let after = pattern(5000, 5);
        f.append_rest_of(&mut source("after.bin", &after)).unwrap();
        want.extend_from_slice(&after);
        f.writer().write_all(b"tail").unwrap();
        want.extend_from_slice(b"tail");
        f.commit().unwrap();
        assert!(std::fs::read(&target).unwrap() == want);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A file several writeback ranges long, written in uneven pieces,
    /// with its head rewritten after a seek back and more appended at the
    /// end, holds exactly the bytes written: the writeback requests change
    /// nothing in the file.
    #[test]
    fn writeback_leaves_the_bytes_as_written() {
        let dir = std::env::temp_dir().join(format!("lidarsim-writeback-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("big.bin");
        let len = 3 * WRITEBACK_BYTES as usize + 12_345;
        let mut want: Vec<u8> = (0..len).map(|i| (i * 7 + i / 251) as u8).collect();
        let mut f = AtomicFile::create(&target).unwrap();
        let mut at = 0;
        for piece in [1usize, 1000, 700 << 10, 17, 1 << 20].iter().cycle() {
            if at == len {
                break;
            }
            let end = (at + piece).min(len);
            f.writer().write_all(&want[at..end]).unwrap();
            at = end;
        }
        let w = f.writer();
        w.seek(SeekFrom::Start(10)).unwrap();
        w.write_all(b"header").unwrap();
        w.seek(SeekFrom::End(0)).unwrap();
        w.write_all(b"tail").unwrap();
        f.commit().unwrap();
        want[10..16].copy_from_slice(b"header");
        want.extend_from_slice(b"tail");
        let got = std::fs::read(&target).unwrap();
        assert_eq!(got.len(), want.len());
        assert!(got == want, "the file differs from the bytes written");
        std::fs::remove_dir_all(&dir).ok();
    }
}
