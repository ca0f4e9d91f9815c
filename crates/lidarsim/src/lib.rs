//! # lidarsim — an airborne LiDAR simulator
//!
//! lidarsim flies a virtual aircraft or drone with a scanning laser over a
//! scene of polygons, meshes, terrain, point clouds and trees, casts every
//! pulse as a bundle of sub-rays, records the returned energy as a full
//! waveform, detects echoes in it and writes georeferenced point clouds
//! (LAS 1.4, LAZ, PLY, XYZ) with ground-truth classes.
//!
//! The models follow the project specification, described in
//! `docs/models.md` of the repository and cited as "specification"; each
//! module names the equations it implements.
//!
//! ## The pipeline
//!
//! 1. [`survey`]: a TOML file read and checked into a [`Survey`] — settings
//!    only, every problem reported at its file, line and key.
//! 2. [`world`]: the scene built from the files the survey names (readers
//!    in [`io`], primitives in [`scene`]), indexed once ([`accel`]), its
//!    forests placed on the ground and its flight lines planned over it.
//! 3. [`sim`]: pulse by pulse, the sensor ([`sensor`]: platform pose,
//!    navigation errors, scanner, beam sub-rays) casts rays into the
//!    index; [`canopy`] attenuates them through crowns, [`radiometry`]
//!    gives their power (specification, Eq. 2), [`waveform`] samples the
//!    signal and [`detection`] finds echoes, which are georeferenced.
//!    Blocks of pulses run in parallel and are written in pulse order.
//! 4. [`output`]: point and waveform files; [`run`] ties a whole run to an
//!    output directory (resume, budget, summary, report).
//!
//! [`plan`] predicts swath and density, [`budget`] disk and memory,
//! [`report`] and [`render`] draw what a run wrote.
//!
//! ## Example
//!
//! ```
//! use lidarsim::{Survey, World, output::MemorySink, sim::Simulator};
//!
//! let text = r#"
//! [scanner]
//! prf_hz = 20000
//! [[flight_line]]
//! start_m = [0.0, -20.0, 300.0]
//! end_m = [0.0, 20.0, 300.0]
//! speed_mps = 50.0
//! [materials.grass]
//! reflectance = 0.4
//! [[polygon]]
//! material = "grass"
//! class = "ground"
//! vertices_m = [[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]]
//! "#;
//! let survey = Survey::from_toml(text, None).unwrap();
//! let world = World::build(&survey).unwrap();
//! let sim = Simulator::new(&survey, &world);
//! let mut points = MemorySink::default();
//! let counts = sim.run(1, &mut [&mut points], &|_| {}).unwrap();
//! // 40 m at 50 m/s and 20 kHz.
//! assert_eq!(counts.pulses, 16_000);
//! // One echo per pulse from a plane, all of them on it.
//! assert_eq!(points.points.len() as u64, counts.pulses);
//! assert!(points.points.iter().all(|p| p.position_m.z.abs() < 0.01));
//! ```

#![deny(missing_docs)]

pub mod accel;
pub mod budget;
pub mod canopy;
pub mod compare;
pub mod demo;
pub mod detection;
pub mod error;
pub mod files;
pub mod flight;
pub mod geometry;
pub mod io;
pub mod kernels;
pub mod memory;
pub mod message;
pub mod output;
pub mod owned;
pub mod plan;
pub mod radiometry;
pub mod render;
pub mod report;
pub mod rng;
pub mod run;
pub mod scan;
pub mod scene;
pub mod sensor;
pub mod sim;
pub mod summary;
pub mod survey;
pub mod twin;
pub mod waveform;
pub mod world;

pub use error::Error;
pub use flight::Flight;
pub use survey::Survey;
pub use world::World;
