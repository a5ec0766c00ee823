//! Fresnel and Snell checks against closed forms and physical identities.

use approx::assert_relative_eq;
use optics::complex::Complex;
use optics::fresnel::*;
use optics::{catalogue, Ior};

const ETAS: [f64; 6] = [1.0003, 1.333, 1.5, 1.7847, 2.4175, 0.8];

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn len(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = len(a);
    [a[0] / l, a[1] / l, a[2] / l]
}

#[test]
fn normal_incidence_matches_closed_form() {
    for &(n1, n2) in &[(1.0f64, 1.5f64), (1.0, 1.333), (1.5, 1.0), (1.333, 2.4175), (1.0, 1.0)] {
        let expected = ((n1 - n2) / (n1 + n2)).powi(2);
        assert_relative_eq!(fresnel_dielectric(1.0, n2 / n1), expected, epsilon = 1e-15);
        // Same from the other side (cos θ = −1 flips η).
        assert_relative_eq!(fresnel_dielectric(-1.0, n1 / n2), expected, epsilon = 1e-15);
    }
    assert_relative_eq!(fresnel_dielectric(1.0, 1.5), 0.04, epsilon = 1e-15);
}

#[test]
fn brewster_angle_zeroes_p_reflectance() {
    for &(n1, n2) in &[(1.0, 1.5), (1.0, 1.333), (1.5, 1.0), (1.0, 2.4175)] {
        let tb = brewster_angle(n1, n2);
        assert_relative_eq!(tb.tan(), n2 / n1, epsilon = 1e-14);
        let c = tb.cos();
        let eta = n2 / n1;
        let rp = fresnel_dielectric_p(c, eta);
        let rs = fresnel_dielectric_s(c, eta);
        assert!(rp < 1e-28, "R_p = {rp}");
        assert!(rs > 0.01);
        assert_relative_eq!(fresnel_dielectric(c, eta), rs / 2.0, epsilon = 1e-15);
        // At Brewster's angle reflected and refracted rays are perpendicular: θB + θt = 90°.
        let st = snell_sin_t(tb.sin(), n1, n2).unwrap();
        assert_relative_eq!(tb + st.asin(), std::f64::consts::FRAC_PI_2, epsilon = 1e-12);
    }
}

#[test]
fn total_internal_reflection_past_the_critical_angle() {
    let (n_glass, n_air) = (1.5, 1.0);
    let tc = critical_angle(n_glass, n_air).unwrap();
    assert_relative_eq!(tc.sin(), 1.0 / 1.5, epsilon = 1e-15);
    assert!(critical_angle(1.0, 1.5).is_none());
    assert!(critical_angle(1.5, 1.5).is_none());
    // From inside glass: η = n_glass/n_air is passed with cos θ < 0 (normal points out of the glass... here the
    // normal points into the air side, so a ray inside has negative cosine).
    let eta = n_glass / n_air;
    for i in 1..=20 {
        let theta = tc + (std::f64::consts::FRAC_PI_2 - tc) * f64::from(i) / 20.0;
        assert_eq!(fresnel_dielectric(-theta.cos(), eta), 1.0, "θ = {theta}");
        assert_eq!(fresnel_dielectric_transmittance(-theta.cos(), eta), 0.0);
        assert!(snell_sin_t(theta.sin(), n_glass, n_air).is_none());
    }
    // Just below the critical angle some light still escapes.
    let below = tc - 1e-3;
    assert!(fresnel_dielectric(-below.cos(), eta) < 1.0);
    assert!(snell_sin_t(below.sin(), n_glass, n_air).is_some());
}

/// Power transmittance from amplitude coefficients, written out independently of the crate.
fn transmittance_independent(theta_i: f64, n1: f64, n2: f64) -> f64 {
    let st = n1 * theta_i.sin() / n2;
    if st >= 1.0 {
        return 0.0;
    }
    let (ci, ct) = (theta_i.cos(), (1.0 - st * st).sqrt());
    let ts = 2.0 * n1 * ci / (n1 * ci + n2 * ct);
    let tp = 2.0 * n1 * ci / (n2 * ci + n1 * ct);
    let factor = (n2 * ct) / (n1 * ci);
    0.5 * factor * (ts * ts + tp * tp)
}

#[test]
fn reflectance_plus_transmittance_is_one() {
    for &eta in &ETAS {
        for i in 0..90 {
            let theta = f64::from(i) * std::f64::consts::FRAC_PI_2 / 90.0;
            let r = fresnel_dielectric(theta.cos(), eta);
            let t_indep = transmittance_independent(theta, 1.0, eta);
            let t = fresnel_dielectric_transmittance(theta.cos(), eta);
            assert_relative_eq!(r + t_indep, 1.0, epsilon = 1e-12);
            assert_relative_eq!(t, t_indep, epsilon = 1e-12);
            // And from inside.
            let r_in = fresnel_dielectric(-theta.cos(), eta);
            let t_in = transmittance_independent(theta, eta, 1.0);
            assert_relative_eq!(r_in + t_in, 1.0, epsilon = 1e-12);
        }
    }
}

#[test]
fn reciprocity_between_the_two_sides() {
    // Stokes relations: R(θi) seen from medium 1 equals R(θt) seen from medium 2.
    for &eta in &ETAS {
        for i in 0..89 {
            let theta_i = f64::from(i) * std::f64::consts::FRAC_PI_2 / 90.0;
            let Some(st) = snell_sin_t(theta_i.sin(), 1.0, eta) else { continue };
            let theta_t = st.asin();
            let outside = fresnel_dielectric(theta_i.cos(), eta);
            let inside = fresnel_dielectric(-theta_t.cos(), eta);
            assert_relative_eq!(outside, inside, epsilon = 1e-12);
            // Equivalently, with the inside ray expressed as the relative index 1/η from a positive cosine.
            assert_relative_eq!(fresnel_dielectric(theta_t.cos(), 1.0 / eta), outside, epsilon = 1e-12);
        }
    }
}

#[test]
fn grazing_incidence_reflects_everything() {
    for &eta in &[1.333, 1.5, 2.4] {
        assert_relative_eq!(fresnel_dielectric(0.0, eta), 1.0, epsilon = 1e-15);
        assert_relative_eq!(fresnel_conductor(0.0, 0.2, 3.0), 1.0, epsilon = 1e-12);
    }
    assert_eq!(fresnel_dielectric(0.3, 1.0), 0.0);
    assert_eq!(fresnel_dielectric_transmittance(0.3, 1.0), 1.0);
}

#[test]
fn conductor_with_zero_k_equals_dielectric() {
    for &eta in &ETAS {
        for i in 0..=90 {
            let c = (f64::from(i) * std::f64::consts::FRAC_PI_2 / 90.0).cos();
            assert_relative_eq!(fresnel_conductor(c, eta, 0.0), fresnel_dielectric(c, eta), epsilon = 1e-12);
            let (rs, rp) = fresnel_complex_sp(c, Complex::from_real(eta));
            assert_relative_eq!(rs, fresnel_dielectric_s(c, eta), epsilon = 1e-12);
            assert_relative_eq!(rp, fresnel_dielectric_p(c, eta), epsilon = 1e-12);
        }
    }
}

#[test]
fn conductor_normal_incidence_closed_form() {
    for &(n, k) in &[(0.155, 3.6), (0.05, 4.4), (1.38, 1.92), (2.74, 3.81), (1.0, 0.0), (1.5, 0.1)] {
        let expected = ((n - 1.0f64).powi(2) + k * k) / ((n + 1.0f64).powi(2) + k * k);
        assert_relative_eq!(fresnel_conductor(1.0, n, k), expected, epsilon = 1e-14);
    }
}

#[test]
fn conductor_reflectance_is_physical() {
    // Between 0 and 1, with the characteristic dip of R_p near the principal angle before the rise to 1.
    let (n, k) = (0.155, 3.6);
    let mut min_rp = 1.0_f64;
    for i in 0..=90 {
        let c = (f64::from(i) * std::f64::consts::FRAC_PI_2 / 90.0).cos();
        let (rs, rp) = fresnel_complex_sp(c, Complex::new(n, k));
        assert!((0.0..=1.0 + 1e-12).contains(&rs) && (0.0..=1.0 + 1e-12).contains(&rp));
        assert!(rs + 1e-12 >= rp, "R_s ≥ R_p for a conductor");
        min_rp = min_rp.min(rp);
    }
    assert!(min_rp < fresnel_conductor(1.0, n, k));
}

#[test]
fn gold_is_yellow() {
    let au = catalogue::lookup("Au").unwrap().ior;
    let r = |l: f64| {
        let (n, k) = au.complex(l);
        fresnel_conductor(1.0, n, k)
    };
    assert!(r(650.0) > 0.9, "R(650) = {}", r(650.0));
    assert!(r(450.0) < 0.45, "R(450) = {}", r(450.0));
    assert!(r(700.0) > r(550.0) && r(550.0) > r(450.0));
    // Silver stays bright across the visible; aluminium too.
    for m in ["Ag", "Al"] {
        let ior: Ior = catalogue::lookup(m).unwrap().ior;
        for l in [400.0, 500.0, 600.0, 700.0] {
            let (n, k) = ior.complex(l);
            assert!(fresnel_conductor(1.0, n, k) > 0.85, "{m} at {l} nm");
        }
    }
}

#[test]
fn refraction_obeys_snell_in_the_plane_of_incidence() {
    let n = [0.0, 0.0, 1.0];
    for &eta in &[1.333, 1.5, 2.4175, 0.75] {
        for i in 0..90 {
            let theta = f64::from(i) * std::f64::consts::FRAC_PI_2 / 90.0;
            let phi = 0.37 * f64::from(i);
            let wi = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
            match refract(wi, n, eta) {
                Some(wt) => {
                    assert_relative_eq!(len(wt), 1.0, epsilon = 1e-12);
                    // Transmitted ray is on the other side.
                    assert!(dot(wt, n) < 0.0);
                    // n1 sin θ1 = n2 sin θ2 (n1 = 1, n2 = η).
                    let sin_t = len(cross(wt, n));
                    assert_relative_eq!(theta.sin(), eta * sin_t, epsilon = 1e-12);
                    // Coplanar with wi and n: wt · (wi × n) = 0, and it continues across (not back).
                    assert!(dot(wt, cross(wi, n)).abs() < 1e-12);
                    if theta > 0.0 {
                        assert!(dot([wt[0], wt[1], 0.0], [wi[0], wi[1], 0.0]) < 0.0);
                    }
                    // Reversibility: refracting −wt... i.e. sending wt back from inside gives wi.
                    let back = refract(wt, n, eta).expect("reverse path exists");
                    for j in 0..3 {
                        assert_relative_eq!(back[j], wi[j], epsilon = 1e-12);
                    }
                }
                None => {
                    // Only possible going into a lower index, past the critical angle.
                    assert!(eta < 1.0);
                    assert!(theta >= critical_angle(1.0, eta).unwrap() - 1e-12);
                }
            }
        }
    }
}

#[test]
fn refraction_from_inside_and_tir() {
    // A ray inside glass (wi below the surface, normal pointing out into air).
    let n = [0.0, 0.0, 1.0];
    let eta = 1.5;
    let tc = critical_angle(1.5, 1.0).unwrap();
    for &theta in &[0.1, 0.5, tc - 1e-6, tc + 1e-6, 1.2] {
        let wi = normalize([theta.sin(), 0.0, -theta.cos()]);
        let wt = refract(wi, n, eta);
        if theta < tc {
            let wt = wt.expect("below the critical angle light escapes");
            assert!(wt[2] > 0.0);
            assert_relative_eq!(1.5 * theta.sin(), len(cross(wt, n)), epsilon = 1e-9);
        } else {
            assert!(wt.is_none(), "θ = {theta} is past the critical angle {tc}");
        }
    }
}

#[test]
fn reflect_mirrors_about_the_normal() {
    let wo = normalize([0.3, -0.4, 0.8]);
    let r = reflect(wo, [0.0, 0.0, 1.0]);
    assert_relative_eq!(r[0], -wo[0], epsilon = 1e-15);
    assert_relative_eq!(r[1], -wo[1], epsilon = 1e-15);
    assert_relative_eq!(r[2], wo[2], epsilon = 1e-15);
}

#[test]
fn minimum_deviation_is_the_least_deviation_of_a_trace() {
    // Minimum deviation of a prism with apex angle A: n = sin((A + δmin)/2)/sin(A/2). Trace through two faces with
    // the scalar Snell helpers and check the minimum over incidence angles.
    let glass = catalogue::lookup("SF11").unwrap().ior;
    let apex = 60f64.to_radians();
    for l in [450.0, 550.0, 650.0] {
        let n = glass.n(l);
        let deviation = |t1: f64| -> Option<f64> {
            let t2 = snell_sin_t(t1.sin(), 1.0, n)?.asin();
            let t3 = apex - t2;
            let t4 = snell_sin_t(t3.sin(), n, 1.0)?.asin();
            Some(t1 + t4 - apex)
        };
        let min = (1..9000)
            .filter_map(|i| deviation(f64::from(i) * 1e-4 * std::f64::consts::FRAC_PI_2 / 0.9))
            .fold(f64::INFINITY, f64::min);
        let closed = prism_minimum_deviation(n, apex).unwrap();
        assert_relative_eq!(min, closed, epsilon = 1e-6);
    }
    // Blue deviates more than red.
    let d = |l: f64| 2.0 * (glass.n(l) * (apex / 2.0).sin()).asin() - apex;
    assert!(d(450.0) > d(650.0));
}
