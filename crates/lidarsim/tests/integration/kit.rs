//! What the library's integration tests share: fresh directories named
//! after the test file that asks for them, survey text built from parts
//! (flight lines, a ground plane, a scanner), and a whole run of a survey
//! into a directory.

// Each test module uses some of these.
#![allow(dead_code)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use lidarsim::run::{RunOptions, Summary, run};
use lidarsim::{Flight, Survey};

/// The directory of test `name` of the calling file, not yet created (a
/// run's fresh output directory): under the system's temporary directory,
/// named after the file and the process so that tests of different files
/// and runs of the suite never share one.
#[track_caller]
pub fn fresh(name: &str) -> PathBuf {
    let file = Path::new(std::panic::Location::caller().file());
    let stem = file
        .file_stem()
        .map_or("test".into(), |s| s.to_string_lossy());
    let d = std::env::temp_dir().join(format!("lidarsim-{stem}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// [`fresh`], created empty.
#[track_caller]
pub fn temp(name: &str) -> PathBuf {
    let d = fresh(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A survey's TOML text built from parts, in the order given: the seed,
/// then tables ([`SurveyText::scanner`], [`SurveyText::line`],
/// [`SurveyText::ground`], or any text with [`SurveyText::raw`]).
#[derive(Clone, Debug)]
pub struct SurveyText(String);

impl SurveyText {
    /// A survey with `seed`.
    pub fn new(seed: u64) -> Self {
        Self(format!("seed = {seed}\n"))
    }

    /// A `[scanner]` table of a pulse rate, a scan half-angle and a
    /// number of sub-rays (everything else at its default).
    pub fn scanner(mut self, prf_hz: f64, scan_angle_deg: f64, subrays: u32) -> Self {
        let _ = writeln!(
            self.0,
            "[scanner]\nprf_hz = {prf_hz}\nscan_angle_deg = {scan_angle_deg}\nsubrays = {subrays}"
        );
        self
    }

    /// A `[[flight_line]]` from `start` to `end` (metres) at `speed_mps`.
    pub fn line(mut self, start: [f64; 3], end: [f64; 3], speed_mps: f64) -> Self {
        let [a, b, c] = start;
        let [d, e, f] = end;
        let _ = writeln!(
            self.0,
            "[[flight_line]]\nstart_m = [{a:?}, {b:?}, {c:?}]\nend_m = [{d:?}, {e:?}, {f:?}]\n\
             speed_mps = {speed_mps:?}"
        );
        self
    }

    /// A level square of ground at height 0, `half_m` from the origin to
    /// each side, of a material `name` of the given reflectance.
    pub fn ground(mut self, name: &str, reflectance: f64, half_m: f64) -> Self {
        let h = half_m;
        let _ = writeln!(
            self.0,
            "[materials.{name}]\nreflectance = {reflectance:?}\n[[polygon]]\nmaterial = \"{name}\"\n\
             class = \"ground\"\nvertices_m = [[{}, {}, 0], [{h}, {}, 0], [{h}, {h}, 0], [{}, {h}, 0]]",
            -h, -h, -h, -h
        );
        self
    }

    /// Any TOML text, as given (a newline is added).
    pub fn raw(mut self, text: &str) -> Self {
        self.0.push_str(text);
        self.0.push('\n');
        self
    }

    /// The text.
    pub fn text(&self) -> &str {
        &self.0
    }

    /// The survey (panics with its problems if the text is not one).
    pub fn survey(&self) -> Survey {
        Survey::from_toml(&self.0, None).unwrap_or_else(|e| panic!("{e}\n{}", self.0))
    }
}

/// Runs `survey` on `threads` threads into the fresh directory `dir`.
pub fn run_into(survey: &Survey, dir: &Path, threads: usize) -> Summary {
    let flight = Flight::build(survey.clone()).unwrap_or_else(|e| panic!("{e}"));
    run(&flight, dir, &RunOptions::new(threads, &|_| {})).unwrap_or_else(|e| panic!("{e}"))
}

/// Builds `survey`'s flight and runs it into `dir` with `options`.
pub fn run_to_dir(
    survey: &Survey,
    dir: &Path,
    options: &RunOptions<'_>,
) -> Result<Summary, lidarsim::Error> {
    run(&Flight::build(survey.clone())?, dir, options)
}
