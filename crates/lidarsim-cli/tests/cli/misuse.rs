//! Inputs an adversarial user tried (issue 22): settings that multiply the
//! work or the memory beyond reason, special files, and values that used
//! to pass silently and give a wrong result. Each must be refused by both
//! `check` and `run` with the key (file, line) and the bound, quickly and
//! within a modest address space, leaving no output; legitimate but
//! suspicious ones get a warning.
//!
//! Every command runs under a 4 GiB address-space limit and is killed
//! after 120 s, so that a regression fails instead of exhausting the
//! machine or hanging CI.

use std::path::Path;

use crate::kit::{limited as lidarsim, temp};

const BASE: &str = r#"seed = 3

[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15

[[flight_line]]
start_m = [0.0, -10.0, 300.0]
end_m = [0.0, 10.0, 300.0]
speed_mps = 50.0

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

/// The base survey with `old` replaced by `new` (which must occur).
fn with(old: &str, new: &str) -> String {
    assert!(BASE.contains(old), "{old}");
    BASE.replacen(old, new, 1)
}

/// `check` and `run` both refuse `text` (written as `survey.toml` in a
/// fresh directory with `files`) with status 2 and every fragment of
/// `expect`; `run` leaves no output. Returns the message.
fn refused(name: &str, text: &str, files: &[(&str, &[u8])], expect: &[&str]) -> String {
    let dir = temp(name);
    for (f, bytes) in files {
        std::fs::write(dir.join(f), bytes).unwrap();
    }
    let survey = dir.join("survey.toml");
    std::fs::write(&survey, text).unwrap();
    let out = dir.join("out");
    let mut first = String::new();
    for args in [
        vec!["check".as_ref(), survey.as_os_str()],
        vec![
            "run".as_ref(),
            survey.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ],
    ] {
        let o = lidarsim(&args);
        let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{name} {:?}: {stderr}", args[0]);
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        for e in expect {
            assert!(stderr.contains(e), "{name}: wanted '{e}' in\n{stderr}");
        }
        // Numbers in exponent form, never hundreds of digits; long values
        // shown in part.
        assert!(
            !stderr
                .split(|c: char| !c.is_ascii_digit())
                .any(|run| run.len() > 24),
            "{name}: a number of more than 24 digits in\n{stderr}"
        );
        assert!(
            stderr.len() < 20_000,
            "{name}: {} bytes of message",
            stderr.len()
        );
        if first.is_empty() {
            first = stderr;
        }
    }
    assert!(!out.exists(), "{name}: run created its output directory");
    std::fs::remove_dir_all(&dir).ok();
    println!("{name:<32} {}", first.lines().next().unwrap_or(""));
    first
}

#[test]
fn receiver_bins_are_bounded_by_the_pulse_and_the_range_window() {
    for bin in ["1e-6", "0.01", "1e-4"] {
        refused(
            &format!("bin-{bin}"),
            &format!("{BASE}\n[receiver]\nbin_ps = {bin}\n"),
            &[],
            &[
                "survey.toml:22:",
                "`receiver.bin_ps`",
                "at most 4096",
                "use bin_ps of at least",
            ],
        );
    }
    // 10 ps: the pulse fits, but the default 1–10 000 m window does not.
    refused(
        "bin-window",
        &format!("{BASE}\n[receiver]\nbin_ps = 5\n"),
        &[],
        &["`receiver.bin_ps`", "range window", "4194304"],
    );
}

#[test]
fn work_multipliers_are_refused_with_their_bound() {
    let plan = |spacing: &str| {
        BASE.replace(
            "[[flight_line]]\nstart_m = [0.0, -10.0, 300.0]\nend_m = [0.0, 10.0, 300.0]\nspeed_mps = 50.0\n",
            &format!(
                "[plan]\nrectangle_m = [-250.0, -250.0, 250.0, 250.0]\naltitude_m = 300.0\n\
                 line_spacing_m = {spacing}\n"
            ),
        )
    };
    for s in ["1e-9", "0.001"] {
        refused(
            &format!("spacing-{s}"),
            &plan(s),
            &[],
            &["`plan.line_spacing_m`", "a plan may make at most 10000"],
        );
    }
    refused(
        "trajectory-interval",
        &format!("{BASE}\n[output]\ntrajectory_interval_s = 1e-9\n"),
        &[],
        &[
            "`output.trajectory_interval_s`",
            "must be between 0.0001 and 3600 s",
        ],
    );
    refused(
        "canopy-step",
        &format!("{BASE}\n[vegetation]\nstep_m = 1e-9\n"),
        &[],
        &["`vegetation.step_m`", "must be between 0.01 and 10 m"],
    );
    let freqs = vec!["0.1"; 100_000].join(", ");
    refused(
        "sway-frequencies",
        &format!("{BASE}\n[platform]\nsway = true\nsway_frequencies_hz = [{freqs}]\n"),
        &[],
        &[
            "`platform.sway_frequencies_hz`",
            "1 to 32 frequencies",
            "100000 entries",
        ],
    );
    let ring: Vec<String> = (0..200_000)
        .map(|i| {
            let a = i as f64 / 200_000.0 * std::f64::consts::TAU;
            format!("[{:.4}, {:.4}, 1]", 50.0 * a.cos(), 50.0 * a.sin())
        })
        .collect();
    refused(
        "huge-polygon",
        &format!(
            "{BASE}\n[[polygon]]\nmaterial = \"grass\"\nvertices_m = [{}]\n",
            ring.join(", ")
        ),
        &[],
        &[
            "`polygon[1].vertices_m`",
            "more than 100000 items, the most a survey array may hold",
        ],
    );
    // 10 million trees: 1000 ha at 10 000 stems/ha.
    refused(
        "ten-million-trees",
        &format!(
            "{BASE}\n[[forest]]\nrectangle_m = [-5000.0, -5000.0, 5000.0, 5000.0]\n\
             stems_per_ha = 1000\n"
        ),
        &[],
        &["`forest[0].stems_per_ha`", "at most 5000000 trees"],
    );
}

#[cfg(unix)]
#[test]
fn special_files_are_refused_before_they_are_read() {
    refused(
        "mesh-dev-zero",
        &format!("{BASE}\n[[mesh]]\nfile = \"/dev/zero\"\nmaterial = \"grass\"\n"),
        &[],
        &["`mesh[0].file`", "not a regular file"],
    );
    refused(
        "trajectory-dev-zero",
        &BASE.replace(
            "[[flight_line]]\nstart_m = [0.0, -10.0, 300.0]\nend_m = [0.0, 10.0, 300.0]\nspeed_mps = 50.0\n",
            "[platform]\ntrajectory_file = \"/dev/zero\"\n",
        ),
        &[],
        &["`platform.trajectory_file`", "not a regular file"],
    );
    // A glTF whose buffer is the device.
    let gltf = br#"{"asset":{"version":"2.0"},"buffers":[{"uri":"/dev/zero","byteLength":36}],
        "scenes":[{"nodes":[]}],"scene":0}"#;
    refused(
        "gltf-buffer-dev-zero",
        &format!("{BASE}\n[[mesh]]\nfile = \"m.gltf\"\nmaterial = \"grass\"\n"),
        &[("m.gltf", gltf)],
        &[
            "`mesh[0].file`",
            "cannot load its buffer '/dev/zero'",
            "not a regular file",
        ],
    );
    let o = lidarsim(&["check".as_ref(), "/dev/zero".as_ref()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("not a regular file"), "{stderr}");
}

#[test]
fn values_that_gave_silent_wrong_results_are_refused() {
    let cases: Vec<(&str, String, &[&str])> = vec![
        (
            "reference-range",
            with(
                "scan_angle_deg = 15\n",
                "scan_angle_deg = 15\nreference_range_m = 1e160\n",
            ),
            &["`scanner.reference_range_m`", "between 1 and 100000 m"],
        ),
        (
            "atmosphere",
            format!("{BASE}\n[receiver]\natmosphere = 1e300\n"),
            &["`receiver.atmosphere`", "between 0 and 1, got 1e300"],
        ),
        (
            "scan-frequency",
            with("scan_frequency_hz = 40", "scan_frequency_hz = 1e300"),
            &[
                "`scanner.scan_frequency_hz`",
                "at most prf_hz / 4 = 5000 Hz",
            ],
        ),
        (
            "species-weight",
            format!(
                "{BASE}\n[[forest]]\nrectangle_m = [-50.0, -50.0, 50.0, 50.0]\nstems_per_ha = 300\n\
                 species = {{ pine = 1e308, spruce = 1e308 }}\n"
            ),
            &["`forest[0].species.pine`", "at most 1000000"],
        ),
        (
            "gnss",
            format!("{BASE}\n[gnss]\nsigma_m = 1e300\n"),
            &["`gnss.sigma_m`", "between 0 and 1000 m, got 1e300"],
        ),
        (
            "las-scale",
            format!("{BASE}\n[output]\nlas_scale_m = 1e-12\n"),
            &["`output.las_scale_m`", "32-bit integers", "at least"],
        ),
        (
            "crs-wkt",
            format!(
                "{BASE}\n[output]\ncrs_wkt = 'PROJCS[\"{}\"]'\n",
                "x".repeat(70_000)
            ),
            &["`output.crs_wkt`", "at most 65534 bytes"],
        ),
        (
            "seconds-as-nanoseconds",
            with(
                "scan_angle_deg = 15\n",
                "scan_angle_deg = 15\npulse_fwhm_ns = 4e-9\n",
            ),
            &["`scanner.pulse_fwhm_ns`", "looks like seconds (4 ns)"],
        ),
    ];
    for (name, text, expect) in &cases {
        refused(name, text, &[], expect);
    }
    // The bin check is not reported under receiver.bin_ps for a pulse
    // that is itself wrong.
    let m = refused(
        "seconds-as-nanoseconds-no-bin",
        &with(
            "scan_angle_deg = 15\n",
            "scan_angle_deg = 15\npulse_fwhm_ns = 4e-9\n",
        ),
        &[],
        &[],
    );
    assert!(!m.contains("receiver.bin_ps"), "{m}");
}

#[test]
fn outlines_that_enclose_nothing_or_cross_themselves_are_refused() {
    let plan = |area: &str| {
        BASE.replace(
            "[[flight_line]]\nstart_m = [0.0, -10.0, 300.0]\nend_m = [0.0, 10.0, 300.0]\nspeed_mps = 50.0\n",
            &format!("[plan]\narea_m = {area}\naltitude_m = 300.0\n"),
        )
    };
    refused(
        "plan-bow-tie",
        &plan("[[-100, -100], [100, 100], [100, -100], [-100, 100]]"),
        &[],
        &["`plan.area_m`", "crosses itself"],
    );
    refused(
        "plan-collinear",
        &plan("[[-100, 0], [0, 0], [100, 0]]"),
        &[],
        &["`plan.area_m`", "encloses no area"],
    );
    refused(
        "forest-bow-tie",
        &format!(
            "{BASE}\n[[forest]]\narea_m = [[-50, -50], [50, 50], [50, -50], [-50, 50]]\n\
             stems_per_ha = 300\n"
        ),
        &[],
        &["`forest[0].area_m`", "crosses itself"],
    );
}

#[test]
fn input_files_with_impossible_values_are_refused() {
    let mesh = |file: &str| format!("{BASE}\n[[mesh]]\nfile = \"{file}\"\nmaterial = \"grass\"\n");
    for (name, v) in [("obj-1e300", "1e300"), ("obj-inf", "inf")] {
        let obj = format!("v 0 0 1\nv 1 0 1\nv 0 {v} 1\nv 1 1 1\nf 1 2 3\nf 2 4 1\n");
        refused(
            name,
            &mesh("m.obj"),
            &[("m.obj", obj.as_bytes())],
            &["`mesh[0].file`", "line 3", "not a finite number within"],
        );
    }
    let terrain = "[[terrain]]\nfile = \"dem.asc\"\nmaterial = \"grass\"\nclass = \"ground\"\n";
    for (name, v) in [("asc-1e300", "1e300"), ("asc-inf", "inf")] {
        let asc = format!(
            "ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 10\nNODATA_value -9999\n\
             1 2 3\n4 {v} 6\n7 8 9\n"
        );
        refused(
            name,
            &format!("{BASE}\n{terrain}"),
            &[("dem.asc", asc.as_bytes())],
            &[
                "`terrain[0].file`",
                "line 8",
                "row 2, column 2",
                "NODATA_value",
            ],
        );
    }
    let traj = |rows: &str| {
        BASE.replace(
            "[[flight_line]]\nstart_m = [0.0, -10.0, 300.0]\nend_m = [0.0, 10.0, 300.0]\nspeed_mps = 50.0\n",
            "[platform]\ntrajectory_file = \"t.csv\"\n",
        ) + rows
    };
    refused(
        "trajectory-far",
        &traj(""),
        &[(
            "t.csv",
            b"time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg\n0,0,0,300,0,0,0\n1,0,1e300,300,0,0,0\n",
        )],
        &["`platform.trajectory_file`", "line 3", "`y_m` is 1e300"],
    );
    refused(
        "trajectory-columns",
        &traj(""),
        &[(
            "t.csv",
            b"time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,line,extra\n0,0,0,300,0,0,0,1\n1,0,50,300,0,0,0,1\n",
        )],
        &["`platform.trajectory_file`", "line 2", "8 values for the header's 9 columns"],
    );
    // A LAS cloud whose header scales x by 0.
    let mut las =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/cloud/good.las"))
            .unwrap();
    las[131..139].copy_from_slice(&0f64.to_le_bytes());
    refused(
        "las-scale-zero",
        &format!(
            "{BASE}\n[[point_cloud]]\nfile = \"c.las\"\nmaterial = \"grass\"\nvoxel_m = 1.0\n"
        ),
        &[("c.las", &las)],
        &["`point_cloud[0].file`", "x scale factor is 0"],
    );
    refused(
        "voxel-tiny",
        &format!(
            "{BASE}\n[[point_cloud]]\nfile = \"c.las\"\nmaterial = \"grass\"\nvoxel_m = 1e-300\n"
        ),
        &[],
        &["`point_cloud[0].voxel_m`", "between 0.01 and 1000 m"],
    );
}

#[test]
fn messages_name_the_key_and_the_near_file() {
    // A mesh placed beyond the coordinate limit by its scale.
    let obj = b"v 0 0 0\nv 5e7 0 0\nv 0 5e7 0\nf 1 2 3\n";
    refused(
        "mesh-far",
        &format!("{BASE}\n[[mesh]]\nfile = \"m.obj\"\nmaterial = \"grass\"\nscale = 10.0\n"),
        &[("m.obj", obj)],
        &["`mesh[0].offset_m`", "reaches 500000000 m"],
    );
    refused(
        "did-you-mean",
        &format!("{BASE}\n[[mesh]]\nfile = \"hosue.obj\"\nmaterial = \"grass\"\n"),
        &[("house.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        &["`mesh[0].file`", "did you mean", "house.obj"],
    );
    // An ASCII grid whose first data row starts with nan (a hole) is data,
    // not a header key.
    let dir = temp("nan-row");
    std::fs::write(
        dir.join("dem.asc"),
        "ncols 3\nnrows 2\nxllcorner -300\nyllcorner -300\ncellsize 300\nnan 1 2\n3 4 5\n",
    )
    .unwrap();
    let survey = dir.join("s.toml");
    std::fs::write(
        &survey,
        BASE.replace(
            "[[polygon]]\nmaterial = \"grass\"\nclass = \"ground\"\nvertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]\n",
            "[[terrain]]\nfile = \"dem.asc\"\nmaterial = \"grass\"\nclass = \"ground\"\n",
        ),
    )
    .unwrap();
    let o = lidarsim(&["check".as_ref(), survey.as_os_str()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A flight line below the terrain gives no points: `check` and `run`
/// say why (a warning: the survey is valid).
#[test]
fn a_flight_below_the_ground_is_warned_about() {
    let dir = temp("below");
    let survey = dir.join("s.toml");
    std::fs::write(&survey, BASE.replace("300.0]", "-50.0]")).unwrap();
    let o = lidarsim(&["check".as_ref(), survey.as_os_str()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("flight line 1 flies below the ground") && stderr.contains("50.0 m above"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A run whose output cannot fit any disk (a day at 10 MHz over ground
/// along the whole line: 8.6 × 10¹¹ pulses, about 43 TB of LAS) is refused
/// before it starts, with the figures; `check` warns about it.
#[test]
fn a_run_too_large_for_the_disk_is_refused_before_it_starts() {
    let dir = temp("huge");
    let survey = dir.join("s.toml");
    let text = format!("{BASE}\n[output]\nlas_scale_m = 0.01\n")
        .replace("prf_hz = 20000", "prf_hz = 10000000")
        .replace(
            "end_m = [0.0, 10.0, 300.0]\nspeed_mps = 50.0",
            "end_m = [0.0, 4319990.0, 300.0]\nspeed_mps = 50.0",
        )
        // Ground under the whole line.
        .replace(
            "[300, 300, 0], [-300, 300, 0]",
            "[300, 4320300, 0], [-300, 4320300, 0]",
        );
    std::fs::write(&survey, text).unwrap();
    let out = dir.join("out");
    let o = lidarsim(&[
        "check".as_ref(),
        survey.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("--no-space-check") && stderr.contains("TB"),
        "{stderr}"
    );
    let o = lidarsim(&[
        "run".as_ref(),
        survey.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("free") && stderr.contains("--no-space-check"),
        "{stderr}"
    );
    let left: Vec<String> = std::fs::read_dir(&out)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .filter(|n| n != ".lidarsim-output")
                .collect()
        })
        .unwrap_or_default();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The estimate of `check` against what a run writes, on a plane that
/// returns one point per pulse: the LAS size exactly, PLY exactly, the
/// text and trajectories within a third.
#[test]
fn the_estimate_matches_the_files_of_a_run() {
    let dir = temp("estimate");
    let survey = dir.join("s.toml");
    std::fs::write(
        &survey,
        format!("{BASE}\n[output]\nformats = [\"las\", \"ply\", \"xyz\"]\n"),
    )
    .unwrap();
    let out = dir.join("out");
    let o = lidarsim(&[
        "run".as_ref(),
        survey.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["points"], summary["pulses"]);
    for f in summary["estimate"]["files"].as_array().unwrap() {
        let name = f["name"].as_str().unwrap();
        let want = f["bytes"].as_u64().unwrap() as f64;
        let have = std::fs::metadata(out.join(name)).unwrap().len() as f64;
        let tolerance = match name {
            "points.las" | "points.ply" => 0.0,
            "report.html" => continue,
            _ => 1.0 / 3.0,
        };
        assert!(
            (want - have).abs() <= tolerance * have,
            "{name}: estimated {want} bytes, wrote {have}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
