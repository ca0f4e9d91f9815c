//! `lidarsim render`: a LAS or LAZ file read, checked and drawn as a top
//! view or a cross-section PNG.

use std::path::Path;
use std::process::ExitCode;

use crate::args::RenderArgs;
use crate::console::fail;

/// `lidarsim render`.
pub fn command(args: RenderArgs) -> ExitCode {
    let RenderArgs {
        cloud,
        output,
        color,
        resolution,
        profile,
    } = args;
    let output = output.unwrap_or_else(|| beside(&cloud, profile.is_some(), &color));
    match render(&cloud, &output, &color, resolution, profile.as_deref()) {
        Ok(()) => {
            say!("wrote {}", output.display());
            ExitCode::SUCCESS
        }
        Err((code, msg)) => fail(code, &msg),
    }
}

/// The picture's path when `-o` is not given: beside the cloud, named
/// after it, the view and the colours (`points-top-height.png`), so that
/// pictures of several clouds and views do not replace each other.
fn beside(cloud: &Path, profile: bool, color: &str) -> std::path::PathBuf {
    let stem = cloud
        .file_stem()
        .map_or_else(|| "cloud".into(), |s| s.to_string_lossy());
    let view = if profile { "profile" } else { "top" };
    cloud.with_file_name(format!("{stem}-{view}-{color}.png"))
}

/// Reads a LAS file and writes a top view or profile PNG. Errors carry the
/// exit status: 2 for bad arguments, 1 for unreadable or unwritable files.
fn render(
    cloud: &Path,
    output: &Path,
    color: &str,
    resolution: Option<f64>,
    profile: Option<&str>,
) -> Result<(), (u8, String)> {
    use lidarsim::render::ColorBy;
    let by = ColorBy::from_name(color).ok_or_else(|| {
        (
            2,
            format!("--color {color}: expected height, intensity, class, return, strip or time"),
        )
    })?;
    if resolution.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
        return Err((2, "--resolution must be a positive number of metres".into()));
    }
    let section = match profile {
        None => None,
        Some(p) => {
            let v: Vec<f64> = p
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    (
                        2,
                        format!("--profile {p}: expected five numbers x0,y0,x1,y1,width"),
                    )
                })?;
            if v.len() != 5 || v[4] <= 0.0 || v.iter().any(|x| !x.is_finite()) {
                return Err((
                    2,
                    format!("--profile {p}: expected x0,y0,x1,y1,width with width > 0"),
                ));
            }
            Some(v)
        }
    };
    let points = read_cloud(cloud).map_err(|e| (1, e))?;
    let img = match section {
        None => lidarsim::render::top_view(&points, by, resolution),
        Some(v) => {
            lidarsim::render::profile(&points, (v[0], v[1]), (v[2], v[3]), v[4], by, resolution)
        }
    }
    .map_err(|e| match resolution {
        Some(_) => (2, format!("--resolution: {e}")),
        None => (1, format!("{}: {e}", cloud.display())),
    })?;
    img.save_png(output)
        .map_err(|e| (1, format!("{}: {e}", output.display())))
}

/// Refuses a file that does not start as a LAS or LAZ file does ("LASF"),
/// saying so in words with its first bytes. Shorter files that begin like
/// one are left to the LAS reader, which says they end early.
fn check_las_signature(cloud: &Path) -> Result<(), String> {
    use std::io::Read;
    let Ok(file) = std::fs::File::open(cloud) else {
        return Ok(());
    };
    let mut head = Vec::with_capacity(4);
    if file.take(4).read_to_end(&mut head).is_err() || b"LASF".starts_with(&head) {
        return Ok(());
    }
    let shown: String = head
        .iter()
        .map(|&b| match b {
            b'"' => "\\\"".to_string(),
            0x20..=0x7e => char::from(b).to_string(),
            _ => format!("\\x{b:02x}"),
        })
        .collect();
    Err(format!(
        "{} is not a LAS or LAZ file (it starts with \"{shown}\"); render takes a point cloud \
         such as points.las",
        cloud.display()
    ))
}

/// Reads every point of a LAS file for rendering. Errors name the file and
/// say what is wrong in words (a truncated file, a header that promises
/// more points than the file holds) before any large allocation.
fn read_cloud(cloud: &Path) -> Result<Vec<lidarsim::render::RenderPoint>, String> {
    use lidarsim::io::cloud::{describe_las_error, open_las};
    use lidarsim::render::RenderPoint;
    let bad = |e: las::Error| format!("{}: {}", cloud.display(), describe_las_error(&e));
    check_las_signature(cloud)?;
    let mut reader = open_las(cloud).map_err(|why| format!("{}: {why}", cloud.display()))?;
    reader
        .read_all()
        .map_err(bad)?
        .points()
        .map(|p| {
            p.map(|p| RenderPoint {
                x: p.x,
                y: p.y,
                z: p.z,
                intensity: p.intensity,
                classification: u8::from(p.classification),
                return_number: p.return_number,
                number_of_returns: p.number_of_returns,
                source: p.point_source_id,
                gps_time_s: p.gps_time.unwrap_or(0.0),
            })
        })
        .collect::<Result<Vec<RenderPoint>, _>>()
        .map_err(bad)
        .and_then(|points| {
            match points
                .iter()
                .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
            {
                Some(i) => Err(format!(
                    "{}: point {} has a coordinate that is not a finite number (check the \
                     header's scale and offset)",
                    cloud.display(),
                    i + 1
                )),
                None => Ok(points),
            }
        })
}

#[cfg(test)]
mod tests {
    use super::read_cloud;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    use std::cell::Cell;

    /// The LAS reader of `render` on 256 mangled copies of a valid file
    /// (bytes changed anywhere, the header most often, or cut short):
    /// never a panic or a huge allocation, errors name the file.
    #[test]
    fn render_reads_mangled_las_files_without_panicking() {
        let dir = std::env::temp_dir().join(format!("lidarsim-cli-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/corpus/las/count_too_large.las");
        let mut bytes = std::fs::read(good).unwrap();
        // Repair the corpus file's point count (40 points).
        bytes[247..255].copy_from_slice(&40u64.to_le_bytes());
        let path = dir.join("mangled.las");
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(read_cloud(&path).unwrap().len(), 40);
        let n = bytes.len();
        let at = prop_oneof![3 => 0..375usize, 1 => 0..n];
        let edits = proptest::collection::vec((at, any::<u8>()), 1..6);
        let cut = prop_oneof![3 => Just(n), 1 => 0..n];
        let mut runner = TestRunner::new_with_rng(
            Config {
                cases: 256,
                failure_persistence: None,
                ..Config::default()
            },
            TestRng::deterministic_rng(RngAlgorithm::ChaCha),
        );
        let (ok, rejected) = (Cell::new(0u32), Cell::new(0u32));
        runner
            .run(&(edits, cut), |(edits, cut)| {
                let mut b = bytes.clone();
                for (at, v) in edits {
                    b[at] = v;
                }
                b.truncate(cut);
                std::fs::write(&path, &b).unwrap();
                match read_cloud(&path) {
                    Ok(points) => {
                        ok.set(ok.get() + 1);
                        prop_assert!(points.len() <= 40);
                    }
                    Err(e) => {
                        rejected.set(rejected.get() + 1);
                        prop_assert!(e.contains("mangled.las"), "{e}");
                    }
                }
                Ok(())
            })
            .unwrap();
        std::fs::remove_dir_all(&dir).ok();
        println!(
            "LAS for render: 256 cases, {} read, {} rejected naming the file",
            ok.get(),
            rejected.get()
        );
    }
}
