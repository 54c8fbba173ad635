//! Coefficients of the Rosenbrock method RODAS4 (6 stages, order 4, embedded
//! order 3, stiffly accurate, L-stable) in the Hairer–Wanner "transformed" form.
//!
//! Source: E. Hairer & G. Wanner, *Solving Ordinary Differential Equations II*,
//! 2nd ed., Springer 1996, §IV.7 ("Implementation of Rosenbrock-type methods",
//! method RODAS), with the numerical values as published in the authors' Fortran
//! code `rodas.f` (coefficient set METH = 1) and reproduced in W. H. Press et al.,
//! *Numerical Recipes*, 3rd ed., §17.5.1 (stepper "StepperRoss"). The values were
//! checked against several public transcriptions of that table.
//!
//! With `J = ∂f/∂y(t0, y0)`, `f_t = ∂f/∂t(t0, y0)` and `γ = 1/4`, one step of size `h` is
//! ```text
//!   (I/(hγ) − J) u_i = f(t0 + c_i h, y0 + Σ_{j<i} a_ij u_j) + Σ_{j<i} (c_ij / h) u_j + h d_i f_t ,  i = 1..6
//!   ŷ1 = y0 + Σ_{j<5} a_5j u_j + u_5      (3rd order; equals the argument of stage 6)
//!   y1 = ŷ1 + u_6                         (4th order; u_6 is the local error estimate)
//! ```
//! Stage 6 reuses the argument of stage 5 plus `u_5`, and stages 5 and 6 have
//! `c = 1` and no `f_t` term (`d_5 = d_6 = 0`).
//!
//! Dense output (order 3), with `θ = (t − t0)/h`:
//! ```text
//!   y(t0 + θh) ≈ (1 − θ) y0 + θ [ y1 + (1 − θ)(q1 + θ q2) ],
//!   q1 = Σ_{j≤5} e1_j u_j ,  q2 = Σ_{j≤5} e2_j u_j .
//! ```

// The published digits are kept verbatim (some exceed f64 precision).
#![allow(clippy::excessive_precision)]

/// Diagonal coefficient γ.
pub const GAMMA: f64 = 0.25;

/// Stage abscissae c_i (fractions of h), stages 1..6.
pub const C: [f64; 6] = [0.0, 0.386, 0.21, 0.63, 1.0, 1.0];

/// Coefficients d_i = γ_i multiplying h·f_t, stages 1..4 (zero for 5 and 6).
pub const D: [f64; 4] = [0.25, -0.1043, 0.1035, -0.3620000000000023e-01];

/// Stage-argument coefficients a_ij (row i = stage 2..5, j < i).
pub const A21: f64 = 0.1544000000000000e+01;
pub const A31: f64 = 0.9466785280815826e+00;
pub const A32: f64 = 0.2557011698983284e+00;
pub const A41: f64 = 0.3314825187068521e+01;
pub const A42: f64 = 0.2896124015972201e+01;
pub const A43: f64 = 0.9986419139977817e+00;
pub const A51: f64 = 0.1221224509226641e+01;
pub const A52: f64 = 0.6019134481288629e+01;
pub const A53: f64 = 0.1253708332932087e+02;
pub const A54: f64 = -0.6878860361058950e+00;

/// Coupling coefficients c_ij (divided by h in the stage equations).
pub const C21: f64 = -0.5668800000000000e+01;
pub const C31: f64 = -0.2430093356833875e+01;
pub const C32: f64 = -0.2063599157091915e+00;
pub const C41: f64 = -0.1073529058151375e+00;
pub const C42: f64 = -0.9594562251023355e+01;
pub const C43: f64 = -0.2047028614809616e+02;
pub const C51: f64 = 0.7496443313967647e+01;
pub const C52: f64 = -0.1024680431464352e+02;
pub const C53: f64 = -0.3399990352819905e+02;
pub const C54: f64 = 0.1170890893206160e+02;
pub const C61: f64 = 0.8083246795921522e+01;
pub const C62: f64 = -0.7981132988064893e+01;
pub const C63: f64 = -0.3152159432874371e+02;
pub const C64: f64 = 0.1631930543123136e+02;
pub const C65: f64 = -0.6058818238834054e+01;

/// Dense-output coefficients e1_j (for q1), j = 1..5.
pub const E1: [f64; 5] =
    [0.1012623508344586e+02, -0.7487995877610167e+01, -0.3480091861555747e+02, -0.7992771707568823e+01, 0.1025137723295662e+01];

/// Dense-output coefficients e2_j (for q2), j = 1..5.
pub const E2: [f64; 5] =
    [-0.6762803392801253e+00, 0.6087714651680015e+01, 0.1643084320892478e+02, 0.2476722511418386e+02, -0.6594389125716872e+01];

/// Order of the embedded (error-estimating) solution plus one: the local error
/// estimate behaves like h^4, which sets the controller exponent 1/4.
pub const ERR_EXPONENT: f64 = 0.25;

#[cfg(test)]
mod tests {
    //! Checks the transcribed table against the Rosenbrock order conditions
    //! (Hairer & Wanner II, §IV.7, order conditions up to order 4) after converting it back to the
    //! original form: Γ⁻¹ = I/γ − (c_ij), α = A·Γ, bᵀ = mᵀ·Γ, β = α + Γ.
    use super::*;

    type M = [[f64; 6]; 6];

    fn inverse_lower(l: &M) -> M {
        // Forward substitution column by column for a lower-triangular matrix.
        let mut inv = [[0.0; 6]; 6];
        for c in 0..6 {
            for r in 0..6 {
                let mut s = if r == c { 1.0 } else { 0.0 };
                for k in 0..r {
                    s -= l[r][k] * inv[k][c];
                }
                inv[r][c] = s / l[r][r];
            }
        }
        inv
    }

    fn mul(a: &M, b: &M) -> M {
        let mut p = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                p[i][j] = (0..6).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        p
    }

    struct Original {
        alpha: M,
        gam: M,
        b: [f64; 6],
        b_hat: [f64; 6],
    }

    fn original() -> Original {
        let c: M = [
            [0.0; 6],
            [C21, 0.0, 0.0, 0.0, 0.0, 0.0],
            [C31, C32, 0.0, 0.0, 0.0, 0.0],
            [C41, C42, C43, 0.0, 0.0, 0.0],
            [C51, C52, C53, C54, 0.0, 0.0],
            [C61, C62, C63, C64, C65, 0.0],
        ];
        let mut ginv = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                ginv[i][j] = if i == j { 1.0 / GAMMA } else { -c[i][j] };
            }
        }
        let gam = inverse_lower(&ginv);
        let a: M = [
            [0.0; 6],
            [A21, 0.0, 0.0, 0.0, 0.0, 0.0],
            [A31, A32, 0.0, 0.0, 0.0, 0.0],
            [A41, A42, A43, 0.0, 0.0, 0.0],
            [A51, A52, A53, A54, 0.0, 0.0],
            [A51, A52, A53, A54, 1.0, 0.0],
        ];
        let alpha = mul(&a, &gam);
        let m = [A51, A52, A53, A54, 1.0, 1.0];
        let m_hat = [A51, A52, A53, A54, 1.0, 0.0];
        let mut b = [0.0; 6];
        let mut b_hat = [0.0; 6];
        for j in 0..6 {
            b[j] = (0..6).map(|i| m[i] * gam[i][j]).sum();
            b_hat[j] = (0..6).map(|i| m_hat[i] * gam[i][j]).sum();
        }
        Original { alpha, gam, b, b_hat }
    }

    /// Residuals of the conditions up to `order` for weights `b`.
    fn residuals(o: &Original, b: &[f64; 6], order: usize) -> Vec<f64> {
        let g = GAMMA;
        let al: Vec<f64> = (0..6).map(|i| o.alpha[i].iter().sum()).collect();
        // β strictly lower.
        let mut beta = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..i {
                beta[i][j] = o.alpha[i][j] + o.gam[i][j];
            }
        }
        let bp: Vec<f64> = (0..6).map(|i| beta[i].iter().sum()).collect();
        let dot = |v: &dyn Fn(usize) -> f64| (0..6).map(|i| b[i] * v(i)).sum::<f64>();
        let mut r = vec![dot(&|_| 1.0) - 1.0];
        if order >= 2 {
            r.push(dot(&|i| bp[i]) - (0.5 - g));
        }
        if order >= 3 {
            r.push(dot(&|i| al[i] * al[i]) - 1.0 / 3.0);
            r.push(dot(&|i| (0..6).map(|k| beta[i][k] * bp[k]).sum()) - (1.0 / 6.0 - g + g * g));
        }
        if order >= 4 {
            r.push(dot(&|i| al[i].powi(3)) - 0.25);
            r.push(dot(&|i| al[i] * (0..6).map(|k| o.alpha[i][k] * bp[k]).sum::<f64>()) - (1.0 / 8.0 - g / 3.0));
            r.push(dot(&|i| (0..6).map(|k| beta[i][k] * al[k] * al[k]).sum()) - (1.0 / 12.0 - g / 3.0));
            r.push(
                dot(&|i| (0..6).map(|k| beta[i][k] * (0..6).map(|l| beta[k][l] * bp[l]).sum::<f64>()).sum())
                    - (1.0 / 24.0 - g / 2.0 + 1.5 * g * g - g * g * g),
            );
        }
        r
    }

    #[test]
    fn abscissae_and_gamma_sums_match_table() {
        let o = original();
        for i in 0..6 {
            let a: f64 = o.alpha[i].iter().sum();
            assert!((a - C[i]).abs() < 1e-12, "alpha_{} = {a}", i + 1);
        }
        for i in 0..4 {
            let gi: f64 = o.gam[i].iter().sum();
            assert!((gi - D[i]).abs() < 1e-12, "gamma_{} = {gi}", i + 1);
        }
    }

    #[test]
    fn order_conditions_hold() {
        let o = original();
        for (k, r) in residuals(&o, &o.b, 4).iter().enumerate() {
            assert!(r.abs() < 1e-12, "order-4 condition {k}: residual {r}");
        }
        for (k, r) in residuals(&o, &o.b_hat, 3).iter().enumerate() {
            assert!(r.abs() < 1e-12, "embedded order-3 condition {k}: residual {r}");
        }
        // The embedded solution is genuinely of lower order (otherwise the error estimate is void).
        let r4 = residuals(&o, &o.b_hat, 4);
        assert!(r4[4..].iter().any(|r| r.abs() > 1e-3));
    }

    #[test]
    fn dense_output_interpolates_end_points() {
        // θ = 1 must reproduce y1 whatever q1, q2 are (structure), and the formula's
        // derivative at θ = 0 must be consistent: Σ (e1_j) weights produce h·f0 for
        // y' = const (u_j = h·γ·f for all stages when J = 0, f constant).
        // With f ≡ v constant and J = 0: u_1 = hγ v, u_i = hγ (v + Σ c_ij u_j / h).
        let mut u = [0.0_f64; 6];
        let c = [[0.0; 5], [C21, 0.0, 0.0, 0.0, 0.0], [C31, C32, 0.0, 0.0, 0.0], [C41, C42, C43, 0.0, 0.0], [C51, C52, C53, C54, 0.0]];
        let (h, v) = (0.1, 1.0);
        for i in 0..5 {
            let s: f64 = (0..i).map(|j| c[i][j] * u[j]).sum();
            u[i] = h * GAMMA * (v + s / h);
        }
        let q1: f64 = (0..5).map(|j| E1[j] * u[j]).sum();
        let q2: f64 = (0..5).map(|j| E2[j] * u[j]).sum();
        // Exact solution is linear, so the interpolant's quadratic/cubic parts vanish.
        assert!(q1.abs() < 1e-12 && q2.abs() < 1e-12, "q1 = {q1}, q2 = {q2}");
    }
}
