//! A minimal complex number, just enough for the complex index of refraction, conductor Fresnel and the Mie series.

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub, SubAssign};

/// A complex number `re + i·im` in `f64`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    /// `re + i·im`.
    pub const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }

    /// The real number `re + 0i`.
    pub const fn from_real(re: f64) -> Self {
        Self { re, im: 0.0 }
    }

    /// Squared modulus `re² + im²`.
    pub fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }

    /// Modulus `|z|`, computed without overflow (`hypot`).
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }

    /// Complex conjugate `re − i·im`.
    pub fn conj(self) -> Self {
        Self::new(self.re, -self.im)
    }

    /// `e^{iφ} = cos φ + i·sin φ`, the unit complex number at angle `phi` (radians).
    pub fn cis(phi: f64) -> Self {
        let (s, c) = phi.sin_cos();
        Self::new(c, s)
    }

    /// Reciprocal `1/z = conj(z)/|z|²` (infinite or NaN parts for `z = 0`, like `1.0/0.0`).
    pub fn inv(self) -> Self {
        let d = self.norm_sqr();
        Self::new(self.re / d, -self.im / d)
    }

    /// Cosine: cos(a + ib) = cos a·cosh b − i·sin a·sinh b.
    pub fn cos(self) -> Self {
        let (s, c) = self.re.sin_cos();
        Self::new(c * self.im.cosh(), -s * self.im.sinh())
    }

    /// Sine: sin(a + ib) = sin a·cosh b + i·cos a·sinh b.
    pub fn sin(self) -> Self {
        let (s, c) = self.re.sin_cos();
        Self::new(s * self.im.cosh(), c * self.im.sinh())
    }

    /// Principal square root, by the closed form of seed 000 (Frisvad, "Dispersion and Spectral Rendering"):
    /// √(a+ib) = √((|z|+a)/2) + i·sgn(b)·√((|z|−a)/2).
    ///
    /// `sgn(b)` is taken from the sign bit of `b` with `+0` counting as positive, so √(−4 + 0i) = 2i (the principal
    /// branch, real part ≥ 0); the seed's formula with sgn(0) = 0 would lose the imaginary part of negative reals.
    pub fn sqrt(self) -> Self {
        let m = self.abs();
        // max(0, …) guards against |z| − a being a rounding error below zero.
        let re = ((m + self.re) * 0.5).max(0.0).sqrt();
        let im = ((m - self.re) * 0.5).max(0.0).sqrt();
        Self::new(re, im.copysign(self.im))
    }
}

impl From<f64> for Complex {
    fn from(re: f64) -> Self {
        Self::from_real(re)
    }
}

impl Add for Complex {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
}

impl Sub for Complex {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
}

impl Mul for Complex {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Self::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
}

impl Mul<f64> for Complex {
    type Output = Self;
    fn mul(self, s: f64) -> Self {
        Self::new(self.re * s, self.im * s)
    }
}

impl Mul<Complex> for f64 {
    type Output = Complex;
    fn mul(self, z: Complex) -> Complex {
        z * self
    }
}

impl Div<f64> for Complex {
    type Output = Self;
    fn div(self, s: f64) -> Self {
        Self::new(self.re / s, self.im / s)
    }
}

impl AddAssign for Complex {
    fn add_assign(&mut self, o: Self) {
        self.re += o.re;
        self.im += o.im;
    }
}

impl SubAssign for Complex {
    fn sub_assign(&mut self, o: Self) {
        self.re -= o.re;
        self.im -= o.im;
    }
}

impl Div for Complex {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        // z/w = z·conj(w)/|w|².
        let d = o.norm_sqr();
        let n = self * o.conj();
        Self::new(n.re / d, n.im / d)
    }
}

impl Neg for Complex {
    type Output = Self;
    fn neg(self) -> Self {
        Self::new(-self.re, -self.im)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn sqrt_squares_back_and_takes_principal_branch() {
        for &(a, b) in &[(3.0, 4.0), (-3.0, 4.0), (-3.0, -4.0), (2.0, -0.5), (0.0, 1.0), (1e-3, 7.0)] {
            let z = Complex::new(a, b);
            let r = z.sqrt();
            let back = r * r;
            assert_relative_eq!(back.re, a, epsilon = 1e-12);
            assert_relative_eq!(back.im, b, epsilon = 1e-12);
            assert!(r.re >= 0.0);
        }
        assert_eq!(Complex::new(3.0, 4.0).sqrt(), Complex::new(2.0, 1.0));
        assert_eq!(Complex::new(-4.0, 0.0).sqrt(), Complex::new(0.0, 2.0));
        assert_eq!(Complex::new(4.0, 0.0).sqrt(), Complex::new(2.0, 0.0));
    }

    #[test]
    fn arithmetic() {
        let z = Complex::new(1.0, 2.0);
        let w = Complex::new(-0.5, 3.0);
        let q = (z * w) / w;
        assert_relative_eq!(q.re, 1.0, epsilon = 1e-14);
        assert_relative_eq!(q.im, 2.0, epsilon = 1e-14);
        assert_eq!(z + w - w, z);
        assert_eq!(-z, Complex::new(-1.0, -2.0));
        assert_eq!(z.norm_sqr(), 5.0);
        let r = z * z.inv();
        assert_relative_eq!(r.re, 1.0, epsilon = 1e-15);
        assert_relative_eq!(r.im, 0.0, epsilon = 1e-15);
        assert_eq!(2.0 * z, z * 2.0);
        assert_eq!((z * 2.0) / 2.0, z);
        let mut acc = z;
        acc += w;
        acc -= z;
        assert_eq!(acc, w);
        let c = Complex::cis(std::f64::consts::FRAC_PI_2);
        assert_relative_eq!(c.re, 0.0, epsilon = 1e-16);
        assert_eq!(c.im, 1.0);
    }

    #[test]
    fn cosine_and_sine_of_complex_arguments() {
        // cos² + sin² = 1, and cos(ib) = cosh b, sin(ib) = i·sinh b, and the reals agree with f64's.
        for &(a, b) in &[(0.3, 0.0), (1.2, -0.7), (-2.5, 3.0), (0.0, 1.5)] {
            let z = Complex::new(a, b);
            let (c, s) = (z.cos(), z.sin());
            let one = c * c + s * s;
            assert_relative_eq!(one.re, 1.0, epsilon = 1e-12);
            assert_relative_eq!(one.im, 0.0, epsilon = 1e-12);
            // cos z = (e^{iz} + e^{−iz})/2 with e^{iz} = e^{−b}·cis(a).
            let e = Complex::cis(a) * (-b).exp();
            let f = Complex::cis(-a) * b.exp();
            assert_relative_eq!(c.re, 0.5 * (e.re + f.re), epsilon = 1e-12);
            assert_relative_eq!(c.im, 0.5 * (e.im + f.im), epsilon = 1e-12);
        }
        assert_eq!(Complex::new(0.3, 0.0).cos().re, 0.3f64.cos());
        assert_eq!(Complex::new(0.0, 1.5).sin(), Complex::new(0.0, 1.5f64.sinh()));
    }
}
