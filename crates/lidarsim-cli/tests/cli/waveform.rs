//! `lidarsim waveform`: a pulse of a run simulated again, named by line and
//! number, by GPS time or by a place, over any scene the run had.

use crate::kit::{GOOD, bin, run_survey, temp};

#[test]
fn waveform_plots_a_pulse_of_a_run() {
    let dir = temp("waveform");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success());
    assert!(out.join("survey.toml").exists());
    let png = dir.join("w.png");
    let o = bin()
        .arg("waveform")
        .arg(&out)
        .args(["--pulse", "100", "-o"])
        .arg(&png)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // One echo from the plane 300 m below at the pulse's scan angle.
    assert!(text.contains("1 echo(es)"), "{text}");
    assert!(text.contains("range 30"), "{text}");
    assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
    // The run's survey.toml repeats the run exactly.
    let again = dir.join("again");
    let o = bin()
        .arg("run")
        .arg(out.join("survey.toml"))
        .arg("-o")
        .arg(&again)
        .env("SOURCE_DATE_EPOCH", "1790000000")
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(
        std::fs::read(out.join("points.xyz")).unwrap(),
        std::fs::read(again.join("points.xyz")).unwrap()
    );
    for bad in [
        vec!["--pulse", "99999999"],
        vec!["--line", "5", "--pulse", "1"],
        vec![],
    ] {
        let o = bin().arg("waveform").arg(&out).args(&bad).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Regression: a run's survey.toml kept terrain raster paths relative to
/// the original survey, so `waveform` (which reloads it from the output
/// directory) could not find the raster.
#[test]
fn waveform_replays_a_run_over_a_relative_terrain_raster() {
    let dir = temp("waveform-terrain");
    std::fs::write(
        dir.join("dem.asc"),
        "ncols 3\nnrows 3\nxllcorner -300\nyllcorner -300\ncellsize 200\n\
         12 12 12\n12 12 12\n12 12 12\n",
    )
    .unwrap();
    let text = GOOD.replace(
        "[[polygon]]\nmaterial = \"grass\"\nclass = \"ground\"\n\
         vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]\n",
        "[[terrain]]\nfile = \"dem.asc\"\nmaterial = \"grass\"\n",
    );
    assert!(text.contains("[[terrain]]"));
    let (o, out) = run_survey(&dir, &text);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = bin()
        .arg("waveform")
        .arg(&out)
        .args(["--pulse", "100", "-o"])
        .arg(dir.join("w.png"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The flat raster at 12 m, 288 m below the 300 m line.
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("1 echo(es)") && text.contains("range 29"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `waveform --near X,Y[,Z]` takes the pulse of the point of points.las
/// nearest to a place: its line from the point source ID, its pulse from
/// its GPS time (pulse k of the line at 20 kHz leaves at k / 20 000 s).
/// The pulse simulated again has an echo at that point's range.
#[test]
fn waveform_near_finds_the_pulse_of_the_nearest_point() {
    let dir = temp("waveform-near");
    let (o, out) = run_survey(&dir, GOOD);
    assert!(o.status.success());
    let xyz = std::fs::read_to_string(out.join("points.xyz")).unwrap();
    let png = dir.join("w.png");
    for row in [50usize, 3000, 7000] {
        let cols: Vec<&str> = xyz.lines().nth(row).unwrap().split_whitespace().collect();
        let num = |i: usize| cols[i].parse::<f64>().unwrap();
        let (x, y, z, gps, source, range) = (num(0), num(1), num(2), num(7), cols[9], num(12));
        let pulse = (gps * 20_000.0).round() as u64;
        for near in [format!("{x},{y}"), format!("{x},{y},{z}")] {
            let o = bin()
                .arg("waveform")
                .arg(&out)
                .args(["--near", &near, "-o"])
                .arg(&png)
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            assert_eq!(source, "1");
            // The point chosen: the one of the row (points.las and
            // points.xyz round to the millimetre each their own way).
            let chosen: Vec<f64> = text
                .split_once(&format!("nearest point to {near}: ("))
                .and_then(|(_, rest)| rest.split_once(" m away, line 1 (point source ID)"))
                .map(|(nums, _)| {
                    nums.split([',', ')', ' '])
                        .filter_map(|v| v.parse().ok())
                        .collect()
                })
                .unwrap_or_default();
            assert_eq!(chosen.len(), 4, "{text}");
            assert!(
                (chosen[0] - x).abs() <= 0.0015
                    && (chosen[1] - y).abs() <= 0.0015
                    && (chosen[2] - z).abs() <= 0.0015
                    && chosen[3] <= 0.003,
                "{text}"
            );
            assert!(
                text.contains(&format!("line 1 pulse {pulse} ")),
                "{near}: pulse {pulse} wanted: {text}"
            );
            let ranges: Vec<f64> = text
                .split("range ")
                .skip(1)
                .filter_map(|r| r.split(' ').next()?.parse().ok())
                .collect();
            assert!(
                ranges.iter().any(|r| (r - range).abs() < 0.0015),
                "{range} not among {ranges:?}"
            );
        }
    }
    for bad in [
        vec!["--near", "1"],
        vec!["--near", "a,b"],
        vec!["--near", "1,2,3,4"],
        vec!["--near", "0,0", "--pulse", "3"],
        vec!["--near", "0,0", "--gps-time", "0.1"],
    ] {
        let o = bin().arg("waveform").arg(&out).args(&bad).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // A run without points.las or points.laz.
    std::fs::remove_file(out.join("points.las")).unwrap();
    let o = bin()
        .arg("waveform")
        .arg(&out)
        .args(["--near", "0,0"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("neither points.las nor points.laz"));
    std::fs::remove_dir_all(&dir).ok();
}

/// The help says where pulse numbers and GPS times come from.
#[test]
fn waveform_help_says_where_pulses_come_from() {
    let o = bin().args(["waveform", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&o.stdout).replace(char::is_whitespace, " ");
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    for words in [
        "the point source ID of points.las",
        "1 for the first",
        "the gps_time of any point in points.las, points.xyz or points.ply",
        "--near <X,Y[,Z]>",
        "Point files have no pulse column",
    ] {
        assert!(help.contains(words), "no '{words}' in {help}");
    }
    assert!(!help.contains("points.xyz order"), "{help}");
}
