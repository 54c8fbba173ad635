//! Time responses of ẋ = A x + B u, y = C x + D u from x(0) = 0, by the
//! exact discretisation of the system for an input held over each step
//! (zero-order hold): with the matrix exponential
//! exp([A B; 0 0]·h) = [Φ Γ; 0 I], x_{k+1} = Φ x_k + Γ u_k — exact at the
//! sample instants for a step input, whatever the step h.
//!
//! The exponential is computed by scaling and squaring with a Taylor
//! polynomial (Moler & Van Loan 2003, method 3): the matrix is halved until
//! its norm is below 1/2, the series is summed to 20 terms (truncation
//! below 1e-20 relative), then squared back.

use crate::{LinearError, Matrix};

/// exp(M).
pub fn expm(m: &Matrix) -> Result<Matrix, LinearError> {
    m.check_finite("matrix")?;
    let n = m.rows();
    let norm = (0..n).map(|i| m.row(i).iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max);
    let squarings = if norm > 0.5 { (norm / 0.5).log2().ceil() as i32 } else { 0 };
    if squarings > 1000 {
        return Err(LinearError::Shape(format!("matrix norm {norm:e} too large for exp")));
    }
    let mut scaled = m.clone();
    let f = 0.5f64.powi(squarings);
    for i in 0..n {
        for j in 0..n {
            scaled[(i, j)] *= f;
        }
    }
    let mut sum = Matrix::identity(n);
    let mut term = Matrix::identity(n);
    for k in 1..=20 {
        term = term.mul(&scaled);
        let inv = 1.0 / k as f64;
        for i in 0..n {
            for j in 0..n {
                term[(i, j)] *= inv;
                sum[(i, j)] += term[(i, j)];
            }
        }
    }
    for _ in 0..squarings {
        sum = sum.mul(&sum);
    }
    Ok(sum)
}

/// Outputs at t = 0, h, 2h, … (`samples` of them) after a unit step of
/// input `input` at t = 0 from x = 0: `out[k]` holds the p outputs at t = k h.
pub fn step(a: &Matrix, b: &Matrix, c: &Matrix, d: &Matrix, input: usize, h: f64, samples: usize) -> Result<Vec<Vec<f64>>, LinearError> {
    let n = a.rows();
    if input >= b.cols() {
        return Err(LinearError::Shape(format!("no input {input} (the system has {})", b.cols())));
    }
    let mut aug = Matrix::zeros(n + 1, n + 1);
    for i in 0..n {
        for j in 0..n {
            aug[(i, j)] = a[(i, j)] * h;
        }
        aug[(i, n)] = b[(i, input)] * h;
    }
    let e = expm(&aug)?;
    let mut x = vec![0.0; n];
    let mut out = Vec::with_capacity(samples);
    for _ in 0..samples {
        out.push((0..c.rows()).map(|i| c.row(i).iter().zip(&x).map(|(p, q)| p * q).sum::<f64>() + d[(i, input)]).collect());
        let next: Vec<f64> = (0..n).map(|i| (0..n).map(|j| e[(i, j)] * x[j]).sum::<f64>() + e[(i, n)]).collect();
        x = next;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_of_a_rotation_and_a_decay() {
        let t = 0.7;
        let r = expm(&Matrix::from_rows(&[vec![0.0, t], vec![-t, 0.0]]).unwrap()).unwrap();
        assert!((r[(0, 0)] - t.cos()).abs() < 1e-15 && (r[(0, 1)] - t.sin()).abs() < 1e-15);
        let big = expm(&Matrix::from_rows(&[vec![-30.0]]).unwrap()).unwrap();
        assert!((big[(0, 0)] / (-30f64).exp() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn step_of_a_first_order_lag_is_exact_at_the_samples() {
        let a = Matrix::from_rows(&[vec![-2.0]]).unwrap();
        let b = Matrix::from_rows(&[vec![2.0]]).unwrap();
        let y = step(&a, &b, &Matrix::identity(1), &Matrix::zeros(1, 1), 0, 0.1, 11).unwrap();
        for (k, yk) in y.iter().enumerate() {
            let t = k as f64 * 0.1;
            assert!((yk[0] - (1.0 - (-2.0 * t).exp())).abs() < 1e-14, "t = {t}");
        }
    }
}
