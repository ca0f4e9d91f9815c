//! `lidarsim twin`: a survey that re-flies a real scan, and what was read
//! from the scan to make it.

use std::process::ExitCode;

use lidarsim::scan::read_scan;
use lidarsim::scene::Species;
use lidarsim::twin::acquisition::AcquisitionSettings;
use lidarsim::twin::trees::{TreeSettings, Window};
use lidarsim::twin::{TwinError, TwinOptions, twin, write::write_twin};

use crate::args::TwinArgs;
use crate::console::{Steps, fail};

/// `lidarsim twin`.
pub fn command(args: TwinArgs) -> ExitCode {
    let options = match options(&args) {
        Ok(o) => o,
        Err(message) => return fail(2, &message),
    };
    let steps = Steps::new();
    let progress = |step: &str, done: f64| steps.report(step, done);
    let made = read_scan(&args.scan, &progress)
        .map_err(TwinError::from)
        .and_then(|cloud| twin(&cloud, &options, &progress));
    steps.finish();
    let twin = match made {
        Ok(t) => t,
        Err(e @ TwinError::Option { .. }) => return fail(2, &e.to_string()),
        Err(e) => return fail(1, &e.to_string()),
    };
    let survey = match write_twin(&twin, &args.output, args.overwrite) {
        Ok(p) => p,
        Err(e) => return fail(1, &e.to_string()),
    };
    say!("twin of {}", args.scan.display());
    for line in twin.summary_lines() {
        say!("  {line}");
    }
    say!(
        "wrote {} (what was read, and how sure: {})",
        survey.display(),
        args.output.join("twin.json").display()
    );
    say!(
        "fly it: lidarsim run {} -o {}",
        survey.display(),
        args.output.join("run").display()
    );
    ExitCode::SUCCESS
}

/// The options as the library takes them; errors name the option.
fn options(args: &TwinArgs) -> Result<TwinOptions, String> {
    let species = Species::from_name(&args.species)
        .ok_or_else(|| format!("--species {}: expected pine, spruce or birch", args.species))?;
    let window = match &args.window {
        None => Window::LIDR_BOOK,
        Some(text) => {
            let v: Vec<f64> = text
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("--window {text}: expected three numbers A,B,C"))?;
            match v.as_slice() {
                &[a_m, b, c_per_m]
                    if v.iter().all(|x| x.is_finite())
                        && a_m > 0.0
                        && b >= 0.0
                        && c_per_m >= 0.0 =>
                {
                    Window { a_m, b, c_per_m }
                }
                _ => {
                    return Err(format!(
                        "--window {text}: expected A,B,C with A > 0 m and B, C ≥ 0 (the \
                         diameter A + B·h + C·h²)"
                    ));
                }
            }
        }
    };
    Ok(TwinOptions {
        trees: TreeSettings {
            window,
            species,
            chm_cell_m: args.chm_cell_m,
            ..TreeSettings::default()
        },
        acquisition: AcquisitionSettings {
            altitude_m: args.altitude_m,
            speed_mps: args.speed_mps,
            prf_hz: args.prf_hz,
            scan_frequency_hz: args.scan_frequency_hz,
            scan_angle_deg: args.scan_angle_deg,
            heading_deg: args.heading_deg,
            line_spacing_m: args.line_spacing_m,
        },
        instrument: args.instrument.clone(),
    })
}
