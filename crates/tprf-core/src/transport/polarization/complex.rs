//! The few complex operations the Fresnel amplitudes of conductors need.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A complex number `re + i im`, single precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Complex {
    pub re: f32,
    pub im: f32,
}

impl Complex {
    pub const fn new(re: f32, im: f32) -> Complex {
        Complex { re, im }
    }

    pub const fn real(re: f32) -> Complex {
        Complex { re, im: 0.0 }
    }

    pub fn conj(self) -> Complex {
        Complex::new(self.re, -self.im)
    }

    /// `|z|^2`.
    pub fn norm_sqr(self) -> f32 {
        self.re * self.re + self.im * self.im
    }

    /// The principal square root (non-negative real part; for a negative real `z` the
    /// root on the positive imaginary axis).
    pub fn sqrt(self) -> Complex {
        let n = self.norm_sqr().sqrt();
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        if t1 == 0.0 {
            return Complex::real(0.0);
        }
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Complex::new(t1, t2)
        } else {
            Complex::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

impl Add for Complex {
    type Output = Complex;
    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }
}

impl Sub for Complex {
    type Output = Complex;
    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }
}

impl Neg for Complex {
    type Output = Complex;
    fn neg(self) -> Complex {
        Complex::new(-self.re, -self.im)
    }
}

impl Mul for Complex {
    type Output = Complex;
    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}

impl Mul<f32> for Complex {
    type Output = Complex;
    fn mul(self, s: f32) -> Complex {
        Complex::new(self.re * s, self.im * s)
    }
}

impl Div for Complex {
    type Output = Complex;
    fn div(self, o: Complex) -> Complex {
        let d = o.norm_sqr();
        let n = self * o.conj();
        Complex::new(n.re / d, n.im / d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_root_squares_back_on_every_quadrant() {
        for (re, im) in [
            (4.0f32, 0.0f32),
            (-4.0, 0.0),
            (-4.0, -0.0),
            (3.0, 4.0),
            (-3.0, 4.0),
            (-3.0, -4.0),
            (0.0, 2.0),
        ] {
            let z = Complex::new(re, im);
            let r = z.sqrt();
            let back = r * r;
            assert!(r.re >= 0.0, "{z:?}: principal root {r:?}");
            assert!(
                (back.re - re).abs() < 1e-5 && (back.im - im).abs() < 1e-5,
                "{z:?}: {r:?} squared is {back:?}"
            );
        }
        let q = Complex::new(1.0, 2.0) / Complex::new(3.0, -1.0);
        let b = q * Complex::new(3.0, -1.0);
        assert!((b.re - 1.0).abs() < 1e-6 && (b.im - 2.0).abs() < 1e-6);
    }
}
