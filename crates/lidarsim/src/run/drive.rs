//! The second stage of a run: a [`Source`] of points — the simulator
//! ([`Simulation`]), or the parts of a split run (the merge's) — hands
//! them, in pulse order, to the prepared point files and the report, while
//! the trajectories are written on a thread beside it. What comes out is
//! what the run did ([`Driven`]), for [`super::finish`].

use std::path::Path;

use super::RunOptions;
use super::names::TRAJECTORY_FILES;
use super::prepare::Prepared;
use crate::error::Error;
use crate::files::write_trajectory;
use crate::flight::Flight;
use crate::output::{PointSink, WriteError};
use crate::report::ReportSink;
use crate::sim::{PulsePosition, RunControl, RunCounts, RunOutcome, Simulator, Timer};

/// A point file, the report or another sink of a run's points.
pub type RunSink<'a> = &'a mut (dyn PointSink<Error = WriteError> + 'static);

/// Where a run's points come from.
pub trait Source {
    /// Hands every block of points, in pulse order, to `sinks` and to
    /// `report`; `progress` is called with the pulse slots done so far.
    /// Returns what was done and the simulation time it took, s.
    fn feed<'s>(
        self,
        sinks: Vec<RunSink<'s>>,
        report: &'s mut ReportSink,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Fed, Error>;
}

/// What a [`Source`] fed.
#[derive(Clone, Debug, Default)]
pub struct Fed {
    /// Its counts, and where it stopped if it stopped early.
    pub outcome: RunOutcome,
    /// The simulation time of those points, s.
    pub wall_time_s: f64,
}

/// What a whole run did, its earlier sessions included.
#[derive(Clone, Debug)]
pub struct Driven {
    /// Counts over every session.
    pub counts: RunCounts,
    /// The first pulse not simulated, when the run stopped early.
    pub stopped_at: Option<PulsePosition>,
    /// Simulation time over every session, s.
    pub wall_time_s: f64,
}

/// The simulator as a source: every pulse from where the run starts, until
/// the end, a stop request or the pulse budget.
pub struct Simulation<'a> {
    sim: Simulator<'a>,
    control: RunControl<'a>,
    threads: usize,
}

impl<'a> Simulation<'a> {
    /// The simulation of `flight` from where `prepared` starts, stopped as
    /// `options` say.
    pub fn new(flight: &'a Flight, prepared: &Prepared, options: &RunOptions<'a>) -> Self {
        let survey = flight.survey();
        Self {
            sim: Simulator::new(survey, flight.world())
                .with_waveforms(survey.output.formats.las_waveform),
            control: RunControl {
                start: prepared.before.start,
                stop: options.stop,
                pulse_budget: options.pulse_budget,
                only: None,
            },
            threads: options.threads,
        }
    }
}

impl Source for Simulation<'_> {
    fn feed<'s>(
        self,
        mut sinks: Vec<RunSink<'s>>,
        report: &'s mut ReportSink,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Fed, Error> {
        sinks.push(report);
        let timer = Timer::start();
        let outcome = self
            .sim
            .run_from(self.threads, &mut sinks, progress, &self.control)?;
        Ok(Fed {
            outcome,
            wall_time_s: timer.seconds(),
        })
    }
}

/// Drives `source` into `prepared`'s point files and report, writing the
/// trajectories beside it when they are due. A run that fails discards
/// its point files.
pub fn drive(
    flight: &Flight,
    prepared: &mut Prepared,
    source: impl Source,
    options: &RunOptions<'_>,
) -> Result<Driven, Error> {
    let before = prepared.before.clone();
    let progress = |n: u64| (options.progress)(before.counts.pulse_slots + n);
    let Prepared {
        out_dir,
        sinks,
        report,
        trajectories,
        ..
    } = prepared;
    let (fed, written) = std::thread::scope(|scope| {
        let writer = trajectories.then(|| scope.spawn(|| write_trajectories(flight, out_dir)));
        let refs: Vec<RunSink<'_>> = sinks.iter_mut().map(|s| s.as_mut()).collect();
        let fed = source.feed(refs, report, &progress);
        let written = writer.map_or(Ok(()), |w| {
            w.join().expect("the trajectory writer does not panic")
        });
        (fed, written)
    });
    let fed = match fed {
        Ok(fed) => fed,
        Err(e) => {
            for s in std::mem::take(sinks) {
                s.discard();
            }
            return Err(e);
        }
    };
    written?;
    let mut counts = before.counts;
    counts.add(&fed.outcome.counts);
    Ok(Driven {
        counts,
        stopped_at: fed.outcome.stopped_at,
        wall_time_s: before.wall_time_s + fed.wall_time_s,
    })
}

/// Writes the trajectory flown (`trajectory.csv`, kept under its first
/// name, and `trajectory_true.csv`, formatted once for both) and the one
/// the GNSS/IMU measured into `out_dir`.
fn write_trajectories(flight: &Flight, out_dir: &Path) -> Result<(), Error> {
    for observed in [false, true] {
        let paths: Vec<_> = TRAJECTORY_FILES
            .iter()
            .filter(|(_, o)| *o == observed)
            .map(|(name, _)| out_dir.join(name))
            .collect();
        let refs: Vec<&Path> = paths.iter().map(|p| p.as_path()).collect();
        write_trajectory(flight.survey(), flight.lines(), &refs, observed)?;
    }
    Ok(())
}
