//! Pictures of point clouds without system libraries: top views and
//! cross-sections rendered to RGB rasters and PNG files, with a legend or
//! colour bar and a scale bar (specification: "Ultimately the output is
//! visual"), and the plots of the report: a pulse's waveform and
//! quantities against time. Everything here draws data it is given.
//!
//! From the bottom up: the [`Image`] raster and its PNG encoding, text in
//! an embedded open font ([`text_width`]), the [`Figure`] of marks drawn
//! either as pixels (PNG) or as SVG (the report); numbers on pictures ([`fixed`]), colours and legends
//! ([`Palette`]) and size limits ([`TooLarge`]); the frame around a map
//! ([`framed`]); then the pictures: [`top_view()`], [`profile()`],
//! [`WaveformPlot`] and [`time_panels()`].

mod figure;
mod frame;
mod image;
mod labels;
mod limits;
mod palette;
mod point;
mod profile;
#[cfg(test)]
mod testing;
mod text;
mod time_panels;
mod top_view;
mod waveform_plot;

pub use figure::{Anchor, Figure, LABEL_PX, Mark, TITLE_PX};
pub use frame::{NO_DATA, framed, no_data};
pub use image::{Image, base64};
pub use labels::{fixed, nice_ticks};
pub use limits::{MAX_MAP_PIXELS, MAX_SIDE_PX, TooLarge};
pub use palette::{ColorBy, Palette, ROBUST_QUANTILES, class_color, ramp};
pub use point::RenderPoint;
pub use profile::{EMPTY, PROFILE_AXIS_PX, profile, profile_exaggerated, profile_row};
pub use text::text_width;
pub use time_panels::{SERIES_HEIGHT, SERIES_WIDTH, Series, time_panels};
pub use top_view::{hole_source, top_view};
pub use waveform_plot::{PLOT_HEIGHT, PLOT_WIDTH, WaveformPlot};
