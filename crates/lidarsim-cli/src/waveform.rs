//! `lidarsim waveform`: one pulse of a run, named by line and number, by a
//! point's GPS time or by a place, simulated again and plotted.

use std::path::Path;
use std::process::ExitCode;

use lidarsim::world::load;

use crate::args::WaveformArgs;
use crate::console::fail;

/// `lidarsim waveform`: errors carry exit status 2 for bad arguments, 1
/// for unreadable or unwritable files.
pub fn command(args: WaveformArgs) -> ExitCode {
    let WaveformArgs {
        dir,
        pulse,
        line,
        gps_time,
        near,
        output,
    } = args;
    match waveform(&dir, pulse, line, gps_time, near.as_deref(), &output) {
        Ok(()) => ExitCode::SUCCESS,
        Err((code, msg)) => fail(code, &msg),
    }
}

/// The point of a run's point file nearest to a place.
struct Nearest {
    /// Its coordinates, as in the file.
    at: [f64; 3],
    /// Its distance from the place, m.
    distance_m: f64,
    /// Its point source ID (flight line number, 1 for the first).
    source: u16,
    /// Its GPS time, s.
    gps_time_s: f64,
}

/// The point of a run's `points.las` (or `points.laz`) nearest to `near`
/// ("X,Y" or "X,Y,Z", horizontal distance without Z).
fn nearest_point(dir: &Path, near: &str) -> Result<Nearest, (u8, String)> {
    let q: Vec<f64> = near
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()
        .filter(|v: &Vec<f64>| (2..=3).contains(&v.len()) && v.iter().all(|x| x.is_finite()))
        .ok_or_else(|| (2, format!("--near {near}: expected X,Y or X,Y,Z in metres")))?;
    let cloud = ["points.las", "points.laz"]
        .iter()
        .map(|f| dir.join(f))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            (
                2,
                format!(
                    "--near: {} holds neither points.las nor points.laz (the run's [output] \
                     formats need las or laz)",
                    dir.display()
                ),
            )
        })?;
    let bad = |e: las::Error| {
        (
            1,
            format!(
                "{}: {}",
                cloud.display(),
                lidarsim::io::cloud::describe_las_error(&e)
            ),
        )
    };
    let mut reader = lidarsim::io::cloud::open_las(&cloud)
        .map_err(|why| (1, format!("{}: {why}", cloud.display())))?;
    let mut best: Option<([f64; 3], f64, u16, Option<f64>)> = None;
    loop {
        let batch = reader.read_points(1 << 16).map_err(bad)?;
        if batch.is_empty() {
            break;
        }
        for p in batch.points() {
            let p = p.map_err(bad)?;
            let (dx, dy) = (p.x - q[0], p.y - q[1]);
            let dz = q.get(2).map_or(0.0, |z| p.z - z);
            let d2 = dx * dx + dy * dy + dz * dz;
            if d2.is_finite() && best.is_none_or(|b| d2 < b.1) {
                best = Some(([p.x, p.y, p.z], d2, p.point_source_id, p.gps_time));
            }
        }
    }
    let (at, d2, source, gps) =
        best.ok_or_else(|| (2, format!("--near: {} holds no point", cloud.display())))?;
    let gps = gps.ok_or_else(|| {
        (
            2,
            format!(
                "--near: the points of {} carry no GPS time",
                cloud.display()
            ),
        )
    })?;
    Ok(Nearest {
        at,
        distance_m: d2.sqrt(),
        source,
        gps_time_s: gps,
    })
}

/// Simulates one pulse of a run again and plots its waveform.
fn waveform(
    dir: &Path,
    pulse: Option<u64>,
    line: u32,
    gps_time: Option<f64>,
    near: Option<&str>,
    output: &Path,
) -> Result<(), (u8, String)> {
    let survey_path = dir.join("survey.toml");
    let (survey, world) = load(&survey_path, None).map_err(|e| (2, e.to_string()))?;
    let offset = survey.output.gps_start_time_s.unwrap_or(0.0);
    let prf = survey.scanner.prf_hz;
    // The line and pulse: given, or found from a point's GPS time (and,
    // for --near, its point source ID).
    let (line_ref, k) = match (near, gps_time) {
        (Some(near), _) => {
            let Nearest {
                at: [x, y, z],
                distance_m: d,
                source,
                gps_time_s: gps,
            } = nearest_point(dir, near)?;
            let l = world
                .lines
                .get(usize::from(source).wrapping_sub(1))
                .ok_or_else(|| {
                    (
                        2,
                        format!(
                            "--near: the nearest point has point source ID {source}, but the \
                             survey has flight lines 1 to {}",
                            world.lines.len()
                        ),
                    )
                })?;
            let k = ((gps - offset - l.start_time_s) * prf).round().max(0.0) as u64;
            say!(
                "nearest point to {near}: ({x:.3}, {y:.3}, {z:.3}), {d:.3} m away, \
                 line {source} (point source ID), GPS time {gps:.6} s: pulse {k}"
            );
            (l, k)
        }
        (None, Some(t)) => {
            let t = t - offset;
            let l = world
                .lines
                .iter()
                .find(|l| t >= l.start_time_s - 0.5 / prf && t < l.start_time_s + l.duration_s())
                .ok_or_else(|| {
                    (
                        2,
                        format!("--gps-time {}: no flight line was flying then", t + offset),
                    )
                })?;
            (l, ((t - l.start_time_s) * prf).round().max(0.0) as u64)
        }
        (None, None) => {
            let l = world
                .lines
                .get((line as usize).wrapping_sub(1))
                .ok_or_else(|| {
                    (
                        2,
                        format!(
                            "--line {line}: the survey has {} line(s)",
                            world.lines.len()
                        ),
                    )
                })?;
            let k = pulse.ok_or_else(|| {
                (
                    2,
                    "give --pulse N (with --line L), --gps-time T or --near X,Y[,Z]".to_string(),
                )
            })?;
            (l, k)
        }
    };
    let n = survey.pulses_of(line_ref);
    if k >= n {
        return Err((
            2,
            format!(
                "pulse {k}: line {} has pulses 0 to {}",
                line_ref.index + 1,
                n - 1
            ),
        ));
    }
    let sim = lidarsim::sim::Simulator::new(&survey, &world);
    let (plot, scratch) = lidarsim::run::replay::pulse(&sim, line_ref, k);
    plot.render()
        .save_png(output)
        .map_err(|e| (1, format!("{}: {e}", output.display())))?;
    say!(
        "line {} pulse {k} (GPS time {:.6} s): {} sub-ray returns, {} echo(es)",
        line_ref.index + 1,
        offset + sim.pulse_time(line_ref, k),
        scratch.returns().len(),
        scratch.echoes().len()
    );
    for (i, e) in scratch.echoes().iter().enumerate() {
        say!(
            "  echo {}: range {:.3} m, peak {:.4}, energy amplitude {:.4}, width {:.2} ns",
            i + 1,
            e.range_m,
            e.peak_amplitude,
            e.amplitude,
            e.width_ns
        );
    }
    say!("wrote {}", output.display());
    Ok(())
}
