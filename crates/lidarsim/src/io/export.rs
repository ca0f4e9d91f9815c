//! Scene data written in the formats the readers of this module read, so
//! that what a program gave as data (a mesh, a height grid, points) can be
//! named by a survey file and read back to the same values: an OBJ of
//! vertices and faces, a single-band float GeoTIFF of a height grid, an
//! XYZ text file of points. Numbers are written in their shortest form
//! that reads back to the same `f64` (or `f32`).

use std::io::{self, BufWriter, Write};
use std::path::Path;

use crate::geometry::DVec3;
use crate::scene::terrain::HeightGrid;

/// `GTRasterTypeGeoKey` = `RasterPixelIsPoint` (GeoTIFF 1.1 §7.4.2): the
/// pixels are the grid's nodes.
const PIXEL_IS_POINT_KEYS: [u16; 8] = [1, 1, 0, 1, 1025, 0, 1, 2];

/// Writes `vertices` and `faces` (0-based vertex indices) as an OBJ file
/// without groups or materials.
pub fn write_obj(path: &Path, vertices: &[DVec3], faces: &[[u32; 3]]) -> io::Result<()> {
    let mut w = BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "# written by lidarsim: a mesh given as data")?;
    for v in vertices {
        writeln!(w, "v {} {} {}", v.x, v.y, v.z)?;
    }
    for f in faces {
        writeln!(w, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1)?;
    }
    w.into_inner().map_err(|e| e.into_error())?.sync_all()
}

/// Writes `grid` as a GeoTIFF of 32-bit float heights (NaN for nodata),
/// its nodes as pixels (`RasterPixelIsPoint`), rows from the south, placed
/// by a `ModelTransformationTag` that holds the grid's origin and spacing
/// as they are. The grid's `z_offset_m` must be 0.
pub fn write_geotiff(path: &Path, grid: &HeightGrid) -> io::Result<()> {
    use tiff::encoder::{TiffEncoder, colortype::Gray32Float};
    use tiff::tags::Tag;
    if grid.z_offset_m != 0.0 {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "a height grid with a height offset is not written",
        ));
    }
    let tiff_err = |e: tiff::TiffError| io::Error::other(e.to_string());
    let file = BufWriter::new(std::fs::File::create(path)?);
    let mut tiff = TiffEncoder::new(file).map_err(tiff_err)?;
    let (cols, rows) = (
        u32::try_from(grid.cols).map_err(io::Error::other)?,
        u32::try_from(grid.rows).map_err(io::Error::other)?,
    );
    let mut image = tiff
        .new_image::<Gray32Float>(cols, rows)
        .map_err(tiff_err)?;
    let [x0, y0] = grid.origin_m;
    let [dx, dy] = grid.spacing_m;
    // Model X = x0 + dx·I, Y = y0 + dy·J: row J of the file is grid row J.
    let transform: [f64; 16] = [
        dx, 0.0, 0.0, x0, //
        0.0, dy, 0.0, y0, //
        0.0, 0.0, 1.0, 0.0, //
        0.0, 0.0, 0.0, 1.0,
    ];
    image
        .encoder()
        .write_tag(Tag::ModelTransformationTag, &transform[..])
        .map_err(tiff_err)?;
    image
        .encoder()
        .write_tag(Tag::GeoKeyDirectoryTag, &PIXEL_IS_POINT_KEYS[..])
        .map_err(tiff_err)?;
    image.write_data(&grid.heights).map_err(tiff_err)
}

/// Writes points as an XYZ text file, `x y z class` a line.
pub fn write_xyz(path: &Path, positions: &[DVec3], classes: &[u8]) -> io::Result<()> {
    let mut w = BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        w,
        "# written by lidarsim: points given as data (x y z class)"
    )?;
    for (i, p) in positions.iter().enumerate() {
        let class = classes.get(i).copied().unwrap_or(1);
        writeln!(w, "{} {} {} {class}", p.x, p.y, p.z)?;
    }
    w.into_inner().map_err(|e| e.into_error())?.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::cloud::CloudPlacement;
    use crate::scene::{MeshPlacement, Scene, Shape, SurfaceClass};

    fn dir() -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("lidarsim-export-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A grid with awkward numbers (spacing and origin with no short
    /// decimal form, a nodata node, a negative height) reads back as
    /// itself.
    #[test]
    fn a_written_geotiff_reads_back_as_the_grid() {
        let grid = HeightGrid {
            cols: 5,
            rows: 3,
            origin_m: [512_345.123_456_789, 6_789_012.987_654_321],
            spacing_m: [0.1 + 0.2, 1.0 / 3.0],
            z_offset_m: 0.0,
            heights: (0..15)
                .map(|i| {
                    if i == 7 {
                        f32::NAN
                    } else {
                        i as f32 * 0.37 - 2.0
                    }
                })
                .collect(),
        };
        let path = dir().join("grid.tif");
        write_geotiff(&path, &grid).unwrap();
        let back = crate::io::raster::read_raster(&path).unwrap();
        assert_eq!((back.cols, back.rows), (5, 3));
        assert_eq!(back.origin_m, grid.origin_m);
        assert_eq!(back.spacing_m, grid.spacing_m);
        for (a, b) in back.heights.iter().zip(&grid.heights) {
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
        }
    }

    /// An OBJ of awkward vertices gives the triangles the data gives.
    #[test]
    fn a_written_obj_reads_back_as_the_mesh() {
        let vertices = vec![
            DVec3::new(0.1, 0.2, 0.3),
            DVec3::new(10.0 / 3.0, -1e-7, 2.0f64.sqrt()),
            DVec3::new(-5.5, 7.0 + 1e-12, 0.0),
            DVec3::new(1.0, 1.0, 1.0),
        ];
        let faces = vec![[0, 1, 2], [1, 2, 3]];
        let path = dir().join("mesh.obj");
        write_obj(&path, &vertices, &faces).unwrap();
        let material = crate::scene::Material {
            name: "m".into(),
            reflectance: 0.5,
            incidence_exponent: 1.0,
            spectrum: Vec::new(),
        };
        let placement = MeshPlacement {
            scale: 1.0,
            rotation_z_rad: 0.0,
            offset_m: DVec3::ZERO,
            default_class: SurfaceClass::Roof,
            default_material: Some(material.clone()),
            class_map: Vec::new(),
        };
        let mut from_file = Scene::default();
        crate::io::obj::load_obj(&path, &placement, &Default::default(), &mut from_file).unwrap();
        let mut from_data = Scene::default();
        let m = from_data.add_material(material);
        placement.add_triangles(&mut from_data, &vertices, &faces, m, "data");
        let corners = |s: &Scene| -> Vec<[DVec3; 3]> {
            s.primitives
                .iter()
                .map(|p| match &p.shape {
                    Shape::Triangle(t) => t.vertices(),
                    _ => unreachable!(),
                })
                .collect()
        };
        assert_eq!(corners(&from_file), corners(&from_data));
        assert!(
            from_file
                .primitives
                .iter()
                .all(|p| p.class == SurfaceClass::Roof)
        );
    }

    /// An XYZ file of points gives the voxels the points give.
    #[test]
    fn a_written_xyz_reads_back_as_the_points() {
        let positions: Vec<DVec3> = (0..200)
            .map(|i| DVec3::new(i as f64 * 0.013, (i % 7) as f64 / 3.0, 1.0 / (i + 1) as f64))
            .collect();
        let classes: Vec<u8> = (0..200).map(|i| [2u8, 5, 6][i % 3]).collect();
        let path = dir().join("cloud.xyz");
        write_xyz(&path, &positions, &classes).unwrap();
        let placement = CloudPlacement {
            voxel_m: 0.1,
            offset_m: DVec3::ZERO,
            material: 0,
            class: None,
        };
        let (mut a, mut b) = (Scene::default(), Scene::default());
        let (read, voxels) = crate::io::cloud::load_point_cloud(&path, &placement, &mut a).unwrap();
        crate::io::cloud::add_point_data(&positions, &classes, &placement, "data", &mut b).unwrap();
        assert_eq!(read, 200);
        assert_eq!(voxels, b.primitives.len());
        let cells = |s: &Scene| -> Vec<(DVec3, SurfaceClass)> {
            s.primitives
                .iter()
                .map(|p| match &p.shape {
                    Shape::Voxel(v) => (v.bounds.min, p.class),
                    _ => unreachable!(),
                })
                .collect()
        };
        assert_eq!(cells(&a), cells(&b));
    }
}
