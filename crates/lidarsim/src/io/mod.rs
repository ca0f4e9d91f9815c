//! Readers: the files a survey names, turned into parts of the scene or
//! into flight lines. Every reader takes only regular files within a size
//! bound ([`input`]) and names the file, and where meaningful the line, of
//! each problem. [`export`] writes scene data in the readers' formats.

pub mod cloud;
pub mod export;
pub mod gltf;
pub mod input;
pub mod mesh;
pub mod obj;
pub mod raster;
pub mod trajectory;
pub mod tree_table;
