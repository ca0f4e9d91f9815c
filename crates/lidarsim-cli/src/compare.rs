//! `lidarsim compare`: two clouds side by side, as a table and, with
//! `-o DIR`, as `compare.json` and `compare.html`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use lidarsim::compare::{CompareError, CompareOptions, compare, table, write_comparison};
use lidarsim::scan::{ScanCloud, read_scan};

use crate::args::CompareArgs;
use crate::console::{Steps, fail};

/// `lidarsim compare`.
pub fn command(args: CompareArgs) -> ExitCode {
    let options = match options(&args) {
        Ok(o) => o,
        Err(message) => return fail(2, &message),
    };
    let steps = Steps::new();
    let read = |path: &Path| -> Result<ScanCloud, String> {
        let file = points_of(path)?;
        read_scan(&file, &|step, done| steps.report(step, done)).map_err(|e| e.to_string())
    };
    let clouds = read(&args.a).and_then(|a| Ok((a, read(&args.b)?)));
    let (a, b) = match clouds {
        Ok(c) => c,
        Err(e) => {
            steps.finish();
            return fail(1, &e);
        }
    };
    steps.report("comparing", 0.0);
    let made = compare(&a, &b, &options);
    steps.finish();
    let c = match made {
        Ok(c) => c,
        Err(e @ CompareError::Option { .. }) => return fail(2, &e.to_string()),
        Err(e) => return fail(1, &e.to_string()),
    };
    say!(
        "{} against {}: common area {:.0} m²",
        c.b.label,
        c.a.label,
        c.area_m2
    );
    for line in table::text(&c).lines() {
        say!("{line}");
    }
    for n in &c.notes {
        say!("note: {n}");
    }
    if let Some(dir) = &args.output {
        if let Err(e) = write_comparison(&c, dir, args.overwrite) {
            return fail(1, &e.to_string());
        }
        say!(
            "wrote {} and {}",
            dir.join("compare.json").display(),
            dir.join("compare.html").display()
        );
    }
    ExitCode::SUCCESS
}

/// The point file of `path`: the file itself, or a run's directory's
/// `points.las` (else `points.laz`).
fn points_of(path: &Path) -> Result<PathBuf, String> {
    if !path.is_dir() {
        return Ok(path.to_path_buf());
    }
    ["points.las", "points.laz"]
        .iter()
        .map(|n| path.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            format!(
                "{}: a directory without points.las or points.laz; give a LAS or LAZ file or a \
                 run's output directory",
                path.display()
            )
        })
}

/// The options as the library takes them; errors name the option.
fn options(args: &CompareArgs) -> Result<CompareOptions, String> {
    let area = match &args.area {
        None => None,
        Some(text) => {
            let v: Vec<f64> = text
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("--area {text}: expected four numbers XMIN,YMIN,XMAX,YMAX"))?;
            match v.as_slice() {
                &[x0, y0, x1, y1] if v.iter().all(|x| x.is_finite()) && x1 > x0 && y1 > y0 => {
                    Some([x0, y0, x1, y1])
                }
                _ => {
                    return Err(format!(
                        "--area {text}: expected XMIN,YMIN,XMAX,YMAX with XMAX > XMIN and YMAX > YMIN"
                    ));
                }
            }
        }
    };
    let name = |p: &Path| {
        let p = if p.is_dir() {
            p.file_name()
        } else {
            p.file_stem()
        };
        p.map_or_else(String::new, |s| s.to_string_lossy().into_owned())
    };
    let labels = match &args.labels {
        Some(text) => match text.split_once(',') {
            Some((a, b)) if !a.trim().is_empty() && !b.trim().is_empty() => {
                [a.trim().to_string(), b.trim().to_string()]
            }
            _ => return Err(format!("--labels {text}: expected two names A,B")),
        },
        None => {
            let (a, b) = (name(&args.a), name(&args.b));
            if a.is_empty() || a == b {
                ["A".into(), "B".into()]
            } else {
                [a, b]
            }
        }
    };
    Ok(CompareOptions {
        area,
        cell_m: args.cell_m,
        match_density: args.match_density,
        seed: args.seed,
        labels,
    })
}
