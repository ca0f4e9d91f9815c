//! What a finished run prints: its figures and the files it wrote.

use std::path::Path;

use lidarsim::run::Summary;

/// Prints the run's figures and the files it wrote into `output`.
pub fn print(s: &Summary, output: &Path) {
    say!(
        "{} pulses → {} points ({} pulses with an echo) in {:.2} s: {:.0} pulses/s on {} thread(s)",
        s.pulses,
        s.points,
        s.pulses_with_echo,
        s.wall_time_s,
        s.pulses_per_second,
        s.threads
    );
    say!(
        "expected swath {:.1} m, density {:.2} points/m² per line",
        s.swath_width_m,
        s.point_density_per_m2
    );
    for f in &s.files {
        say!("wrote {}", output.join(f).display());
    }
    if let Some(w) = lidarsim::summary::no_point_warning(s.pulses, s.points) {
        note!("warning: {w}");
    }
}
