//! Index-of-refraction models: constant, Sellmeier, Cauchy (and its Abbe-number form), tabulated real and complex
//! indices, and the complex index of a material given by its permittivity, permeability and conductivity.
//!
//! Wavelengths are in nanometres at every public entry point; Sellmeier and Cauchy coefficients follow the
//! catalogues and use micrometres, so those two convert internally.

use std::sync::Arc;

use spectral::{PiecewiseLinear, Spectrum};

use crate::complex::Complex;
use crate::error::{check, finite, OpticsError};

/// Helium d line, nm (the reference wavelength of n_d and V_d).
pub const LAMBDA_D_NM: f64 = 587.5618;
/// Hydrogen F line, nm.
pub const LAMBDA_F_NM: f64 = 486.1327;
/// Hydrogen C line, nm.
pub const LAMBDA_C_NM: f64 = 656.2725;

/// Speed of light in vacuo, m/s (exact, SI 2019).
pub const SPEED_OF_LIGHT: f64 = 299_792_458.0;
/// Vacuum permittivity ε₀, F/m (CODATA 2018).
pub const EPSILON_0: f64 = 8.854_187_812_8e-12;
/// Vacuum permeability μ₀, H/m (CODATA 2018).
pub const MU_0: f64 = 1.256_637_062_12e-6;

/// First wavelength of the grid `to_spectrum` tabulates on, nm.
const GRID_MIN_NM: f64 = 360.0;
/// Last wavelength of the grid `to_spectrum` tabulates on, nm.
const GRID_MAX_NM: f64 = 830.0;

/// The 1 nm wavelength grid 360–830 nm (471 points) on which models are validated and tabulated.
fn visible_grid() -> impl Iterator<Item = f64> {
    (0..=((GRID_MAX_NM - GRID_MIN_NM) as usize)).map(|i| GRID_MIN_NM + i as f64)
}

/// Rejects a model whose index is not finite and positive everywhere on the 360–830 nm grid.
fn check_positive_on_grid(what: &str, f: impl Fn(f64) -> f64) -> Result<(), OpticsError> {
    for l in visible_grid() {
        let n = f(l);
        if !(n.is_finite() && n > 0.0) {
            return Err(OpticsError::OutOfRange {
                name: format!("{what} n({l} nm)"),
                value: n,
                expected: "the coefficients must give a finite, positive index over 360–830 nm".into(),
            });
        }
    }
    Ok(())
}

/// A wavelength-independent index, n > 0 (validated by [`ConstantIor::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantIor(f64);

impl ConstantIor {
    /// A constant index `n`, which must be finite and positive.
    pub fn new(n: f64) -> Result<Self, OpticsError> {
        check("n", n, n > 0.0, "an index of refraction must be positive").map(Self)
    }

    /// The index.
    pub fn value(self) -> f64 {
        self.0
    }
}

/// Sellmeier dispersion formula n² = 1 + A0 + Σ Bᵢλ²/(λ² − Cᵢ), λ in µm and Cᵢ in µm² (SCHOTT convention; see
/// `data/SOURCES.md` §5). Any number of terms.
#[derive(Clone, Debug, PartialEq)]
pub struct Sellmeier {
    a0: f64,
    terms: Vec<(f64, f64)>,
}

impl Sellmeier {
    /// Builds the formula from `A0` and `(Bᵢ, Cᵢ (µm²))` pairs. Every coefficient must be finite, every `Cᵢ` ≥ 0, and
    /// the formula must give a finite positive index at every nm of 360–830 nm (no resonance inside the visible).
    pub fn new(a0: f64, terms: &[(f64, f64)]) -> Result<Self, OpticsError> {
        finite("Sellmeier A0", a0)?;
        for (i, &(b, c)) in terms.iter().enumerate() {
            finite(&format!("Sellmeier B{}", i + 1), b)?;
            check(&format!("Sellmeier C{} (µm²)", i + 1), c, c >= 0.0, "must be ≥ 0 (a squared resonance wavelength)")?;
            // A pole λ² = Cᵢ inside the tabulation range would make n blow up there.
            let lo = (GRID_MIN_NM * 1e-3).powi(2);
            let hi = (GRID_MAX_NM * 1e-3).powi(2);
            if b != 0.0 && c >= lo && c <= hi {
                return Err(OpticsError::OutOfRange {
                    name: format!("Sellmeier C{} (µm²)", i + 1),
                    value: c,
                    expected: format!("a resonance outside the visible, not in [{lo:.4}, {hi:.4}] µm²"),
                });
            }
        }
        let s = Self { a0, terms: terms.to_vec() };
        check_positive_on_grid("Sellmeier", |l| s.n(l))?;
        Ok(s)
    }

    /// `A0`.
    pub fn a0(&self) -> f64 {
        self.a0
    }

    /// The `(Bᵢ, Cᵢ (µm²))` terms.
    pub fn terms(&self) -> &[(f64, f64)] {
        &self.terms
    }

    /// n(λ), λ in nm.
    pub fn n(&self, lambda_nm: f64) -> f64 {
        // n² = 1 + A0 + Σ Bᵢλ²/(λ² − Cᵢ), λ in µm (SOURCES.md §5, SCHOTT formula).
        let l2 = (lambda_nm * 1e-3).powi(2);
        let n2 = 1.0 + self.a0 + self.terms.iter().map(|&(b, c)| b * l2 / (l2 - c)).sum::<f64>();
        n2.max(0.0).sqrt()
    }
}

/// Cauchy's formula n(λ) = A + B/λ² + C/λ⁴, λ in µm (C may be 0 for the two-term form).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cauchy {
    a: f64,
    b: f64,
    c: f64,
}

impl Cauchy {
    /// Builds the formula from `A`, `B` (µm²) and `C` (µm⁴); all finite, and n must be positive over 360–830 nm.
    pub fn new(a: f64, b: f64, c: f64) -> Result<Self, OpticsError> {
        finite("Cauchy A", a)?;
        finite("Cauchy B", b)?;
        finite("Cauchy C", c)?;
        let s = Self { a, b, c };
        check_positive_on_grid("Cauchy", |l| s.n(l))?;
        Ok(s)
    }

    /// The two-term Cauchy fit through the d, F and C lines for glass with index `nd` and Abbe number `vd`:
    /// B = (n_d − 1)/(V_d·(1/λF² − 1/λC²)), A = n_d − B/λd², so n(λd) = n_d and (n_d − 1)/(n(λF) − n(λC)) = V_d.
    /// Requires n_d > 1 and V_d > 0.
    pub fn from_abbe(nd: f64, vd: f64) -> Result<Self, OpticsError> {
        check("n_d", nd, nd > 1.0, "the Abbe form needs n_d > 1")?;
        check("V_d", vd, vd > 0.0, "an Abbe number must be positive")?;
        let (ld, lf, lc) = (LAMBDA_D_NM * 1e-3, LAMBDA_F_NM * 1e-3, LAMBDA_C_NM * 1e-3);
        // Two-term Cauchy through (λd, n_d) with n_F − n_C = (n_d − 1)/V_d; λ in µm.
        let b = (nd - 1.0) / (vd * (1.0 / (lf * lf) - 1.0 / (lc * lc)));
        let a = nd - b / (ld * ld);
        Self::new(a, b, 0.0)
    }

    /// `A`.
    pub fn a(&self) -> f64 {
        self.a
    }

    /// `B`, µm².
    pub fn b(&self) -> f64 {
        self.b
    }

    /// `C`, µm⁴.
    pub fn c(&self) -> f64 {
        self.c
    }

    /// n(λ), λ in nm.
    pub fn n(&self, lambda_nm: f64) -> f64 {
        // n = A + B/λ² + C/λ⁴, λ in µm (Cauchy 1836).
        let inv2 = 1.0 / (lambda_nm * 1e-3).powi(2);
        self.a + inv2 * (self.b + inv2 * self.c)
    }
}

/// Linear interpolation in a table, holding the end values outside it (an index of refraction should not drop to 0
/// just past the last sample, as `spectral::PiecewiseLinear::eval` does).
fn eval_clamped(t: &PiecewiseLinear, lambda_nm: f64) -> f64 {
    let ls = t.lambdas();
    // NaN stays NaN through clamp; callers pass finite wavelengths.
    t.eval(lambda_nm.clamp(ls[0], ls[ls.len() - 1]))
}

fn build_table(
    what: &str,
    lambdas: Vec<f64>,
    values: Vec<f64>,
    min_ok: f64,
    inclusive: bool,
) -> Result<PiecewiseLinear, OpticsError> {
    for (i, &l) in lambdas.iter().enumerate() {
        check(&format!("{what} wavelength[{i}] (nm)"), l, l > 0.0, "wavelengths must be positive")?;
    }
    for (i, &v) in values.iter().enumerate() {
        let ok = if inclusive { v >= min_ok } else { v > min_ok };
        let rule = if inclusive { "must be ≥ 0" } else { "must be > 0" };
        check(&format!("{what}[{i}]"), v, ok, rule)?;
    }
    PiecewiseLinear::new(lambdas, values).map_err(|e| OpticsError::BadTable(format!("{what}: {e}")))
}

/// A tabulated real index n(λ), linearly interpolated and held constant beyond its end samples.
#[derive(Clone, Debug, PartialEq)]
pub struct TabulatedIor {
    n: Arc<PiecewiseLinear>,
}

impl TabulatedIor {
    /// From wavelengths (nm, positive, strictly increasing) and indices (finite, > 0) of equal length.
    pub fn new(lambdas_nm: Vec<f64>, n: Vec<f64>) -> Result<Self, OpticsError> {
        Ok(Self { n: Arc::new(build_table("n", lambdas_nm, n, 0.0, false)?) })
    }

    /// The table.
    pub fn table(&self) -> &PiecewiseLinear {
        &self.n
    }

    /// n(λ), λ in nm.
    pub fn n(&self, lambda_nm: f64) -> f64 {
        eval_clamped(&self.n, lambda_nm)
    }
}

/// A tabulated complex index n + ik (metals), both parts linearly interpolated and held beyond the end samples.
#[derive(Clone, Debug, PartialEq)]
pub struct TabulatedComplexIor {
    n: Arc<PiecewiseLinear>,
    k: Arc<PiecewiseLinear>,
}

impl TabulatedComplexIor {
    /// From wavelengths (nm, positive, strictly increasing), real parts n (> 0) and extinction coefficients k (≥ 0),
    /// all of equal length.
    pub fn new(lambdas_nm: Vec<f64>, n: Vec<f64>, k: Vec<f64>) -> Result<Self, OpticsError> {
        let nt = build_table("n", lambdas_nm.clone(), n, 0.0, false)?;
        let kt = build_table("k", lambdas_nm, k, 0.0, true)?;
        Ok(Self { n: Arc::new(nt), k: Arc::new(kt) })
    }

    /// The table of n.
    pub fn n_table(&self) -> &PiecewiseLinear {
        &self.n
    }

    /// The table of k.
    pub fn k_table(&self) -> &PiecewiseLinear {
        &self.k
    }

    /// The n table, shared (for named spectra).
    pub(crate) fn n_arc(&self) -> Arc<PiecewiseLinear> {
        Arc::clone(&self.n)
    }

    /// The k table, shared (for named spectra).
    pub(crate) fn k_arc(&self) -> Arc<PiecewiseLinear> {
        Arc::clone(&self.k)
    }

    /// n(λ), λ in nm.
    pub fn n(&self, lambda_nm: f64) -> f64 {
        eval_clamped(&self.n, lambda_nm)
    }

    /// k(λ), λ in nm.
    pub fn k(&self, lambda_nm: f64) -> f64 {
        eval_clamped(&self.k, lambda_nm)
    }
}

/// A homogeneous isotropic material given by its relative permittivity ε_r, relative permeability μ_r and
/// conductivity σ (S/m), all taken as constant in wavelength.
///
/// Its complex index follows seed 000 (Frisvad, "Dispersion and Spectral Rendering"): n = n' + i n'' =
/// c·√(μ(ε + iσ/ω)) with ω = 2πc/λ. With ε = ε_r·ε₀, μ = μ_r·μ₀ and c² = 1/(ε₀μ₀) this is
/// n = √(μ_r(ε_r + iσ/(ωε₀))) = √(μ_r(ε_r + iσλ/(2πcε₀))), evaluated with the seed's closed-form complex square root.
/// σ = 0 gives the real index √(ε_r μ_r); σ > 0 gives absorption (n'' > 0) that grows with λ, and also raises n' with
/// λ (anomalous dispersion).
///
/// The fields are relative (dimensionless) values; use [`MaterialConstants::from_absolute`] for SI ε (F/m) and
/// μ (H/m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialConstants {
    epsilon_r: f64,
    mu_r: f64,
    sigma: f64,
}

impl MaterialConstants {
    /// From relative permittivity ε_r > 0, relative permeability μ_r > 0 and conductivity σ ≥ 0 (S/m).
    pub fn new(epsilon_r: f64, mu_r: f64, sigma: f64) -> Result<Self, OpticsError> {
        check("epsilon_r", epsilon_r, epsilon_r > 0.0, "relative permittivity must be positive")?;
        check("mu_r", mu_r, mu_r > 0.0, "relative permeability must be positive")?;
        check("sigma", sigma, sigma >= 0.0, "conductivity must be ≥ 0 S/m")?;
        Ok(Self { epsilon_r, mu_r, sigma })
    }

    /// From absolute SI permittivity ε (F/m), permeability μ (H/m) and conductivity σ (S/m)
    /// (ε_r = ε/ε₀, μ_r = μ/μ₀).
    pub fn from_absolute(epsilon: f64, mu: f64, sigma: f64) -> Result<Self, OpticsError> {
        check("epsilon", epsilon, epsilon > 0.0, "permittivity must be positive")?;
        check("mu", mu, mu > 0.0, "permeability must be positive")?;
        Self::new(epsilon / EPSILON_0, mu / MU_0, sigma)
    }

    /// ε_r.
    pub fn epsilon_r(&self) -> f64 {
        self.epsilon_r
    }

    /// μ_r.
    pub fn mu_r(&self) -> f64 {
        self.mu_r
    }

    /// σ, S/m.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// The complex index (n', n'') at wavelength `lambda_nm` (in vacuo).
    pub fn complex_index(&self, lambda_nm: f64) -> (f64, f64) {
        // ω = 2πc/λ; seed 000: n = c√(μ(ε + iσ/ω)) = √(μ_r(ε_r + iσ/(ωε₀))).
        let omega = 2.0 * std::f64::consts::PI * SPEED_OF_LIGHT / (lambda_nm * 1e-9);
        let z = Complex::new(self.mu_r * self.epsilon_r, self.mu_r * self.sigma / (omega * EPSILON_0));
        let n = z.sqrt();
        (n.re, n.im)
    }
}

/// An index-of-refraction model. Every variant holds a value validated on construction (see the constructors on
/// `Ior` and on the variant types), so evaluation does not fail for wavelengths in 360–830 nm.
///
/// All methods take wavelengths in nm (in vacuo).
#[derive(Clone, Debug, PartialEq)]
pub enum Ior {
    /// The same index at every wavelength.
    Constant(ConstantIor),
    /// Sellmeier formula.
    Sellmeier(Sellmeier),
    /// Cauchy formula (also what [`Ior::abbe`] builds).
    Cauchy(Cauchy),
    /// Tabulated real index.
    Tabulated(TabulatedIor),
    /// Tabulated complex index n + ik (metals).
    TabulatedComplex(TabulatedComplexIor),
    /// Complex index from ε_r, μ_r, σ (seed 000).
    Conductive(MaterialConstants),
}

impl Ior {
    /// A constant index n > 0.
    pub fn constant(n: f64) -> Result<Self, OpticsError> {
        ConstantIor::new(n).map(Self::Constant)
    }

    /// Sellmeier n² = 1 + A0 + Σ Bᵢλ²/(λ² − Cᵢ), λ in µm, terms `(Bᵢ, Cᵢ (µm²))` (see [`Sellmeier::new`]).
    pub fn sellmeier(a0: f64, terms: &[(f64, f64)]) -> Result<Self, OpticsError> {
        Sellmeier::new(a0, terms).map(Self::Sellmeier)
    }

    /// Cauchy n = A + B/λ² + C/λ⁴, λ in µm (see [`Cauchy::new`]).
    pub fn cauchy(a: f64, b: f64, c: f64) -> Result<Self, OpticsError> {
        Cauchy::new(a, b, c).map(Self::Cauchy)
    }

    /// The two-term Cauchy fit reproducing n_d and V_d exactly (see [`Cauchy::from_abbe`]).
    pub fn abbe(nd: f64, vd: f64) -> Result<Self, OpticsError> {
        Cauchy::from_abbe(nd, vd).map(Self::Cauchy)
    }

    /// Tabulated real index (see [`TabulatedIor::new`]).
    pub fn tabulated(lambdas_nm: Vec<f64>, n: Vec<f64>) -> Result<Self, OpticsError> {
        TabulatedIor::new(lambdas_nm, n).map(Self::Tabulated)
    }

    /// Tabulated complex index (see [`TabulatedComplexIor::new`]).
    pub fn tabulated_complex(lambdas_nm: Vec<f64>, n: Vec<f64>, k: Vec<f64>) -> Result<Self, OpticsError> {
        TabulatedComplexIor::new(lambdas_nm, n, k).map(Self::TabulatedComplex)
    }

    /// Complex index from relative ε_r, μ_r and σ (S/m) (see [`MaterialConstants`]).
    pub fn conductive(epsilon_r: f64, mu_r: f64, sigma: f64) -> Result<Self, OpticsError> {
        MaterialConstants::new(epsilon_r, mu_r, sigma).map(Self::Conductive)
    }

    /// Real part n of the index at `lambda_nm`.
    pub fn n(&self, lambda_nm: f64) -> f64 {
        match self {
            Self::Constant(c) => c.value(),
            Self::Sellmeier(s) => s.n(lambda_nm),
            Self::Cauchy(c) => c.n(lambda_nm),
            Self::Tabulated(t) => t.n(lambda_nm),
            Self::TabulatedComplex(t) => t.n(lambda_nm),
            Self::Conductive(m) => m.complex_index(lambda_nm).0,
        }
    }

    /// Imaginary part (extinction coefficient) k of the index at `lambda_nm`; 0 for the dielectric models.
    pub fn k(&self, lambda_nm: f64) -> f64 {
        match self {
            Self::TabulatedComplex(t) => t.k(lambda_nm),
            Self::Conductive(m) => m.complex_index(lambda_nm).1,
            _ => 0.0,
        }
    }

    /// `(n, k)` at `lambda_nm`.
    pub fn complex(&self, lambda_nm: f64) -> (f64, f64) {
        match self {
            Self::Conductive(m) => m.complex_index(lambda_nm),
            _ => (self.n(lambda_nm), self.k(lambda_nm)),
        }
    }

    /// The index at `lambda_nm` as a [`Complex`] n + ik.
    pub fn complex_value(&self, lambda_nm: f64) -> Complex {
        let (n, k) = self.complex(lambda_nm);
        Complex::new(n, k)
    }

    /// Whether the index may vary with wavelength: false for `Constant`, and also for models whose coefficients make
    /// them constant (Sellmeier with every Bᵢ = 0, Cauchy with B = C = 0, ε/μ/σ with σ = 0); true otherwise.
    pub fn is_dispersive(&self) -> bool {
        match self {
            Self::Constant(_) => false,
            Self::Sellmeier(s) => s.terms.iter().any(|&(b, _)| b != 0.0),
            Self::Cauchy(c) => c.b != 0.0 || c.c != 0.0,
            Self::Tabulated(_) | Self::TabulatedComplex(_) => true,
            Self::Conductive(m) => m.sigma != 0.0,
        }
    }

    /// Whether the model has an imaginary part (metals, conductive media).
    pub fn is_complex(&self) -> bool {
        matches!(self, Self::TabulatedComplex(_) | Self::Conductive(_))
    }

    /// n at the helium d line (587.5618 nm).
    pub fn nd(&self) -> f64 {
        self.n(LAMBDA_D_NM)
    }

    /// Abbe number V_d = (n_d − 1)/(n_F − n_C) (F = 486.1327 nm, C = 656.2725 nm); infinite without dispersion.
    pub fn vd(&self) -> f64 {
        let dn = self.n(LAMBDA_F_NM) - self.n(LAMBDA_C_NM);
        if dn == 0.0 {
            f64::INFINITY
        } else {
            (self.nd() - 1.0) / dn
        }
    }

    /// n(λ) as a spectrum: `Spectrum::Constant` for a constant index, otherwise n tabulated every 1 nm over
    /// 360–830 nm as a piecewise-linear spectrum (zero outside that range, as every `spectral` table is).
    pub fn to_spectrum(&self) -> Spectrum {
        match self {
            Self::Constant(c) => Spectrum::Constant(c.value()),
            _ => tabulate(|l| self.n(l)),
        }
    }

    /// k(λ) as a spectrum, like [`Ior::to_spectrum`]; `Spectrum::Constant(0.0)` for the dielectric models.
    pub fn k_spectrum(&self) -> Spectrum {
        if self.is_complex() {
            tabulate(|l| self.k(l))
        } else {
            Spectrum::Constant(0.0)
        }
    }
}

/// Tabulates `f` every 1 nm over 360–830 nm. Validated models are finite there; should a value still not be, the
/// result falls back to the constant value at the d line rather than panicking.
fn tabulate(f: impl Fn(f64) -> f64) -> Spectrum {
    let lambdas: Vec<f64> = visible_grid().collect();
    let values: Vec<f64> = lambdas.iter().map(|&l| f(l)).collect();
    Spectrum::piecewise_linear(lambdas, values).unwrap_or_else(|_| Spectrum::Constant(f(LAMBDA_D_NM)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// N-BK7 (SCHOTT), `data/glass_sellmeier.csv`.
    fn bk7() -> Ior {
        Ior::sellmeier(0.0, &[(1.03961212, 0.00600069867), (0.231792344, 0.0200179144), (1.01046945, 103.560653)])
            .unwrap()
    }

    #[test]
    fn sellmeier_bk7_matches_schott() {
        let g = bk7();
        assert_relative_eq!(g.nd(), 1.5168, epsilon = 3e-6);
        assert_relative_eq!(g.vd(), 64.17, epsilon = 0.005);
        // Normal dispersion: n falls with λ over the visible.
        assert!(g.n(400.0) > g.n(500.0) && g.n(500.0) > g.n(700.0));
        assert!(g.is_dispersive());
        assert_eq!(g.k(550.0), 0.0);
    }

    #[test]
    fn abbe_reproduces_nd_and_vd_exactly() {
        for &(nd, vd) in &[(1.5168, 64.17), (1.78472, 25.68), (1.333, 55.8), (2.4175, 55.3), (1.9, 18.0)] {
            let g = Ior::abbe(nd, vd).unwrap();
            assert_relative_eq!(g.nd(), nd, epsilon = 1e-12);
            assert_relative_eq!(g.vd(), vd, max_relative = 1e-10);
            let Ior::Cauchy(c) = &g else { panic!("abbe builds a Cauchy model") };
            assert_eq!(c.c(), 0.0);
            assert!(c.b() > 0.0);
        }
    }

    #[test]
    fn abbe_of_bk7_is_close_to_sellmeier_in_the_visible() {
        let s = bk7();
        let a = Ior::abbe(s.nd(), s.vd()).unwrap();
        for l in [450.0, 500.0, 550.0, 600.0, 650.0] {
            assert!((s.n(l) - a.n(l)).abs() < 3e-4, "λ = {l}: {} vs {}", s.n(l), a.n(l));
        }
    }

    #[test]
    fn cauchy_three_terms() {
        let c = Ior::cauchy(1.5, 0.004, 0.0001).unwrap();
        let l = 0.5_f64;
        assert_relative_eq!(c.n(500.0), 1.5 + 0.004 / (l * l) + 0.0001 / l.powi(4), epsilon = 1e-14);
    }

    #[test]
    fn constant_is_not_dispersive() {
        let c = Ior::constant(1.5).unwrap();
        assert!(!c.is_dispersive());
        assert_eq!(c.n(400.0), 1.5);
        assert_eq!(c.vd(), f64::INFINITY);
        assert_eq!(c.to_spectrum(), Spectrum::Constant(1.5));
    }

    #[test]
    fn invalid_parameters_are_rejected_with_their_name() {
        let name_of = |e: OpticsError| match e {
            OpticsError::NotFinite { name, .. } | OpticsError::OutOfRange { name, .. } => name,
            other => panic!("unexpected error {other:?}"),
        };
        assert_eq!(name_of(Ior::constant(f64::NAN).unwrap_err()), "n");
        assert_eq!(name_of(Ior::constant(-1.0).unwrap_err()), "n");
        assert_eq!(name_of(Ior::constant(f64::INFINITY).unwrap_err()), "n");
        assert_eq!(name_of(Ior::sellmeier(0.0, &[(1.0, 0.01), (f64::NAN, 0.02)]).unwrap_err()), "Sellmeier B2");
        assert_eq!(name_of(Ior::sellmeier(0.0, &[(1.0, -0.01)]).unwrap_err()), "Sellmeier C1 (µm²)");
        // A resonance at 500 nm (0.25 µm²) lies inside the visible.
        assert_eq!(name_of(Ior::sellmeier(0.0, &[(1.0, 0.25)]).unwrap_err()), "Sellmeier C1 (µm²)");
        assert_eq!(name_of(Ior::sellmeier(f64::INFINITY, &[]).unwrap_err()), "Sellmeier A0");
        assert_eq!(name_of(Ior::cauchy(1.5, f64::NAN, 0.0).unwrap_err()), "Cauchy B");
        assert!(matches!(Ior::cauchy(-3.0, 0.0, 0.0), Err(OpticsError::OutOfRange { .. })));
        assert_eq!(name_of(Ior::abbe(0.9, 50.0).unwrap_err()), "n_d");
        assert_eq!(name_of(Ior::abbe(1.5, 0.0).unwrap_err()), "V_d");
        assert_eq!(name_of(Ior::abbe(1.5, f64::NAN).unwrap_err()), "V_d");
        assert_eq!(name_of(Ior::conductive(1.0, 1.0, -1.0).unwrap_err()), "sigma");
        assert_eq!(name_of(Ior::conductive(0.0, 1.0, 0.0).unwrap_err()), "epsilon_r");
        assert_eq!(name_of(Ior::conductive(1.0, f64::NAN, 0.0).unwrap_err()), "mu_r");
        assert_eq!(name_of(Ior::tabulated(vec![400.0, 500.0], vec![1.5, -1.0]).unwrap_err()), "n[1]");
        assert_eq!(
            name_of(Ior::tabulated_complex(vec![400.0, 500.0], vec![1.0, 1.0], vec![0.0, -0.1]).unwrap_err()),
            "k[1]"
        );
        assert!(matches!(Ior::tabulated(vec![500.0, 400.0], vec![1.5, 1.5]), Err(OpticsError::BadTable(_))));
        assert!(matches!(Ior::tabulated(vec![500.0], vec![1.5, 1.5]), Err(OpticsError::BadTable(_))));
        assert!(matches!(Ior::tabulated(vec![], vec![]), Err(OpticsError::BadTable(_))));
    }

    #[test]
    fn tabulated_interpolates_and_clamps() {
        let t = Ior::tabulated(vec![400.0, 600.0], vec![1.6, 1.5]).unwrap();
        assert_relative_eq!(t.n(500.0), 1.55, epsilon = 1e-14);
        assert_eq!(t.n(300.0), 1.6);
        assert_eq!(t.n(900.0), 1.5);
        let c = Ior::tabulated_complex(vec![400.0, 600.0], vec![0.2, 0.4], vec![3.0, 4.0]).unwrap();
        assert_eq!(c.complex(500.0), (0.30000000000000004, 3.5));
        assert_eq!(c.k(1000.0), 4.0);
        assert!(c.is_complex() && c.is_dispersive());
    }

    #[test]
    fn to_spectrum_tabulates_every_nm() {
        let g = bk7();
        let Spectrum::PiecewiseLinear(p) = g.to_spectrum() else { panic!("expected a table") };
        assert_eq!(p.lambdas().len(), 471);
        assert_eq!(p.lambdas()[0], 360.0);
        assert_eq!(p.lambdas()[470], 830.0);
        assert_relative_eq!(p.eval(587.0), g.n(587.0), epsilon = 1e-15);
        assert_relative_eq!(p.eval(587.5618), g.nd(), epsilon = 1e-6);
        assert_eq!(g.k_spectrum(), Spectrum::Constant(0.0));
    }

    #[test]
    fn conductive_without_sigma_is_the_real_index() {
        for &(er, mr) in &[(1.0, 1.0), (2.25, 1.0), (4.0, 1.5), (1.7689, 1.0)] {
            let m = MaterialConstants::new(er, mr, 0.0).unwrap();
            for l in [360.0, 550.0, 830.0] {
                let (n, k) = m.complex_index(l);
                assert_relative_eq!(n, (er * mr).sqrt(), epsilon = 1e-14);
                assert_eq!(k, 0.0);
            }
            assert!(!Ior::Conductive(m).is_dispersive());
        }
        // Absolute SI values: c·√(εμ) with ε = 2.25 ε₀ and μ = μ₀ is 1.5.
        let m = MaterialConstants::from_absolute(2.25 * EPSILON_0, MU_0, 0.0).unwrap();
        assert_relative_eq!(m.complex_index(500.0).0, 1.5, epsilon = 1e-12);
        assert_relative_eq!(SPEED_OF_LIGHT * (2.25 * EPSILON_0 * MU_0).sqrt(), 1.5, epsilon = 1e-9);
    }

    #[test]
    fn conductive_matches_the_seed_closed_form() {
        // Seed 000: n = c√(μ/2)(√(√(ε² + σ²λ²/(4π²c²)) + ε) + i√(√(ε² + σ²λ²/(4π²c²)) − ε)), absolute ε and μ.
        let (er, mr, sigma) = (2.0, 1.2, 1.0e4);
        let (eps, mu, c) = (er * EPSILON_0, mr * MU_0, SPEED_OF_LIGHT);
        let m = MaterialConstants::from_absolute(eps, mu, sigma).unwrap();
        for l_nm in [400.0, 550.0, 700.0] {
            let l = l_nm * 1e-9;
            let pi = std::f64::consts::PI;
            let root = (eps * eps + sigma * sigma * l * l / (4.0 * pi * pi * c * c)).sqrt();
            let n1 = c * (mu / 2.0).sqrt() * (root + eps).sqrt();
            let n2 = c * (mu / 2.0).sqrt() * (root - eps).sqrt();
            let (n, k) = m.complex_index(l_nm);
            assert_relative_eq!(n, n1, max_relative = 1e-9);
            assert_relative_eq!(k, n2, max_relative = 1e-6);
        }
    }

    #[test]
    fn conductivity_raises_absorption() {
        let l = 550.0;
        let mut last = -1.0;
        for sigma in [0.0, 1.0, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7] {
            let (_, k) = MaterialConstants::new(2.25, 1.0, sigma).unwrap().complex_index(l);
            assert!(k > last, "σ = {sigma}: n'' = {k} not above {last}");
            last = k;
        }
    }

    #[test]
    fn absorption_grows_with_wavelength_at_fixed_sigma() {
        let m = MaterialConstants::new(2.25, 1.0, 1e3).unwrap();
        let mut last = 0.0;
        for l in (360..=830).step_by(10).map(f64::from) {
            let k = m.complex_index(l).1;
            assert!(k > last);
            last = k;
        }
    }

    #[test]
    fn large_conductivity_gives_anomalous_dispersion() {
        // Seed 000: larger σ ↔ larger n'', and then n' may increase with λ (anomalous dispersion), unlike glass.
        let glass = bk7();
        assert!(glass.n(700.0) < glass.n(400.0));
        let weak = Ior::conductive(2.25, 1.0, 1.0).unwrap();
        let strong = Ior::conductive(2.25, 1.0, 1e6).unwrap();
        // Weak conduction: n' essentially flat (changes well below 1e-6 across the visible).
        assert!((weak.n(700.0) - weak.n(400.0)).abs() < 1e-6);
        // Strong conduction: n' rises markedly with λ, at every step.
        let mut last = 0.0;
        for l in (360..=830).step_by(10).map(f64::from) {
            assert!(strong.n(l) > last);
            last = strong.n(l);
        }
        assert!(strong.n(700.0) - strong.n(400.0) > 0.8);
        assert!(strong.k(550.0) > 1.0);
    }
}
