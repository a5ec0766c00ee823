//! Thin films: the reflectance and transmittance of a stack of parallel layers, per wavelength, angle and
//! polarisation, by the characteristic-matrix (transfer-matrix) method.
//!
//! Light arrives from a non-absorbing incident medium of index n₀ at angle θ₀, crosses layers j = 1…m of complex
//! index N_j = n_j + ik_j and thickness d_j, and enters a substrate of complex index N_s. Snell's invariant
//! n₀ sin θ₀ = N_j sin θ_j gives each medium's (complex) cos θ_j = √(1 − (n₀ sin θ₀ / N_j)²), on the branch where the
//! wave N_j cos θ_j decays forward (Im ≥ 0), which also covers total internal reflection inside a layer (an
//! evanescent wave: cos θ_j imaginary) and absorbing layers. With the tilted admittances η = N cos θ (s) and
//! η = N / cos θ (p), and phase thicknesses δ_j = 2π N_j d_j cos θ_j / λ, each layer's characteristic matrix is
//! [[cos δ, −i sin δ / η], [−i η sin δ, cos δ]] (Born & Wolf, *Principles of Optics*, 7th ed., §1.6.2, for time
//! dependence e^(−iωt) and N = n + ik), and
//!
//! ```text
//! [B, C]ᵀ = M₁ M₂ … M_m [1, η_s]ᵀ,   r = (η₀B − C)/(η₀B + C),   R = |r|²,   T = 4 η₀ Re(η_s) / |η₀B + C|²
//! ```
//!
//! (Macleod, *Thin-Film Optical Filters*, 5th ed., §2.2–2.4). R + T + A = 1, A being what the layers absorb; for a
//! lossless stack A = 0 exactly up to rounding. A single layer reduces to Airy's formula; a layer of zero thickness
//! is the identity matrix, so the bare interface comes back exactly. Wavelengths and thicknesses are in nanometres.

use crate::Complex;

/// One layer of a film stack: its complex index of refraction N = n + ik (k ≥ 0 absorbs) and thickness in nm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmLayer {
    /// Complex index of refraction at the wavelength considered.
    pub n: Complex,
    /// Thickness in nanometres (≥ 0).
    pub thickness_nm: f64,
}

impl FilmLayer {
    /// A layer of complex index `n` and thickness `thickness_nm`.
    pub fn new(n: Complex, thickness_nm: f64) -> Self {
        Self { n, thickness_nm }
    }
}

/// Power reflectance and transmittance of a film stack for s- and p-polarised light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmResponse {
    /// Reflectance of s-polarised light (electric field perpendicular to the plane of incidence).
    pub r_s: f64,
    /// Reflectance of p-polarised light (electric field in the plane of incidence).
    pub r_p: f64,
    /// Transmittance of s-polarised light into the substrate.
    pub t_s: f64,
    /// Transmittance of p-polarised light into the substrate.
    pub t_p: f64,
}

impl FilmResponse {
    /// Reflectance of unpolarised light, (R_s + R_p)/2.
    pub fn reflectance(&self) -> f64 {
        0.5 * (self.r_s + self.r_p)
    }

    /// Transmittance of unpolarised light into the substrate, (T_s + T_p)/2.
    pub fn transmittance(&self) -> f64 {
        0.5 * (self.t_s + self.t_p)
    }

    /// What the layers absorb of unpolarised light, 1 − R − T (0 up to rounding for lossless layers).
    pub fn absorptance(&self) -> f64 {
        1.0 - self.reflectance() - self.transmittance()
    }
}

/// cos θ in a medium of index `n` for Snell's invariant squared `s2 = (n₀ sin θ₀)²`, on the branch whose wave
/// N cos θ decays (or, lossless and propagating, travels) forward: Im(N cos θ) ≥ 0, and Re ≥ 0 where Im is 0.
fn cos_in(n: Complex, s2: f64) -> Complex {
    let c = (Complex::from_real(1.0) - Complex::from_real(s2) / (n * n)).sqrt();
    let w = n * c;
    let c = if w.im < 0.0 || (w.im == 0.0 && w.re < 0.0) { -c } else { c };
    // Exactly at a critical angle cos θ is 0 and the p admittance N / cos θ infinite; a tiny cosine keeps the
    // matrix finite (its products η sin δ and sin δ / η stay finite) and changes nothing measurable.
    if c == Complex::default() {
        Complex::new(1e-150, 0.0)
    } else {
        c
    }
}

/// Reflectance and transmittance of `layers` (listed from the incident side) between an incident medium of real
/// index `n_incident` and a substrate of complex index `n_substrate`, for light at `cos_theta_i` (its sign is
/// ignored) and wavelength `lambda_nm` in vacuo. With no layers this is the bare interface's Fresnel reflectance.
///
/// Light from the substrate side of a dielectric stack is the same call with the media swapped and the layers
/// reversed (the substrate must then not absorb).
pub fn film_stack(
    n_incident: f64,
    layers: &[FilmLayer],
    n_substrate: Complex,
    cos_theta_i: f64,
    lambda_nm: f64,
) -> FilmResponse {
    stack_response(n_incident, layers.iter(), n_substrate, cos_theta_i, lambda_nm)
}

/// [`film_stack`] for light arriving from the other side: `layers` are listed as for [`film_stack`] from the far
/// medium (of complex index `n_exit`) towards the incident one (real `n_incident`), and are crossed in reverse, so
/// a coating stored outermost first is lit from its substrate without copying it.
pub fn film_stack_reversed(
    n_incident: f64,
    layers: &[FilmLayer],
    n_exit: Complex,
    cos_theta_i: f64,
    lambda_nm: f64,
) -> FilmResponse {
    stack_response(n_incident, layers.iter().rev(), n_exit, cos_theta_i, lambda_nm)
}

/// The characteristic-matrix product of `layers` (an iterator from the incident side towards the substrate).
fn stack_response<'a>(
    n_incident: f64,
    layers: impl DoubleEndedIterator<Item = &'a FilmLayer>,
    n_substrate: Complex,
    cos_theta_i: f64,
    lambda_nm: f64,
) -> FilmResponse {
    let c0 = cos_theta_i.abs().min(1.0);
    if c0 == 0.0 {
        // Grazing incidence: everything is reflected.
        return FilmResponse { r_s: 1.0, r_p: 1.0, t_s: 0.0, t_p: 0.0 };
    }
    let s2 = n_incident * n_incident * (1.0 - c0 * c0);
    let k0 = 2.0 * std::f64::consts::PI / lambda_nm;
    let cos_sub = cos_in(n_substrate, s2);
    let one = Complex::from_real(1.0);
    let i = Complex::new(0.0, 1.0);
    // Tilted admittances: N cos θ for s, N / cos θ for p. Both polarisations are carried through the stack together,
    // since each layer's angle and phase thickness (the costly part) are the same for both.
    let eta0 = [n_incident * c0, n_incident / c0];
    let eta_sub = [n_substrate * cos_sub, n_substrate / cos_sub];
    // [B, C]ᵀ = M₁ … M_m [1, η_s]ᵀ, applied from the substrate outwards.
    let (mut b, mut c) = ([one; 2], eta_sub);
    for layer in layers.rev() {
        let cj = cos_in(layer.n, s2);
        let delta = layer.n * cj * (k0 * layer.thickness_nm);
        let (cd, sd) = (delta.cos(), delta.sin());
        let eta = [layer.n * cj, layer.n / cj];
        for pol in 0..2 {
            (b[pol], c[pol]) = (cd * b[pol] - i * sd / eta[pol] * c[pol], -(i * eta[pol] * sd) * b[pol] + cd * c[pol]);
        }
    }
    let response = [0, 1].map(|pol| {
        let denominator = b[pol] * eta0[pol] + c[pol];
        let r = ((b[pol] * eta0[pol] - c[pol]) / denominator).norm_sqr();
        let t = 4.0 * eta0[pol] * eta_sub[pol].re / denominator.norm_sqr();
        (r.min(1.0), t.max(0.0))
    });
    FilmResponse { r_s: response[0].0, r_p: response[1].0, t_s: response[0].1, t_p: response[1].1 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{fresnel_complex_sp, fresnel_dielectric_p, fresnel_dielectric_s};

    fn real(n: f64) -> Complex {
        Complex::from_real(n)
    }

    /// cos θ in medium `n` for incidence from real `n0` at `c0`, principal branch with forward decay.
    fn cos_t(n0: f64, c0: f64, n: Complex) -> Complex {
        cos_in(n, n0 * n0 * (1.0 - c0 * c0))
    }

    /// Airy's formula for one film (Born & Wolf §1.6.4 / Heavens): the classic Fresnel amplitude coefficients of
    /// both interfaces and the film's round-trip phase, written independently of the matrix code.
    fn airy(n0: f64, n1: Complex, d: f64, n2: Complex, c0: f64, lambda: f64) -> (f64, f64, f64, f64) {
        let (a0, a1, a2) = (real(n0), n1, n2);
        let (c0c, c1, c2) = (real(c0), cos_t(n0, c0, n1), cos_t(n0, c0, n2));
        let rs = |na: Complex, ca: Complex, nb: Complex, cb: Complex| (na * ca - nb * cb) / (na * ca + nb * cb);
        let rp = |na: Complex, ca: Complex, nb: Complex, cb: Complex| (nb * ca - na * cb) / (nb * ca + na * cb);
        let ts = |na: Complex, ca: Complex, nb: Complex, cb: Complex| (na * ca * 2.0) / (na * ca + nb * cb);
        let tp = |na: Complex, ca: Complex, nb: Complex, cb: Complex| (na * ca * 2.0) / (nb * ca + na * cb);
        let beta = n1 * c1 * (2.0 * std::f64::consts::PI * d / lambda);
        // e^(iβ) = e^(−Im β)·cis(Re β).
        let e1 = Complex::cis(beta.re) * (-beta.im).exp();
        let e2 = e1 * e1;
        let (r01s, r12s, r01p, r12p) =
            (rs(a0, c0c, a1, c1), rs(a1, c1, a2, c2), rp(a0, c0c, a1, c1), rp(a1, c1, a2, c2));
        let r_s = (r01s + r12s * e2) / (Complex::from_real(1.0) + r01s * r12s * e2);
        let r_p = (r01p + r12p * e2) / (Complex::from_real(1.0) + r01p * r12p * e2);
        let t_s = ts(a0, c0c, a1, c1) * ts(a1, c1, a2, c2) * e1 / (Complex::from_real(1.0) + r01s * r12s * e2);
        let t_p = tp(a0, c0c, a1, c1) * tp(a1, c1, a2, c2) * e1 / (Complex::from_real(1.0) + r01p * r12p * e2);
        // Power transmittance into a non-absorbing substrate: the ratio of the normal energy flows.
        let flow = (n2 * c2).re / (n0 * c0);
        (r_s.norm_sqr(), r_p.norm_sqr(), flow * t_s.norm_sqr(), flow * t_p.norm_sqr())
    }

    #[test]
    fn one_film_is_airys_formula() {
        let films = [
            (1.0, real(1.38), 100.0, real(1.52)),           // MgF₂ on glass
            (1.0, real(2.35), 317.0, real(1.45)),           // TiO₂ on silica, thick
            (1.33, real(1.5), 42.0, real(1.0)),             // from water through oil into air (TIR beyond 48.8°)
            (1.0, Complex::new(2.0, 0.3), 80.0, real(1.5)), // an absorbing film
            (1.0, real(1.33), 500.0, real(1.0)),            // a soap film in air
        ];
        for &(n0, n1, d, n2) in &films {
            for &lambda in &[380.0, 455.0, 550.0, 700.0] {
                for &c0 in &[1.0, 0.9, 0.6, 0.25, 0.05] {
                    let f = film_stack(n0, &[FilmLayer::new(n1, d)], n2, c0, lambda);
                    let (rs, rp, ts, tp) = airy(n0, n1, d, n2, c0, lambda);
                    let what = format!("n0 {n0} n1 {n1:?} d {d} n2 {n2:?} λ {lambda} cos {c0}");
                    assert!((f.r_s - rs).abs() < 1e-12, "{what}: R_s {} vs {rs}", f.r_s);
                    assert!((f.r_p - rp).abs() < 1e-12, "{what}: R_p {} vs {rp}", f.r_p);
                    if n2.im == 0.0 && n0 * n0 * (1.0 - c0 * c0) < n2.re * n2.re {
                        assert!((f.t_s - ts).abs() < 1e-12, "{what}: T_s {} vs {ts}", f.t_s);
                        assert!((f.t_p - tp).abs() < 1e-12, "{what}: T_p {} vs {tp}", f.t_p);
                    }
                }
            }
        }
    }

    #[test]
    fn a_quarter_wave_layer_at_normal_incidence() {
        // R = ((n₀n_s − n₁²)/(n₀n_s + n₁²))² at the design wavelength: MgF₂ on crown glass, and a perfect AR
        // coating n₁ = √(n₀ n_s) that reflects nothing.
        for &(n0, n1, ns) in &[(1.0, 1.38, 1.52), (1.0, 1.52f64.sqrt(), 1.52), (1.33, 2.0, 1.5)] {
            let lambda = 550.0;
            let f = film_stack(n0, &[FilmLayer::new(real(n1), lambda / (4.0 * n1))], real(ns), 1.0, lambda);
            let want = ((n0 * ns - n1 * n1) / (n0 * ns + n1 * n1)).powi(2);
            assert!((f.reflectance() - want).abs() < 1e-14, "{n1}: {} vs {want}", f.reflectance());
            assert!((f.r_s - f.r_p).abs() < 1e-15);
        }
    }

    #[test]
    fn a_half_wave_layer_and_a_layer_of_no_thickness_are_absent() {
        let bare = |c0: f64, n0: f64, ns: Complex| film_stack(n0, &[], ns, c0, 500.0);
        for &c0 in &[1.0, 0.7, 0.2] {
            // Zero thickness: the bare interface, exactly as the Fresnel functions give it.
            for &ns in &[real(1.5), Complex::new(0.2, 3.0)] {
                let f = film_stack(1.0, &[FilmLayer::new(real(2.1), 0.0)], ns, c0, 500.0);
                let (rs, rp) = fresnel_complex_sp(c0, ns);
                assert!((f.r_s - rs).abs() < 1e-14 && (f.r_p - rp).abs() < 1e-14, "{ns:?} {c0}");
                assert_eq!(f, bare(c0, 1.0, ns));
            }
            let f = bare(c0, 1.0, real(1.5));
            assert!((f.r_s - fresnel_dielectric_s(c0, 1.5)).abs() < 1e-14);
            assert!((f.r_p - fresnel_dielectric_p(c0, 1.5)).abs() < 1e-14);
        }
        // A half-wave layer at normal incidence and its design wavelength: the bare interface.
        let (n1, lambda) = (1.9, 600.0);
        let f = film_stack(1.0, &[FilmLayer::new(real(n1), lambda / (2.0 * n1))], real(1.5), 1.0, lambda);
        assert!((f.reflectance() - 0.04).abs() < 1e-14, "{}", f.reflectance());
    }

    /// A few stacks, lossless and not, with a layer that totally reflects inside at oblique angles (n = 1.1
    /// between 1.6 and 1.5: frustrated total internal reflection beyond 43°).
    fn stacks() -> Vec<(f64, Vec<FilmLayer>, Complex)> {
        let l = |n: f64, d: f64| FilmLayer::new(real(n), d);
        vec![
            (1.0, vec![l(1.38, 99.6), l(2.1, 130.0), l(1.65, 83.0)], real(1.52)),
            (1.6, vec![l(1.1, 150.0)], real(1.5)),
            (1.6, vec![l(1.1, 700.0), l(2.3, 40.0)], real(1.7)),
            (1.0, (0..16).map(|k| if k % 2 == 0 { l(2.35, 58.5) } else { l(1.46, 94.2) }).collect(), real(1.52)),
        ]
    }

    #[test]
    fn lossless_stacks_conserve_energy_and_are_reciprocal() {
        for (n0, layers, ns) in stacks() {
            for &lambda in &[400.0, 487.0, 550.0, 633.0, 780.0] {
                for k in 0..=20 {
                    let c0 = k as f64 / 20.0;
                    let f = film_stack(n0, &layers, ns, c0, lambda);
                    for (r, t) in [(f.r_s, f.t_s), (f.r_p, f.t_p)] {
                        assert!((r + t - 1.0).abs() < 1e-12, "{n0} {lambda} {c0}: R {r} + T {t}");
                    }
                    // From the substrate at the refracted angle, through the reversed stack: the same R and T.
                    let sin2_sub = n0 * n0 * (1.0 - c0 * c0) / (ns.re * ns.re);
                    if sin2_sub < 1.0 && c0 > 0.0 {
                        let reversed: Vec<FilmLayer> = layers.iter().rev().copied().collect();
                        let g = film_stack(ns.re, &reversed, real(n0), (1.0 - sin2_sub).sqrt(), lambda);
                        let h = film_stack_reversed(ns.re, &layers, real(n0), (1.0 - sin2_sub).sqrt(), lambda);
                        assert_eq!(g, h, "film_stack_reversed is film_stack of the reversed layers");
                        assert!((g.t_s - f.t_s).abs() < 1e-11 && (g.t_p - f.t_p).abs() < 1e-11, "{f:?} {g:?}");
                        assert!((g.r_s - f.r_s).abs() < 1e-11 && (g.r_p - f.r_p).abs() < 1e-11);
                    } else {
                        // Beyond the critical angle of the substrate itself nothing gets through.
                        assert!(f.t_s == 0.0 && f.t_p == 0.0 && (f.reflectance() - 1.0).abs() < 1e-12);
                    }
                }
            }
        }
    }

    #[test]
    fn frustrated_total_internal_reflection_falls_with_the_gap() {
        // Glass 1.6 | air gap | glass 1.6 at 60° (beyond the 38.7° critical angle): the evanescent wave tunnels
        // through a thin gap and dies across a thick one.
        let t = |d: f64| film_stack(1.6, &[FilmLayer::new(real(1.0), d)], real(1.6), 0.5, 550.0).transmittance();
        assert!(t(0.0) == 1.0 && t(20.0) > 0.5 && t(200.0) < 0.1 && t(2000.0) < 1e-12, "{}", t(200.0));
        assert!(t(20.0) > t(50.0) && t(50.0) > t(100.0));
    }

    #[test]
    fn absorbing_layers_absorb() {
        // A thin metal-like layer (chromium-ish 3.1 + 3.3i) on glass: part absorbed, none created.
        let layers = [FilmLayer::new(Complex::new(3.1, 3.3), 10.0)];
        for &c0 in &[1.0, 0.5, 0.1] {
            let f = film_stack(1.0, &layers, real(1.52), c0, 550.0);
            assert!(f.absorptance() > 0.01 && f.absorptance() < 1.0, "{f:?}");
        }
        // Thick enough, the layer is the bulk metal.
        let thick = film_stack(1.0, &[FilmLayer::new(Complex::new(3.1, 3.3), 500.0)], real(1.52), 0.8, 550.0);
        let (rs, rp) = fresnel_complex_sp(0.8, Complex::new(3.1, 3.3));
        assert!((thick.r_s - rs).abs() < 1e-12 && (thick.r_p - rp).abs() < 1e-12, "{thick:?} vs {rs} {rp}");
        assert!(thick.transmittance() < 1e-14, "{thick:?}");
    }
}
