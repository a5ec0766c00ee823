//! What the builder's directive families share, so that their files depend on this one and never on each other
//! (`mod.rs` calls the families in order and hands each what the earlier ones made): the command-line overrides,
//! the error helpers, the named textures, materials and media with their lookups (made by `textures.rs`,
//! `materials.rs` and `media.rs`, read by the families after them), a shape's alpha (made by `shapes.rs`, read by
//! the area lights of `lights.rs`), pbrt-v4's photometric normalisation of emission (lights and glowing media) and
//! its named measured media (`homogeneous` presets and `subsurface` names).

use std::cell::{Cell, RefCell};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use film::{ChannelSelect, ColorEncoding};
use scene::{EmbeddedImage, FloatParam, Loc, MaterialRef, ParamSet, SceneError, SpectrumKind, SpectrumParam};
use spectral::rgb_uplift::RgbUnboundedSpectrum;
use spectral::{Observer, Spectrum};

use crate::bump::NormalPerturbation;
use crate::material::Material;
use crate::medium::{HomogeneousMedium, Medium};
use crate::scene::NO_MATERIAL;
use crate::texture::{FloatTexture, ImageTexture, MipMap, RgbImage, SpectrumTexture, WrapMode};
use crate::RenderError;

/// Command-line overrides of the scene's settings.
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    /// Film resolution instead of the scene's.
    pub resolution: Option<(u32, u32)>,
    /// Samples per pixel instead of the scene's.
    pub spp: Option<u32>,
    /// Output file instead of the film's `filename`.
    pub output: Option<PathBuf>,
    /// pbrt-v4's `--cropwindow x0 x1 y0 y1` (fractions of the image in [0, 1]): overrides the film's.
    pub crop_window: Option<[f64; 4]>,
    /// pbrt-v4's `--pixelbounds x0 x1 y0 y1` (pixels, half-open): overrides the film's.
    pub pixel_bounds: Option<[u32; 4]>,
    /// The view transform of display output instead of the film's `"string view"`.
    pub view: Option<film::View>,
    /// The output colour space instead of the film's `"string colorspace"`.
    pub color_space: Option<spectral::RgbColorSpace>,
}

/// What the builder's functions return.
pub(super) type Result<T> = std::result::Result<T, RenderError>;

/// An error at `loc`.
pub(super) fn err<T>(loc: &Loc, message: impl Into<String>) -> Result<T> {
    Err(SceneError::at(loc.clone(), message).into())
}

/// An error at `loc` about the file `path` that the scene names there: it cannot be read or holds data that
/// cannot be used (`message` names the file).
pub(super) fn file_err(loc: &Loc, path: &Path, message: impl Into<String>) -> RenderError {
    RenderError::ReferencedFile { loc: loc.clone(), path: path.to_path_buf(), message: message.into() }
}

/// `v` if it is finite and positive; otherwise an error naming parameter `name`.
pub(super) fn finite_positive(loc: &Loc, name: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        err(loc, format!("'{name}' must be a positive number, got {v}"))
    }
}

/// The message for a type name Prismatic does not know, listing the ones it does.
pub(super) fn unsupported(what: &str, name: &str, supported: &[&str]) -> String {
    format!("{what} '{name}' is not supported; supported: {}", supported.join(", "))
}

// Named textures (made by `textures.rs`).

/// Where an image's pixels come from: a file the scene names, or an image a reader embedded in the description.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(super) enum ImageSource {
    /// A file (`"string filename"`, `"string normalmap"`).
    File(PathBuf),
    /// `SceneDescription::images[i]` (`"integer image"`).
    Embedded(usize),
}

impl ImageSource {
    /// What messages call it.
    fn describe(&self, embedded: &[EmbeddedImage]) -> String {
        match self {
            ImageSource::File(path) => path.display().to_string(),
            ImageSource::Embedded(i) => {
                embedded.get(*i).map_or_else(|| format!("embedded image {i}"), |e| e.name.clone())
            }
        }
    }
}

/// The scene's named textures. A spectrum texture is kept twice, uplifted as an albedo and as an unbounded
/// spectrum, because which one a parameter needs is only known where it is used.
pub(super) struct Textures {
    float: HashMap<String, FloatTexture>,
    spectrum: HashMap<String, (SpectrumTexture, SpectrumTexture)>, // (albedo, unbounded) variants
    /// Images read so far, by source, encoding and channels (textures and normal maps share them).
    images: RefCell<HashMap<(ImageSource, String, ChannelSelect), Arc<RgbImage>>>,
    /// The encoded images a reader took out of the scene's files (`SceneDescription::images`).
    embedded: Vec<EmbeddedImage>,
    /// Embedded images decoded so far, by index: a glTF image read as colour and as alpha, or as metalness and as
    /// roughness, is decoded once.
    decoded: RefCell<HashMap<usize, Arc<film::DecodedImage>>>,
    /// MIP maps built so far, by image (its address in `images`) and wrap mode.
    mipmaps: RefCell<HashMap<(usize, WrapMode), Arc<MipMap>>>,
    /// The named float and spectrum textures that contain an image map (directly or through textures they use).
    float_with_image: HashSet<String>,
    spectrum_with_image: HashSet<String>,
    /// Set whenever a texture containing an image map is built or handed out (see [`Textures::take_image_use`]).
    image_used: Cell<bool>,
}

impl Textures {
    /// No textures yet.
    pub(super) fn new(embedded: Vec<EmbeddedImage>) -> Self {
        Textures {
            float: HashMap::new(),
            spectrum: HashMap::new(),
            images: RefCell::default(),
            embedded,
            decoded: RefCell::default(),
            mipmaps: RefCell::default(),
            float_with_image: HashSet::new(),
            spectrum_with_image: HashSet::new(),
            image_used: Cell::new(false),
        }
    }

    /// Names float texture `tex`; `with_image` says whether it contains an image map (directly or through
    /// textures it uses).
    pub(super) fn define_float(&mut self, name: &str, tex: FloatTexture, with_image: bool) {
        self.float.insert(name.to_owned(), tex);
        if with_image {
            self.float_with_image.insert(name.to_owned());
        }
    }

    /// Names a spectrum texture, as an (albedo, unbounded) pair; `with_image` as for [`Textures::define_float`].
    pub(super) fn define_spectrum(&mut self, name: &str, pair: (SpectrumTexture, SpectrumTexture), with_image: bool) {
        self.spectrum.insert(name.to_owned(), pair);
        if with_image {
            self.spectrum_with_image.insert(name.to_owned());
        }
    }

    /// Whether a texture containing an image map was built or handed out (by [`Textures::float_param`],
    /// [`Textures::spectrum_param`]) since the last call: what a material reads through footprints.
    pub(super) fn take_image_use(&self) -> bool {
        self.image_used.replace(false)
    }

    /// The image at `source` read with `encoding` (named `enc_name`) into the channels `select` picks, from the
    /// cache if it was read so before; `loc` is where the scene names it.
    pub(super) fn image(
        &self,
        source: &ImageSource,
        encoding: ColorEncoding,
        enc_name: &str,
        select: ChannelSelect,
        loc: &Loc,
    ) -> Result<Arc<RgbImage>> {
        let key = (source.clone(), enc_name.to_ascii_lowercase(), select);
        if let Some(img) = self.images.borrow().get(&key) {
            return Ok(img.clone());
        }
        let (w, h, texels) = match source {
            ImageSource::File(path) => {
                if select != ChannelSelect::Rgb {
                    return err(loc, "'channel' picks a channel of an embedded image ('integer image') only");
                }
                film::read_texels_encoded(path, encoding)
                    .map_err(|e| file_err(loc, path, format!("cannot read image {}: {e}", path.display())))?
            }
            ImageSource::Embedded(i) => {
                let decoded = self.decoded_image(*i, loc)?;
                (decoded.width, decoded.height, decoded.to_texels(encoding, select))
            }
        };
        if w == 0 || h == 0 {
            return err(loc, format!("image {} is empty", source.describe(&self.embedded)));
        }
        let img = Arc::new(RgbImage { width: w as usize, height: h as usize, texels });
        self.images.borrow_mut().insert(key, img.clone());
        Ok(img)
    }

    /// Lets go of embedded image `i`'s decoded samples (no texture still to be built reads it; a later read would
    /// decode it again).
    pub(super) fn forget_decoded(&self, i: usize) {
        self.decoded.borrow_mut().remove(&i);
    }

    /// Embedded image `i`, decoded the first time it is asked for.
    fn decoded_image(&self, i: usize, loc: &Loc) -> Result<Arc<film::DecodedImage>> {
        if let Some(d) = self.decoded.borrow().get(&i) {
            return Ok(d.clone());
        }
        let Some(image) = self.embedded.get(i) else {
            return err(loc, format!("no embedded image {i}: the scene has {}", self.embedded.len()));
        };
        let name = Path::new(&image.name);
        let decoded = film::decode_image_bytes(&image.bytes, name)
            .map_err(|e| file_err(loc, name, format!("cannot read image {}: {e}", image.name)))?;
        let decoded = Arc::new(decoded);
        self.decoded.borrow_mut().insert(i, decoded.clone());
        Ok(decoded)
    }

    /// The image map that spectrum texture `name` is, if it is one (a normal map reads its RGB as it is); counts as
    /// a use of an image.
    pub(super) fn image_texture(&self, name: &str) -> Option<ImageTexture> {
        let Some((SpectrumTexture::Image { tex, .. }, _)) = self.spectrum.get(name) else { return None };
        self.image_used.set(true);
        Some((**tex).clone())
    }

    /// The MIP map of `image` (one of `images`) under `wrap`, built once; counts as a use of an image.
    pub(super) fn mipmap(&self, image: &Arc<RgbImage>, wrap: WrapMode) -> Arc<MipMap> {
        self.image_used.set(true);
        let key = (Arc::as_ptr(image) as usize, wrap);
        self.mipmaps.borrow_mut().entry(key).or_insert_with(|| Arc::new(MipMap::new(image, wrap))).clone()
    }

    /// A float parameter that may name a float texture.
    pub(super) fn float_param(&self, p: &ParamSet, name: &str, default: f64) -> Result<FloatTexture> {
        match p.get_float_texture(name, default)? {
            FloatParam::Value(v) => {
                // Single precision is what the renderer keeps: 1e40 would be infinite there.
                if !(v as f32).is_finite() {
                    let at =
                        p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| Loc::builtin(Arc::from(PathBuf::new())));
                    return err(&at, format!("'{name}' must be a finite number, got {v}"));
                }
                Ok(FloatTexture::Constant(v as f32))
            }
            FloatParam::Texture(t) => {
                if self.float_with_image.contains(&t) {
                    self.image_used.set(true);
                }
                self.float.get(&t).cloned().ok_or_else(|| {
                    SceneError::at(p.get(name).map(|q| q.loc.clone()).unwrap(), format!("no float texture named '{t}'"))
                        .into()
                })
            }
        }
    }

    /// A spectrum parameter that may be a texture; `kind` chooses the albedo or unbounded uplifting.
    pub(super) fn spectrum_param(
        &self,
        p: &ParamSet,
        name: &str,
        kind: SpectrumKind,
        default: f64,
    ) -> Result<SpectrumTexture> {
        match p.get_spectrum_texture(name, kind)? {
            None => Ok(SpectrumTexture::Constant(Spectrum::Constant(default))),
            Some(SpectrumParam::Value(v)) => Ok(SpectrumTexture::Constant(v)),
            Some(SpectrumParam::Texture(t)) => {
                let pair = self.spectrum.get(&t).ok_or_else(|| {
                    SceneError::at(
                        p.get(name).map(|q| q.loc.clone()).unwrap(),
                        format!("no spectrum texture named '{t}'"),
                    )
                })?;
                if self.spectrum_with_image.contains(&t) {
                    self.image_used.set(true);
                }
                Ok(if kind == SpectrumKind::Albedo { pair.0.clone() } else { pair.1.clone() })
            }
        }
    }
}

// Named materials (made by `materials.rs`).

/// The scene's materials, anonymous first, then named; a name maps to its index.
pub(super) struct Materials {
    /// In the order of [`crate::scene::RenderScene::materials`].
    pub(super) list: Vec<Material>,
    /// Each material's bump or normal map, in the same order.
    pub(super) perturbations: Vec<Option<NormalPerturbation>>,
    /// The medium inside a `subsurface` material's shapes, in the same order (appended to the scene's media by
    /// [`Materials::attach_interiors`]).
    interiors: Vec<Option<HomogeneousMedium>>,
    /// The index of that medium among the scene's media, once attached.
    interior_index: Vec<Option<u32>>,
    /// Whether each material reads a texture through the ray's footprint (an image map; for a mix, its amount or
    /// a material it may pick), so that hits on it need their footprint.
    pub(super) reads_footprint: Vec<bool>,
    names: HashMap<String, u32>,
}

impl Materials {
    /// The materials read, in the order of [`crate::scene::RenderScene::materials`] (anonymous first, then named),
    /// with each one's bump map, interior medium and footprint use in the same order, and the index of each name.
    pub(super) fn new(
        list: Vec<Material>,
        perturbations: Vec<Option<NormalPerturbation>>,
        interiors: Vec<Option<HomogeneousMedium>>,
        reads_footprint: Vec<bool>,
        names: HashMap<String, u32>,
    ) -> Self {
        let interior_index = vec![None; list.len()];
        Materials { list, perturbations, interiors, interior_index, reads_footprint, names }
    }

    /// Appends the interior media of `subsurface` materials to `media` and records their indices.
    pub(super) fn attach_interiors(&mut self, media: &mut Vec<Medium>) {
        for (i, interior) in self.interiors.iter_mut().enumerate() {
            if let Some(m) = interior.take() {
                self.interior_index[i] = Some(media.len() as u32);
                media.push(Medium::Homogeneous(m));
            }
        }
    }

    /// The index of each named material.
    pub(super) fn names(&self) -> &HashMap<String, u32> {
        &self.names
    }

    /// The medium inside shapes of material `index` (a `subsurface` material's), if any.
    pub(super) fn interior(&self, index: u32) -> Option<u32> {
        self.interior_index.get(index as usize).copied().flatten()
    }

    /// The index a shape's material reference resolves to; an `interface` material is [`NO_MATERIAL`], a boundary
    /// between media only.
    pub(super) fn index(&self, r: &MaterialRef, loc: &Loc) -> Result<u32> {
        let i = match r {
            MaterialRef::Anonymous(i) => *i as u32,
            MaterialRef::Named(n) => {
                *self.names.get(n).ok_or_else(|| SceneError::at(loc.clone(), format!("no material named '{n}'")))?
            }
        };
        Ok(if matches!(self.list[i as usize], Material::Interface) { NO_MATERIAL } else { i })
    }
}

// Named media (made by `media.rs`).

/// The scene's media and the index each name maps to.
pub(super) struct Media {
    /// In the order of [`crate::scene::RenderScene::media`].
    pub(super) list: Vec<Medium>,
    index: HashMap<String, u32>,
}

impl Media {
    /// The media read, in the order of [`crate::scene::RenderScene::media`], and the index of each name.
    pub(super) fn new(list: Vec<Medium>, index: HashMap<String, u32>) -> Self {
        Media { list, index }
    }

    /// The index of each name.
    pub(super) fn names(&self) -> &HashMap<String, u32> {
        &self.index
    }

    /// True if some medium scatters or glows (not only absorbs).
    pub(super) fn any_scattering(&self) -> bool {
        self.list.iter().any(|m| !m.is_absorbing_only())
    }

    /// True if some medium glows.
    pub(super) fn any_emissive(&self) -> bool {
        self.list.iter().any(|m| m.is_emissive())
    }

    /// The medium `name` refers to; no name or an empty one is vacuum.
    pub(super) fn of(&self, name: &Option<String>, loc: &Loc) -> Result<Option<u32>> {
        match name {
            None => Ok(None),
            Some(n) if n.is_empty() => Ok(None),
            Some(n) => self
                .index
                .get(n)
                .copied()
                .map(Some)
                .ok_or_else(|| SceneError::at(loc.clone(), format!("no medium named '{n}'")).into()),
        }
    }
}

// A shape's alpha (made by `shapes.rs`, read by its area lights in `lights.rs`).

/// A shape's alpha (pbrt-v4's `"float alpha"` / `"texture alpha"`): what rays and its area light make of it.
pub(super) enum ShapeAlpha {
    /// No alpha, or a constant 1: the fast path.
    Opaque,
    /// A constant 0: rays never hit the shape (it is left out of the BVH); an area light on it still emits, found
    /// only by light sampling, as pbrt-v4's invisible area lights.
    Invisible,
    /// Anything else: a stochastic test at every hit.
    CutOut(FloatTexture),
}

// Emission (lights and media that glow).

/// Luminance Y of a spectrum in our convention (Y = 1 for a constant 1); for an RGB illuminant only the
/// illuminant counts, as pbrt-v4's `SpectrumToPhotometric` does.
fn photometric(s: &Spectrum) -> f64 {
    match s {
        Spectrum::RgbIlluminant(_) => 1.0, // the colour space illuminant is normalised to Y = 1
        other @ (Spectrum::Constant(_)
        | Spectrum::PiecewiseLinear(_)
        | Spectrum::Blackbody(_)
        | Spectrum::RgbAlbedo(_)
        | Spectrum::RgbUnbounded(_)) => Observer::Cie1931.spectrum_to_xyz(other).y,
    }
}

/// Scales an emission spectrum so that `scale` is its luminance in nits (pbrt-v4: `scale /= SpectrumToPhotometric`).
pub(super) fn normalise_emission(loc: &Loc, s: Spectrum, scale: f64) -> Result<Spectrum> {
    let y = photometric(&s);
    if y.is_nan() || y <= 0.0 {
        return err(loc, "emission spectrum has no luminance (it is zero across the visible range)");
    }
    if !scale.is_finite() || scale < 0.0 {
        return err(loc, format!("emission scale must be a finite non-negative number, got {scale}"));
    }
    let scaled = s.scaled(scale / y);
    // Radiance is carried in f32: anything near its range would overflow along a path.
    let peak = scaled.max_value();
    if peak.is_nan() || peak >= 1e30 {
        return err(loc, format!("emission is too large ('scale'/'power' give a peak of {:e})", scaled.max_value()));
    }
    Ok(scaled)
}

// Named measured media (`homogeneous` presets and `subsurface` names).

/// pbrt-v4's named measured medium `name` as (σa, σs) spectra in mm⁻¹ (reduced scattering as σs, for g = 0); an
/// error at `loc` listing the known names if there is none.
pub(super) fn measured_medium(name: &str, loc: &Loc) -> Result<(Spectrum, Spectrum)> {
    let Some(preset) = MEASURED_MEDIA.iter().find(|mm| mm.name == name) else {
        let names: Vec<&str> = MEASURED_MEDIA.iter().map(|mm| mm.name).collect();
        return err(loc, format!("unknown measured medium '{name}'; known names: {}", names.join(", ")));
    };
    let rgb = |v: [f64; 3]| {
        RgbUnboundedSpectrum::new(v).map(Spectrum::RgbUnbounded).map_err(|e| SceneError::at(loc.clone(), e.to_string()))
    };
    Ok((rgb(preset.sigma_a)?, rgb(preset.sigma_prime_s)?))
}

/// One of pbrt-v4's named measured media: reduced scattering σ's and absorption σa in mm⁻¹ at red, green and
/// blue, used as σs and σa of a `homogeneous` medium (`"string preset"`).
pub(super) struct MeasuredMedium {
    /// pbrt-v4's name.
    pub(super) name: &'static str,
    /// Reduced scattering σ's at red, green and blue (mm⁻¹).
    pub(super) sigma_prime_s: [f64; 3],
    /// Absorption σa at red, green and blue (mm⁻¹).
    pub(super) sigma_a: [f64; 3],
}

const fn mm(name: &'static str, sigma_prime_s: [f64; 3], sigma_a: [f64; 3]) -> MeasuredMedium {
    MeasuredMedium { name, sigma_prime_s, sigma_a }
}

/// Measured scattering data in mm⁻¹: the first twelve from Jensen, Marschner, Levoy & Hanrahan 2001, "A Practical
/// Model for Subsurface Light Transport", Figure 5; the others from Narasimhan, Gupta, Donner, Ramamoorthi, Nayar &
/// Jensen 2006, "Acquiring Scattering Properties of Participating Media by Dilution", Table 1 — the names and values
/// pbrt-v4 uses for its `preset` parameter.
pub(super) const MEASURED_MEDIA: &[MeasuredMedium] = &[
    mm("Apple", [2.29, 2.39, 1.97], [0.0030, 0.0034, 0.046]),
    mm("Chicken1", [0.15, 0.21, 0.38], [0.015, 0.077, 0.19]),
    mm("Chicken2", [0.19, 0.25, 0.32], [0.018, 0.088, 0.20]),
    mm("Cream", [7.38, 5.47, 3.15], [0.0002, 0.0028, 0.0163]),
    mm("Ketchup", [0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    mm("Marble", [2.19, 2.62, 3.00], [0.0021, 0.0041, 0.0071]),
    mm("Potato", [0.68, 0.70, 0.55], [0.0024, 0.0090, 0.12]),
    mm("Skimmilk", [0.70, 1.22, 1.90], [0.0014, 0.0025, 0.0142]),
    mm("Skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    mm("Skin2", [1.09, 1.59, 1.79], [0.013, 0.070, 0.145]),
    mm("Spectralon", [11.6, 20.4, 14.9], [0.00, 0.00, 0.00]),
    mm("Wholemilk", [2.55, 3.21, 3.77], [0.0011, 0.0024, 0.014]),
    mm("Lowfat Milk", [0.89187, 1.5136, 2.532], [0.002875, 0.00575, 0.0115]),
    mm("Reduced Milk", [2.4858, 3.1669, 4.5214], [0.0025556, 0.0051111, 0.012778]),
    mm("Regular Milk", [4.5513, 5.8294, 7.136], [0.0015333, 0.0046, 0.019933]),
    mm("Espresso", [0.72378, 0.84557, 1.0247], [4.7984, 6.5751, 8.8493]),
    mm("Mint Mocha Coffee", [0.31602, 0.38538, 0.48131], [3.772, 5.8228, 7.82]),
    mm("Lowfat Soy Milk", [0.30576, 0.34233, 0.61664], [0.0014375, 0.0071875, 0.035937]),
    mm("Regular Soy Milk", [0.59223, 0.73866, 1.4693], [0.0019167, 0.0095833, 0.065167]),
    mm("Lowfat Chocolate Milk", [0.64925, 0.83916, 1.1057], [0.0115, 0.0368, 0.1564]),
    mm("Regular Chocolate Milk", [1.4585, 2.1289, 2.9527], [0.010063, 0.043125, 0.14375]),
    mm("Coke", [8.9053e-05, 8.372e-05, 0.0], [0.10014, 0.16503, 0.2468]),
    mm("Pepsi", [6.1697e-05, 4.2564e-05, 0.0], [0.091641, 0.14158, 0.20729]),
    mm("Sprite", [6.0306e-06, 6.4139e-06, 6.5504e-06], [0.001886, 0.0018308, 0.0020025]),
    mm("Gatorade", [0.0024574, 0.003007, 0.0037325], [0.024794, 0.019289, 0.008878]),
    mm("Chardonnay", [1.7982e-05, 1.3758e-05, 1.2023e-05], [0.010782, 0.011855, 0.023997]),
    mm("White Zinfandel", [1.7501e-05, 1.9069e-05, 1.288e-05], [0.012072, 0.016184, 0.019843]),
    mm("Merlot", [2.1129e-05, 0.0, 0.0], [0.11632, 0.25191, 0.29434]),
    mm("Budweiser Beer", [2.4356e-05, 2.4079e-05, 1.0564e-05], [0.011492, 0.024911, 0.057786]),
    mm("Coors Light Beer", [5.0922e-05, 4.301e-05, 0.0], [0.006164, 0.013984, 0.034983]),
    mm("Clorox", [0.0024035, 0.0031373, 0.003991], [0.0033542, 0.014892, 0.026297]),
    mm("Apple Juice", [0.00013612, 0.00015836, 0.000227], [0.012957, 0.023741, 0.052184]),
    mm("Cranberry Juice", [0.00010402, 0.00011646, 7.8139e-05], [0.039437, 0.094223, 0.12426]),
    mm("Grape Juice", [5.382e-05, 0.0, 0.0], [0.10404, 0.23958, 0.29325]),
    mm("Ruby Grapefruit Juice", [0.011002, 0.010927, 0.011036], [0.085867, 0.18314, 0.25262]),
    mm("White Grapefruit Juice", [0.22826, 0.23998, 0.32748], [0.0138, 0.018831, 0.056781]),
    mm("Shampoo", [0.0007176, 0.0008303, 0.0009016], [0.014107, 0.045693, 0.061717]),
    mm("Strawberry Shampoo", [0.00015671, 0.00015947, 1.518e-05], [0.01449, 0.05796, 0.075823]),
    mm("Head & Shoulders Shampoo", [0.023805, 0.028804, 0.034306], [0.084621, 0.15688, 0.20365]),
    mm("Lemon Tea Powder", [0.040224, 0.045264, 0.051081], [2.4288, 4.5757, 7.2127]),
    mm("Orange Powder", [0.00015617, 0.00017482, 0.0001762], [0.001449, 0.003441, 0.007863]),
    mm("Pink Lemonade Powder", [0.00012103, 0.00013073, 0.00012528], [0.001165, 0.002366, 0.003195]),
    mm("Cappuccino Powder", [1.8436, 2.5851, 2.1662], [35.844, 49.547, 61.084]),
    mm("Salt Powder", [0.027333, 0.032451, 0.031979], [0.28415, 0.3257, 0.34148]),
    mm("Sugar Powder", [0.00022272, 0.00025513, 0.000271], [0.012638, 0.031051, 0.050124]),
    mm("Suisse Mocha Powder", [2.7979, 3.5452, 4.3365], [17.502, 27.004, 35.433]),
    mm("Pacific Ocean Surface Water", [0.0001764, 0.00032095, 0.00019617], [0.031845, 0.031324, 0.030147]),
];

#[cfg(test)]
mod tests {
    use super::*;

    /// An embedded image read by several textures is decoded once, and its decoded samples are let go once the
    /// last texture that reads it is built.
    #[test]
    fn decoded_images_are_let_go_after_their_last_texture() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../film/tests/fixtures/two-colours-lossless.webp");
        let bytes: Arc<[u8]> = std::fs::read(path).unwrap().into();
        let text = "WorldBegin\n\
            Texture \"colour\" \"spectrum\" \"imagemap\" \"integer image\" 0\n\
            Texture \"checks\" \"float\" \"checkerboard\"\n\
            Texture \"alpha\" \"float\" \"imagemap\" \"integer image\" 0 \"string channel\" \"a\"\n";
        let mut desc = pbrt::parse_str(text, Path::new("embedded.pbrt")).unwrap_or_else(|e| panic!("{e}"));
        desc.images = vec![EmbeddedImage { name: "plates.glb#images[0]".into(), bytes }];
        let textures = super::super::textures::build(&desc).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(textures.images.borrow().len(), 2, "read as colour and as alpha");
        assert!(textures.decoded.borrow().is_empty(), "the decoded samples outlived the last texture that reads them");
    }

    /// An 8-bit image is kept as 8-bit samples (one per texel for one channel), reading as the linear values it
    /// decodes to; its MIP levels above the first keep floats, one per texel for one channel.
    #[test]
    fn eight_bit_images_stay_eight_bit() {
        // Pillow's lossless 16×8 WebP: the left half sRGB (200, 30, 30) with alpha 255, the right half
        // (30, 200, 30) with alpha 128.
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../film/tests/fixtures/two-colours-lossless.webp");
        let bytes: Arc<[u8]> = std::fs::read(path).unwrap().into();
        let textures = Textures::new(vec![EmbeddedImage { name: "plates.glb#images[0]".into(), bytes }]);
        let loc = Loc::builtin(Arc::from(PathBuf::new()));
        let read = |encoding, name, select| {
            textures.image(&ImageSource::Embedded(0), encoding, name, select, &loc).unwrap_or_else(|e| panic!("{e}"))
        };
        let srgb = |v: u8| spectral::color::srgb_decode(f64::from(v) / 255.0) as f32;
        let kind = |t: &film::Texels| format!("{t:?}").chars().take_while(|c| c.is_alphanumeric()).collect::<String>();
        let rgb = read(ColorEncoding::Srgb, "sRGB", ChannelSelect::Rgb);
        assert!(matches!(rgb.texels, film::Texels::Rgb8 { .. }), "{}", kind(&rgb.texels));
        assert_eq!(rgb.texels.bytes(), 16 * 8 * 3);
        assert_eq!(rgb.texel(13, 4, WrapMode::Clamp), [srgb(30), srgb(200), srgb(30)]);
        let alpha = read(ColorEncoding::Linear, "linear", ChannelSelect::One(3));
        assert!(matches!(alpha.texels, film::Texels::Grey8 { .. }), "{}", kind(&alpha.texels));
        assert_eq!(alpha.texels.bytes(), 16 * 8);
        assert_eq!(alpha.texel(13, 4, WrapMode::Clamp), [(128.0f64 / 255.0) as f32; 3]);
        let green = read(ColorEncoding::Linear, "linear", ChannelSelect::One(1));
        assert_eq!(green.texel(2, 4, WrapMode::Clamp), [(30.0f64 / 255.0) as f32; 3]);
        let mip = textures.mipmap(&alpha, WrapMode::Clamp);
        assert!(std::ptr::eq(mip.level(0), &*alpha), "a power-of-two image is its own first level");
        let level1 = mip.level(1);
        assert!(matches!(level1.texels, film::Texels::Grey(_)), "{}", kind(&level1.texels));
        assert_eq!(level1.texels.bytes(), 8 * 4 * 4);
        assert_eq!(level1.texel(7, 2, WrapMode::Clamp), [(128.0f64 / 255.0) as f32; 3]);
    }

    #[test]
    fn presets_are_valid_and_named_once() {
        let mut names: Vec<&str> = MEASURED_MEDIA.iter().map(|m| m.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), MEASURED_MEDIA.len());
        assert_eq!(MEASURED_MEDIA.len(), 47);
        for m in MEASURED_MEDIA {
            assert!(RgbUnboundedSpectrum::new(m.sigma_a).is_ok(), "{}", m.name);
            assert!(RgbUnboundedSpectrum::new(m.sigma_prime_s).is_ok(), "{}", m.name);
        }
    }
}
