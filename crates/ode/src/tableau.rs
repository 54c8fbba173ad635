//! Rosenbrock tableaus in the transformed form the integrator uses, and the
//! two methods offered: RODAS4 and ROS34PW2.
//!
//! One step of an s-stage Rosenbrock(-W) method with the matrix
//! `W = I/(hγ) − A` (A = ∂f/∂y for a classical Rosenbrock method, any
//! approximation of it for a W-method) is, in the variables of Hairer &
//! Wanner, *Solving ODEs II*, §IV.7, eq. (7.8)–(7.9):
//! ```text
//!   W u_i = f(t0 + c_i h, y0 + Σ_{j<i} a_ij u_j) + Σ_{j<i} (γc_ij / h) u_j + h d_i f_t
//!   y1 = y0 + Σ m_j u_j ,      error estimate  e = Σ (m_j − m̂_j) u_j
//! ```
//! From a method given as (α_ij, γ_ij, b_j, b̂_j) (α strictly lower, Γ = (γ_ij)
//! lower triangular with γ on its diagonal) the transformed coefficients are
//! `a = αΓ⁻¹`, `γc = diag(1/γ) − Γ⁻¹`, `m = bΓ⁻¹`, `m̂ = b̂Γ⁻¹`,
//! `c_i = Σ_j α_ij`, `d_i = Σ_j γ_ij`.
//!
//! - **RODAS4** (Hairer & Wanner 1996, §IV.7): 6 stages, order 4(3), stiffly
//!   accurate, L-stable; needs the exact Jacobian at every step for its
//!   order. Its coefficients are published already transformed (`rodas4.rs`);
//!   its dense output is its own continuous extension of order 3.
//! - **ROS34PW2** (J. Rang & L. Angermann, "New Rosenbrock W-methods of order
//!   3 for partial differential algebraic equations of index 1", BIT Numer.
//!   Math. 45 (2005) 761–787, Table "ROS34PW2"): 4 stages, order 3(2),
//!   stiffly accurate, L-stable, and a **W-method**: its order holds for any
//!   matrix A, so a Jacobian may be reused over many steps and the matrices
//!   of quadratures left out. Dense output: the cubic Hermite interpolant of
//!   y0, y1, f(y0), f(y1) (order 3, continuous with continuous derivative).

use crate::rodas4 as r4;

/// How a method interpolates inside a step.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum DenseKind {
    /// RODAS4's continuous extension: q1 = Σ e1_j u_j, q2 = Σ e2_j u_j (j < 5).
    Rodas { e1: Vec<f64>, e2: Vec<f64> },
    /// Cubic Hermite from y0, y1 and the derivatives at both ends.
    Hermite,
}

/// A Rosenbrock tableau in transformed form (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Tableau {
    pub name: &'static str,
    pub stages: usize,
    pub gamma: f64,
    /// Stage abscissae c_i.
    pub c: Vec<f64>,
    /// Coefficients d_i of h·f_t.
    pub d: Vec<f64>,
    /// a_ij (row i, j < i).
    pub a: Vec<Vec<f64>>,
    /// γc_ij (row i, j < i), divided by h in the stage equations.
    pub gc: Vec<Vec<f64>>,
    /// Solution weights m_j.
    pub m: Vec<f64>,
    /// Error weights m_j − m̂_j.
    pub e: Vec<f64>,
    /// Exponent of the step-size controller: 1/(embedded order + 1).
    pub err_exponent: f64,
    /// Whether the method keeps its order with an inexact Jacobian.
    pub w_method: bool,
    pub dense: DenseKind,
}

impl Tableau {
    pub(crate) fn rodas4() -> Tableau {
        let a = vec![
            vec![],
            vec![r4::A21],
            vec![r4::A31, r4::A32],
            vec![r4::A41, r4::A42, r4::A43],
            vec![r4::A51, r4::A52, r4::A53, r4::A54],
            // stage 6 is evaluated at the embedded solution: stage-5 argument + u5
            vec![r4::A51, r4::A52, r4::A53, r4::A54, 1.0],
        ];
        let gc = vec![
            vec![],
            vec![r4::C21],
            vec![r4::C31, r4::C32],
            vec![r4::C41, r4::C42, r4::C43],
            vec![r4::C51, r4::C52, r4::C53, r4::C54],
            vec![r4::C61, r4::C62, r4::C63, r4::C64, r4::C65],
        ];
        // y1 = stage-6 argument + u6 (order 4), ŷ1 = stage-6 argument (order 3): e = u6
        let m = vec![r4::A51, r4::A52, r4::A53, r4::A54, 1.0, 1.0];
        let e = vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        Tableau {
            name: "RODAS4 (Hairer-Wanner), Rosenbrock order 4(3), L-stable, dense output order 3",
            stages: 6,
            gamma: r4::GAMMA,
            c: r4::C.to_vec(),
            d: vec![r4::D[0], r4::D[1], r4::D[2], r4::D[3], 0.0, 0.0],
            a,
            gc,
            m,
            e,
            err_exponent: r4::ERR_EXPONENT,
            w_method: false,
            dense: DenseKind::Rodas { e1: r4::E1.to_vec(), e2: r4::E2.to_vec() },
        }
    }

    /// ROS34PW2 from its published (α, Γ, b, b̂) by the transformation above.
    #[allow(clippy::excessive_precision)]
    pub(crate) fn ros34pw2() -> Tableau {
        let g = 4.3586652150845900e-01;
        let alpha = [
            [0.0, 0.0, 0.0, 0.0],
            [8.7173304301691801e-01, 0.0, 0.0, 0.0],
            [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ];
        let gamma = [
            [g, 0.0, 0.0, 0.0],
            [-8.7173304301691801e-01, g, 0.0, 0.0],
            [-9.0338057013044082e-01, 5.4180672388095326e-02, g, 0.0],
            [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, g],
        ];
        let b = [2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, 4.3586652150845900e-01];
        let b_hat = [3.7810903145819369e-01, -9.6042292212423178e-02, 5.0000000000000000e-01, 2.1793326075422950e-01];
        Self::from_original(
            "ROS34PW2 (Rang-Angermann), Rosenbrock-W order 3(2), L-stable, Hermite dense output",
            &alpha,
            &gamma,
            &b,
            &b_hat,
        )
    }

    /// Transform a method given as (α, Γ, b, b̂) (HW II (7.8)–(7.9)).
    fn from_original(name: &'static str, alpha: &[[f64; 4]; 4], gamma: &[[f64; 4]; 4], b: &[f64; 4], b_hat: &[f64; 4]) -> Tableau {
        let s = 4;
        let g = gamma[0][0];
        // Γ⁻¹ by forward substitution (Γ lower triangular)
        let mut inv = [[0.0; 4]; 4];
        for col in 0..s {
            for i in 0..s {
                let mut v = if i == col { 1.0 } else { 0.0 };
                for k in 0..i {
                    v -= gamma[i][k] * inv[k][col];
                }
                inv[i][col] = v / gamma[i][i];
            }
        }
        let row_times_inv = |row: &[f64]| -> Vec<f64> { (0..s).map(|j| (0..s).map(|k| row[k] * inv[k][j]).sum()).collect() };
        let a: Vec<Vec<f64>> = (0..s).map(|i| row_times_inv(&alpha[i])[..i].to_vec()).collect();
        let gc: Vec<Vec<f64>> = (0..s).map(|i| (0..i).map(|j| -inv[i][j]).collect()).collect();
        let m = row_times_inv(b);
        let m_hat = row_times_inv(b_hat);
        Tableau {
            name,
            stages: s,
            gamma: g,
            c: (0..s).map(|i| alpha[i].iter().sum()).collect(),
            d: (0..s).map(|i| gamma[i].iter().sum()).collect(),
            a,
            gc,
            e: m.iter().zip(&m_hat).map(|(x, y)| x - y).collect(),
            m,
            err_exponent: 1.0 / 3.0,
            w_method: true,
            dense: DenseKind::Hermite,
        }
    }
}

#[cfg(test)]
#[allow(clippy::excessive_precision)]
mod tests {
    use super::*;

    #[test]
    fn ros34pw2_transformation_is_consistent() {
        let t = Tableau::ros34pw2();
        // stiffly accurate: the last stage argument plus γ·(its u) is the solution,
        // i.e. m_j = a_4j for j < 4 and m_4 = 1 (HW II, §IV.7)
        for j in 0..3 {
            assert!((t.m[j] - t.a[3][j]).abs() < 1e-12, "m{j} {} a4{j} {}", t.m[j], t.a[3][j]);
        }
        assert!((t.m[3] - 1.0).abs() < 1e-12, "{}", t.m[3]);
        assert_eq!(t.c, vec![0.0, 8.7173304301691801e-01, 8.4457060015369423e-01 - 1.1299064236484185e-01, 1.0]);
        // Γ row sums: d_1 = γ, d_4 = Σγ_4j = b sum − 1 + γ... the consistency Σ b_j = 1
        let b_sum: f64 = [2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, 4.3586652150845900e-01].iter().sum();
        assert!((b_sum - 1.0).abs() < 1e-12);
    }
}
