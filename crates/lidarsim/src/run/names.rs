//! The names of what a run writes into its output directory, and of what
//! a part of a split run writes into its own: one list, read by the rules
//! that keep a run from touching what it did not write ([`super::outdir`]),
//! by the run's stages and by the merge.

/// The run's summary.
pub const SUMMARY: &str = "summary.json";
/// The run's report.
pub const REPORT: &str = "report.html";
/// The survey as run.
pub const SURVEY: &str = "survey.toml";
/// The saved report state of an interrupted run, or of a stitched part.
pub const REPORT_STATE: &str = "report.state";
/// A part's point file, every field of every point (when not
/// [`super::part::stitched`]).
pub const PART_POINTS: &str = "points.part";
/// A stitched part's point file: its records as the unsplit run's LAS
/// file holds them.
pub const PART_LAS: &str = "points.las";
/// A part's record.
pub const PART_RECORD: &str = "part.json";

/// The trajectory files, by name, and whether each is the observed one
/// (`trajectory.csv`, kept under its first name, is the flown one, as
/// `trajectory_true.csv` is).
pub const TRAJECTORY_FILES: [(&str, bool); 3] = [
    ("trajectory.csv", false),
    ("trajectory_true.csv", false),
    ("trajectory_observed.csv", true),
];

/// The file that marks a directory as one a run wrote into.
pub const MARKER: &str = ".lidarsim-output";

/// Every file a run may write, by its final name.
pub const RUN_FILES: [&str; 14] = [
    "points.las",
    "points.laz",
    "points.ply",
    "points.xyz",
    "points.wdp",
    "survey.toml",
    "trajectory.csv",
    "trajectory_true.csv",
    "trajectory_observed.csv",
    "summary.json",
    "report.html",
    REPORT_STATE,
    PART_POINTS,
    PART_RECORD,
];

/// The directory in which a run writes the scene entries a program gave
/// as data ([`crate::files::data_files`]).
pub const DATA_DIR: &str = "scene";

/// Whether `name` is a file a run writes: one of [`RUN_FILES`], the same
/// with `.partial` (a file being written), or the [`MARKER`].
pub fn is_run_file(name: &str) -> bool {
    let base = name.strip_suffix(".partial").unwrap_or(name);
    name == MARKER || RUN_FILES.contains(&base)
}

/// The directories of strips and tiles ([`crate::files::layout_dir`]).
pub const LAYOUT_DIRS: [&str; 2] = ["strips", "tiles"];

/// Whether `name` is a file a run writes into [`DATA_DIR`]:
/// `mesh-I.obj`, `terrain-I.tif` or `point_cloud-I.xyz`.
pub fn is_data_file(name: &str) -> bool {
    [
        ("mesh-", ".obj"),
        ("terrain-", ".tif"),
        ("point_cloud-", ".xyz"),
    ]
    .iter()
    .any(|(prefix, suffix)| {
        name.strip_prefix(prefix)
            .and_then(|rest| rest.strip_suffix(suffix))
            .is_some_and(|i| !i.is_empty() && i.bytes().all(|b| b.is_ascii_digit()))
    })
}

/// Whether `name` is a file a run writes into a strips or tiles
/// directory: `line-NNNN.las`/`.laz`, `tile_X_Y.las`/`.laz`, the tiles'
/// `index.geojson`, the same with `.partial`, and the `.spill` directory.
pub fn is_layout_file(name: &str) -> bool {
    let base = name.strip_suffix(".partial").unwrap_or(name);
    let las = |stem: &str| {
        [".las", ".laz"]
            .iter()
            .any(|ext| base.strip_prefix(stem).is_some_and(|r| r.ends_with(ext)))
    };
    las("line-") || las("tile_") || base == "index.geojson" || name == ".spill"
}
