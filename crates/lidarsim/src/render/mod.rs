//! Pictures of point clouds without system libraries: top views and
//! cross-sections rendered to RGB rasters and PNG files, with a legend or
//! colour bar and a scale bar (specification: "Ultimately the output is
//! visual"), and the plots of the report: a pulse's waveform and
//! quantities against time. Everything here draws data it is given.
//!
//! From the bottom up: the [`Image`] raster, its PNG encoding and its
//! built-in font; numbers on pictures ([`fixed`]), colours and legends
//! ([`Palette`]) and size limits ([`TooLarge`]); the frame around a map
//! ([`framed`]); then the pictures: [`top_view()`], [`profile()`],
//! [`WaveformPlot`] and [`time_panels()`].

mod font;
mod frame;
mod image;
mod labels;
mod limits;
mod palette;
mod point;
mod profile;
#[cfg(test)]
mod testing;
mod time_panels;
mod top_view;
mod waveform_plot;

pub use frame::{NO_DATA, framed, no_data};
pub use image::Image;
pub use labels::fixed;
pub use limits::{MAX_MAP_PIXELS, MAX_SIDE_PX, TooLarge};
pub use palette::{ColorBy, Palette, ROBUST_QUANTILES, class_color, ramp};
pub use point::RenderPoint;
pub use profile::{EMPTY, PROFILE_AXIS_PX, profile, profile_exaggerated, profile_row};
pub use time_panels::{SERIES_HEIGHT, SERIES_WIDTH, Series, time_panels};
pub use top_view::{hole_source, top_view};
pub use waveform_plot::{PLOT_HEIGHT, PLOT_WIDTH, WaveformPlot};
