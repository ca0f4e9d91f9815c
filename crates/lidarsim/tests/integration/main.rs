//! The library's integration tests, one binary: each module tests one
//! capability end to end through the public API (see the table in
//! ARCHITECTURE.md); `kit` holds what they share.

mod kit;

mod canopy_marches;
mod channels;
mod deflectors;
mod erf;
mod fuzz;
mod gltf;
mod las_format;
mod layouts;
mod navigation;
mod outputs;
mod physics;
mod point_cloud;
mod presets;
mod resume;
mod terrain;
mod twin;
mod vegetation;
