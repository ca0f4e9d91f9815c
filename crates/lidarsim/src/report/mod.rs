//! `report.html`: one self-contained page per run — survey parameters, the
//! figures of `summary.json`, top views by height, intensity and class, a
//! cross-section, returns per pulse, the point density against the plan,
//! the scan pattern of the first scan lines over level ground, the flight
//! (attitude against time, observed against true trajectory),
//! the points' georeferencing errors when the survey has navigation
//! errors, and sample waveforms — with every picture embedded, so it opens
//! in any browser without a network.
//!
//! The pictures are accumulated while the points stream past
//! ([`ReportSink`] is a [`PointSink`](crate::output::PointSink)): per pixel
//! the highest point and a count, on at most 500 000 pixels (coarser for
//! large areas), so memory is bounded whatever the area or the length of
//! the flight. The flight plots are computed from the survey alone.
//!
//! From the bottom up: the [`ErrorStats`] and the [`ReportSink`] that
//! gathers them with the maps' pixels, its saved state (`report.state`),
//! the maps drawn from it, the flight plots ([`attitude_plot`],
//! [`trajectory_error_plots`]), HTML text ([`base64`]) and the page
//! ([`html`]).

mod error_stats;
mod flight;
mod maps;
mod markup;
mod page;
mod pattern;
mod sink;
mod state;
#[cfg(test)]
mod testing;

pub use error_stats::ErrorStats;
pub use flight::{attitude_plot, trajectory_error_plots};
pub use markup::base64;
pub use page::html;
pub use pattern::{pattern_points, scan_pattern_plot};
pub use sink::{ReportSink, SamplePulse};
pub use state::StateError;
