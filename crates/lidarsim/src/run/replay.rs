//! A pulse of a run simulated again and plotted: the report's sample
//! waveforms and `lidarsim waveform`. Every random number of a pulse is
//! keyed by the pulse, so the pulse simulated again is the pulse of the run.

use crate::render::WaveformPlot;
use crate::sensor::platform::FlightLine;
use crate::sim::{Scratch, Simulator};

/// Simulates pulse `k` of `line` again and plots its waveform with the
/// detection threshold and the echoes; the scratch holds the pulse's
/// sub-ray returns and echoes.
pub fn pulse(sim: &Simulator<'_>, line: &FlightLine, k: u64) -> (WaveformPlot, Scratch) {
    let mut scratch = Scratch::default();
    sim.simulate_pulse(line, k, &mut scratch, &mut Vec::new());
    let plot = WaveformPlot::new(
        scratch.waveform(),
        scratch.echoes(),
        sim.receiver().config().bin_s,
        sim.detector().threshold(),
    );
    (plot, scratch)
}
