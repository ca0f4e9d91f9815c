//! What a run will cost before it runs: the size of every file it writes
//! and the memory it needs, and whether the machine has them.
//!
//! Points, waveform samples and text bytes are measured on a sample of the
//! survey's own pulses ([`SAMPLE_SLOTS`] pulse slots in [`STRETCH`]-slot
//! stretches spread over the whole flight, one stretch at a varying place
//! in each equal share of it), simulated exactly as the run will simulate
//! them, and scaled to every pulse slot: the estimate follows whatever the
//! physics gives (a canopy's extra returns, pulses that miss the scene),
//! within a few per cent for surveys whose scene does not change abruptly
//! between the stretches. A survey of at most that many slots is
//! simulated whole, and its estimate is exact. LAS and PLY sizes follow
//! exactly from the points; LAZ is taken as two fifths of the LAS file;
//! the trajectories are formatted row by row; the report is bounded from
//! above ([`FileEstimate::at_most`]). Memory follows from the scene as
//! loaded, its index, the per-thread buffers of the receiver and the
//! sinks' buffers.

use std::path::Path;

use serde::Serialize;

use crate::output::{WAVEFORM_BITS, WDP_HEADER_LEN, WaveformBlock};
use crate::scene::{Scene, Shape};
use crate::sensor::platform::FlightLine;
use crate::sim::BlockJob;
use crate::survey::Survey;
use crate::waveform::range_to_bin;
use crate::world::World;

/// Pulse slots of the sample simulated to estimate a run (the whole
/// survey when it has no more).
pub const SAMPLE_SLOTS: u64 = 4096;

/// Consecutive pulse slots of each stretch of the sample: short enough
/// for many stretches, long enough to cover a scan pattern's neighbours.
pub const STRETCH: u64 = 32;

/// Bytes of index (bounding volume hierarchy) per primitive at its peak
/// during the build: the binary tree, the primitives' boxes and centroids,
/// and the eight-wide tree it is collapsed into.
const INDEX_BYTES_PER_PRIMITIVE: u64 = 128;

/// Pixels of the report's maps at most (see `report::ReportSink`).
const REPORT_MAP_PIXELS: f64 = 500_000.0;

/// Bytes of the report besides its maps at most: the text, the tables
/// and the plots drawn as SVG.
const REPORT_FIXED_BYTES: u64 = 1 << 20;

/// Memory the report gathers while a run lasts at most, bytes (its
/// maps' pixels and the cross-section's points).
const REPORT_MEMORY: u64 = 8 << 20;

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
    /// Whether `bytes` is an upper bound rather than an estimate (the
    /// report, whose pictures compress by what they show).
    pub at_most: bool,
}

/// The expected cost of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Budget {
    /// Pulses that fire.
    pub pulses: u64,
    /// Expected points: the sample's points per pulse slot times the slots.
    pub points: u64,
    /// Pulse slots simulated for the estimate.
    pub sampled_slots: u64,
    /// Points per pulse slot in the sample.
    pub points_per_slot: f64,
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

/// What the sample of a survey's pulses gave.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sample {
    /// Pulse slots simulated.
    slots: u64,
    /// Points they gave.
    points: u64,
    /// Waveform samples kept for the pulses with an echo.
    waveform_samples: u64,
    /// Pulses with an echo (a waveform record each).
    waveforms: u64,
    /// Bytes of their lines in `points.xyz`.
    xyz_bytes: u64,
}

/// The stretches of the sample over `slots_per_line`: `(line, first slot,
/// end)`. The slots of all lines, one line after the other, are cut into
/// equal shares, one stretch in each, at a place that moves from share to
/// share by the golden ratio (so that it does not keep the same phase of a
/// periodic scan pattern).
fn sample_stretches(slots_per_line: &[u64]) -> Vec<BlockJob> {
    let total: u64 = slots_per_line.iter().sum();
    let whole = |(line, &end): (usize, &u64)| {
        (end > 0).then_some(BlockJob {
            line,
            start: 0,
            end,
        })
    };
    if total <= SAMPLE_SLOTS {
        return slots_per_line
            .iter()
            .enumerate()
            .filter_map(whole)
            .collect();
    }
    let count = SAMPLE_SLOTS / STRETCH;
    let share = total as f64 / count as f64;
    let golden = 0.618_033_988_749_894_9;
    let mut out = Vec::with_capacity(count as usize);
    for i in 0..count {
        let room = (share - STRETCH as f64).max(0.0);
        let at = (i as f64 * share + (i as f64 * golden).fract() * room) as u64;
        // The global slot `at` in its line.
        let (mut line, mut k) = (0, at.min(total - 1));
        while k >= slots_per_line[line] {
            k -= slots_per_line[line];
            line += 1;
        }
        out.push(BlockJob {
            line,
            start: k,
            end: (k + STRETCH).min(slots_per_line[line]),
        });
    }
    out
}

/// Simulates the sample's stretches on the calling thread.
fn sample(survey: &Survey, world: &World, line_pulses: &[u64]) -> Sample {
    let lines = &world.lines[..];
    let waveforms = survey.output.formats.las_waveform;
    let sim = crate::sim::Simulator::new(survey, world).with_waveforms(waveforms);
    let mut scratch = crate::sim::Scratch::default();
    let (mut points, mut block, mut text) = (Vec::new(), WaveformBlock::default(), Vec::new());
    let origin = survey.output.offset_m.to_array();
    let mut s = Sample::default();
    for job in sample_stretches(line_pulses) {
        let record = waveforms.then_some(&mut block);
        let line = &lines[job.line];
        let counts = sim.simulate_block_recording(
            line,
            job.start,
            job.end,
            &mut scratch,
            &mut points,
            record,
        );
        s.slots += counts.pulse_slots;
        s.points += counts.points;
        s.waveforms += counts.pulses_with_echo;
        s.waveform_samples += block.packets.iter().map(|p| p.len as u64).sum::<u64>();
        text.clear();
        crate::output::push_xyz_lines(&mut text, &points, origin);
        s.xyz_bytes += text.len() as u64;
    }
    s
}

/// Rows of each flight line's trajectory formatted for the estimate, at
/// most (the others are taken as long as these on average).
const TRAJECTORY_SAMPLE_ROWS: u64 = 1024;

/// Bytes of a trajectory file of `lines`: of each line, up to
/// [`TRAJECTORY_SAMPLE_ROWS`] of its rows spread over it formatted as the
/// writer formats them, scaled to all its rows (the flown trajectory's;
/// the observed one's differ by a sign here and there). Exact for lines of
/// no more rows; a day-long line is not listed row by row.
fn trajectory_bytes(survey: &Survey, lines: &[FlightLine]) -> u64 {
    let o = &survey.output;
    let (offset, dt) = (o.gps_start_time_s.unwrap_or(0.0), o.trajectory_interval_s);
    let mut row = Vec::with_capacity(128);
    let mut bytes = crate::files::TRAJECTORY_HEADER.len() as f64;
    for line in lines {
        let rows = (line.duration_s() / dt).floor() as u64 + 1;
        let taken = rows.min(TRAJECTORY_SAMPLE_ROWS);
        let mut sampled = 0u64;
        for i in 0..taken {
            let j = i * rows / taken;
            let t = j as f64 * dt;
            let p = line.pose_at(t);
            row.clear();
            crate::files::TrajectoryRow {
                gps_time_s: offset + line.start_time_s + t,
                position_m: p.position_m + o.offset_m,
                attitude_deg: [
                    p.attitude.roll_rad.to_degrees(),
                    p.attitude.pitch_rad.to_degrees(),
                    p.attitude.yaw_rad.to_degrees(),
                ],
                line: line.index + 1,
            }
            .push_csv(&mut row);
            sampled += row.len() as u64;
        }
        bytes += sampled as f64 * rows as f64 / taken.max(1) as f64;
    }
    bytes.round() as u64
}

/// The most bytes `report.html` takes: its maps (height, intensity, class
/// and density, at most [`REPORT_MAP_PIXELS`] each, over the area the
/// lines reach at about four points per pixel), stored as PNG in base64 no
/// larger than their raw pixels, the cross-section, and the rest.
fn report_bytes(survey: &Survey, world: &World, density_per_m2: f64) -> u64 {
    let area = crate::world::reachable_area(survey, world.scene_bounds(), &world.lines);
    let pixels = if area.is_empty() {
        0.0
    } else {
        let res = (4.0 / density_per_m2.max(1e-6)).sqrt().max(0.05);
        ((area.extent().x / res + 2.0) * (area.extent().y / res + 2.0)).min(REPORT_MAP_PIXELS)
    };
    let profile = 8192.0 * 300.0;
    let base64 = 4.0 / 3.0;
    ((4.0 * pixels + profile) * 3.0 * base64) as u64 + REPORT_FIXED_BYTES
}

/// Estimates the run of `survey` over `world` on `threads` threads (see
/// the module documentation): a sample of its pulses is simulated on the
/// calling thread.
pub fn estimate(survey: &Survey, world: &World, line_pulses: &[u64], threads: usize) -> Budget {
    let (scene, lines) = (world.scene(), &world.lines[..]);
    let o = &survey.output;
    let f = &o.formats;
    let slots: u64 = line_pulses.iter().sum();
    let plan = crate::plan::plan(survey, world);
    let sample = sample(survey, world, line_pulses);
    // Per pulse slot of the sample, times the survey's slots.
    let scaled = |v: u64| (v as f64 * slots as f64 / sample.slots.max(1) as f64).round() as u64;
    let points = scaled(sample.points);
    let b = world.scene_bounds();
    let mut files = Vec::new();
    let mut add = |name: &str, bytes: u64, at_most: bool| {
        files.push(FileEstimate {
            name: name.to_string(),
            bytes,
            at_most,
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
        let name = if single { "points.las" } else { "LAS files" };
        add(name, s.file_len(points) + headers, false);
    }
    if f.las_waveform {
        let samples = scaled(sample.waveform_samples);
        add(
            "points.wdp",
            WDP_HEADER_LEN + samples * u64::from(WAVEFORM_BITS / 8),
            false,
        );
    }
    if f.laz {
        // LASzip keeps a third or less of the bytes of airborne points.
        let name = if single { "points.laz" } else { "LAZ files" };
        add(name, las.file_len(points) * 2 / 5 + headers, false);
    }
    if f.ply {
        add(
            "points.ply",
            crate::output::PlyWriter::file_len(points),
            false,
        );
    }
    if f.xyz {
        let header = crate::output::XYZ_COLUMNS.len() as u64 + 1;
        add("points.xyz", header + scaled(sample.xyz_bytes), false);
    }
    let trajectory = trajectory_bytes(survey, lines);
    for name in ["trajectory_true.csv", "trajectory_observed.csv"] {
        add(name, trajectory, false);
    }
    add(
        "report.html",
        report_bytes(survey, world, plan.point_density_per_m2),
        true,
    );
    let total_bytes = files.iter().map(|f| f.bytes).sum();
    let per_slot = sample.points as f64 / sample.slots.max(1) as f64;
    Budget {
        pulses: plan.pulses,
        points,
        sampled_slots: sample.slots,
        points_per_slot: per_slot,
        layout_files,
        files,
        total_bytes,
        memory_bytes: memory_bytes(survey, scene, threads, per_slot),
    }
}

/// Peak memory of a run on `threads` threads giving `per_slot` points per
/// pulse slot: the scene, its index, and per thread the receiver's record
/// (samples, impulses, background and detection: four f64 buffers) of the
/// longest pulse window, the ordering window of blocks of points, the
/// sinks' buffers and the report.
fn memory_bytes(survey: &Survey, scene: &Scene, threads: usize, per_slot: f64) -> u64 {
    let threads = threads.max(1) as u64;
    let window = (range_to_bin(
        survey.scanner.max_range_m - survey.scanner.min_range_m,
        survey.receiver.bin_s,
    ) + 64.0)
        .min(crate::survey::MAX_WINDOW_SAMPLES as f64) as u64;
    let per_thread = 4 * 8 * window + (1 << 20);
    let block_points = (crate::sim::BLOCK_PULSES as f64 * per_slot.max(1.0)) as u64;
    let ordering = WINDOW_BLOCKS_PER_THREAD
        * threads
        * block_points
        * std::mem::size_of::<crate::output::PointRecord>() as u64;
    let sinks = 4 << 20;
    BASE_MEMORY
        + scene_bytes(scene)
        + scene.primitives.len() as u64 * INDEX_BYTES_PER_PRIMITIVE
        + threads * per_thread
        + ordering
        + sinks
        + REPORT_MEMORY
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
    fn human_bytes_in_words() {
        assert_eq!(human_bytes(1_500_000_000), "1.5 GB");
        assert_eq!(human_bytes(830_000_000), "830.0 MB");
        assert_eq!(human_bytes(12_000), "12 kB");
    }

    #[test]
    fn shortfalls_name_disk_and_memory() {
        let b = Budget {
            pulses: 10,
            points: 10,
            sampled_slots: 10,
            points_per_slot: 1.0,
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
