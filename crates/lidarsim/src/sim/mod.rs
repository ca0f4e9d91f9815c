//! The simulation driver: pulses in, points out.
//!
//! A pulse `k` of a flight line runs through the stages of `sim/pulse.rs`: pose
//! and mirror angle at `t_k` → sub-rays → closest hits → Eq. 2 per sub-ray
//! (through the crowns, with speckle) → waveform → echoes → georeferenced
//! points (Eq. 1 on the central ray) with their ground truth (`sim/truth.rs`).
//! Pulses are independent; blocks of [`BLOCK_PULSES`] run in parallel on
//! the run's threads and are handed to the sinks in pulse order by the
//! [`Executor`], so the output is the same for any number of threads and
//! memory does not grow with the length of the flight.

mod cone;
mod executor;
mod frames;
pub mod parts;
mod pulse;
mod scratch;
mod truth;

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::accel::RayCaster;
use crate::canopy::CanopyConfig;
use crate::detection::Detector;
use crate::geometry::DMat3;
use crate::output::{PointRecord, PointSink, WaveformBlock, WaveformPacket};
use crate::radiometry::Speckle;
use crate::scene::Material;
use crate::sensor::beam::Beam;
use crate::sensor::channel::{Channel, FiringOrder};
use crate::sensor::platform::FlightLine;
use crate::survey::{ScannerSettings, Survey};
use crate::waveform::Receiver;
use crate::world::World;
pub use executor::{Executor, InOrder};
pub use scratch::PulseDetail;
pub(crate) use scratch::Scratch;
pub use truth::ReturnSource;

/// ASPRS class of an echo no surface contributed to (receiver noise).
pub const NOISE_CLASS: u8 = 7;

/// Pulses per parallel work unit.
pub const BLOCK_PULSES: u64 = 2048;

/// Counts gathered while simulating.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunCounts {
    /// Pulses emitted.
    pub pulses: u64,
    /// Pulse slots simulated: every tick `k / PRF`, a polygon's silent
    /// ones included (what progress counts and where a resumed run goes
    /// on).
    pub pulse_slots: u64,
    /// Points written.
    pub points: u64,
    /// Pulses with at least one echo.
    pub pulses_with_echo: u64,
    /// Points by return number (index 0 = first return).
    pub points_by_return: [u64; 15],
}

impl RunCounts {
    /// Adds the counts of `o`.
    pub fn add(&mut self, o: &RunCounts) {
        self.pulses += o.pulses;
        self.pulse_slots += o.pulse_slots;
        self.points += o.points;
        self.pulses_with_echo += o.pulses_with_echo;
        for (a, b) in self.points_by_return.iter_mut().zip(o.points_by_return) {
            *a += b;
        }
    }
}

/// Everything needed to simulate pulses of one survey.
pub struct Simulator<'a> {
    survey: &'a Survey,
    caster: &'a dyn RayCaster,
    /// The ground-class surfaces alone, when the world indexes them apart.
    ground: Option<&'a dyn RayCaster>,
    lines: &'a [FlightLine],
    receiver: Receiver,
    detector: Detector,
    /// The sub-ray patterns of each channel's beam (one when all channels
    /// share their divergence).
    beams: Vec<Beam>,
    /// Range difference between neighbouring sub-rays that makes their
    /// cells be sampled again: the range resolution, `c·FWHM/2` (closer
    /// surfaces merge into one echo whatever their share).
    discontinuity_m: f64,
    speckle: Option<Speckle>,
    canopy: CanopyConfig,
    time_offset_s: f64,
    /// Keep each pulse's waveform for the sinks (full-waveform output).
    record_waveforms: bool,
    /// Boresight misalignment of the real scanner (identity without).
    boresight: DMat3,
    /// True when no navigation or measurement error is configured.
    exact_georeferencing: bool,
    /// Mounting rotation of each channel of a multi-channel head; empty
    /// for the single straight channel of most scanners.
    mounts: Vec<DMat3>,
    /// Which channel fires each pulse.
    firing: FiringOrder,
    /// Reflectance of each material at each channel's wavelength
    /// (`[channel][material]`; one row when the channels share theirs).
    reflectance: Vec<Vec<f64>>,
}

/// One beam per channel, or one for all when their divergences agree.
fn beams(s: &ScannerSettings) -> Vec<Beam> {
    let beam = |c: &Channel| Beam::elliptical(s.subrays, c.divergence_rad, c.divergence_along_rad);
    match s.channels.as_slice() {
        [first, rest @ ..]
            if rest.iter().all(|c| {
                (c.divergence_rad, c.divergence_along_rad)
                    == (first.divergence_rad, first.divergence_along_rad)
            }) =>
        {
            vec![beam(first)]
        }
        [] => vec![Beam::elliptical(
            s.subrays,
            s.divergence_rad,
            s.divergence_along_rad,
        )],
        channels => channels.iter().map(beam).collect(),
    }
}

/// The reflectance of every material at each channel's wavelength, one
/// row when the channels share their wavelength.
fn reflectance(s: &ScannerSettings, materials: &[Material]) -> Vec<Vec<f64>> {
    let row = |nm: f64| materials.iter().map(|m| m.reflectance_at(nm)).collect();
    match s.channels.as_slice() {
        [first, rest @ ..] if rest.iter().all(|c| c.wavelength_nm == first.wavelength_nm) => {
            vec![row(first.wavelength_nm)]
        }
        [] => vec![row(s.wavelength_nm)],
        channels => channels.iter().map(|c| row(c.wavelength_nm)).collect(),
    }
}

impl<'a> Simulator<'a> {
    /// Prepares the receiver, detector and beam pattern of `survey` over the
    /// scene indexed by `caster`.
    pub fn new(survey: &'a Survey, world: &'a World) -> Self {
        let receiver = Receiver::new(survey.receiver.clone());
        let detector = Detector::new(survey.detector.clone(), &receiver);
        Self {
            survey,
            caster: world.index(),
            ground: world.ground_index().map(|g| g as &dyn RayCaster),
            lines: &world.lines,
            beams: beams(&survey.scanner),
            discontinuity_m: crate::geometry::SPEED_OF_LIGHT_MPS * survey.receiver.pulse.fwhm_s()
                / 2.0,
            speckle: survey.speckle_looks.and_then(Speckle::new),
            canopy: survey.canopy,
            boresight: survey.navigation.boresight(),
            exact_georeferencing: survey.navigation.is_zero(),
            mounts: match survey.scanner.channels.as_slice() {
                [c] if c.is_straight() => Vec::new(),
                channels => channels.iter().map(|c| c.mount()).collect(),
            },
            firing: FiringOrder::new(&survey.scanner.channels),
            reflectance: reflectance(&survey.scanner, &world.scene().materials),
            receiver,
            detector,
            time_offset_s: survey.output.gps_start_time_s.unwrap_or(0.0),
            record_waveforms: false,
        }
    }

    /// Makes [`Simulator::run`] hand every pulse's recorded waveform to the
    /// sinks with its points ([`PointSink::write_block`]); off by default,
    /// when it costs nothing.
    pub fn with_waveforms(mut self, on: bool) -> Self {
        self.record_waveforms = on;
        self
    }

    /// The survey.
    pub fn survey(&self) -> &Survey {
        self.survey
    }

    /// The receiver.
    pub fn receiver(&self) -> &Receiver {
        &self.receiver
    }

    /// The echo detector.
    pub fn detector(&self) -> &Detector {
        &self.detector
    }

    /// Time of emission of pulse `k` of `line` since the flight start, s
    /// (`t_k = t_0 + k / PRF`, computed from the integer tick).
    #[inline]
    pub fn pulse_time(&self, line: &FlightLine, k: u64) -> f64 {
        line.start_time_s + k as f64 / self.survey.scanner.prf_hz
    }

    /// Simulates pulse `k` of `line` on its own (the pulse of a run: every
    /// random number of a pulse is keyed by the pulse) and keeps what it
    /// left: its waveform, echoes, sub-ray returns and points.
    pub fn replay(&self, line: &FlightLine, k: u64) -> PulseDetail {
        let mut scratch = Scratch::default();
        let mut points = Vec::new();
        let emitted = self
            .simulate_pulse(line, k, &mut scratch, &mut points)
            .is_some();
        scratch.detail(emitted, points)
    }

    /// Simulates pulses `[k0, k1)` of `line` into `points`; with
    /// `waveforms`, also keeps the waveform of every pulse that has an echo
    /// there (the whole window the receiver synthesised: from before the
    /// first sub-ray return by the pulse's rise to after the last by its
    /// tail, see [`Receiver::synthesize`]). Both are cleared first, so that
    /// a caller can give the same buffers block after block.
    // Kept out of line: profiles (scripts/profile_bench.sh) count the
    // instructions under it, whatever the inlining around it.
    #[inline(never)]
    pub(crate) fn simulate_block_recording(
        &self,
        line: &FlightLine,
        k0: u64,
        k1: u64,
        scratch: &mut Scratch,
        points: &mut Vec<PointRecord>,
        mut waveforms: Option<&mut WaveformBlock>,
    ) -> RunCounts {
        points.clear();
        points.reserve(((k1 - k0) as usize) * 2);
        if let Some(w) = waveforms.as_deref_mut() {
            w.packets.clear();
            w.samples.clear();
        }
        let mut counts = RunCounts::default();
        let bin_ps = self.survey.receiver.bin_s * 1e12;
        for k in k0..k1 {
            counts.pulse_slots += 1;
            // A polygon's ticks in its dead time emit nothing.
            let Some(n) = self.simulate_pulse(line, k, scratch, points) else {
                continue;
            };
            counts.pulses += 1;
            if n > 0 {
                counts.pulses_with_echo += 1;
                if let Some(w) = waveforms.as_deref_mut() {
                    let wf = &scratch.waveform;
                    w.packets.push(WaveformPacket {
                        point_source_id: (line.index + 1).min(u16::MAX as u32) as u16,
                        pulse_index: k,
                        first_sample_ps: wf.first_bin as f64 * bin_ps,
                        start: w.samples.len(),
                        len: wf.samples.len(),
                    });
                    w.samples.extend(wf.samples.iter().map(|&v| v as f32));
                }
            }
        }
        counts.points = points.len() as u64;
        for p in points.iter() {
            counts.points_by_return[usize::from(p.return_number.clamp(1, 15)) - 1] += 1;
        }
        counts
    }

    /// Simulates every pulse of every flight line on `threads` threads and
    /// writes the points, in pulse order, to `sinks`. The calling thread is
    /// one of the `threads`: it writes each block as soon as the blocks
    /// before it are written and simulates blocks in between, so one
    /// thread runs everything in turn on the caller.
    /// `progress` is called with the number of pulses done so far.
    /// The sinks are not finished here.
    pub fn run<E>(
        &self,
        threads: usize,
        sinks: &mut [&mut (dyn PointSink<Error = E> + 'static)],
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<RunCounts, E> {
        self.run_from(threads, sinks, progress, &RunControl::default())
            .map(|o| o.counts)
    }

    /// [`Simulator::run`] from `control.start` on, stopping at the next
    /// block boundary once `control.stop` is set (checked before every
    /// block a thread takes; the blocks already simulated are written
    /// first, as far as they follow each other).
    /// The counts are those of the pulses simulated by this call; the
    /// outcome says where it stopped, if it did. The first error of a
    /// sink stops the run and is returned.
    pub fn run_from<E>(
        &self,
        threads: usize,
        sinks: &mut [&mut (dyn PointSink<Error = E> + 'static)],
        progress: &(dyn Fn(u64) + Sync),
        control: &RunControl<'_>,
    ) -> Result<RunOutcome, E> {
        let blocks = self.blocks(control);
        self.run_jobs(blocks, threads.max(1), sinks, progress, control)
    }

    /// The blocks to simulate, in output order, within the pulse budget
    /// (a block is taken while fewer pulses than the budget precede it),
    /// and where the budget ends them, if it does.
    fn blocks(&self, control: &RunControl<'_>) -> (Vec<BlockJob>, Option<PulsePosition>) {
        let whole: Vec<parts::PulseRange> = match control.only {
            Some(_) => Vec::new(),
            None => self
                .lines
                .iter()
                .enumerate()
                .map(|(line, l)| parts::PulseRange {
                    line,
                    start: 0,
                    end: self.survey.pulses_of(l),
                })
                .collect(),
        };
        let ranges = control.only.unwrap_or(&whole);
        let mut jobs = Vec::new();
        let mut budget_end = None;
        let mut sent = 0u64;
        'lines: for r in ranges {
            let (l, n) = (
                r.line,
                r.end.min(self.survey.pulses_of(&self.lines[r.line])),
            );
            if (l, n) <= (control.start.line, control.start.pulse) {
                continue;
            }
            let mut k = if l == control.start.line {
                control.start.pulse.max(r.start)
            } else {
                r.start
            };
            while k < n {
                if control.pulse_budget.is_some_and(|b| sent >= b) {
                    budget_end = Some(PulsePosition { line: l, pulse: k });
                    break 'lines;
                }
                let k1 = (k + BLOCK_PULSES).min(n);
                jobs.push(BlockJob {
                    line: l,
                    start: k,
                    end: k1,
                });
                sent += k1 - k;
                k = k1;
            }
        }
        (jobs, budget_end)
    }

    /// Runs `jobs` in order into `sinks` (see [`Simulator::run_from`]);
    /// returns where the run stopped early, if it did (`budget_end` when
    /// every job ran).
    fn run_jobs<E>(
        &self,
        (jobs, budget_end): (Vec<BlockJob>, Option<PulsePosition>),
        threads: usize,
        sinks: &mut [&mut (dyn PointSink<Error = E> + 'static)],
        progress: &(dyn Fn(u64) + Sync),
        control: &RunControl<'_>,
    ) -> Result<RunOutcome, E> {
        let stopped = || control.stop.is_some_and(|s| s.load(Ordering::SeqCst));
        // Blocks in order to every sink, at most 4 per thread ahead of the
        // writer (executor.rs).
        let executor = Executor {
            threads,
            window: 4 * threads,
            stop: &stopped,
        };
        // The writer hands each block back once written, and the next job
        // fills it again: a block's buffers (some 660 KB of points) are
        // allocated once per block in flight, not once per block. An
        // allocator that gives large blocks back to the system at once
        // (glibc with MALLOC_TRIM_THRESHOLD_ set, as Dask's workers are)
        // would otherwise map them and fault them in for every block.
        let spare = Mutex::new(Vec::new());
        let mut writer = Writer {
            sinks,
            total: RunCounts::default(),
            progress,
            spare: &spare,
        };
        let done = executor.run(
            jobs.len(),
            Scratch::default,
            |j, scratch| {
                let BlockJob { line, start, end } = jobs[j];
                let mut block: Block = lock(&spare).pop().unwrap_or_default();
                let Block {
                    points,
                    counts,
                    waves,
                } = &mut block;
                let record = self.record_waveforms.then_some(waves);
                *counts = self.simulate_block_recording(
                    &self.lines[line],
                    start,
                    end,
                    scratch,
                    points,
                    record,
                );
                block
            },
            &mut writer,
        )?;
        // Stopped early when blocks remain unwritten; a stop requested
        // after the last block changes nothing.
        let stopped_at = match jobs.get(done) {
            Some(job) => Some(PulsePosition {
                line: job.line,
                pulse: job.start,
            }),
            None => budget_end,
        };
        Ok(RunOutcome {
            counts: writer.total,
            stopped_at,
        })
    }
}

/// A block of pulses to simulate: pulses `start..end` of flight line
/// `line` (its index).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BlockJob {
    /// Index of the flight line.
    pub line: usize,
    /// First pulse slot.
    pub start: u64,
    /// One past the last pulse slot.
    pub end: u64,
}

/// The points, counts and waveforms of one block of pulses.
#[derive(Default)]
struct Block {
    points: Vec<PointRecord>,
    counts: RunCounts,
    waves: WaveformBlock,
}

/// Writes blocks in pulse order to every sink, counting them.
struct Writer<'s, 'p, E> {
    sinks: &'s mut [&'p mut (dyn PointSink<Error = E> + 'static)],
    total: RunCounts,
    progress: &'s (dyn Fn(u64) + Sync),
    /// Written blocks, for the next jobs to fill again.
    spare: &'s Mutex<Vec<Block>>,
}

impl<E> InOrder<Block> for Writer<'_, '_, E> {
    type Error = E;

    fn take(&mut self, _: usize, block: Block) -> Result<(), E> {
        for sink in self.sinks.iter_mut() {
            sink.write_block(&block.points, &block.waves)?;
        }
        self.total.add(&block.counts);
        lock(self.spare).push(block);
        Ok(())
    }

    fn caught_up(&mut self) {
        (self.progress)(self.total.pulse_slots);
    }
}

/// The spare blocks, whether or not a thread panicked holding them (they
/// are emptied before use).
fn lock(spare: &Mutex<Vec<Block>>) -> std::sync::MutexGuard<'_, Vec<Block>> {
    spare.lock().unwrap_or_else(|e| e.into_inner())
}

/// A pulse of a survey: flight line (0-based index) and pulse within it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PulsePosition {
    /// Index of the flight line (0 = first).
    pub line: usize,
    /// Pulse index within the line.
    pub pulse: u64,
}

/// Where [`Simulator::run_from`] starts and what makes it stop early.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunControl<'a> {
    /// First pulse to simulate (the pulses before it are skipped).
    pub start: PulsePosition,
    /// Set (by a signal handler, say) to stop at the next block boundary.
    pub stop: Option<&'a AtomicBool>,
    /// Stop once this many pulses were simulated, rounded up to a whole
    /// block (at the end of a line, where the line ends): a run in slices.
    pub pulse_budget: Option<u64>,
    /// Simulate only these pulses, in this order (a part of a split
    /// survey, [`parts`]); `None`: every pulse of every line.
    pub only: Option<&'a [parts::PulseRange]>,
}

/// What [`Simulator::run_from`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunOutcome {
    /// Counts of the pulses simulated by this call.
    pub counts: RunCounts,
    /// The first pulse not simulated when the run was stopped early; `None`
    /// when it reached the end of the survey.
    pub stopped_at: Option<PulsePosition>,
}

/// Simulates a whole survey into memory on `threads` threads: its world
/// built, every pulse, the points in pulse order. For tests and small
/// surveys; [`crate::run::run`] streams to files instead.
pub fn simulate_to_memory(
    survey: &Survey,
    threads: usize,
) -> Result<Vec<PointRecord>, crate::survey::SurveyError> {
    let world = World::build(survey)?;
    Ok(simulate_world_to_memory(survey, &world, threads))
}

/// Simulates a survey over a world already built (its lines perhaps
/// changed since) into memory on `threads` threads, the points in pulse
/// order.
pub fn simulate_world_to_memory(
    survey: &Survey,
    world: &World,
    threads: usize,
) -> Vec<PointRecord> {
    let sim = Simulator::new(survey, world);
    let mut sink = crate::output::MemorySink::default();
    let Ok(_) = sim.run(threads, &mut [&mut sink], &|_| {});
    sink.points
}

/// Wall-clock timing helper for summaries.
#[derive(Debug)]
pub struct Timer(Instant);

impl Timer {
    /// Starts timing.
    pub fn start() -> Self {
        Self(Instant::now())
    }

    /// Seconds since the start.
    pub fn seconds(&self) -> f64 {
        self.0.elapsed().as_secs_f64()
    }
}
