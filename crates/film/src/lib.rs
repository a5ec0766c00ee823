//! The film of Prismatic: pixel filters, per-pixel accumulation of colour and spectral radiance, and image output.
//!
//! - [`Filter`] and [`FilterSampler`]: pbrt-v4's pixel filters, importance sampled so each camera sample lands in
//!   its own pixel with weight f/pdf (lock-free, thread-count independent rendering).
//! - [`Film`]: `f64` accumulators per pixel (XYZ, weight, and for a spectral film `nbuckets` wavelength buckets;
//!   optionally albedo and normal AOVs and pbrt-v4's geometry buffer), written row by row in parallel and mergeable across processes. The film
//!   draws the wavelengths paths carry ([`Film::sample_wavelengths`]) and takes their radiance at those
//!   wavelengths: the conversion to XYZ, the bucket assignment and the sensor's response are its own
//!   ([`SampleConversion`]), written once for camera samples, splats and photon-mapping estimates.
//! - [`write_image`]: EXR (linear float RGB, AOV layers, and the spectral layout of Fichet et al. 2021), PNG
//!   (dithered 8-bit through a [`View`] into sRGB, Display P3 or Rec. 2020, tagged with `cICP` and an ICC profile)
//!   or PFM by extension, always atomically; readers for each format, and for TGA textures ([`tga`]).
//!
//! ```
//! use film::{Film, FilmKind, FilmSpec, FilterSampler};
//! use spectral::SampledSpectrum;
//!
//! let mut spec = FilmSpec::new(4, 3, "out.exr");
//! spec.kind = FilmKind::spectral_default();
//! let sampler = FilterSampler::new(&spec.filter).unwrap();
//! let mut film = Film::new(spec).unwrap();
//! for mut row in film.rows_mut() {
//!     for x in 0..row.width() {
//!         let s = sampler.sample([0.3, 0.7]);
//!         // One path sample: radiance 0.5 at the wavelengths the film drew for it.
//!         let wl = row.sample_wavelengths(0.25);
//!         row.add_sample(x, &SampledSpectrum::splat(0.5), &wl, s.weight);
//!     }
//! }
//! // A constant spectrum of 0.5 has Y = 0.5 (up to the estimate's noise: one sample per pixel).
//! assert!((film.pixel_xyz(1, 2).y - 0.5).abs() < 0.1);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod decode;
mod error;
pub mod film;
pub mod filter;
pub mod hdr;
mod icc;
pub mod image_io;
pub mod texels;
pub mod tga;
pub mod view;

pub use decode::{decode_image_bytes, sniff_format, ChannelSelect, DecodedImage, Samples};
pub use error::{FilmError, ImageError};
pub use film::{
    AovImages, CameraResponse, Film, FilmKind, FilmRow, FilmSpec, FilmState, GBuffer, GBufferCoordinates,
    GBufferImages, GBufferPixel, PixelBounds, PixelSensor, Plane, SampleConversion, SpectralEstimates, Splat,
    VisibleSurface,
};
pub use filter::{Filter, FilterSample, FilterSampler};
pub use image_io::{encode_display_png, read_exr_color_space, write_display_png};
pub use image_io::{
    parse_spectral_channel_name, read_exr_aovs, read_exr_layout, read_exr_rgb, read_exr_spectral, read_pfm,
    read_png_linear, read_rgb, spectral_channel_name, write_image, write_rgb, ExrLayout, ImageFormat, SpectralImage,
};
pub use image_io::{
    read_exr_channels, read_exr_text_attributes, read_rgb_encoded, read_texels_encoded, write_image_with,
    ColorEncoding, NamedChannels,
};
pub use image_io::{read_part, write_file_atomic, write_part};
pub use texels::{sample_table, SampleTable, Texels};
pub use view::{display_space_for, DisplayEncoding, DisplayTransform, View};
