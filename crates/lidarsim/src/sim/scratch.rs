//! Reusable per-thread buffers of the per-pulse computation.

use super::frames::FrameCache;
use super::truth::ReturnSource;
use crate::accel::PulseTrace;
use crate::canopy::PulseMarch;
use crate::detection::{DetectScratch, Echo};
use crate::geometry::DVec3;
use crate::waveform::{Return, Waveform};

/// Reusable per-thread buffers of the per-pulse computation; after
/// [`super::Simulator::simulate_pulse`] they hold that pulse's waveform,
/// echoes and sub-ray returns.
#[derive(Default)]
pub struct Scratch {
    /// Sub-ray directions in the world frame.
    pub(super) dirs: Vec<DVec3>,
    /// Their closest hits and the crowns on their way.
    pub(super) trace: PulseTrace,
    /// How finely each sub-ray's cell is sampled again, if it is.
    pub(super) refine: Vec<Option<crate::sensor::beam::Fineness>>,
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

impl Scratch {
    /// The waveform of the last simulated pulse.
    pub fn waveform(&self) -> &Waveform {
        &self.waveform
    }

    /// The echoes of the last simulated pulse.
    pub fn echoes(&self) -> &[Echo] {
        &self.echoes
    }

    /// The sub-ray returns of the last simulated pulse.
    pub fn returns(&self) -> &[Return] {
        &self.returns
    }
}
