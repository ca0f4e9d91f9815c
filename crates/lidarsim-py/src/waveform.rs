//! One pulse simulated on its own, its full waveform as NumPy arrays: the
//! received signal on its time axis, the sub-ray returns it is made of,
//! the detection threshold, the echoes found and the points they give.
//! Every random number of a pulse is keyed by the pulse, so this is the
//! pulse of a run.

use lidarsim::Flight;
use lidarsim::sim::Simulator;
use lidarsim::waveform::bin_to_range;
use numpy::PyArray1;
use pyo3::exceptions::PyIndexError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::point_error;
use crate::points::pack;

fn array<'py>(py: Python<'py>, values: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, values)
}

/// The waveform of pulse `pulse` of flight line `line` (0 for the first):
/// a dict of `time_ns` (two-way time of each sample), `range_m`,
/// `samples`, `background`, `threshold`, `returns_range_m`,
/// `returns_power`, the echoes' `echo_range_m`, `echo_amplitude`,
/// `echo_peak_amplitude`, `echo_width_ns`, `points` (packed records) and
/// `emitted` (false for a polygon's silent pulse slot).
pub fn waveform<'py>(
    py: Python<'py>,
    flight: &Flight,
    line: usize,
    pulse: u64,
) -> PyResult<Bound<'py, PyAny>> {
    let Some(flight_line) = flight.lines().get(line) else {
        return Err(PyIndexError::new_err(format!(
            "line {line}: the survey has {} flight line(s), numbered from 0",
            flight.lines().len()
        )));
    };
    let pulses = flight.line_pulses()[line];
    if pulse >= pulses {
        return Err(PyIndexError::new_err(format!(
            "pulse {pulse}: flight line {line} has {pulses} pulses, numbered from 0"
        )));
    }
    let survey = flight.survey();
    let sim = Simulator::new(survey, flight.world());
    let detail = py.detach(|| sim.replay(flight_line, pulse));
    let bin_s = survey.receiver.bin_s;
    let wf = &detail.waveform;
    let bins: Vec<f64> = (0..wf.samples.len())
        .map(|i| (wf.first_bin + i as i64) as f64)
        .collect();
    let out = PyDict::new(py);
    out.set_item("emitted", detail.emitted)?;
    out.set_item(
        "time_ns",
        array(py, bins.iter().map(|b| b * bin_s * 1e9).collect()),
    )?;
    out.set_item(
        "range_m",
        array(py, bins.iter().map(|&b| bin_to_range(b, bin_s)).collect()),
    )?;
    out.set_item("samples", array(py, wf.samples.clone()))?;
    out.set_item(
        "background",
        array(
            py,
            (0..wf.samples.len()).map(|i| wf.background_at(i)).collect(),
        ),
    )?;
    out.set_item("threshold", sim.detector().threshold())?;
    let returns = &detail.returns;
    out.set_item(
        "returns_range_m",
        array(py, returns.iter().map(|r| r.range_m).collect()),
    )?;
    out.set_item(
        "returns_power",
        array(py, returns.iter().map(|r| r.power).collect()),
    )?;
    let echoes = &detail.echoes;
    out.set_item(
        "echo_range_m",
        array(py, echoes.iter().map(|e| e.range_m).collect()),
    )?;
    out.set_item(
        "echo_amplitude",
        array(py, echoes.iter().map(|e| e.amplitude).collect()),
    )?;
    out.set_item(
        "echo_peak_amplitude",
        array(py, echoes.iter().map(|e| e.peak_amplitude).collect()),
    )?;
    out.set_item(
        "echo_width_ns",
        array(py, echoes.iter().map(|e| e.width_ns).collect()),
    )?;
    let settings = flight.las_settings();
    let mut packed = Vec::new();
    for p in &detail.points {
        pack(&settings, p, &mut packed).map_err(|e| point_error(&e))?;
    }
    out.set_item("points", PyArray1::from_vec(py, packed))?;
    Ok(out.into_any())
}
