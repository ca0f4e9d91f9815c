//! `summary.json`: what a run did, the parameters it used and what it
//! expected (the plan), and, for an interrupted run, where to go on.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::budget::Budget;
use crate::flight::Flight;
use crate::plan::Plan;
use crate::sim::{PulsePosition, RunCounts};

/// Contents of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Version of the simulator.
    pub lidarsim_version: &'static str,
    /// True when every pulse was simulated and every file written; false
    /// for a run that was interrupted (see `next_pulse`): its point files
    /// are then complete for the pulses simulated but keep their
    /// `.partial` names.
    pub complete: bool,
    /// Whether `lidarsim run --resume` can continue this run when it is
    /// interrupted (not when it writes LAZ).
    pub resumable: bool,
    /// Of an interrupted run: the first pulse not simulated, where
    /// `lidarsim run --resume` continues (flight line 1 is the first).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub next_pulse: Option<NextPulse>,
    /// Of an interrupted run: the state of its files, which a resumed run
    /// checks before it appends to them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resume: Option<ResumeState>,
    /// Seed of the random streams.
    pub seed: u64,
    /// Threads the run used (the one that wrote the output among them).
    pub threads: usize,
    /// Pulses emitted.
    pub pulses: u64,
    /// Pulse slots simulated: `pulses` and a polygon's silent ticks.
    pub pulse_slots: u64,
    /// Points written.
    pub points: u64,
    /// Pulses with at least one echo.
    pub pulses_with_echo: u64,
    /// Points by return number (first, second, …).
    pub points_by_return: Vec<u64>,
    /// Sub-rays per pulse.
    pub subrays_per_pulse: usize,
    /// Laser wavelength, nm (for the record: reflectances are given at it).
    pub wavelength_nm: f64,
    /// Wall-clock time of the simulation (scene indexing excluded), s;
    /// summed over the sessions of a resumed run.
    pub wall_time_s: f64,
    /// Time to build the acceleration structure, s.
    pub index_time_s: f64,
    /// Simulated pulses per wall-clock second.
    pub pulses_per_second: f64,
    /// Expected swath width (pulse-weighted mean over lines), m.
    pub swath_width_m: f64,
    /// Expected point density of one line, per m².
    pub point_density_per_m2: f64,
    /// Expected nadir footprint diameter, m.
    pub footprint_diameter_m: f64,
    /// What the GPS time of the points means.
    pub gps_time: &'static str,
    /// LAS intensity per unit of echo energy amplitude.
    pub intensity_gain: f64,
    /// Reference range of Eq. 2, m.
    pub reference_range_m: f64,
    /// Primitives in the scene.
    pub scene_primitives: usize,
    /// Files written, relative to the output directory (an interrupted
    /// run's point files under their `.partial` names).
    pub files: Vec<String>,
    /// Warnings about the survey (see `lidarsim check`).
    pub warnings: Vec<String>,
    /// Trees placed by each `[[forest]]` entry.
    pub forest_trees: Vec<usize>,
    /// The expected figures per flight line.
    pub plan: Plan,
    /// The expected points, file sizes and memory of the run.
    pub estimate: Budget,
}

/// What a run measured, beside its flight.
pub struct Measured {
    /// Counts over every session of the run.
    pub counts: RunCounts,
    /// Threads of this session.
    pub threads: usize,
    /// Simulation time over every session, s.
    pub wall_time_s: f64,
    /// The expected cost of the run.
    pub estimate: Budget,
}

impl Summary {
    /// The summary of a complete run of `flight` that wrote `files` (the
    /// interrupted fields unset), with the flight's warnings and one when
    /// the run recorded no point.
    pub fn of(flight: &Flight, m: &Measured, files: Vec<String>) -> Self {
        let (survey, world, plan) = (flight.survey(), flight.world(), flight.plan().clone());
        let counts = &m.counts;
        let last = counts
            .points_by_return
            .iter()
            .rposition(|&n| n > 0)
            .map_or(0, |i| i + 1);
        let mut warnings = flight.warnings().to_vec();
        warnings.extend(no_point_warning(counts.pulses, counts.points));
        Summary {
            lidarsim_version: env!("CARGO_PKG_VERSION"),
            complete: true,
            resumable: !survey.output.formats.laz
                && survey.output.layout == crate::survey::Layout::Single,
            next_pulse: None,
            resume: None,
            seed: survey.seed,
            threads: m.threads,
            pulses: counts.pulses,
            pulse_slots: counts.pulse_slots,
            points: counts.points,
            pulses_with_echo: counts.pulses_with_echo,
            points_by_return: counts.points_by_return[..last].to_vec(),
            subrays_per_pulse: survey.scanner.subrays,
            wavelength_nm: survey.scanner.wavelength_nm,
            wall_time_s: m.wall_time_s,
            index_time_s: world.index_time_s,
            pulses_per_second: if m.wall_time_s > 0.0 {
                counts.pulses as f64 / m.wall_time_s
            } else {
                0.0
            },
            swath_width_m: plan.swath_width_m,
            point_density_per_m2: plan.point_density_per_m2,
            footprint_diameter_m: plan.footprint_diameter_m,
            gps_time: if survey.output.gps_start_time_s.is_some() {
                "adjusted standard GPS time (GPS seconds minus 1e9), flight start at output.gps_start_time_s"
            } else {
                "seconds since the start of the flight"
            },
            intensity_gain: survey.intensity_gain,
            reference_range_m: survey.receiver.reference_range_m,
            scene_primitives: world.scene().primitives.len(),
            files,
            warnings,
            forest_trees: world.forest_trees.clone(),
            plan,
            estimate: m.estimate.clone(),
        }
    }
}

/// The warning of a run whose `pulses` recorded no point at all
/// (`points` is 0), if so.
pub fn no_point_warning(pulses: u64, points: u64) -> Option<String> {
    (pulses > 0 && points == 0).then(|| {
        format!(
            "the run recorded no point: none of its {} pulses returned an echo above the \
             receiver's threshold (look at the swath and the scene's extent in `lidarsim \
             check`, and at its warnings)",
            pulses
        )
    })
}

/// A pulse as users count flight lines: line 1 is the first (the LAS
/// point source ID).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct NextPulse {
    /// Flight line number, 1 for the first.
    pub line: u32,
    /// Pulse index within the line, 0 for the first.
    pub pulse: u64,
}

impl NextPulse {
    /// The user's numbering of an internal position.
    pub fn of(p: PulsePosition) -> Self {
        Self {
            line: p.line as u32 + 1,
            pulse: p.pulse,
        }
    }
}

/// One file of an interrupted run, as it was when the run stopped.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileState {
    /// Its length, bytes.
    pub bytes: u64,
    /// FNV-1a hash of its last mebibyte (of the whole file when shorter).
    pub tail_fnv1a: String,
}

/// The record of an interrupted run that a resumed run checks.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ResumeState {
    /// Each point file by its final name (on disk as `NAME.partial`).
    pub files: BTreeMap<String, FileState>,
    /// FNV-1a hash of the run's `survey.toml`.
    pub survey_fnv1a: String,
    /// FNV-1a hash of the report's saved state.
    pub report_state_fnv1a: String,
    /// FNV-1a hash over the seed, the next pulse, the counts and the
    /// hashes above: any edit of the record shows.
    pub state_fnv1a: String,
}
