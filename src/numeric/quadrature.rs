//! Gauss-Legendre quadrature.
//!
//! # Formula
//!
//! `integral_a^b f = (b-a)/2 sum_i w_i f((a+b)/2 + (b-a)/2 x_i)` with `x_i`
//! the roots of the Legendre polynomial `P_n` and
//! `w_i = 2 / ((1 - x_i^2) P_n'(x_i)^2)`; exact for polynomials of degree
//! `2n - 1`.
//!
//! ```
//! use hbis::numeric::quadrature::GaussLegendre;
//! let gl = GaussLegendre::new(8);
//! let i = gl.integrate(0.0, std::f64::consts::PI, f64::sin);
//! assert!((i - 2.0).abs() < 1e-12);
//! ```

/// An `n`-point Gauss-Legendre rule on `[-1, 1]`.
#[derive(Debug, Clone)]
pub struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    /// Nodes and weights by Newton iteration on `P_n` from Chebyshev guesses.
    pub fn new(n: usize) -> Self {
        let n = n.max(1);
        let mut nodes = Vec::with_capacity(n);
        let mut weights = Vec::with_capacity(n);
        for i in 0..n {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                // P_n(x) and P_n'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let kf = k as f64;
                    let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                    p0 = p1;
                    p1 = p2;
                }
                let pn = if n == 1 { x } else { p1 };
                let pm = if n == 1 { 1.0 } else { p0 };
                dp = n as f64 * (x * pn - pm) / (x * x - 1.0);
                let dx = pn / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            nodes.push(x);
            weights.push(2.0 / ((1.0 - x * x) * dp * dp));
        }
        Self { nodes, weights }
    }

    /// Integral of `f` over `[a, b]`.
    pub fn integrate(&self, a: f64, b: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
        let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
        h * self
            .nodes
            .iter()
            .zip(&self.weights)
            .map(|(&x, &w)| w * f(m + h * x))
            .sum::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_for_polynomials_of_degree_2n_minus_1() {
        for n in 1..20 {
            let gl = GaussLegendre::new(n);
            let d = 2 * n - 1;
            let i = gl.integrate(0.0, 1.0, |x| x.powi(d as i32));
            assert!((i - 1.0 / (d as f64 + 1.0)).abs() < 1e-14, "n={n}");
        }
    }
}
