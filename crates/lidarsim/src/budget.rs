//! What a run will cost before it runs: the size of every file it writes
//! and the memory it needs, and whether the machine has them.
//!
//! Points are estimated as one per pulse that can reach the scene (the
//! pulses emitted while the line's swath overlaps the scene's extent),
//! plus an allowance for multiple returns under crowns:
//! [`EXTRA_RETURNS_UNDER_CROWNS`] more per pulse over the share of the
//! scene's area that crowns cover (at most `max_returns − 1`). Pulses over
//! the scene that find nothing (gaps between objects) are counted, so the
//! estimate errs on the large side. File sizes follow from the points and
//! each format's record; memory from the scene as loaded, its index, the
//! per-thread buffers of the receiver and the sinks' buffers.

use std::path::Path;

use serde::Serialize;

use crate::geometry::Aabb;
use crate::output::{WAVEFORM_BITS, WDP_HEADER_LEN};
use crate::scene::{Scene, Shape};
use crate::survey::Survey;
use crate::waveform::range_to_bin;
use crate::world::World;

/// Extra returns per pulse allowed for where crowns cover the ground
/// (foliage echoes at two depths before the ground echo: 2.28 points per
/// pulse in `examples/forest.toml`, whose crowns cover 66 % of the area).
pub const EXTRA_RETURNS_UNDER_CROWNS: f64 = 2.0;

/// Bytes of index (bounding volume hierarchy) per primitive at its peak
/// during the build: the binary tree, the primitives' boxes and centroids,
/// and the eight-wide tree it is collapsed into.
const INDEX_BYTES_PER_PRIMITIVE: u64 = 128;

/// Bytes of a line of `points.xyz` besides its coordinates, times and
/// ranges: the fixed-width columns and the separators.
const XYZ_FIXED_BYTES: u64 = 60;

/// Bytes of the report page at most (maps of at most 500 000 pixels).
const REPORT_BYTES: u64 = 8 << 20;

/// Memory of the program itself and its allocator, bytes.
const BASE_MEMORY: u64 = 16 << 20;

/// Pulses per block (see `sim::BLOCK_PULSES`) held in the ordering window.
const WINDOW_BLOCKS_PER_THREAD: u64 = 4;

/// One output file and its expected size.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FileEstimate {
    /// Its name in the output directory.
    pub name: String,
    /// Expected size, bytes.
    pub bytes: u64,
}

/// The expected cost of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Budget {
    /// Pulses.
    pub pulses: u64,
    /// Expected points (see the module documentation).
    pub points: u64,
    /// Share of the scene's area under crowns, 0–1.
    pub crown_cover: f64,
    /// Point files per format: 1, or a file per flight line (strips) or
    /// per tile the lines may reach, at most (tiles).
    pub layout_files: u64,
    /// Every file the run writes.
    pub files: Vec<FileEstimate>,
    /// Their total, bytes.
    pub total_bytes: u64,
    /// Peak memory of the run, bytes.
    pub memory_bytes: u64,
}

/// Number of decimal digits of the integer part of `v` (at least 1).
fn digits(v: f64) -> u64 {
    let mut n = 1;
    let mut x = v.abs();
    while x >= 10.0 && n < 400 {
        x /= 10.0;
        n += 1;
    }
    n
}

/// Share of the scene's horizontal extent that crown envelopes cover:
/// `1 − exp(−CAI)` for the crown area index CAI (the summed areas of the
/// crowns' largest circles over the extent), the cover of randomly placed
/// overlapping discs (the Boolean model of stochastic geometry).
fn crown_cover(scene: &Scene, b: Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let area = (b.extent().x * b.extent().y).max(1.0);
    let crowns: f64 = scene
        .primitives
        .iter()
        .filter_map(|p| match &p.shape {
            Shape::Crown(c) => Some(std::f64::consts::PI * c.max_radius_m().powi(2)),
            _ => None,
        })
        .sum();
    1.0 - (-crowns / area).exp()
}

/// Bytes the loaded scene occupies: its primitives, what they own, shared
/// terrain grids and object names.
fn scene_bytes(scene: &Scene) -> u64 {
    let mut grids = std::collections::HashSet::new();
    let mut bytes =
        (scene.primitives.len() * std::mem::size_of::<crate::scene::Primitive>()) as u64;
    for p in &scene.primitives {
        bytes += match &p.shape {
            Shape::Polygon(poly) => poly.heap_bytes() as u64,
            Shape::Crown(_) => std::mem::size_of::<crate::scene::tree::Crown>() as u64,
            Shape::Terrain(tile) => {
                let grid = tile.grid();
                if grids.insert(std::ptr::from_ref(grid)) {
                    (grid.heights.len() * 4) as u64
                } else {
                    0
                }
            }
            _ => 0,
        };
    }
    bytes
        + scene
            .objects
            .iter()
            .map(|o| (std::mem::size_of_val(o) + o.heap_bytes()) as u64)
            .sum::<u64>()
}

/// The share of `line`'s duration during which its swath (the scan
/// half-angle over the height above the scene's bottom, plus the
/// footprint) overlaps the scene's extent `b` in plan, from 256 samples.
fn share_over_scene(survey: &Survey, line: &crate::sensor::platform::FlightLine, b: Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let s = &survey.scanner;
    let samples = 256;
    let over = (0..samples)
        .filter(|&k| {
            let t = line.duration_s() * (f64::from(k) + 0.5) / f64::from(samples);
            let p = line.pose_at(t).position_m;
            let h = (p.z - b.min.z).max(0.0).min(s.max_range_m);
            let reach = h * (s.deflector.max_off_nadir_rad() + 0.5 * s.divergence_rad).tan() + 1.0;
            p.x + reach >= b.min.x
                && p.x - reach <= b.max.x
                && p.y + reach >= b.min.y
                && p.y - reach <= b.max.y
        })
        .count();
    over as f64 / f64::from(samples)
}

/// Estimates the run of `survey` over `world` on `threads` threads, its
/// flight lines of `line_pulses` pulse slots each
/// ([`crate::flight::Flight::estimate`] gives them).
pub fn estimate(survey: &Survey, world: &World, line_pulses: &[u64], threads: usize) -> Budget {
    let (scene, lines) = (world.scene(), &world.lines[..]);
    let o = &survey.output;
    let f = &o.formats;
    let pulses: u64 = line_pulses.iter().sum();
    let b = world.scene_bounds();
    let cover = crown_cover(scene, b);
    let extra = EXTRA_RETURNS_UNDER_CROWNS.min(survey.detector.max_returns as f64 - 1.0);
    let per_pulse = 1.0 + cover * extra;
    // Pulse slots in which a pulse leaves (a polygon's facets look
    // outside the field of view for part of each turn).
    let fired = survey.scanner.deflector.emitted_share();
    let over: f64 = lines
        .iter()
        .zip(line_pulses)
        .map(|(l, &n)| n as f64 * fired * share_over_scene(survey, l, b))
        .sum();
    let points = (over * per_pulse).ceil() as u64;
    // The largest coordinate written, for the text formats.
    let mut far = if b.is_empty() {
        0.0
    } else {
        b.min.abs().max(b.max.abs()).max_element()
    };
    for l in lines {
        far = far.max(
            l.start_m
                .abs()
                .max_element()
                .max(l.end_m.abs().max_element()),
        );
    }
    far += o.offset_m.abs().max_element();
    let flight_s = lines
        .last()
        .map_or(0.0, |l| l.start_time_s + l.duration_s())
        + o.gps_start_time_s.unwrap_or(0.0);
    let coord = 3 * (digits(far) + 5);
    let mut files = Vec::new();
    let mut add = |name: &str, bytes: u64| {
        files.push(FileEstimate {
            name: name.to_string(),
            bytes,
        })
    };
    let las = crate::files::las_settings_for(survey, b, lines);
    let single = o.layout == crate::survey::Layout::Single;
    // Strips and tiles: a file (its header and VLRs) per line or tile.
    let layout_files = match o.layout {
        crate::survey::Layout::Single => 1,
        crate::survey::Layout::Strips => lines.len() as u64,
        crate::survey::Layout::Tiles(tile_m) => {
            crate::world::tiles_over(crate::world::reachable_area(survey, b, lines), tile_m) as u64
        }
    };
    let headers = (layout_files - 1) * las.file_len(0);
    if f.las {
        let mut s = las.clone();
        if f.las_waveform {
            s.waveform = Some(crate::output::Digitizer::with_full_scale(
                (survey.receiver.bin_s * 1e12).round() as u32,
                1.0,
            ));
        }
        add(
            if single { "points.las" } else { "LAS files" },
            s.file_len(points) + headers,
        );
    }
    if f.las_waveform {
        // Each pulse with an echo keeps its record: the pulse shape, the
        // spread of its returns (the scene's height at most) and guards.
        let bin = survey.receiver.bin_s;
        let (before, after) = survey.receiver.pulse.support_s();
        let spread = if b.is_empty() {
            0.0
        } else {
            b.extent().z.min(200.0)
        };
        let samples = ((before + after) / bin + range_to_bin(spread, bin)).ceil() as u64 + 10;
        add(
            "points.wdp",
            WDP_HEADER_LEN + pulses * samples * u64::from(WAVEFORM_BITS / 8),
        );
    }
    if f.laz {
        // LASzip keeps a third or less of the bytes of airborne points.
        add(
            if single { "points.laz" } else { "LAZ files" },
            las.file_len(points) * 2 / 5 + headers,
        );
    }
    if f.ply {
        add("points.ply", crate::output::PlyWriter::file_len(points));
    }
    if f.xyz {
        let line = coord + digits(flight_s) + 10 + digits(survey.scanner.max_range_m) + 5;
        add("points.xyz", 140 + points * (line + XYZ_FIXED_BYTES));
    }
    let rows: u64 = lines
        .iter()
        .map(|l| (l.duration_s() / o.trajectory_interval_s).floor() as u64 + 1)
        .sum();
    let row = digits(flight_s) + 7 + coord + 3 * 12 + digits(lines.len() as f64) + 8;
    for name in [
        "trajectory.csv",
        "trajectory_true.csv",
        "trajectory_observed.csv",
    ] {
        add(name, 60 + rows * row);
    }
    add("report.html", REPORT_BYTES);
    let total_bytes = files.iter().map(|f| f.bytes).sum();

    // Memory: the scene, its index, and per thread the receiver's record
    // (samples, impulses, background and detection: four f64 buffers) of
    // the longest pulse window, the ordering window of blocks of points,
    // and the sinks' buffers.
    let threads = threads.max(1) as u64;
    let window = (range_to_bin(
        survey.scanner.max_range_m - survey.scanner.min_range_m,
        survey.receiver.bin_s,
    ) + 64.0)
        .min(crate::survey::MAX_WINDOW_SAMPLES as f64) as u64;
    let per_thread = 4 * 8 * window + (1 << 20);
    let block_points = (crate::sim::BLOCK_PULSES as f64 * per_pulse) as u64;
    let ordering = WINDOW_BLOCKS_PER_THREAD
        * threads
        * block_points
        * std::mem::size_of::<crate::output::PointRecord>() as u64;
    let sinks = 4 << 20;
    let memory_bytes = BASE_MEMORY
        + scene_bytes(scene)
        + scene.primitives.len() as u64 * INDEX_BYTES_PER_PRIMITIVE
        + threads * per_thread
        + ordering
        + sinks
        + REPORT_BYTES;
    Budget {
        pulses,
        points,
        crown_cover: cover,
        layout_files,
        files,
        total_bytes,
        memory_bytes,
    }
}

/// Bytes free to an unprivileged user on the file system that holds
/// `dir` (or its nearest existing ancestor); `None` where unknown.
pub fn free_bytes(dir: &Path) -> Option<u64> {
    let mut d = std::path::absolute(dir).ok()?;
    while !d.exists() {
        d = d.parent()?.to_path_buf();
    }
    statvfs_free(&d)
}

#[cfg(target_os = "linux")]
fn statvfs_free(dir: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c` is a NUL-terminated path and `st` points to writable
    // memory of the structure's size, which statvfs fills on success.
    let r = unsafe { libc::statvfs(c.as_ptr(), st.as_mut_ptr()) };
    if r != 0 {
        return None;
    }
    // SAFETY: initialised by the successful call above.
    let st = unsafe { st.assume_init() };
    // The fields' integer types differ between platforms.
    #[allow(clippy::unnecessary_cast)]
    Some(st.f_bavail as u64 * st.f_frsize as u64)
}

#[cfg(not(target_os = "linux"))]
fn statvfs_free(_dir: &Path) -> Option<u64> {
    None
}

/// Memory the system can give a new program without swapping
/// (`MemAvailable` of `/proc/meminfo`), bytes; `None` where unknown.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Bytes in words: `1.5 GB`, `830 MB`, `12 kB`.
pub fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1e12 {
        format!("{:.1} TB", b / 1e12)
    } else if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.1} MB", b / 1e6)
    } else if b >= 1e3 {
        format!("{:.0} kB", b / 1e3)
    } else {
        format!("{b:.0} B")
    }
}

impl Budget {
    /// The problems of running this into `dir` given `free` bytes on its
    /// file system and `memory` bytes available (either unknown: not
    /// checked); `share` is the part of the run still to do (1 for a fresh
    /// run).
    pub fn shortfalls(
        &self,
        dir: &Path,
        free: Option<u64>,
        memory: Option<u64>,
        share: f64,
    ) -> Vec<String> {
        let mut out = Vec::new();
        let need = (self.total_bytes as f64 * share) as u64;
        if let Some(free) = free
            && need > free
        {
            out.push(format!(
                "the run would write about {} ({} points) but the file system of {} has {} free",
                human_bytes(need),
                self.points,
                dir.display(),
                human_bytes(free)
            ));
        }
        if let Some(mem) = memory
            && self.memory_bytes > mem
        {
            out.push(format!(
                "the run would need about {} of memory but {} is available",
                human_bytes(self.memory_bytes),
                human_bytes(mem)
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_and_human_bytes() {
        assert_eq!(digits(0.5), 1);
        assert_eq!(digits(9.99), 1);
        assert_eq!(digits(10.0), 2);
        assert_eq!(digits(-123456.7), 6);
        assert_eq!(human_bytes(1_500_000_000), "1.5 GB");
        assert_eq!(human_bytes(830_000_000), "830.0 MB");
        assert_eq!(human_bytes(12_000), "12 kB");
    }

    #[test]
    fn shortfalls_name_disk_and_memory() {
        let b = Budget {
            pulses: 10,
            points: 10,
            crown_cover: 0.0,
            layout_files: 1,
            files: Vec::new(),
            total_bytes: 2_000_000_000,
            memory_bytes: 3_000_000_000,
        };
        let d = Path::new("/out");
        assert!(
            b.shortfalls(d, Some(3_000_000_000), Some(4_000_000_000), 1.0)
                .is_empty()
        );
        let s = b.shortfalls(d, Some(1_000_000_000), Some(1_000_000_000), 1.0);
        assert_eq!(s.len(), 2, "{s:?}");
        assert!(
            s[0].contains("2.0 GB") && s[0].contains("1.0 GB free"),
            "{s:?}"
        );
        assert!(s[1].contains("3.0 GB of memory"), "{s:?}");
        // Half of the run done: half the bytes still to write.
        assert!(b.shortfalls(d, Some(1_500_000_000), None, 0.5).is_empty());
        assert!(b.shortfalls(d, None, None, 1.0).is_empty());
    }
}
