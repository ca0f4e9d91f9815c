//! `lidarsim waveform`: one pulse of a run, named by line and number, by a
//! point's GPS time or by a place, simulated again and plotted.

use std::path::Path;
use std::process::ExitCode;

use lidarsim::message::{fixed, num};
use lidarsim::run::replay::pulse_at_gps_time;
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
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    loop {
        let batch = reader.read_points(1 << 16).map_err(bad)?;
        if batch.is_empty() {
            break;
        }
        for p in batch.points() {
            let p = p.map_err(bad)?;
            // Without overflow: a place 1e200 m away is far, not infinite.
            let d = (p.x - q[0])
                .hypot(p.y - q[1])
                .hypot(q.get(2).map_or(0.0, |z| p.z - z));
            if d.is_finite() && best.is_none_or(|b| d < b.1) {
                best = Some(([p.x, p.y, p.z], d, p.point_source_id, p.gps_time));
            }
            (lo[0], lo[1]) = (lo[0].min(p.x), lo[1].min(p.y));
            (hi[0], hi[1]) = (hi[0].max(p.x), hi[1].max(p.y));
        }
    }
    let (at, d, source, gps) =
        best.ok_or_else(|| (2, format!("--near: {} holds no point", cloud.display())))?;
    // A place beyond the cloud (by more than this) is near no point of it.
    const OUTSIDE_M: f64 = 10.0;
    if (0..2).any(|a| q[a] < lo[a] - OUTSIDE_M || q[a] > hi[a] + OUTSIDE_M) {
        return Err((
            2,
            format!(
                "--near {near}: no point of {} is near that place: its points span x {} to {} \
                 m, y {} to {} m (the nearest is {} m away)",
                cloud.display(),
                fixed(lo[0], 2),
                fixed(hi[0], 2),
                fixed(lo[1], 2),
                fixed(hi[1], 2),
                fixed(d, 1)
            ),
        ));
    }
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
        distance_m: d,
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
    let at_time = |line: Option<usize>, t: f64, what: &str| {
        pulse_at_gps_time(&survey, &world.lines, line, t)
            .map(|(l, k)| (&world.lines[l], k))
            .map_err(|why| (2, format!("{what}: {why}")))
    };
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
            let l = usize::from(source).wrapping_sub(1);
            if l >= world.lines.len() {
                return Err((
                    2,
                    format!(
                        "--near: the nearest point has point source ID {source}, but the \
                         survey has flight lines 1 to {}",
                        world.lines.len()
                    ),
                ));
            }
            let what = format!(
                "--near: the nearest point ({}, {}, {})",
                fixed(x, 3),
                fixed(y, 3),
                fixed(z, 3)
            );
            let (line_ref, k) = at_time(Some(l), gps, &what)?;
            say!(
                "nearest point to {near}: ({}, {}, {}), {} m away, line {source} (point source \
                 ID), GPS time {} s: pulse {k}",
                fixed(x, 3),
                fixed(y, 3),
                fixed(z, 3),
                fixed(d, 3),
                fixed(gps, 6)
            );
            (line_ref, k)
        }
        (None, Some(t)) => at_time(None, t, &format!("--gps-time {}", num(t)))?,
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
    let (plot, detail) = lidarsim::run::replay::pulse(&sim, line_ref, k);
    plot.render()
        .save_png(output)
        .map_err(|e| (1, format!("{}: {e}", output.display())))?;
    say!(
        "line {} pulse {k} (GPS time {} s): {} sub-ray returns, {} echo(es)",
        line_ref.index + 1,
        fixed(offset + sim.pulse_time(line_ref, k), 6),
        detail.returns.len(),
        detail.echoes.len()
    );
    for (i, e) in detail.echoes.iter().enumerate() {
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
