//! A pulse of a run simulated again and plotted: the report's sample
//! waveforms and `lidarsim waveform`. Every random number of a pulse is
//! keyed by the pulse, so the pulse simulated again is the pulse of the run.

use crate::message::num;
use crate::render::WaveformPlot;
use crate::sensor::platform::FlightLine;
use crate::sim::{PulseDetail, Simulator};
use crate::survey::Survey;

/// Simulates pulse `k` of `line` again and plots its waveform with the
/// detection threshold and the echoes; returns the plot and the pulse.
pub fn pulse(sim: &Simulator<'_>, line: &FlightLine, k: u64) -> (WaveformPlot, PulseDetail) {
    let detail = sim.replay(line, k);
    let plot = WaveformPlot::new(
        &detail.waveform,
        &detail.echoes,
        sim.receiver().config().bin_s,
        sim.detector().threshold(),
    );
    (plot, detail)
}

/// The flight line (index from 0) and pulse emitted at GPS time
/// `gps_time_s` (as the run's points record it), on line `line` if given:
/// the pulse nearest that time, which must be within half a pulse period
/// of it. An error says why no pulse was: a time that is not a number, or
/// when no line was flying.
pub fn pulse_at_gps_time(
    survey: &Survey,
    lines: &[FlightLine],
    line: Option<usize>,
    gps_time_s: f64,
) -> Result<(usize, u64), String> {
    if !gps_time_s.is_finite() {
        return Err(format!(
            "GPS time {gps_time_s} is not a number: it names no pulse"
        ));
    }
    let offset = survey.output.gps_start_time_s.unwrap_or(0.0);
    let prf = survey.scanner.prf_hz;
    let t = gps_time_s - offset;
    let pulse_of = |l: &FlightLine| -> Option<u64> {
        let k = ((t - l.start_time_s) * prf).round();
        (k >= 0.0 && k < survey.pulses_of(l) as f64).then_some(k as u64)
    };
    let found = match line {
        Some(i) => lines.get(i).and_then(|l| Some((i, pulse_of(l)?))),
        None => lines
            .iter()
            .enumerate()
            .find_map(|(i, l)| Some((i, pulse_of(l)?))),
    };
    found.ok_or_else(|| {
        let spans: Vec<String> = lines
            .iter()
            .filter(|l| line.is_none_or(|i| l.index as usize == i))
            .map(|l| {
                format!(
                    "line {} from {} to {} s",
                    l.index + 1,
                    num(offset + l.start_time_s),
                    num(offset + l.start_time_s + l.duration_s())
                )
            })
            .collect();
        format!(
            "no pulse was emitted at GPS time {} s (the survey flies {})",
            num(gps_time_s),
            spans.join(", ")
        )
    })
}
