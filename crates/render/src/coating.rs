//! Thin-film coatings: a stack of layers a few to a few thousand nanometres thick on a surface, whose reflections
//! interfere (an oxide's heat tint on steel and titanium, anodising, oil on water, anti-reflection coatings).
//!
//! A coating is a list of layers from the outside in, each with its index n(λ) (and k(λ) for an absorbing layer) and
//! a thickness in nm that may come from a texture. At a hit it is evaluated at the path's wavelengths into a
//! [`CoatingAt`], whose reflectance and transmittance are exact per carried wavelength and angle (s and p averaged for
//! unpolarised light): one non-absorbing layer, the common case, by Airy's closed form for the four wavelength slots
//! at once, anything else by [`optics::film_stack`]'s characteristic matrices. No wavelength is dropped, since the
//! layers are parallel and the directions of reflection and refraction do not depend on them. The medium outside the coating
//! is taken as vacuum (index 1), as a conductor's and a dielectric's relative index are relative to it.
//!
//! Rough coated surfaces use the film's Fresnel term in the microfacet model in place of the bare interface's, at
//! the angle to the microfacet normal: the layers follow the microsurface, as in Belcour & Barla, "A Practical
//! Extension to Microfacet Theory for the Modeling of Varying Iridescence" (SIGGRAPH 2017), which evaluates the
//! same Airy reflectance per wavelength (and only needs its spectral antialiasing for RGB rendering).

use glam::Vec4;
use optics::{film_stack, film_stack_reversed, Complex, FilmLayer, FilmResponse, Ior};
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
        Some(Box::new(CoatingAt::new(wl.lambdas(), layers, n_layers)))
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
    /// One non-absorbing layer (the common case: an oxide, a soap or oil film), for Airy's closed form.
    single: Option<SingleLayer>,
}

/// One non-absorbing layer per slot: its index n and its phase thickness per cosine, 2π·n·d/λ.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SingleLayer {
    n: Vec4,
    phase: [f64; N_WAVELENGTHS],
}

impl CoatingAt {
    fn new(lambda: [f32; N_WAVELENGTHS], layers: Vec<FilmLayer>, n_layers: usize) -> Self {
        let single = (n_layers == 1 && layers.iter().all(|l| l.n.im == 0.0 && l.n.re > 0.0)).then(|| SingleLayer {
            n: Vec4::from_array(std::array::from_fn(|i| layers[i].n.re as f32)),
            phase: std::array::from_fn(|i| {
                2.0 * std::f64::consts::PI * layers[i].n.re * layers[i].thickness_nm / lambda[i] as f64
            }),
        });
        Self { lambda, layers, n_layers, single }
    }

    /// The same layers at every carried wavelength `lambda` (indices that do not depend on λ).
    #[cfg(any(test, feature = "internals"))]
    pub fn uniform(lambda: [f32; N_WAVELENGTHS], layers: &[FilmLayer]) -> Self {
        let per_slot = layers.iter().copied();
        Self::new(lambda, (0..N_WAVELENGTHS).flat_map(|_| per_slot.clone()).collect(), layers.len())
    }

    /// Unpolarised reflectance per slot from media of real index `n0` onto substrates `n2 + i·k2` (per slot), at
    /// `cos_i`; `reversed`: the stack is crossed from its innermost layer. Airy's closed form for one non-absorbing
    /// layer, the characteristic-matrix method otherwise (and in a slot where the single layer totally reflects).
    fn reflectance(&self, n0: Vec4, n2: Vec4, k2: Vec4, cos_i: f32, reversed: bool) -> [f32; N_WAVELENGTHS] {
        let (mut r, mut closed) = ([0.0; N_WAVELENGTHS], [false; N_WAVELENGTHS]);
        if let Some(single) = &self.single {
            (r, closed) = airy_reflectance(n0, single.n, &single.phase, n2, k2, cos_i);
        }
        for i in 0..N_WAVELENGTHS {
            if !closed[i] {
                r[i] = self.slot_response(i, n0[i], n2[i], k2[i], cos_i, reversed).reflectance() as f32;
            }
        }
        r
    }

    fn slot_response(&self, i: usize, n0: f32, n2: f32, k2: f32, cos_i: f32, reversed: bool) -> FilmResponse {
        let (substrate, c, lambda) = (Complex::new(n2 as f64, k2 as f64), cos_i.abs() as f64, self.lambda[i] as f64);
        if reversed {
            film_stack_reversed(n0 as f64, self.stack(i), substrate, c, lambda)
        } else {
            film_stack(n0 as f64, self.stack(i), substrate, c, lambda)
        }
    }

    /// Reflectance and transmittance per slot between real media `n0` (incident) and `n2`: for one non-absorbing
    /// layer Airy's R and 1 − R where light leaves into `n2` (R = 1, T = 0 beyond its critical angle), the matrix
    /// method otherwise.
    fn reflectance_transmittance(
        &self,
        n0: Vec4,
        n2: Vec4,
        cos_i: f32,
        reversed: bool,
    ) -> (SampledSpectrum, SampledSpectrum) {
        let (mut r, mut t) = (SampledSpectrum::zero(), SampledSpectrum::zero());
        let (mut airy, mut closed) = ([0.0; N_WAVELENGTHS], [false; N_WAVELENGTHS]);
        if let Some(single) = &self.single {
            (airy, closed) = airy_reflectance(n0, single.n, &single.phase, n2, Vec4::ZERO, cos_i);
        }
        let c = cos_i.abs().min(1.0);
        for i in 0..N_WAVELENGTHS {
            (r[i], t[i]) = if closed[i] {
                let propagates = n0[i] * n0[i] * (1.0 - c * c) < n2[i] * n2[i] && c > 0.0;
                if propagates {
                    (airy[i], 1.0 - airy[i])
                } else {
                    (1.0, 0.0)
                }
            } else {
                let response = self.slot_response(i, n0[i], n2[i], 0.0, cos_i, reversed);
                (response.reflectance() as f32, response.transmittance() as f32)
            };
        }
        (r, t)
    }

    fn stack(&self, i: usize) -> &[FilmLayer] {
        &self.layers[i * self.n_layers..(i + 1) * self.n_layers]
    }

    /// Unpolarised reflectance per slot of the coating on a conductor of complex index `eta + ik` (relative to the
    /// outside), for light at `cos_i` to the (micro)surface normal.
    pub fn conductor_reflectance(&self, cos_i: f32, eta: &SampledSpectrum, k: &SampledSpectrum) -> SampledSpectrum {
        SampledSpectrum(self.reflectance(Vec4::ONE, Vec4::from_array(eta.0), Vec4::from_array(k.0), cos_i, false))
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
        let eta = Vec4::from_array(eta.0);
        if cos_i >= 0.0 {
            self.reflectance_transmittance(Vec4::ONE, eta, cos_i, false)
        } else {
            self.reflectance_transmittance(eta, Vec4::ONE, cos_i, true)
        }
    }

    /// Unpolarised reflectance and transmittance per slot of the layers alone, free-standing in vacuum (a soap
    /// film), for light at `cos_i` to the normal from either side.
    pub fn free_film_reflectance_transmittance(&self, cos_i: f32) -> (SampledSpectrum, SampledSpectrum) {
        self.reflectance_transmittance(Vec4::ONE, Vec4::ONE, cos_i, cos_i < 0.0)
    }
}

/// Unpolarised reflectance of one non-absorbing layer of index `n1` and phase thickness per cosine `phase`
/// (2π·n1·d/λ) between a non-absorbing medium `n0` and a substrate N₂ = `n2` + i·`k2`, for light at `cos0`, in the
/// four slots at once: Airy's formula r = (r₀₁ + r₁₂e^{2iβ})/(1 + r₀₁r₁₂e^{2iβ}), β = phase·cos θ₁ (Born & Wolf,
/// *Principles of Optics*, 7th ed., §1.6.4), for s and p. With w = N cos θ for each medium,
/// r_s = (w_a − w_b)/(w_a + w_b) and r_p = (N_b²w_a − N_a²w_b)/(N_b²w_a + N_a²w_b), kept as fractions so that R
/// takes one division. The second array says which slots it computed: not those where the layer itself totally
/// reflects (an evanescent wave inside: the matrix method's case).
fn airy_reflectance(
    n0: Vec4,
    n1: Vec4,
    phase: &[f64; N_WAVELENGTHS],
    n2: Vec4,
    k2: Vec4,
    cos0: f32,
) -> ([f32; N_WAVELENGTHS], [bool; N_WAVELENGTHS]) {
    let c0 = cos0.abs().min(1.0);
    if c0 == 0.0 {
        return ([1.0; N_WAVELENGTHS], [true; N_WAVELENGTHS]);
    }
    let s2 = n0 * n0 * (1.0 - c0 * c0);
    let c1_squared = Vec4::ONE - s2 / (n1 * n1);
    let closed = c1_squared.cmpgt(Vec4::ZERO);
    let c1 = c1_squared.max(Vec4::ZERO).sqrt();
    let (w0, w1) = (n0 * c0, n1 * c1);
    // w₂ = N₂ cos θ₂ = √(N₂² − s²) on the principal branch, whose imaginary part is ≥ 0 (Im N₂² = 2n₂k₂ ≥ 0): the
    // wave decays into the substrate, and beyond a critical angle w₂ is imaginary.
    let (n2_squared_re, n2_squared_im) = (n2 * n2 - k2 * k2, 2.0 * n2 * k2);
    let (re, im) = (n2_squared_re - s2, n2_squared_im);
    let m = (re * re + im * im).sqrt();
    let (w2_re, w2_im) = ((0.5 * (m + re)).max(Vec4::ZERO).sqrt(), (0.5 * (m - re)).max(Vec4::ZERO).sqrt());
    // e^{2iβ}: the round-trip phase reaches hundreds of radians in thick films, so it is formed and reduced to
    // [−π, π] in f64 (cos θ₁ again in f64); its sine and cosine then in f32.
    let (mut e_re, mut e_im) = ([0.0f32; N_WAVELENGTHS], [0.0f32; N_WAVELENGTHS]);
    let sin2 = 1.0 - c0 as f64 * c0 as f64;
    for i in 0..N_WAVELENGTHS {
        let (a, b) = (n0[i] as f64, n1[i] as f64);
        let two_beta = 2.0 * phase[i] * (1.0 - a * a * sin2 / (b * b)).max(0.0).sqrt();
        let reduced = two_beta - std::f64::consts::TAU * (two_beta / std::f64::consts::TAU).round();
        (e_im[i], e_re[i]) = (reduced as f32).sin_cos();
    }
    let (e_re, e_im) = (Vec4::from_array(e_re), Vec4::from_array(e_im));
    // With r₀₁ = p/q and r₁₂ = a/b, r = (pb + qae)/(qb + pae): |numerator|² and |denominator|².
    let squares = |p: Vec4, q: Vec4, a: (Vec4, Vec4), b: (Vec4, Vec4)| {
        let ae = (a.0 * e_re - a.1 * e_im, a.0 * e_im + a.1 * e_re);
        let num = (p * b.0 + q * ae.0, p * b.1 + q * ae.1);
        let den = (q * b.0 + p * ae.0, q * b.1 + p * ae.1);
        (num.0 * num.0 + num.1 * num.1, den.0 * den.0 + den.1 * den.1)
    };
    let (num_s, den_s) = squares(w0 - w1, w0 + w1, (w1 - w2_re, -w2_im), (w1 + w2_re, w2_im));
    // p: N₂²w₁ and n₁²w₂.
    let (n0_2, n1_2) = (n0 * n0, n1 * n1);
    let n2w1 = (n2_squared_re * w1, n2_squared_im * w1);
    let n1w2 = (n1_2 * w2_re, n1_2 * w2_im);
    let (num_p, den_p) = squares(
        n1_2 * w0 - n0_2 * w1,
        n1_2 * w0 + n0_2 * w1,
        (n2w1.0 - n1w2.0, n2w1.1 - n1w2.1),
        (n2w1.0 + n1w2.0, n2w1.1 + n1w2.1),
    );
    let r = (0.5 * (num_s * den_p + num_p * den_s) / (den_s * den_p)).min(Vec4::ONE);
    let mask = closed.bitmask();
    (r.to_array(), std::array::from_fn(|i| mask & (1 << i) != 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};

    /// Airy's closed form (f32 lanes) is the characteristic-matrix method's reflectance (f64) to 1e-5 (f32 rounding,
    /// largest near grazing incidence; far below anything visible): onto metals, glass and air, from air and from
    /// glass, from normal to grazing incidence, thin to thick, and beyond the substrate's critical angle; it leaves to
    /// the matrix method the slots where the layer itself totally reflects.
    #[test]
    fn airys_closed_form_is_the_matrix_methods_reflectance() {
        let mut worst = 0.0f64;
        for &(n0, n1) in &[(1.0f32, 1.33f32), (1.0, 2.4), (1.0, 1.38), (1.5, 1.38), (1.5, 2.1), (1.33, 1.5)] {
            for &(n2, k2) in &[(2.7f32, 3.8f32), (0.2, 3.0), (1.52, 0.0), (1.0, 0.0), (0.05, 4.2)] {
                for &d in &[0.0f64, 80.0, 300.0, 2000.0] {
                    let lambda = [380.0f64, 480.0, 550.0, 720.0];
                    let phase = lambda.map(|l| 2.0 * std::f64::consts::PI * n1 as f64 * d / l);
                    for &c in &[1.0f32, 0.8, 0.5, 0.2, 0.03] {
                        let (r, closed) = airy_reflectance(
                            Vec4::splat(n0),
                            Vec4::splat(n1),
                            &phase,
                            Vec4::splat(n2),
                            Vec4::splat(k2),
                            c,
                        );
                        for i in 0..N_WAVELENGTHS {
                            let evanescent = n0 * n0 * (1.0 - c * c) >= n1 * n1;
                            assert_eq!(closed[i], !evanescent, "n0 {n0} n1 {n1} cos {c}");
                            if evanescent {
                                continue;
                            }
                            let layer = [FilmLayer::new(Complex::from_real(n1 as f64), d)];
                            let substrate = Complex::new(n2 as f64, k2 as f64);
                            let want = film_stack(n0 as f64, &layer, substrate, c as f64, lambda[i]).reflectance();
                            worst = worst.max((r[i] as f64 - want).abs());
                            assert!(
                                (r[i] as f64 - want).abs() < 1e-5,
                                "n0 {n0} n1 {n1} N2 {n2}+{k2}i d {d} λ {} cos {c}: {} vs {want}",
                                lambda[i],
                                r[i]
                            );
                        }
                    }
                }
            }
        }
        eprintln!("largest difference: {worst:e}");
    }

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
