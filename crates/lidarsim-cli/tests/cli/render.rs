//! `lidarsim render`: top views and cross-sections of LAS and LAZ files,
//! bad options refused, pictures bounded in size, files that are not
//! point clouds named as such.

use std::path::Path;

use crate::kit::{GOOD, Limit, bin, limited_by, run_survey, temp, write_las};

#[test]
fn render_writes_top_views_and_profiles_and_rejects_bad_options() {
    let dir = temp("render");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success());
    let las = out.join("points.las");
    for (color, extra) in [
        ("class", None),
        ("height", None),
        ("strip", Some("-20,0,20,0,2")),
    ] {
        let png = dir.join(format!("{color}.png"));
        let mut cmd = bin();
        cmd.arg("render")
            .arg(&las)
            .arg("-o")
            .arg(&png)
            .args(["--color", color]);
        if let Some(p) = extra {
            cmd.args(["--profile", p]);
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    }
    for bad in [
        vec!["--color", "rainbow"],
        vec!["--profile", "1,2,3"],
        vec!["--resolution", "-1"],
    ] {
        let o = bin()
            .arg("render")
            .arg(&las)
            .args(["-o"])
            .arg(dir.join("x.png"))
            .args(&bad)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    }
    let o = bin().args(["render", "/nonexistent.las"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 49: without `-o` the picture went into the current directory as
/// top.png. It goes beside the cloud, named after it, the view and the
/// colours, and the command says where.
#[test]
fn render_without_o_writes_beside_the_cloud_and_says_where() {
    let dir = temp("render-beside");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success());
    let elsewhere = dir.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    for (args, name) in [
        (vec!["--color", "class"], "points-top-class.png"),
        (
            vec!["--color", "height", "--profile", "-20,0,20,0,2"],
            "points-profile-height.png",
        ),
    ] {
        let o = bin()
            .arg("render")
            .arg(out.join("points.las"))
            .args(&args)
            .current_dir(&elsewhere)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let png = out.join(name);
        assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
        let said = String::from_utf8_lossy(&o.stdout);
        assert!(said.contains(&format!("wrote {}", png.display())), "{said}");
    }
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_reads_laz_and_point_format_9() {
    // The fixture writes points.las (format 9 + points.wdp), points.laz
    // (format 9, compressed), points.ply and points.xyz.
    let dir = temp("render-laz");
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/fixtures/two-planes.toml");
    let out = dir.join("out");
    let o = bin()
        .arg("run")
        .arg(&fixture)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "points.las",
        "points.wdp",
        "points.laz",
        "points.ply",
        "points.xyz",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    for cloud in ["points.las", "points.laz"] {
        let png = dir.join(format!("{cloud}.png"));
        let o = bin()
            .arg("render")
            .arg(out.join(cloud))
            .arg("-o")
            .arg(&png)
            .args(["--color", "class"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{cloud}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(&std::fs::read(&png).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Width and height of a PNG, from its IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
    let be = |at: usize| u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
    (be(16), be(20))
}

/// `render` bounds the picture to 8192 px a side and 16 million pixels:
/// a finer `--resolution` is refused (exit status 2) with the smallest
/// that fits, and an automatic one is coarsened, whatever the extent of
/// the cloud or of the cross-section, within a 2 GiB address space.
#[test]
fn render_bounds_the_picture_size_instead_of_allocating_without_limit() {
    let dir = temp("render-limits");
    // 4000 km × 3000 km, corners and a few points between.
    let wide = dir.join("wide.las");
    let pts: Vec<(f64, f64, f64)> = (0..=100)
        .map(|i| (i as f64 * 4e4, i as f64 * 3e4, i as f64))
        .collect();
    write_las(&wide, &pts);
    // 400 m × 300 m.
    let small = dir.join("small.las");
    let pts: Vec<(f64, f64, f64)> = (0..=400)
        .flat_map(|i| (0..=30).map(move |j| (i as f64, j as f64 * 10.0, 0.5 * j as f64)))
        .collect();
    write_las(&small, &pts);
    let png = dir.join("x.png");
    let run = |cloud: &Path, extra: &[&str]| {
        let _ = std::fs::remove_file(&png);
        let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), cloud.as_os_str()];
        args.extend(["-o".as_ref(), png.as_os_str()]);
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        limited_by(&args, Limit::AddressSpace(2 << 30))
    };
    // Refused: the smallest pixel that fits 400 × 300 m in 16 M pixels is
    // √(400 · 300 / 16e6) = 0.0866 m; for 4000 km × 3000 km it is 866 m.
    for (cloud, res, smallest) in [
        (&small, "1e-9", 0.0866),
        (&small, "0.0001", 0.0866),
        (&small, "0.05", 0.0866),
        (&wide, "1", 866.0),
    ] {
        let o = run(cloud, &["--resolution", res]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{res}: {err}");
        assert!(!err.contains("panicked") && !png.exists(), "{res}: {err}");
        assert!(err.contains("8192 px a side and 16000000 pixels"), "{err}");
        let offered: f64 = err
            .split("the smallest pixel size that fits is ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|r| r.parse().ok())
            .unwrap_or_else(|| panic!("no smallest resolution in {err}"));
        assert!(
            offered >= smallest && offered < smallest * 1.01,
            "{res}: {offered} vs {smallest}"
        );
        // The resolution offered works.
        let o = run(cloud, &["--resolution", &offered.to_string()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (w, h) = png_size(&png);
        assert!(
            u64::from(w) * u64::from(h) <= 16_200_000 + 150 * 8192,
            "{w} × {h}"
        );
    }
    // Automatic: coarsened to fit.
    for (cloud, extra) in [
        (&wide, vec![]),
        (&wide, vec!["--profile", "0,0,4e6,3e6,1e5"]),
        (&small, vec!["--profile", "0,0,1e7,0,5"]),
    ] {
        let o = run(cloud, &extra);
        assert!(
            o.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let (w, h) = png_size(&png);
        assert!(w <= 8192 + 200 && h <= 8192 + 40, "{extra:?}: {w} × {h}");
    }
    // A cross-section 10 000 km long at 1 cm per pixel.
    let o = run(
        &small,
        &["--profile", "0,0,1e7,0,5", "--resolution", "0.01"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("the smallest pixel size that fits is 1230 m"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_of_a_survey_file_says_it_is_not_a_point_cloud() {
    let dir = temp("render-toml");
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, GOOD).unwrap();
    let o = bin()
        .arg("render")
        .arg(&survey)
        .arg("-o")
        .arg(dir.join("x.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("survey.toml is not a LAS or LAZ file (it starts with \"seed\"); render takes a point cloud such as points.las"),
        "{err}"
    );
    assert!(!err.contains("signature") && !err.contains("[115"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
