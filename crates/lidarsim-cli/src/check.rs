//! `lidarsim check`: a survey file validated and what it will give
//! predicted (pulses, swath, density, points, files, disk and memory),
//! without simulating.

use std::path::Path;
use std::process::ExitCode;

use lidarsim::Survey;
use lidarsim::plan::plan;
use lidarsim::world::{World, load};

use crate::args::CheckArgs;
use crate::console::{fail_survey, source_name, warn};

/// `lidarsim check`: exit status 2 for a bad survey.
pub fn command(args: CheckArgs) -> ExitCode {
    match load(&args.survey, None) {
        Ok((s, w)) => {
            warn(&s, &w);
            check(&s, &w, &args.output);
            // The process ends here: its memory goes back whole, faster
            // than the world's millions of primitives are dropped one by
            // one (0.3 s for a stand of 1.5 M trees).
            std::mem::forget(w);
            ExitCode::SUCCESS
        }
        Err(e) => fail_survey(&e),
    }
}

/// Prints the survey's plan and estimates, warning of shortfalls of disk
/// or memory.
fn check(survey: &Survey, world: &World, output: &Path) {
    use lidarsim::budget::{available_memory, estimate, free_bytes, human_bytes};
    let p = plan(survey, world);
    for w in lidarsim::plan::warnings(survey, world, &p) {
        note!("warning: {}: {w}", source_name(survey));
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let b = estimate(survey, world, threads);
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
    say!("flight time:          {:.1} s", p.flight_time_s);
    say!("swath width:          {:.1} m", p.swath_width_m);
    say!(
        "point density:        {:.2} points/m² per line",
        p.point_density_per_m2
    );
    say!(
        "footprint diameter:   {:.3} m at nadir",
        p.footprint_diameter_m
    );
    say!(
        "expected points:      ~{} (one per pulse, more under crowns: {:.0} % of the area)",
        b.points,
        b.crown_cover * 100.0
    );
    for f in &b.files {
        say!("  {:<24}~{}", f.name, human_bytes(f.bytes));
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
        say!(
            "  line {}: {} pulses, {:.1} s, {:.1} m above ground, swath {:.1} m, {:.2} pts/m², \
             scan lines every {:.2} m, footprints every {:.2} m across",
            l.line,
            l.pulses,
            l.duration_s,
            l.height_above_ground_m,
            l.swath_width_m,
            l.point_density_per_m2,
            l.scan_line_spacing_m,
            l.across_track_spacing_m
        );
        if let Some(deg) = l.echo_limit_deg {
            say!(
                "    the swath ends where the ground's echo is lost, {deg:.1}° off nadir \
                 (within the scan's field of view)"
            );
        }
    }
}
