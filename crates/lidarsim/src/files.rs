//! The files a survey asks for: its point files and their settings (the
//! LAS header fields, the waveform digitiser), the trajectory files, and
//! the survey as it is replayed from an output directory.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::output::{AtomicFile, LasSettings, WriteError};
use crate::sensor::navigation::observed_pose;
use crate::sensor::platform::FlightLine;
use crate::survey::{Layout, Survey};
use crate::world::World;

/// The single point files a survey writes, by final name (`points.wdp`
/// with full waveforms); LAS and LAZ points laid out in strips or tiles
/// are in [`layout_dir`] instead.
pub fn point_files(survey: &Survey) -> Vec<&'static str> {
    let f = &survey.output.formats;
    let single = survey.output.layout == Layout::Single;
    [
        ("points.las", f.las && single),
        ("points.wdp", f.las_waveform),
        ("points.laz", f.laz && single),
        ("points.ply", f.ply),
        ("points.xyz", f.xyz),
    ]
    .into_iter()
    .filter_map(|(n, on)| on.then_some(n))
    .collect()
}

/// The directory of the LAS and LAZ files of a survey laid out in strips
/// (`strips`) or tiles (`tiles`).
pub fn layout_dir(survey: &Survey) -> Option<&'static str> {
    match survey.output.layout {
        Layout::Single => None,
        Layout::Strips => Some("strips"),
        Layout::Tiles(_) => Some("tiles"),
    }
}

/// The files `survey` reads: the survey file, meshes, rasters, point
/// clouds, tree tables and the trajectory file.
pub fn input_files(survey: &Survey) -> Vec<PathBuf> {
    let raw = replayable(survey);
    let mut inputs: Vec<PathBuf> = survey.source.iter().cloned().collect();
    let files = raw
        .meshes
        .iter()
        .map(|m| &m.file)
        .chain(raw.terrains.iter().map(|t| &t.file))
        .chain(raw.point_clouds.iter().map(|c| &c.file))
        .chain(raw.tree_tables.iter().map(|t| &t.file))
        .chain(std::iter::once(&raw.platform.trajectory_file));
    inputs.extend(files.flatten().map(PathBuf::from));
    inputs
}

/// The raw survey with its seed fixed and relative file paths (meshes,
/// terrain rasters, point clouds, tree tables, trajectory file) resolved
/// against the survey's directory.
pub fn replayable(survey: &Survey) -> crate::survey::RawSurvey {
    let mut raw = survey.raw.clone();
    raw.seed = Some(survey.seed);
    let base = survey
        .source
        .as_ref()
        .and_then(|p| p.parent())
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let resolve = |f: &mut String| {
        let p = base.join(&*f);
        if let Ok(abs) = std::path::absolute(&p) {
            *f = abs.display().to_string();
        }
    };
    let files = raw
        .meshes
        .iter_mut()
        .map(|m| &mut m.file)
        .chain(raw.terrains.iter_mut().map(|t| &mut t.file))
        .chain(raw.point_clouds.iter_mut().map(|c| &mut c.file))
        .chain(raw.tree_tables.iter_mut().map(|t| &mut t.file));
    for f in files.flatten() {
        resolve(f);
    }
    if let Some(f) = raw.platform.trajectory_file.as_mut() {
        resolve(f);
    }
    raw
}

/// A scene entry given as data, and the file a run writes it to beside
/// its `survey.toml` (a path relative to the output directory).
#[derive(Clone, Debug)]
pub struct DataFile {
    /// Where it goes, relative to the output directory (`scene/...`).
    pub path: String,
    /// What it holds.
    pub entry: DataEntry,
}

/// The entry a [`DataFile`] holds.
#[derive(Clone, Debug)]
pub enum DataEntry {
    /// A `[[mesh]]` given as data.
    Mesh(crate::survey::spec::MeshEntry),
    /// A `[[terrain]]` given as data.
    Terrain(crate::survey::spec::TerrainEntry),
    /// A `[[point_cloud]]` given as data.
    Cloud(crate::survey::spec::CloudEntry),
}

/// The scene entries of `survey` given as data ([`crate::survey::data`]),
/// each with the file it is written to: `scene/mesh-I.obj` (the vertices
/// placed), `scene/terrain-I.tif`, `scene/point_cloud-I.xyz`, `I` the
/// entry's index in its table.
pub fn data_files(survey: &Survey) -> Vec<DataFile> {
    let spec = &survey.scene_spec;
    let meshes = spec
        .meshes
        .iter()
        .filter(|m| m.is_data())
        .map(|m| DataFile {
            path: format!("scene/mesh-{}.obj", m.index),
            entry: DataEntry::Mesh(m.clone()),
        });
    let terrains = spec
        .terrains
        .iter()
        .filter(|t| t.is_data())
        .map(|t| DataFile {
            path: format!("scene/terrain-{}.tif", t.index),
            entry: DataEntry::Terrain(t.clone()),
        });
    let clouds = spec
        .clouds
        .iter()
        .filter(|c| c.is_data())
        .map(|c| DataFile {
            path: format!("scene/point_cloud-{}.xyz", c.index),
            entry: DataEntry::Cloud(c.clone()),
        });
    meshes.chain(terrains).chain(clouds).collect()
}

impl DataFile {
    /// Writes the entry's data to `dir.join(self.path)`.
    pub fn write(&self, dir: &Path) -> io::Result<()> {
        use crate::survey::spec::{CloudSource, MeshSource, TerrainSource};
        let path = dir.join(&self.path);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        match &self.entry {
            DataEntry::Mesh(m) => {
                let MeshSource::Data(data) = &m.source else {
                    return Ok(());
                };
                let place = m.placement.placer();
                let placed: Vec<_> = data.vertices.iter().map(|&v| place(v)).collect();
                crate::io::export::write_obj(&path, &placed, &data.faces)
            }
            DataEntry::Terrain(t) => match &t.source {
                TerrainSource::Grid(grid) => crate::io::export::write_geotiff(&path, grid),
                _ => Ok(()),
            },
            DataEntry::Cloud(c) => match &c.source {
                CloudSource::Data(points) => {
                    crate::io::export::write_xyz(&path, &points.positions, &points.classes)
                }
                CloudSource::File(_) => Ok(()),
            },
        }
    }

    /// The survey table entry that names the written file.
    fn raw_entry(&self, raw: &mut crate::survey::RawSurvey) {
        use crate::survey::raw::{RawMesh, RawPointCloud, RawTerrain};
        let file = Some(self.path.clone());
        match &self.entry {
            DataEntry::Mesh(m) => raw.meshes.push(RawMesh {
                file,
                class: Some(m.placement.default_class.name().to_string()),
                material: m
                    .placement
                    .default_material
                    .as_ref()
                    .map(|m| m.name.clone()),
                ..RawMesh::default()
            }),
            DataEntry::Terrain(t) => raw.terrains.push(RawTerrain {
                file,
                class: Some(t.class.name().to_string()),
                material: Some(t.material.name.clone()),
                ..RawTerrain::default()
            }),
            DataEntry::Cloud(c) => raw.point_clouds.push(RawPointCloud {
                file,
                voxel_m: Some(c.voxel_m),
                class: c.class.map(|k| k.name().to_string()),
                material: Some(c.material.name.clone()),
                ..RawPointCloud::default()
            }),
        }
    }
}

/// [`replayable`] with the entries given as data naming the files
/// [`data_files`] gives (relative to the directory the survey is written
/// to), so that the survey written beside them runs the same scene.
pub fn replayable_with_data(survey: &Survey) -> crate::survey::RawSurvey {
    let mut raw = replayable(survey);
    for f in data_files(survey) {
        f.raw_entry(&mut raw);
    }
    raw
}

/// LAS header settings: offset at the scene centre (plus `[output]
/// offset_m`) rounded to 100 m (so that coordinates stay small integers),
/// the survey's scale, the creation date from `SOURCE_DATE_EPOCH` if set
/// (reproducible files) or today, echo attributes and error vector as extra
/// bytes, the CRS; point format 6, uncompressed.
pub fn las_settings(survey: &Survey, world: &World) -> LasSettings {
    las_settings_for(survey, world.scene_bounds(), &world.lines)
}

/// [`las_settings`] for a scene with bounds `b`.
pub fn las_settings_for(
    survey: &Survey,
    b: crate::geometry::Aabb,
    lines: &[FlightLine],
) -> LasSettings {
    let origin = survey.output.offset_m;
    let c = origin
        + if b.is_empty() {
            crate::geometry::DVec3::ZERO
        } else {
            b.center()
        };
    let round = |v: f64| (v / 100.0).round() * 100.0;
    let now = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs() as i64)
        });
    LasSettings {
        scale_m: survey.output.las_scale_m,
        offset_m: [round(c.x), round(c.y), round(origin.z)],
        origin_m: origin.to_array(),
        adjusted_standard_gps_time: survey.output.gps_start_time_s.is_some(),
        file_source_id: if lines.len() == 1 {
            (lines[0].index + 1) as u16
        } else {
            0
        },
        creation_day_year: crate::output::day_of_year(now),
        generating_software: format!("lidarsim {}", env!("CARGO_PKG_VERSION")),
        error_extra_bytes: !survey.navigation.is_zero(),
        attribute_extra_bytes: survey.output.extra_bytes,
        crs_wkt: survey.output.crs_wkt.clone(),
        compressed: false,
        waveform: None,
        waveform_file_shared: false,
    }
}

/// The waveform digitiser of a survey: its receiver's sample spacing, and
/// a full scale of twice the strongest echo the survey can give without
/// speckle — a white Lambertian surface filling the beam head-on at the
/// closest range a flight line comes to the top of the scene, `(Rn / R)²`
/// (specification Eq. 2) — and at least 1.
pub fn digitizer(survey: &Survey, world: &World) -> crate::output::Digitizer {
    let top = world.scene_bounds();
    let top_z = if top.is_empty() { 0.0 } else { top.max.z };
    let closest = world
        .lines
        .iter()
        .map(|l| l.start_m.z.min(l.end_m.z) - top_z)
        .fold(f64::INFINITY, f64::min)
        .max(survey.scanner.min_range_m)
        .max(1.0);
    let rn = survey.receiver.reference_range_m;
    crate::output::Digitizer::with_full_scale(
        (survey.receiver.bin_s * 1e12).round() as u32,
        (2.0 * (rn / closest).powi(2)).max(1.0),
    )
}

/// One row of a trajectory: the scanner's pose at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryRow {
    /// Time in the points' time base (GPS time when `gps_start_time_s` is
    /// set), s.
    pub gps_time_s: f64,
    /// Position in output coordinates (`[output] offset_m` added), m.
    pub position_m: crate::geometry::DVec3,
    /// Roll, pitch and yaw, degrees.
    pub attitude_deg: [f64; 3],
    /// Flight line number, 1 for the first.
    pub line: u32,
}

/// The trajectory, one row per `trajectory_interval_s` of each flight
/// line. `observed` selects the trajectory the GNSS/IMU measured (biases
/// and correlated errors; the per-pulse white noise is not in it) instead
/// of the one flown.
pub fn trajectory_rows(
    survey: &Survey,
    lines: &[FlightLine],
    observed: bool,
) -> Vec<TrajectoryRow> {
    let offset = survey.output.gps_start_time_s.unwrap_or(0.0);
    let dt = survey.output.trajectory_interval_s;
    let origin = survey.output.offset_m;
    let mut rows = Vec::new();
    for line in lines {
        let n = (line.duration_s() / dt).floor() as u64;
        for j in 0..=n {
            let t = j as f64 * dt;
            let truth = line.pose_at(t);
            let p = if observed {
                observed_pose(&truth, &survey.navigation, &line.nav_errors, t, None)
            } else {
                truth
            };
            rows.push(TrajectoryRow {
                gps_time_s: offset + line.start_time_s + t,
                position_m: p.position_m + origin,
                attitude_deg: [
                    p.attitude.roll_rad.to_degrees(),
                    p.attitude.pitch_rad.to_degrees(),
                    p.attitude.yaw_rad.to_degrees(),
                ],
                line: line.index + 1,
            });
        }
    }
    rows
}

/// Writes the trajectory (observed or flown, as [`trajectory_rows`]) as CSV
/// into each of `paths` (the same bytes in each, formatted once). Each file
/// is written under a temporary name and renamed when complete; an error
/// names the file.
pub fn write_trajectory(
    survey: &Survey,
    lines: &[FlightLine],
    paths: &[&Path],
    observed: bool,
) -> Result<(), WriteError> {
    let mut files = paths
        .iter()
        .map(|p| AtomicFile::create(p))
        .collect::<Result<Vec<_>, _>>()?;
    let write_all = |files: &mut [AtomicFile], row: &[u8]| -> Result<(), WriteError> {
        for f in files.iter_mut() {
            f.writer().write_all(row).map_err(|e| f.error(e))?;
        }
        Ok(())
    };
    write_all(
        &mut files,
        b"gps_time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,line\n",
    )?;
    // Rows as `{:.6},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{}` writes them,
    // a block of them at a time.
    let mut block = Vec::with_capacity(1 << 16);
    for r in trajectory_rows(survey, lines, observed) {
        use crate::output::text::{push_fixed, push_u64};
        push_fixed(&mut block, r.gps_time_s, 6);
        for v in r.position_m.to_array() {
            block.push(b',');
            push_fixed(&mut block, v, 4);
        }
        for v in r.attitude_deg {
            block.push(b',');
            push_fixed(&mut block, v, 6);
        }
        block.push(b',');
        push_u64(&mut block, u64::from(r.line));
        block.push(b'\n');
        if block.len() >= 1 << 16 {
            write_all(&mut files, &block)?;
            block.clear();
        }
    }
    write_all(&mut files, &block)?;
    for f in files {
        f.commit()?;
    }
    Ok(())
}
