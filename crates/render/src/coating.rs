//! Thin-film coatings: a stack of layers a few to a few thousand nanometres thick on a surface, whose reflections
//! interfere (an oxide's heat tint on steel and titanium, anodising, oil on water, anti-reflection coatings).
//!
//! A coating is a list of layers from the outside in, each with its index n(λ) (and k(λ) for an absorbing layer) and
//! a thickness in nm that may come from a texture. At a hit it is evaluated at the path's wavelengths into a
//! [`CoatingAt`], whose reflectance and transmittance are exact per carried wavelength and angle
//! ([`optics::film_stack`], s and p averaged for unpolarised light): no wavelength is dropped, since the layers are
//! parallel and the directions of reflection and refraction do not depend on them. The medium outside the coating
//! is taken as vacuum (index 1), as a conductor's and a dielectric's relative index are relative to it.
//!
//! Rough coated surfaces use the film's Fresnel term in the microfacet model in place of the bare interface's, at
//! the angle to the microfacet normal: the layers follow the microsurface, as in Belcour & Barla, "A Practical
//! Extension to Microfacet Theory for the Modeling of Varying Iridescence" (SIGGRAPH 2017), which evaluates the
//! same Airy reflectance per wavelength (and only needs its spectral antialiasing for RGB rendering).

use optics::{film_stack, film_stack_reversed, Complex, FilmLayer, Ior};
use spectral::{SampledSpectrum, SampledWavelengths, Spectrum, N_WAVELENGTHS};

use crate::texture::{FloatTexture, TextureEvalContext};

/// The index of one coating layer.
#[derive(Clone, Debug)]
pub enum LayerIndex {
    /// A model of the optics crate (a catalogue glass, crystal or metal: complex where the catalogue has k).
    Model(Ior),
    /// n(λ) given in the scene (real).
    Spectrum(Spectrum),
}

impl LayerIndex {
    /// The complex index n + ik at `lambda_nm`.
    pub fn at(&self, lambda_nm: f32) -> Complex {
        match self {
            LayerIndex::Model(m) => m.complex_value(lambda_nm as f64),
            LayerIndex::Spectrum(s) => Complex::from_real(s.eval(lambda_nm as f64)),
        }
    }
}

/// One layer of a coating.
#[derive(Clone, Debug)]
pub struct CoatingLayer {
    /// Its index.
    pub index: LayerIndex,
    /// Its thickness in nm (clamped at 0 where a texture gives less).
    pub thickness: FloatTexture,
}

/// A coating: layers from the outside in (empty: no coating).
#[derive(Clone, Debug, Default)]
pub struct Coating {
    /// The layers, outermost first.
    pub layers: Vec<CoatingLayer>,
}

impl Coating {
    /// The coating at a shading point, at the path's wavelengths; `None` without layers (or with every layer of
    /// zero thickness there, which is the bare surface exactly).
    pub fn at(&self, ctx: &TextureEvalContext, wl: &SampledWavelengths) -> Option<Box<CoatingAt>> {
        if self.layers.is_empty() {
            return None;
        }
        let n_layers = self.layers.len();
        let mut layers = Vec::with_capacity(N_WAVELENGTHS * n_layers);
        // The first slot's layers carry each texture's thickness, evaluated once; the other slots copy it.
        let lambda0 = wl.lambda(0);
        layers.extend(
            self.layers.iter().map(|l| FilmLayer::new(l.index.at(lambda0), (l.thickness.eval(ctx) as f64).max(0.0))),
        );
        if layers.iter().all(|l| l.thickness_nm == 0.0) {
            return None;
        }
        for i in 1..N_WAVELENGTHS {
            let lambda = wl.lambda(i);
            for (j, l) in self.layers.iter().enumerate() {
                layers.push(FilmLayer::new(l.index.at(lambda), layers[j].thickness_nm));
            }
        }
        Some(Box::new(CoatingAt { lambda: wl.lambdas(), layers, n_layers }))
    }
}

/// A coating evaluated at a hit: per wavelength slot, its stack of layers.
#[derive(Clone, Debug, PartialEq)]
pub struct CoatingAt {
    /// The path's wavelengths (nm).
    lambda: [f32; N_WAVELENGTHS],
    /// `n_layers` layers per slot, slot after slot, outermost first.
    layers: Vec<FilmLayer>,
    n_layers: usize,
}

impl CoatingAt {
    /// The same layers at every carried wavelength `lambda` (indices that do not depend on λ).
    #[cfg(any(test, feature = "internals"))]
    pub fn uniform(lambda: [f32; N_WAVELENGTHS], layers: &[FilmLayer]) -> Self {
        let per_slot = layers.iter().copied();
        Self { lambda, layers: (0..N_WAVELENGTHS).flat_map(|_| per_slot.clone()).collect(), n_layers: layers.len() }
    }

    fn stack(&self, i: usize) -> &[FilmLayer] {
        &self.layers[i * self.n_layers..(i + 1) * self.n_layers]
    }

    /// Unpolarised reflectance per slot of the coating on a conductor of complex index `eta + ik` (relative to the
    /// outside), for light at `cos_i` to the (micro)surface normal.
    pub fn conductor_reflectance(&self, cos_i: f32, eta: &SampledSpectrum, k: &SampledSpectrum) -> SampledSpectrum {
        let mut r = SampledSpectrum::zero();
        for i in 0..N_WAVELENGTHS {
            let substrate = Complex::new(eta[i] as f64, k[i] as f64);
            let response = film_stack(1.0, self.stack(i), substrate, cos_i.abs() as f64, self.lambda[i] as f64);
            r[i] = response.reflectance() as f32;
        }
        r
    }

    /// Unpolarised reflectance and transmittance per slot of the coating on a dielectric of relative index `eta`
    /// (per slot), for light at `cos_i` to the (micro)surface normal: from outside (`cos_i` > 0) through the layers
    /// outermost first into the dielectric, from inside (`cos_i` < 0) from the dielectric through them in reverse
    /// out into vacuum. Lossless layers give R + T = 1; beyond the critical angle from inside T is 0.
    pub fn dielectric_reflectance_transmittance(
        &self,
        cos_i: f32,
        eta: &SampledSpectrum,
    ) -> (SampledSpectrum, SampledSpectrum) {
        let (mut r, mut t) = (SampledSpectrum::zero(), SampledSpectrum::zero());
        let c = cos_i.abs() as f64;
        for i in 0..N_WAVELENGTHS {
            let (n, lambda) = (eta[i] as f64, self.lambda[i] as f64);
            let response = if cos_i >= 0.0 {
                film_stack(1.0, self.stack(i), Complex::from_real(n), c, lambda)
            } else {
                film_stack_reversed(n, self.stack(i), Complex::from_real(1.0), c, lambda)
            };
            r[i] = response.reflectance() as f32;
            t[i] = response.transmittance() as f32;
        }
        (r, t)
    }

    /// Unpolarised reflectance and transmittance per slot of the layers alone, free-standing in vacuum (a soap
    /// film), for light at `cos_i` to the normal from either side.
    pub fn free_film_reflectance_transmittance(&self, cos_i: f32) -> (SampledSpectrum, SampledSpectrum) {
        let (mut r, mut t) = (SampledSpectrum::zero(), SampledSpectrum::zero());
        let c = cos_i.abs() as f64;
        for i in 0..N_WAVELENGTHS {
            let response = if cos_i >= 0.0 {
                film_stack(1.0, self.stack(i), Complex::from_real(1.0), c, self.lambda[i] as f64)
            } else {
                film_stack_reversed(1.0, self.stack(i), Complex::from_real(1.0), c, self.lambda[i] as f64)
            };
            r[i] = response.reflectance() as f32;
            t[i] = response.transmittance() as f32;
        }
        (r, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};

    #[test]
    fn a_coating_is_evaluated_per_wavelength_and_absent_where_it_has_no_thickness() {
        let ctx = TextureEvalContext::new(Vec3::ZERO, Vec3::Z, Vec2::ZERO);
        let wl = SampledWavelengths::new([450.0, 550.0, 650.0, 750.0], [4.0; 4]);
        let oxide = |d: f32| Coating {
            layers: vec![CoatingLayer {
                index: LayerIndex::Spectrum(Spectrum::Constant(2.4)),
                thickness: FloatTexture::Constant(d),
            }],
        };
        assert!(oxide(0.0).at(&ctx, &wl).is_none());
        assert!(Coating::default().at(&ctx, &wl).is_none());
        let c = oxide(80.0).at(&ctx, &wl).unwrap();
        let (eta, k) = (SampledSpectrum::splat(2.7), SampledSpectrum::splat(3.8));
        let r = c.conductor_reflectance(0.6, &eta, &k);
        for i in 0..N_WAVELENGTHS {
            let want = film_stack(
                1.0,
                &[FilmLayer::new(Complex::from_real(2.4), 80.0)],
                Complex::new(2.7, 3.8),
                0.6f32 as f64,
                wl.lambda(i) as f64,
            )
            .reflectance();
            assert!((r[i] as f64 - want).abs() < 1e-6, "slot {i}: {} vs {want}", r[i]);
        }
        // Interference: the reflectance differs across the wavelengths (a bare metal of constant index would not).
        let spread = (0..N_WAVELENGTHS).map(|i| r[i]).fold(0.0f32, f32::max)
            - (0..N_WAVELENGTHS).map(|i| r[i]).fold(1.0f32, f32::min);
        assert!(spread > 0.05, "{r:?}");
    }
}
