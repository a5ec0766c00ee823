//! Spectra as the integrator carries them: a few values at a few wavelengths.

use std::ops::{Add, AddAssign, Div, Index, IndexMut, Mul, MulAssign, Sub};

/// How many wavelengths a path carries at once (the hero wavelength and three rotated companions).
pub const N_WAVELENGTHS: usize = 4;

/// Values of a spectrum at the wavelengths of a [`SampledWavelengths`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampledSpectrum(pub [f32; N_WAVELENGTHS]);

impl SampledSpectrum {
    /// The same value at every wavelength.
    pub const fn splat(v: f32) -> Self {
        Self([v; N_WAVELENGTHS])
    }

    /// Zero everywhere.
    pub const fn zero() -> Self {
        Self::splat(0.0)
    }

    /// True if every value is zero.
    pub fn is_black(&self) -> bool {
        self.0.iter().all(|&v| v == 0.0)
    }

    /// Largest value.
    pub fn max_value(&self) -> f32 {
        self.0.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    }

    /// Mean of the values.
    pub fn average(&self) -> f32 {
        self.0.iter().sum::<f32>() / N_WAVELENGTHS as f32
    }

    /// Applies `f` to each value.
    pub fn map(self, f: impl Fn(f32) -> f32) -> Self {
        Self(self.0.map(f))
    }

    /// Element-wise exponential, e.g. for Beer–Lambert transmittance.
    pub fn exp(self) -> Self {
        self.map(f32::exp)
    }

    /// Division that gives 0 where the divisor is 0 (used for weights over pdfs of dropped wavelengths).
    pub fn safe_div(self, d: Self) -> Self {
        let mut r = self;
        for i in 0..N_WAVELENGTHS {
            r.0[i] = if d.0[i] != 0.0 { self.0[i] / d.0[i] } else { 0.0 };
        }
        r
    }
}

impl Index<usize> for SampledSpectrum {
    type Output = f32;
    fn index(&self, i: usize) -> &f32 {
        &self.0[i]
    }
}

impl IndexMut<usize> for SampledSpectrum {
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut self.0[i]
    }
}

macro_rules! elementwise {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for SampledSpectrum {
            type Output = Self;
            fn $f(self, o: Self) -> Self {
                let mut r = self;
                for i in 0..N_WAVELENGTHS {
                    r.0[i] = self.0[i] $op o.0[i];
                }
                r
            }
        }
        impl $tr<f32> for SampledSpectrum {
            type Output = Self;
            fn $f(self, o: f32) -> Self {
                self.map(|v| v $op o)
            }
        }
    };
}
elementwise!(Add, add, +);
elementwise!(Sub, sub, -);
elementwise!(Mul, mul, *);
elementwise!(Div, div, /);

impl AddAssign for SampledSpectrum {
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl MulAssign for SampledSpectrum {
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}

impl MulAssign<f32> for SampledSpectrum {
    fn mul_assign(&mut self, o: f32) {
        *self = *self * o;
    }
}

/// The wavelengths a path carries, with the effective density of each.
///
/// The image estimate of a path with radiance values `L` is `Σᵢ L[i] · w(λᵢ) / pdf[i]` over the active slots, where
/// `w` is the film's colour matching function. `pdf` therefore already includes the strategy's stratification: it is
/// `N · p(λᵢ)` for `hero` (the average over N rotated samples), the in-band density for `rgb` (one stratum per
/// band), and `p(λ)` for `cmf`. A slot with `pdf == 0` is inactive (dropped at a dispersive event).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    lambda: [f32; N_WAVELENGTHS],
    pdf: [f32; N_WAVELENGTHS],
}

impl SampledWavelengths {
    /// Builds a set from wavelengths (nm) and effective densities; slots with density 0 are inactive.
    pub fn new(lambda: [f32; N_WAVELENGTHS], pdf: [f32; N_WAVELENGTHS]) -> Self {
        Self { lambda, pdf }
    }

    /// Wavelength of slot `i`, in nm.
    pub fn lambda(&self, i: usize) -> f32 {
        self.lambda[i]
    }

    /// All wavelengths, in nm (inactive slots keep their last value).
    pub fn lambdas(&self) -> [f32; N_WAVELENGTHS] {
        self.lambda
    }

    /// Effective densities as a spectrum (0 for inactive slots).
    pub fn pdf(&self) -> SampledSpectrum {
        SampledSpectrum(self.pdf)
    }

    /// True if slot `i` still contributes to the image.
    pub fn is_active(&self, i: usize) -> bool {
        self.pdf[i] > 0.0
    }

    /// Number of active slots.
    pub fn active_count(&self) -> usize {
        self.pdf.iter().filter(|&&p| p > 0.0).count()
    }

    /// True once at most one wavelength remains (after a dispersive event, or for single-wavelength strategies).
    pub fn is_single(&self) -> bool {
        self.active_count() <= 1
    }

    /// Keeps one wavelength for a dispersive event and drops the others.
    ///
    /// The survivor is chosen uniformly among the active slots with `u ∈ [0, 1)`; its density is multiplied by the
    /// selection probability 1/k, so the estimator stays unbiased (seed 000's Russian roulette over bands with pdf
    /// 1/3 for `rgb`; pbrt-v4's `TerminateSecondary` for `hero`). Returns the index of the kept slot.
    pub fn terminate_secondary(&mut self, u: f32) -> usize {
        let k = self.active_count();
        if k == 0 {
            return 0;
        }
        let pick = ((u * k as f32) as usize).min(k - 1);
        let slot = (0..N_WAVELENGTHS).filter(|&i| self.pdf[i] > 0.0).nth(pick).unwrap_or(0);
        self.keep_only(slot);
        slot
    }

    /// Keeps slot `slot` (which the caller chose uniformly among the k active slots) and drops the others,
    /// dividing its density by k (no-op when at most one slot is active).
    pub fn keep_only(&mut self, slot: usize) {
        let k = self.active_count();
        if k <= 1 {
            return;
        }
        for i in 0..N_WAVELENGTHS {
            if i != slot {
                self.pdf[i] = 0.0;
            }
        }
        self.pdf[slot] /= k as f32;
    }

    /// The wavelengths of one branch of a split path: slot `slot` alone, with its density unchanged (every active
    /// slot gets its own branch, so none is selected and no 1/k enters; see [`Self::keep_only`] for selection).
    pub fn branch(&self, slot: usize) -> Self {
        let mut b = *self;
        for i in 0..N_WAVELENGTHS {
            if i != slot {
                b.pdf[i] = 0.0;
            }
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terminate_secondary_keeps_one_and_scales_its_density() {
        let mut wl = SampledWavelengths::new([400.0, 500.0, 600.0, 700.0], [4.0, 4.0, 4.0, 4.0]);
        let keep = wl.terminate_secondary(0.6);
        assert_eq!(keep, 2);
        assert!(wl.is_single());
        assert_eq!(wl.pdf().0, [0.0, 0.0, 1.0, 0.0]);
        // A second termination changes nothing.
        assert_eq!(wl.terminate_secondary(0.1), 2);
        assert_eq!(wl.pdf().0, [0.0, 0.0, 1.0, 0.0]);
        // A branch keeps one slot at its full density.
        let wl = SampledWavelengths::new([400.0, 500.0, 600.0, 700.0], [4.0, 3.0, 2.0, 1.0]);
        let b = wl.branch(1);
        assert!(b.is_single() && b.is_active(1));
        assert_eq!(b.pdf().0, [0.0, 3.0, 0.0, 0.0]);
        assert_eq!(b.lambda(1), 500.0);
    }

    #[test]
    fn arithmetic_is_elementwise() {
        let a = SampledSpectrum([1.0, 2.0, 3.0, 4.0]);
        let b = SampledSpectrum([2.0, 2.0, 0.0, 1.0]);
        assert_eq!((a * b).0, [2.0, 4.0, 0.0, 4.0]);
        assert_eq!((a + b).0, [3.0, 4.0, 3.0, 5.0]);
        assert_eq!(a.safe_div(b).0, [0.5, 1.0, 0.0, 4.0]);
        assert_eq!(a.max_value(), 4.0);
        assert_eq!(a.average(), 2.5);
    }
}
