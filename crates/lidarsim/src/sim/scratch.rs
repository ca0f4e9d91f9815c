//! Reusable per-thread buffers of the per-pulse computation.

use super::frames::FrameCache;
use super::truth::ReturnSource;
use crate::accel::PulseTrace;
use crate::canopy::PulseMarch;
use crate::detection::{DetectScratch, Echo};
use crate::geometry::DVec3;
use crate::waveform::{Return, Waveform};

/// Reusable per-thread buffers of the per-pulse computation, filled again
/// by every pulse ([`PulseDetail`] is what a pulse leaves for a caller).
#[derive(Default)]
pub(crate) struct Scratch {
    /// Sub-ray directions in the world frame.
    pub(super) dirs: Vec<DVec3>,
    /// Their closest hits and the crowns on their way.
    pub(super) trace: PulseTrace,
    /// Whether each sub-ray's cell is sampled again across a
    /// discontinuity (at the survey's `edge_rays`).
    pub(super) refine: Vec<bool>,
    /// How many fine samples stand for each sub-ray's cell (0: none).
    pub(super) counts: Vec<u32>,
    /// Working storage of the sampling of the beam's cone.
    pub(super) cone: super::cone::ConeScratch,
    /// The fine samples of those cells: undeflected direction and share.
    pub(super) fine: Vec<(DVec3, f64)>,
    /// Their directions in the world frame.
    pub(super) fine_dirs: Vec<DVec3>,
    /// Their closest hits and the crowns on their way.
    pub(super) fine_trace: PulseTrace,
    /// The sub-rays' march through the crowns.
    pub(super) canopy: PulseMarch,
    /// The crowns on the ways of a pulse's sub-rays and fine samples.
    pub(super) volumes: Vec<u32>,
    /// Sub-ray returns: range and power.
    pub(super) returns: Vec<Return>,
    /// Where each return came from, parallel to `returns`.
    pub(super) sources: Vec<ReturnSource>,
    /// The received signal.
    pub(super) waveform: Waveform,
    /// Working storage of the detector.
    pub(super) detect: DetectScratch,
    /// The detected echoes.
    pub(super) echoes: Vec<Echo>,
    /// Energy per primitive within one echo.
    pub(super) energy_by_prim: Vec<(u32, f64)>,
    /// Frames of the last pulse.
    pub(super) frames: FrameCache,
}

/// A pulse simulated on its own, with what a look at it needs
/// ([`super::Simulator::replay`]): the report's sample waveforms, `lidarsim
/// waveform`, Python's `Survey.waveform`.
#[derive(Clone, Debug, Default)]
pub struct PulseDetail {
    /// Whether a pulse left at its tick (a polygon facet looking outside
    /// the field of view emits none).
    pub emitted: bool,
    /// The received signal.
    pub waveform: Waveform,
    /// The detected echoes.
    pub echoes: Vec<Echo>,
    /// The sub-ray returns: range and power.
    pub returns: Vec<Return>,
    /// Its points, as a run writes them.
    pub points: Vec<crate::output::PointRecord>,
}

impl Scratch {
    /// What the last pulse simulated with this scratch left in it, with its
    /// points.
    pub(super) fn detail(
        &self,
        emitted: bool,
        points: Vec<crate::output::PointRecord>,
    ) -> PulseDetail {
        PulseDetail {
            emitted,
            waveform: self.waveform.clone(),
            echoes: self.echoes.clone(),
            returns: self.returns.clone(),
            points,
        }
    }
}
