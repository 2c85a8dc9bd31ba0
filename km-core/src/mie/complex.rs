//! A minimal complex number for Mie theory (the only place km-core needs
//! one): `f64` real and imaginary parts, the four operations, conjugate,
//! modulus and the exponential-free functions the recurrences use.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A complex number `re + i im`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    /// `re + i im`.
    pub const fn new(re: f64, im: f64) -> Complex {
        Complex { re, im }
    }

    /// A real number.
    pub const fn real(re: f64) -> Complex {
        Complex { re, im: 0.0 }
    }

    /// The complex conjugate `re - i im`.
    pub fn conj(self) -> Complex {
        Complex { re: self.re, im: -self.im }
    }

    /// `|z|^2`.
    pub fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }

    /// `|z|`, without overflow for large parts.
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }

    /// `1 / z` (Smith's algorithm: no overflow or underflow of `|z|^2`).
    pub fn recip(self) -> Complex {
        Complex::real(1.0) / self
    }

    /// `z * s` for a real `s`.
    pub fn scale(self, s: f64) -> Complex {
        Complex { re: self.re * s, im: self.im * s }
    }

    /// True when both parts are finite.
    pub fn is_finite(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}

impl Add for Complex {
    type Output = Complex;
    fn add(self, o: Complex) -> Complex {
        Complex { re: self.re + o.re, im: self.im + o.im }
    }
}

impl Sub for Complex {
    type Output = Complex;
    fn sub(self, o: Complex) -> Complex {
        Complex { re: self.re - o.re, im: self.im - o.im }
    }
}

impl Mul for Complex {
    type Output = Complex;
    fn mul(self, o: Complex) -> Complex {
        Complex { re: self.re * o.re - self.im * o.im, im: self.re * o.im + self.im * o.re }
    }
}

impl Div for Complex {
    type Output = Complex;
    /// Smith's (1962) division: scale by the larger part of the divisor.
    fn div(self, o: Complex) -> Complex {
        if o.re.abs() >= o.im.abs() {
            let r = o.im / o.re;
            let d = o.re + o.im * r;
            Complex { re: (self.re + self.im * r) / d, im: (self.im - self.re * r) / d }
        } else {
            let r = o.re / o.im;
            let d = o.re * r + o.im;
            Complex { re: (self.re * r + self.im) / d, im: (self.im * r - self.re) / d }
        }
    }
}

impl Neg for Complex {
    type Output = Complex;
    fn neg(self) -> Complex {
        Complex { re: -self.re, im: -self.im }
    }
}

impl Add<f64> for Complex {
    type Output = Complex;
    fn add(self, o: f64) -> Complex {
        Complex { re: self.re + o, im: self.im }
    }
}

impl Sub<f64> for Complex {
    type Output = Complex;
    fn sub(self, o: f64) -> Complex {
        Complex { re: self.re - o, im: self.im }
    }
}

impl Mul<f64> for Complex {
    type Output = Complex;
    fn mul(self, o: f64) -> Complex {
        self.scale(o)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn division_inverts_multiplication() {
        // Smith's division against the definition, including a divisor with
        // parts near the overflow threshold (|z|^2 would overflow).
        for (a, b) in [
            (Complex::new(1.5, -0.3), Complex::new(0.2, 4.0)),
            (Complex::new(-2.0, 7.0), Complex::new(-3.0, 0.5)),
            (Complex::new(1e300, 1e300), Complex::new(1e300, -2e300)),
        ] {
            let q = a / b;
            let back = q * b;
            let scale = a.abs();
            assert!((back - a).abs() < 1e-15 * scale, "{a:?} / {b:?} = {q:?}");
        }
        assert_eq!(Complex::new(0.0, 2.0).recip(), Complex::new(0.0, -0.5));
    }
}
