//! # lidarsim — an airborne LiDAR simulator
//!
//! lidarsim flies a virtual aircraft with an oscillating-mirror laser
//! scanner over a scene of planar polygons and triangle meshes, casts every
//! pulse as a bundle of sub-rays, records the returned energy as a full
//! waveform, detects echoes in it and writes georeferenced point clouds
//! (LAS 1.4) with ground-truth classes.
//!
//! The models follow the project specification, described in
//! `docs/models.md` of the repository and cited as "specification"; each
//! module names the equations it implements.
//!
//! Data flow, one module per step:
//! [`survey`] (file → validated [`Survey`] and [`scene::Scene`]) →
//! [`accel`] (closest hits) ← [`platform`] (pose at `t`) + [`scanner`]
//! (mirror angle, sub-rays) → [`radiometry`] (Eq. 2) → [`waveform`]
//! (sampled signal) → [`detection`] (echoes) → [`sim`] (georeferencing,
//! classes, parallel blocks) → [`output`] (LAS, XYZ). [`run`] ties a whole
//! run to an output directory; [`plan`] predicts swath and density.
//!
//! ```
//! use lidarsim::{Survey, accel::Bvh, output::MemorySink, sim::Simulator};
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
//! let bvh = Bvh::build(survey.scene.clone());
//! let sim = Simulator::new(&survey, &bvh);
//! let mut points = MemorySink::default();
//! let counts = sim.run(1, &mut [&mut points], &|_| {}).unwrap();
//! assert_eq!(counts.pulses, 16_000);
//! // One echo per pulse from a plane, all of them on it.
//! assert_eq!(points.points.len() as u64, counts.pulses);
//! assert!(points.points.iter().all(|p| p.position_m.z.abs() < 0.01));
//! ```

#![deny(missing_docs)]

pub mod accel;
pub mod bench;
pub mod budget;
pub mod canopy;
pub mod demo;
pub mod detection;
pub mod files;
pub mod geometry;
pub mod io;
pub mod message;
pub mod output;
pub mod plan;
pub mod radiometry;
pub mod render;
pub mod report;
pub mod rng;
pub mod run;
pub mod scene;
pub mod sensor;
pub mod sim;
pub mod summary;
pub mod survey;
pub mod waveform;

pub use survey::Survey;
