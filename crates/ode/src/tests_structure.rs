//! Tests of the declared-structure path: Jacobians stored sparse, filled by
//! grouped differences or by the system, factored by the sparse LU for large
//! systems; and of the event window that merges near-simultaneous roots.
//!
//! Test problem: the one-dimensional Brusselator with diffusion ("BRUSS",
//! Hairer & Wanner, *Solving ODEs II*, §IV.1, eq. 1.6′) on N interior points,
//! states interleaved (u₁, v₁, u₂, v₂, …) so the Jacobian is banded, with an
//! optional trailing quadrature ∫Σuᵢ dt whose row is full.

use crate::*;

struct Bruss {
    n_points: usize,
    /// Declare the structure.
    structured: bool,
    /// Fill the Jacobian analytically (requires `structured`).
    exact: bool,
    /// Append the quadrature ∫Σuᵢ dt.
    quadrature: bool,
    /// Report a wrong structure (for the error test).
    wrong: bool,
}

const ALPHA: f64 = 1.0 / 50.0;

impl Bruss {
    fn new(n_points: usize) -> Bruss {
        Bruss { n_points, structured: false, exact: false, quadrature: false, wrong: false }
    }
    fn c(&self) -> f64 {
        ALPHA * ((self.n_points + 1) as f64).powi(2)
    }
    fn initial(&self) -> Vec<f64> {
        let mut y = Vec::new();
        for i in 0..self.n_points {
            let x = (i + 1) as f64 / (self.n_points + 1) as f64;
            y.push(1.0 + (2.0 * std::f64::consts::PI * x).sin());
            y.push(3.0);
        }
        if self.quadrature {
            y.push(0.0);
        }
        y
    }
    fn columns(&self) -> Vec<Vec<usize>> {
        let n = self.n_points;
        let q = 2 * n;
        (0..2 * n)
            .map(|k| {
                let i = k / 2;
                let mut rows = vec![2 * i, 2 * i + 1];
                if i > 0 {
                    rows.push(k - 2);
                }
                if i + 1 < n {
                    rows.push(k + 2);
                }
                if self.quadrature && k % 2 == 0 {
                    rows.push(q);
                }
                rows
            })
            .collect()
    }
}

impl OdeSystem for Bruss {
    fn dim(&self) -> usize {
        2 * self.n_points + usize::from(self.quadrature)
    }
    fn rhs(&mut self, _t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
        let (n, c) = (self.n_points, self.c());
        for i in 0..n {
            let (u, v) = (y[2 * i], y[2 * i + 1]);
            let (ul, vl) = if i == 0 { (1.0, 3.0) } else { (y[2 * i - 2], y[2 * i - 1]) };
            let (ur, vr) = if i + 1 == n { (1.0, 3.0) } else { (y[2 * i + 2], y[2 * i + 3]) };
            d[2 * i] = 1.0 + u * u * v - 4.0 * u + c * (ul - 2.0 * u + ur);
            d[2 * i + 1] = 3.0 * u - u * u * v + c * (vl - 2.0 * v + vr);
        }
        if self.quadrature {
            d[2 * n] = (0..n).map(|i| y[2 * i]).sum();
        }
        Ok(())
    }
    fn n_quadrature(&self) -> usize {
        usize::from(self.quadrature)
    }
    fn autonomous(&self) -> bool {
        true
    }
    fn jacobian_sparsity(&self) -> Option<Sparsity> {
        if !self.structured {
            return None;
        }
        let mut cols = self.columns();
        if self.wrong {
            cols.pop();
        }
        Some(Sparsity::from_columns(self.dim(), &cols).expect("structure"))
    }
    fn jacobian(&mut self, _t: f64, y: &[f64], _f0: &[f64], _deltas: &[f64], values: &mut [f64]) -> Result<bool, RhsError> {
        if !self.exact {
            return Ok(false);
        }
        let p = self.jacobian_sparsity().expect("structured");
        let c = self.c();
        for k in 0..p.n_columns() {
            let i = k / 2;
            let (u, v) = (y[2 * i], y[2 * i + 1]);
            for (e, &r) in p.column_range(k).zip(p.column(k)) {
                values[e] = match (k % 2, r) {
                    (_, r) if r == 2 * self.n_points => 1.0, // quadrature row, u columns only
                    (0, r) if r == k => 2.0 * u * v - 4.0 - 2.0 * c,
                    (0, r) if r == k + 1 => 3.0 - 2.0 * u * v,
                    (1, r) if r == k - 1 => u * u,
                    (1, r) if r == k => -u * u - 2.0 * c,
                    _ => c, // neighbour, same species
                };
            }
        }
        Ok(true)
    }
}

fn run(sys: &mut Bruss, t_end: f64) -> (Vec<f64>, Stats, &'static str) {
    let y0 = sys.initial();
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-7, 1e-9, y0.len()), y0.len());
    let (mut t, mut y) = (0.0, y0);
    let r = int.advance(sys, &mut t, &mut y, t_end, &mut |_| {}).expect("bruss");
    assert_eq!(r, Advance::Reached);
    (y, int.stats(), int.linear_algebra())
}

/// Evaluations not spent on stages (5 new ones per attempted RODAS4 step), step
/// ends (1 per accepted step) or the start (f at t0 and the initial-step probe).
fn jacobian_evaluations(s: Stats) -> usize {
    s.rhs_evals - 5 * (s.steps + s.rejected) - s.steps - 2
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

#[test]
fn grouped_differences_and_sparse_lu_agree_with_the_dense_path() {
    let (y_dense, s_dense, la_dense) = run(&mut Bruss::new(40), 10.0);
    let (y_sparse, s_sparse, la_sparse) = run(&mut Bruss { structured: true, ..Bruss::new(40) }, 10.0);
    assert_eq!((la_dense, la_sparse), ("dense", "sparse"));
    // same method, Jacobians equal up to difference noise: same solution to well within tolerance
    assert!(max_diff(&y_dense, &y_sparse) < 1e-6, "{}", max_diff(&y_dense, &y_sparse));
    assert!(s_sparse.steps.abs_diff(s_dense.steps) <= s_dense.steps / 20 + 2);
    // the interleaved band groups into 4 (u_i with v_{i+2}: no common row)
    // instead of 80 columns
    assert_eq!(jacobian_evaluations(s_sparse), 4 * s_sparse.jacobians);
    assert_eq!(jacobian_evaluations(s_dense), 80 * s_dense.jacobians);
}

#[test]
fn a_jacobian_filled_by_the_system_is_used_with_its_quadrature_rows() {
    let (y_dense, s_dense, _) = run(&mut Bruss { quadrature: true, ..Bruss::new(40) }, 10.0);
    let mut exact = Bruss { structured: true, exact: true, quadrature: true, ..Bruss::new(40) };
    let (y_exact, s_exact, la) = run(&mut exact, 10.0);
    assert_eq!(la, "sparse");
    assert!(max_diff(&y_dense[..80], &y_exact[..80]) < 1e-6, "{}", max_diff(&y_dense, &y_exact));
    // the quadrature (∫Σu ≈ 40·10·O(1)) agrees to the integration tolerance
    assert!((y_dense[80] - y_exact[80]).abs() < 1e-6 * y_dense[80].abs(), "{} vs {}", y_dense[80], y_exact[80]);
    // no evaluation of f is spent on the Jacobian
    assert_eq!(jacobian_evaluations(s_exact), 0);
    assert!(s_dense.rhs_evals > 10 * s_exact.rhs_evals);
}

#[test]
fn a_small_structured_system_uses_a_dense_lu() {
    let (y_dense, _, _) = run(&mut Bruss::new(5), 5.0);
    let (y_small, _, la) = run(&mut Bruss { structured: true, ..Bruss::new(5) }, 5.0);
    assert_eq!(la, "structured");
    assert!(max_diff(&y_dense, &y_small) < 1e-6);
}

#[test]
fn a_structure_of_the_wrong_size_is_an_error() {
    let mut sys = Bruss { structured: true, wrong: true, ..Bruss::new(5) };
    let y0 = sys.initial();
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-8, y0.len()), y0.len());
    let (mut t, mut y) = (0.0, y0);
    let e = int.advance(&mut sys, &mut t, &mut y, 1.0, &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("Jacobian structure is 10×9"), "{e}");
}

/// Two roots of y' = 1: g₀ = y − 1 and g₁ = y − (1 + gap).
struct TwoThresholds {
    gap: f64,
}

impl OdeSystem for TwoThresholds {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&mut self, _t: f64, _y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
        d[0] = 1.0;
        Ok(())
    }
    fn n_roots(&self) -> usize {
        2
    }
    fn roots(&mut self, _t: f64, y: &[f64], g: &mut [f64]) -> Result<(), RhsError> {
        g[0] = y[0] - 1.0;
        g[1] = y[0] - (1.0 + self.gap);
        Ok(())
    }
}

#[test]
fn roots_within_the_event_window_are_one_event() {
    let first_stop = |window: f64| {
        let opts = Options { root_tol: 1e-13, event_window: window, h_max: 0.3, ..Options::with_tolerances(1e-8, 1e-10, 1) };
        let mut int = Rosenbrock::new(opts, 1);
        let (mut t, mut y) = (0.0, vec![0.0]);
        let r = int.advance(&mut TwoThresholds { gap: 4e-10 }, &mut t, &mut y, 2.0, &mut |_| {}).unwrap();
        (r, t)
    };
    let (separate, t_sep) = first_stop(0.0);
    assert_eq!(separate, Advance::Root { indices: vec![0] });
    assert!((1.0..1.0 + 4e-10).contains(&t_sep));
    let (merged, t_merged) = first_stop(1e-9);
    assert_eq!(merged, Advance::Root { indices: vec![0, 1] });
    // past both, and no later than the window allows
    assert!((1.0 + 4e-10..=1.0 + 1e-9 + 1e-12).contains(&t_merged), "{t_merged}");
    // roots further apart than the window stay separate
    let opts = Options { root_tol: 1e-13, event_window: 1e-9, h_max: 0.3, ..Options::with_tolerances(1e-8, 1e-10, 1) };
    let mut int = Rosenbrock::new(opts, 1);
    let (mut t, mut y) = (0.0, vec![0.0]);
    let r = int.advance(&mut TwoThresholds { gap: 1e-6 }, &mut t, &mut y, 2.0, &mut |_| {}).unwrap();
    assert_eq!(r, Advance::Root { indices: vec![0] });
}
