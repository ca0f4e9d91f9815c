//! `lidarsim check`: a survey file validated and what it will give
//! predicted (pulses, swath, density, points, files, disk and memory),
//! without simulating.

use std::path::Path;
use std::process::ExitCode;

use lidarsim::Flight;
use lidarsim::message::fixed;

use crate::args::CheckArgs;
use crate::console::{fail_survey, source_name, warn};

/// `lidarsim check`: exit status 2 for a bad survey.
pub fn command(args: CheckArgs) -> ExitCode {
    match Flight::load(&args.survey, None) {
        Ok(flight) => {
            warn(&flight);
            check(&flight, &args.output);
            // The process ends here: its memory goes back whole, faster
            // than the world's millions of primitives are dropped one by
            // one (0.3 s for a stand of 1.5 M trees).
            std::mem::forget(flight);
            ExitCode::SUCCESS
        }
        Err(e) => fail_survey(&e),
    }
}

/// Prints the survey's plan and estimates, warning of shortfalls of disk
/// or memory.
fn check(flight: &Flight, output: &Path) {
    use lidarsim::budget::{available_memory, free_bytes, human_bytes};
    let (survey, world, p) = (flight.survey(), flight.world(), flight.plan());
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let b = flight.estimate(threads);
    let (free, memory) = (free_bytes(output), available_memory());
    for s in b.shortfalls(output, free, memory, 1.0) {
        note!(
            "warning: {}: {s}: `lidarsim run` will refuse it without --no-space-check",
            source_name(survey)
        );
    }
    say!(
        "survey OK: {} flight line(s), {} scene primitives, seed {}",
        world.lines.len(),
        world.scene().primitives.len(),
        survey.seed
    );
    if let Some(u) = &survey.preset {
        let pr = u.preset;
        say!("instrument:           {} (preset {})", pr.name, pr.id);
        say!("  source:             {}", pr.source);
        if !pr.note.is_empty() {
            say!("  not modelled:       {}", pr.note);
        }
        say!(
            "  deflector:          {}",
            survey.scanner.deflector.describe()
        );
        for k in &u.set {
            say!("  set by the preset:  scanner.{k}");
        }
    }
    if let Some(u) = &survey.platform_preset {
        let pr = u.preset;
        say!("platform:             {} (preset {})", pr.name, pr.id);
        say!("  source:             {}", pr.source);
        say!("  not modelled:       {}", pr.note);
        for k in &u.set {
            say!("  set by the preset:  platform.{k}");
        }
    }
    say!("pulses:               {}", p.pulses);
    say!("flight time:          {} s", fixed(p.flight_time_s, 1));
    say!("swath width:          {} m", fixed(p.swath_width_m, 1));
    say!(
        "point density:        {} points/m² per line",
        fixed(p.point_density_per_m2, 2)
    );
    say!(
        "footprint diameter:   {} m at nadir",
        fixed(p.footprint_diameter_m, 3)
    );
    if b.crown_cover > 0.0 {
        say!(
            "expected points:      ~{} (one per pulse, more under crowns: {} % of the area)",
            b.points,
            fixed(b.crown_cover * 100.0, 0)
        );
    } else {
        say!("expected points:      ~{} (one per pulse)", b.points);
    }
    for f in &b.files {
        say!("  {:<24}~{}", f.name, human_bytes(f.bytes));
    }
    match survey.output.layout {
        lidarsim::survey::Layout::Single => {}
        lidarsim::survey::Layout::Strips => say!("  strips: {} file(s) per format", b.layout_files),
        lidarsim::survey::Layout::Tiles(_) => {
            say!("  tiles: up to {} file(s) per format", b.layout_files)
        }
    }
    say!(
        "expected output:      ~{}{}",
        human_bytes(b.total_bytes),
        free.map_or_else(String::new, |f| format!(
            " ({} free for {})",
            human_bytes(f),
            output.display()
        ))
    );
    say!(
        "expected memory:      ~{} on {threads} thread(s){}",
        human_bytes(b.memory_bytes),
        memory.map_or_else(String::new, |m| format!(" ({} available)", human_bytes(m)))
    );
    for l in &p.lines {
        let scan_lines = if l.scan_line_spacing_m > 0.0 {
            format!("scan lines every {} m", fixed(l.scan_line_spacing_m, 2))
        } else {
            "no scan lines (the pattern does not repeat across the track)".to_string()
        };
        say!(
            "  line {}: {} pulses, {} s, {} m above ground, swath {} m, {} pts/m², \
             {scan_lines}, footprints every {} m across",
            l.line,
            l.pulses,
            fixed(l.duration_s, 1),
            fixed(l.height_above_ground_m, 1),
            fixed(l.swath_width_m, 1),
            fixed(l.point_density_per_m2, 2),
            fixed(l.across_track_spacing_m, 2)
        );
        if let Some(deg) = l.echo_limit_deg {
            say!(
                "    the swath ends where the ground's echo is lost, {}° off nadir \
                 (within the scan's field of view)",
                fixed(deg, 1)
            );
        }
    }
}
