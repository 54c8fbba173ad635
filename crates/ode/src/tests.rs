//! Integration tests of the RODAS4 integrator: convergence order, stiff
//! benchmarks (Robertson, Van der Pol μ = 1000, Prothero–Robinson), L-stability,
//! dense output, root location and error reporting.
//!
//! Reference values: Robertson at t = 1e5 from SciPy 1.17 `solve_ivp` with the
//! Radau, BDF and LSODA methods at rtol = 1e-13, atol = (1e-17, 1e-21, 1e-17) and
//! exact Jacobian (the three agree to 1e-11 relative); Van der Pol likewise (see
//! the test). All other references are closed-form solutions.

use crate::*;

/// Closure-based system for tests.
struct Sys<F, G = RootFn>
where
    F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), RhsError>,
    G: FnMut(f64, &[f64], &mut [f64]),
{
    n: usize,
    f: F,
    m: usize,
    g: Option<G>,
}

impl<F, G> OdeSystem for Sys<F, G>
where
    F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), RhsError>,
    G: FnMut(f64, &[f64], &mut [f64]),
{
    fn dim(&self) -> usize {
        self.n
    }
    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) -> Result<(), RhsError> {
        (self.f)(t, y, dydt)
    }
    fn n_roots(&self) -> usize {
        self.m
    }
    fn roots(&mut self, t: f64, y: &[f64], g: &mut [f64]) -> Result<(), RhsError> {
        if let Some(g_fn) = self.g.as_mut() {
            g_fn(t, y, g);
        }
        Ok(())
    }
}

fn plain<F>(n: usize, f: F) -> Sys<F>
where
    F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), RhsError>,
{
    Sys { n, f, m: 0, g: None }
}

fn no_obs() -> impl FnMut(&dyn Dense) {
    |_: &dyn Dense| {}
}

// ---------------------------------------------------------------- problems

/// Nonstiff, nonlinear, non-autonomous; exact solution below.
/// y1' = −y1² (1/(1+t)), y2' = −y2 + sin t + cos t (sin t), y3' = y3 (1 − y3) (1/(1 + e^{−t})).
fn smooth_rhs(t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
    d[0] = -y[0] * y[0];
    d[1] = -y[1] + t.sin() + t.cos();
    d[2] = y[2] * (1.0 - y[2]);
    Ok(())
}

fn smooth_exact(t: f64) -> [f64; 3] {
    [1.0 / (1.0 + t), t.sin(), 1.0 / (1.0 + (-t).exp())]
}

fn robertson(_t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
    d[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
    d[2] = 3e7 * y[1] * y[1];
    d[1] = -d[0] - d[2];
    Ok(())
}

/// Van der Pol oscillator x'' − μ(1 − x²)x' + x = 0 (MATLAB's `vdp1000` form).
const MU: f64 = 1000.0;
fn van_der_pol(_t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
    d[0] = y[1];
    d[1] = MU * (1.0 - y[0] * y[0]) * y[1] - y[0];
    Ok(())
}

const G: f64 = 9.81;
fn ball(_t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
    d[0] = y[1];
    d[1] = -G;
    Ok(())
}

fn max_err(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

// ---------------------------------------------------------------- order

/// Fixed-step run of the smooth problem on [0, 2]; returns (error at t = 2, max dense error at step midpoints).
fn fixed_step_errors(h: f64) -> (f64, f64) {
    let mut sys = plain(3, smooth_rhs);
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-6, 3), 3);
    int.set_fixed_step(Some(h));
    let mut t = 0.0;
    let mut y = smooth_exact(0.0).to_vec();
    let mut dense_err: f64 = 0.0;
    let mut buf = [0.0; 3];
    let r = int
        .advance(&mut sys, &mut t, &mut y, 2.0, &mut |d: &dyn Dense| {
            let tm = 0.5 * (d.t_start() + d.t_end());
            d.eval(tm, &mut buf);
            dense_err = dense_err.max(max_err(&buf, &smooth_exact(tm)));
        })
        .expect("fixed-step run");
    assert_eq!(r, Advance::Reached);
    assert_eq!(t, 2.0);
    (max_err(&y, &smooth_exact(2.0)), dense_err)
}

#[test]
fn fixed_step_convergence_order_is_four() {
    let hs = [0.2, 0.1, 0.05, 0.025];
    let errs: Vec<(f64, f64)> = hs.iter().map(|&h| fixed_step_errors(h)).collect();
    for k in 1..hs.len() {
        let p = (errs[k - 1].0 / errs[k].0).log2();
        eprintln!("h = {:6.3}: err = {:.3e}, observed order {p:.2}", hs[k], errs[k].0);
        assert!(p >= 4.0 - 0.3, "observed order {p} between h = {} and {}", hs[k - 1], hs[k]);
        // Dense output is of order 3 (local error O(h^4)).
        let pd = (errs[k - 1].1 / errs[k].1).log2();
        eprintln!("   dense midpoint err = {:.3e}, observed order {pd:.2}", errs[k].1);
        assert!(pd >= 3.0 - 0.3, "dense output order {pd}");
    }
}

#[test]
fn tolerance_sweep_error_is_proportional() {
    // Adaptive mode: the global error must fall with the tolerance, roughly like it.
    let mut prev: Option<(f64, usize)> = None;
    for &tol in &[1e-4, 1e-6, 1e-8, 1e-10] {
        let mut sys = plain(3, smooth_rhs);
        let mut int = Rosenbrock::new(Options::with_tolerances(tol, tol, 3), 3);
        let mut t = 0.0;
        let mut y = smooth_exact(0.0).to_vec();
        int.advance(&mut sys, &mut t, &mut y, 5.0, &mut no_obs()).expect("run");
        let err = max_err(&y, &smooth_exact(5.0));
        let steps = int.stats().steps;
        eprintln!("tol {tol:e}: err {err:.3e}, steps {steps}");
        assert!(err < 20.0 * tol, "tol {tol}: error {err}");
        if let Some((e_prev, s_prev)) = prev {
            assert!(err < e_prev, "error did not decrease");
            // Order 4 → steps grow by about 100^(1/4) ≈ 3.2 per factor 100 of tolerance.
            let ratio = steps as f64 / s_prev as f64;
            assert!(ratio > 1.8 && ratio < 6.0, "step ratio {ratio}");
        }
        prev = Some((err, steps));
    }
}

// ---------------------------------------------------------------- stiff problems

#[test]
fn robertson_to_1e5_matches_reference() {
    let reference = [0.0178659211422, 7.27475146849e-8, 0.982134006110];
    let mut sys = plain(3, robertson);
    let opts = Options { rtol: 1e-6, atol: vec![1e-10, 1e-14, 1e-10], ..Options::default() };
    let mut int = Rosenbrock::new(opts, 3);
    let mut t = 0.0;
    let mut y = vec![1.0, 0.0, 0.0];
    let r = int.advance(&mut sys, &mut t, &mut y, 1e5, &mut no_obs()).expect("Robertson");
    assert_eq!(r, Advance::Reached);
    assert_eq!(t, 1e5);
    let s = int.stats();
    eprintln!("Robertson rtol 1e-6: y = {y:?}, stats {s:?}");
    for i in 0..3 {
        let rel = (y[i] - reference[i]).abs() / reference[i];
        assert!(rel < 1e-4, "component {i}: {} vs {} (rel {rel:e})", y[i], reference[i]);
    }
    // Mass conservation (the method is linear-invariant preserving).
    assert!((y.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert!(s.steps < 500, "{} steps", s.steps);
}

#[test]
fn van_der_pol_mu_1000_is_cheap_and_accurate() {
    let mut sys = plain(2, van_der_pol);
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-6, 2), 2);
    let mut t = 0.0;
    let mut y = vec![2.0, 0.0];
    int.advance(&mut sys, &mut t, &mut y, 3000.0, &mut no_obs()).expect("Van der Pol");
    let s = int.stats();
    eprintln!("Van der Pol mu=1000 rtol 1e-6: y = {y:?}, stats {s:?}");
    assert!(s.steps < 2000, "{} steps", s.steps);
    // SciPy Radau and LSODA at rtol = atol = 1e-12 agree on y1(3000) = −1.5106069362 ± 5e-10
    // (slow phase of the second cycle, where y1' ≈ 1e-3).
    let reference = [-1.5106069362];
    assert!((y[0] - reference[0]).abs() < 1e-4 * reference[0].abs(), "y1 = {} vs {}", y[0], reference[0]);
}

#[test]
fn prothero_robinson_l_stability() {
    // y' = −λ (y − cos t), y(0) = 0, λ = 1e6: exact y = A cos t + B sin t − A e^{−λt},
    // A = λ²/(1+λ²), B = λ/(1+λ²).
    let lam = 1e6;
    let a = lam * lam / (1.0 + lam * lam);
    let b = lam / (1.0 + lam * lam);
    let exact = |t: f64| a * t.cos() + b * t.sin() - a * (-lam * t).exp();
    let f = move |t: f64, y: &[f64], d: &mut [f64]| -> Result<(), RhsError> {
        d[0] = -lam * (y[0] - t.cos());
        Ok(())
    };
    // Fixed steps with hλ = 1e5: an L-stable method damps the initial transient
    // (amplitude 1) by R(−1e5) = O(1e-5) per step; a merely A-stable one
    // (|R(∞)| = 1) would carry an O(1) oscillation along.
    let mut sys = plain(1, f);
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-9, 1), 1);
    int.set_fixed_step(Some(0.1));
    let mut t = 0.0;
    let mut y = vec![0.0];
    let mut errs = Vec::new();
    let mut buf = [0.0];
    int.advance(&mut sys, &mut t, &mut y, 10.0, &mut |d: &dyn Dense| {
        d.eval(d.t_end(), &mut buf);
        errs.push((buf[0] - exact(d.t_end())).abs());
    })
    .expect("fixed");
    let worst_later = errs[2..].iter().cloned().fold(0.0, f64::max);
    eprintln!("Prothero-Robinson fixed h = 0.1: step errors {:.2e}, {:.2e}, then ≤ {worst_later:.2e}", errs[0], errs[1]);
    assert_eq!(errs.len(), 100);
    assert!(errs[0] < 1e-3, "first step error {}", errs[0]);
    assert!(errs[1] < 1e-6, "second step error {}", errs[1]);
    assert!(worst_later < 1e-7, "worst error {worst_later}");

    // Adaptive: large steps after the transient, accurate to tolerance.
    let mut sys = plain(1, f);
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-9, 1), 1);
    let mut t = 0.0;
    let mut y = vec![0.0];
    let mut worst: f64 = 0.0;
    int.advance(&mut sys, &mut t, &mut y, 10.0, &mut |d: &dyn Dense| {
        d.eval(d.t_end(), &mut buf);
        worst = worst.max((buf[0] - exact(d.t_end())).abs());
    })
    .expect("adaptive");
    let s = int.stats();
    eprintln!("Prothero-Robinson adaptive: worst {worst:.3e}, {s:?}");
    assert!(worst < 1e-5, "worst error {worst}");
    assert!(s.steps < 300, "{} steps", s.steps);
}

#[test]
fn stability_function_vanishes_at_infinity() {
    // y' = −1e12 y, one step of h = 1: y1/y0 = R(−1e12) ≈ 0 for an L-stable method.
    let mut sys = plain(1, |_t, y: &[f64], d: &mut [f64]| {
        d[0] = -1e12 * y[0];
        Ok(())
    });
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-9, 1), 1);
    int.set_fixed_step(Some(1.0));
    let mut t = 0.0;
    let mut y = vec![1.0];
    int.advance(&mut sys, &mut t, &mut y, 1.0, &mut no_obs()).expect("step");
    assert!(y[0].abs() < 1e-9, "R(-1e12) = {}", y[0]);
}

// ---------------------------------------------------------------- dense output

#[test]
fn dense_output_is_continuous_and_accurate() {
    // Harmonic oscillator y = (cos t, −sin t) over ~3 periods.
    let mut sys = plain(2, |_t, y: &[f64], d: &mut [f64]| {
        d[0] = y[1];
        d[1] = -y[0];
        Ok(())
    });
    let rtol = 1e-6;
    let mut int = Rosenbrock::new(Options::with_tolerances(rtol, 1e-9, 2), 2);
    let mut t = 0.0;
    let mut y = vec![1.0, 0.0];
    let mut prev_end: Option<(f64, [f64; 2])> = None;
    let mut jump: f64 = 0.0;
    let mut worst: f64 = 0.0;
    let mut calls = 0;
    let mut buf = [0.0; 2];
    for &t_out in &[7.0, 20.0] {
        int.advance(&mut sys, &mut t, &mut y, t_out, &mut |d: &dyn Dense| {
            calls += 1;
            d.eval(d.t_start(), &mut buf);
            if let Some((te, ye)) = prev_end {
                assert_eq!(te, d.t_start(), "steps must tile the time axis");
                jump = jump.max(max_err(&buf, &ye));
            }
            for k in 0..=8 {
                let ts = d.t_start() + (d.t_end() - d.t_start()) * k as f64 / 8.0;
                d.eval(ts, &mut buf);
                worst = worst.max(max_err(&buf, &[ts.cos(), -ts.sin()]));
            }
            d.eval(d.t_end(), &mut buf);
            prev_end = Some((d.t_end(), buf));
        })
        .expect("oscillator");
        assert_eq!(t, t_out);
        // The last dense output ends exactly at the returned state.
        let (te, ye) = prev_end.expect("observer called");
        assert_eq!(te, t);
        assert_eq!(ye.to_vec(), y);
    }
    eprintln!("oscillator: {calls} steps, max jump {jump:e}, max dense error {worst:.3e}");
    assert_eq!(calls, int.stats().steps);
    assert!(jump <= 1e-15, "discontinuity {jump}");
    // Global error after ~3 periods at rtol 1e-6 (tolerance-proportional).
    assert!(worst < 20.0 * rtol, "dense error {worst}");
}

// ---------------------------------------------------------------- roots

type RhsFn = fn(f64, &[f64], &mut [f64]) -> Result<(), RhsError>;
type RootFn = fn(f64, &[f64], &mut [f64]);

fn ball_system(m: usize, g: RootFn) -> Sys<RhsFn> {
    Sys { n: 2, f: ball, m, g: Some(g) }
}

#[test]
fn falling_ball_hits_ground_at_exact_time() {
    let mut sys = ball_system(1, |_t, y, g| g[0] = y[0]);
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 2), 2);
    let mut t = 0.0;
    let mut y = vec![10.0, 0.0];
    let mut last_dense_end = f64::NAN;
    let r = int
        .advance(&mut sys, &mut t, &mut y, 5.0, &mut |d: &dyn Dense| {
            last_dense_end = d.t_end();
        })
        .expect("ball");
    let t_hit = (20.0 / G).sqrt();
    assert_eq!(r, Advance::Root { indices: vec![0] });
    assert!((t - t_hit).abs() < 1e-9, "t = {t}, exact {t_hit}");
    assert!(y[0] <= 0.0 && y[0] > -1e-7, "height {} must be on the new side", y[0]);
    assert_eq!(last_dense_end, t, "observer output truncated at the root");

    // Bounce: reverse velocity with restitution 0.8, clamp height to 0 (a zero at
    // the start must not count), and find the next impact.
    let v = -0.8 * y[1];
    y[0] = 0.0;
    y[1] = v;
    int.reset();
    let t0 = t;
    let r = int.advance(&mut sys, &mut t, &mut y, 5.0, &mut no_obs()).expect("second flight");
    assert_eq!(r, Advance::Root { indices: vec![0] });
    let expected = t0 + 2.0 * v / G;
    assert!((t - expected).abs() < 1e-9, "t = {t}, expected {expected}");
    assert!(y[0] <= 0.0);
}

#[test]
fn oscillator_root_located_to_tolerance() {
    // x = cos t crosses zero at π/2; the smooth (non-polynomial) solution tests
    // the dense output and the Illinois iteration together.
    let mut sys = Sys {
        n: 2,
        f: |_t, y: &[f64], d: &mut [f64]| {
            d[0] = y[1];
            d[1] = -y[0];
            Ok(())
        },
        m: 1,
        g: Some(|_t: f64, y: &[f64], g: &mut [f64]| g[0] = y[0]),
    };
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-10, 1e-12, 2), 2);
    let mut t = 0.0;
    let mut y = vec![1.0, 0.0];
    let r = int.advance(&mut sys, &mut t, &mut y, 3.0, &mut no_obs()).expect("oscillator");
    assert_eq!(r, Advance::Root { indices: vec![0] });
    let e = t - std::f64::consts::FRAC_PI_2;
    eprintln!("cos root error {e:e}");
    assert!(e.abs() < 1e-9, "root error {e}");
    assert!(y[0] <= 0.0);
}

#[test]
fn simultaneous_roots_are_all_reported() {
    // g0: height; g1: t − t_hit (same instant); g2: height − 20 (never);
    // g3: velocity (zero at the start, so its immediate sign change is ignored).
    let mut sys = ball_system(4, |t, y, g| {
        g[0] = y[0];
        g[1] = t - (20.0 / G).sqrt();
        g[2] = y[0] - 20.0;
        g[3] = y[1];
    });
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 2), 2);
    let mut t = 0.0;
    let mut y = vec![10.0, 0.0];
    let r = int.advance(&mut sys, &mut t, &mut y, 5.0, &mut no_obs()).expect("ball");
    assert_eq!(r, Advance::Root { indices: vec![0, 1] });
    assert!(t >= (20.0 / G).sqrt(), "returned point on the new side of g1");
}

/// A system with declared root directions (the wrapped one keeps the default).
struct Directed<S> {
    inner: S,
    directions: Vec<RootDirection>,
}

impl<S: OdeSystem> OdeSystem for Directed<S> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) -> Result<(), RhsError> {
        self.inner.rhs(t, y, dydt)
    }
    fn n_roots(&self) -> usize {
        self.inner.n_roots()
    }
    fn roots(&mut self, t: f64, y: &[f64], g: &mut [f64]) -> Result<(), RhsError> {
        self.inner.roots(t, y, g)
    }
    fn root_directions(&self, out: &mut [RootDirection]) {
        out.copy_from_slice(&self.directions);
    }
}

/// y' = 1 from y = 0 at t = 0, one root function g = y − level.
fn ramp(level: f64, direction: RootDirection) -> Directed<impl OdeSystem> {
    let inner = Sys {
        n: 1,
        f: |_t, _y: &[f64], d: &mut [f64]| {
            d[0] = 1.0;
            Ok(())
        },
        m: 1,
        g: Some(move |_t: f64, y: &[f64], g: &mut [f64]| g[0] = y[0] - level),
    };
    Directed { inner, directions: vec![direction] }
}

#[test]
fn threshold_at_the_restart_point_is_not_missed() {
    // Cause of the stuck-piston defect: a caller restarts with a root function at
    // exactly zero that is about to become positive (a held piston whose applied
    // force equals its breakaway level). Sampling the function a little after the
    // start gives a positive reference, so the crossing was never seen again. A
    // Rising function is watched from its negative side: the event is reported
    // within root_tol of the restart, strictly positive.
    let mut sys = ramp(0.5, RootDirection::Rising);
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 1), 1);
    let (mut t, mut y) = (0.5, vec![0.5]);
    let r = int.advance(&mut sys, &mut t, &mut y, 2.0, &mut no_obs()).expect("ramp");
    assert_eq!(r, Advance::Root { indices: vec![0] });
    assert!(t > 0.5 && t - 0.5 <= 1e-9 && y[0] > 0.5, "t = {t}, y = {}", y[0]);
    // An Either function in the same place takes its side from just after the
    // start (SUNDIALS' rule): already positive, so no event. This is the
    // documented limitation a direction removes.
    let mut sys = ramp(0.5, RootDirection::Either);
    int.reset();
    let (mut t, mut y) = (0.5, vec![0.5]);
    let r = int.advance(&mut sys, &mut t, &mut y, 2.0, &mut no_obs()).expect("ramp");
    assert_eq!(r, Advance::Reached);
}

#[test]
fn directions_filter_crossings() {
    // g = y − 1 rises through zero at t = 1: reported for Rising and Either, not Falling.
    for (direction, fires) in [(RootDirection::Rising, true), (RootDirection::Either, true), (RootDirection::Falling, false)] {
        let mut sys = ramp(1.0, direction);
        let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 1), 1);
        let (mut t, mut y) = (0.0, vec![0.0]);
        let r = int.advance(&mut sys, &mut t, &mut y, 2.0, &mut no_obs()).expect("ramp");
        if fires {
            assert_eq!(r, Advance::Root { indices: vec![0] }, "{direction:?}");
            assert!(t > 1.0 && t - 1.0 <= 1e-9 && y[0] > 1.0, "{direction:?}: t = {t}");
        } else {
            assert_eq!(r, Advance::Reached, "{direction:?}");
        }
    }
    // A Rising function that starts positive is not watched until it is back on
    // its negative side: g = 1 − y falls at t = 1 (ignored), never rises.
    let mut sys = Directed {
        inner: Sys {
            n: 1,
            f: |_t, _y: &[f64], d: &mut [f64]| {
                d[0] = 1.0;
                Ok(())
            },
            m: 1,
            g: Some(|_t: f64, y: &[f64], g: &mut [f64]| g[0] = 1.0 - y[0]),
        },
        directions: vec![RootDirection::Rising],
    };
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 1), 1);
    let (mut t, mut y) = (0.0, vec![0.0]);
    assert_eq!(int.advance(&mut sys, &mut t, &mut y, 2.0, &mut no_obs()).expect("falling"), Advance::Reached);
}

#[test]
fn step_ending_on_an_exact_zero_does_not_hide_the_crossing() {
    // g = 0.5 − t with fixed steps of 0.25: the second step ends with g exactly 0,
    // which is not yet a change (the rule is strict); the next step must still be
    // watched from the positive side the function came from.
    let mut sys = Sys {
        n: 1,
        f: |_t, _y: &[f64], d: &mut [f64]| {
            d[0] = -1.0;
            Ok(())
        },
        m: 1,
        g: Some(|t: f64, _y: &[f64], g: &mut [f64]| g[0] = 0.5 - t),
    };
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 1), 1);
    int.set_fixed_step(Some(0.25));
    let (mut t, mut y) = (0.0, vec![0.5]);
    let mut ends = Vec::new();
    let r = int.advance(&mut sys, &mut t, &mut y, 2.0, &mut |d: &dyn Dense| ends.push(d.t_end())).expect("decay");
    assert_eq!(ends[1], 0.5, "the set-up must end a step on the exact zero: {ends:?}");
    assert_eq!(r, Advance::Root { indices: vec![0] });
    assert!(t > 0.5 && t - 0.5 <= 1e-9, "t = {t}");
}

#[test]
fn stop_time_is_respected_exactly_and_backwards_works() {
    let mut sys = plain(1, |_t, y: &[f64], d: &mut [f64]| {
        d[0] = -y[0];
        Ok(())
    });
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-9, 1e-12, 1), 1);
    let mut t = 0.0;
    let mut y = vec![1.0];
    let stop = 0.1 * 3.0; // not representable exactly; must be hit bit for bit
    int.advance(&mut sys, &mut t, &mut y, stop, &mut no_obs()).expect("forward");
    assert_eq!(t, stop);
    assert!((y[0] - (-stop).exp()).abs() < 1e-9);
    // And back to 0.
    int.advance(&mut sys, &mut t, &mut y, 0.0, &mut no_obs()).expect("backward");
    assert_eq!(t, 0.0);
    assert!((y[0] - 1.0).abs() < 1e-8, "y(0) = {}", y[0]);
}

#[test]
fn h_max_is_honoured() {
    let mut sys = plain(1, |_t, _y: &[f64], d: &mut [f64]| {
        d[0] = 1.0;
        Ok(())
    });
    let opts = Options { h_max: 0.01, ..Options::with_tolerances(1e-6, 1e-6, 1) };
    let mut int = Rosenbrock::new(opts, 1);
    let (mut t, mut y) = (0.0, vec![0.0]);
    let mut longest: f64 = 0.0;
    int.advance(&mut sys, &mut t, &mut y, 1.0, &mut |d: &dyn Dense| {
        longest = longest.max(d.t_end() - d.t_start());
    })
    .expect("run");
    assert!(longest <= 0.01 * (1.0 + 1e-12), "longest step {longest}");
    assert!(int.stats().steps >= 100);
    assert!((y[0] - 1.0).abs() < 1e-12);
}

// ---------------------------------------------------------------- errors

#[test]
fn rhs_error_is_reported_with_time() {
    let mut sys = plain(1, |t, _y: &[f64], d: &mut [f64]| {
        if t > 0.5 {
            return Err(RhsError("table lookup out of range".into()));
        }
        d[0] = 1.0;
        Ok(())
    });
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-6, 1), 1);
    let (mut t, mut y) = (0.0, vec![0.0]);
    match int.advance(&mut sys, &mut t, &mut y, 1.0, &mut no_obs()) {
        Err(e @ IntegratorError::Rhs { .. }) => {
            let IntegratorError::Rhs { t: te, ref source } = e else { unreachable!() };
            assert!(te > 0.5 && te <= 1.0, "t = {te}");
            assert_eq!(source.0, "table lookup out of range");
            let msg = e.to_string();
            assert!(msg.contains("t = ") && !msg.contains('\n'), "{msg}");
        }
        other => panic!("expected Rhs error, got {other:?}"),
    }
}

#[test]
fn a_refused_trial_state_is_rejected_and_the_step_retried() {
    // The system refuses the first state beyond y = 0.5 it is shown, once
    // (as the junction solve refuses an overshooting stage's state): that
    // state is a stage or the end of a step not yet accepted, so the step
    // is rejected and retried smaller, and the run ends where it should.
    let mut refused = false;
    let mut sys = plain(1, |_t, y: &[f64], d: &mut [f64]| {
        if y[0] > 0.5 && !refused {
            refused = true;
            return Err(RhsError("state out of range".into()));
        }
        d[0] = 1.0;
        Ok(())
    });
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-8, 1), 1);
    let (mut t, mut y) = (0.0, vec![0.0]);
    int.advance(&mut sys, &mut t, &mut y, 1.0, &mut no_obs()).expect("the refused trial is retried");
    assert_eq!(t, 1.0);
    assert!((y[0] - 1.0).abs() < 1e-9, "y = {}", y[0]);
    assert!(int.stats().rejected >= 1);
}

#[test]
fn nan_rhs_gives_non_finite() {
    let mut sys = plain(2, |t, y: &[f64], d: &mut [f64]| {
        d[0] = y[1];
        d[1] = if t > 0.5 { f64::NAN } else { -y[0] };
        Ok(())
    });
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-6, 2), 2);
    let (mut t, mut y) = (0.0, vec![1.0, 0.0]);
    match int.advance(&mut sys, &mut t, &mut y, 1.0, &mut no_obs()) {
        Err(IntegratorError::NonFinite { t: te, index }) => {
            assert_eq!(index, 1);
            assert!(te > 0.5 && te < 0.5 + 1e-6, "t = {te}");
            // The accepted state never went past the bad region.
            assert!(t <= 0.5);
        }
        other => panic!("expected NonFinite, got {other:?}"),
    }
}

#[test]
fn shrinking_step_gives_step_size_too_small() {
    // y' = y², y(0) = 1 blows up at t = 1; integrating to 2 must fail cleanly.
    let mut sys = plain(1, |_t, y: &[f64], d: &mut [f64]| {
        d[0] = y[0] * y[0];
        Ok(())
    });
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-6, 1), 1);
    let (mut t, mut y) = (0.0, vec![1.0]);
    let r = int.advance(&mut sys, &mut t, &mut y, 2.0, &mut no_obs());
    eprintln!("blow-up: {r:?} at t = {t}, stats {:?}", int.stats());
    match r {
        Err(IntegratorError::StepSizeTooSmall { t: te, h, .. }) => {
            assert!((te - 1.0).abs() < 1e-3, "t = {te}");
            assert!(h < 1e-6);
        }
        other => panic!("expected StepSizeTooSmall, got {other:?}"),
    }

    // With h_min the stiff Van der Pol transition cannot be resolved either.
    let mut sys = plain(2, van_der_pol);
    let opts = Options { h_min: 1e-2, ..Options::with_tolerances(1e-6, 1e-6, 2) };
    let mut int = Rosenbrock::new(opts, 2);
    let (mut t, mut y) = (0.0, vec![2.0, 0.0]);
    let r = int.advance(&mut sys, &mut t, &mut y, 3000.0, &mut no_obs());
    assert!(matches!(r, Err(IntegratorError::StepSizeTooSmall { h, .. }) if h < 1e-2), "{r:?}");
}

#[test]
fn too_many_steps_is_reported() {
    let mut sys = plain(2, van_der_pol);
    let opts = Options { max_steps: 50, ..Options::with_tolerances(1e-6, 1e-6, 2) };
    let mut int = Rosenbrock::new(opts, 2);
    let (mut t, mut y) = (0.0, vec![2.0, 0.0]);
    let r = int.advance(&mut sys, &mut t, &mut y, 3000.0, &mut no_obs());
    assert!(matches!(r, Err(IntegratorError::TooManySteps { steps: 50, .. })), "{r:?}");
    assert!(t > 0.0 && t < 3000.0);
}

#[test]
fn method_name_and_stats() {
    let int = Rosenbrock::new(Options::default(), 4);
    assert!(int.method_name().contains("RODAS4"));
    assert_eq!(int.options().atol, vec![Options::DEFAULT_ATOL; 4]);
    let s = int.stats();
    assert_eq!((s.steps, s.rhs_evals, s.lu), (0, 0, 0));
}

// ---------------------------------------------------------------- allocation

mod alloc_count {
    //! Per-thread allocation counter (test binary only), to check that the step
    //! loop does not allocate.
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    pub struct Counting;

    thread_local! {
        pub static ALLOCS: Cell<usize> = const { Cell::new(0) };
    }

    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
            // SAFETY: forwarded unchanged to the system allocator.
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: forwarded unchanged to the system allocator.
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
            // SAFETY: forwarded unchanged to the system allocator.
            unsafe { System.realloc(ptr, layout, new_size) }
        }
    }

    #[global_allocator]
    static GLOBAL: Counting = Counting;

    pub fn count() -> usize {
        ALLOCS.with(|c| c.get())
    }
}

#[test]
fn step_loop_does_not_allocate() {
    // Van der Pol with a root function, observer sampling the dense output.
    let mut sys = Sys { n: 2, f: van_der_pol, m: 1, g: Some(|_t: f64, y: &[f64], g: &mut [f64]| g[0] = y[0] - 5.0) };
    let mut int = Rosenbrock::new(Options::with_tolerances(1e-6, 1e-6, 2), 2);
    let (mut t, mut y) = (0.0, vec![2.0, 0.0]);
    let mut buf = [0.0; 2];
    let mut sum = 0.0;
    // Warm-up call (first use of buffers for the root functions).
    int.advance(&mut sys, &mut t, &mut y, 1.0, &mut no_obs()).expect("warm-up");
    let before = alloc_count::count();
    let r = int
        .advance(&mut sys, &mut t, &mut y, 3000.0, &mut |d: &dyn Dense| {
            d.eval(0.5 * (d.t_start() + d.t_end()), &mut buf);
            sum += buf[0];
        })
        .expect("run");
    let after = alloc_count::count();
    // The counter does see allocations on this thread.
    let v = std::hint::black_box(vec![1u8; 64]);
    assert!(alloc_count::count() > after && v.len() == 64);
    assert_eq!(r, Advance::Reached);
    assert!(sum.is_finite() && int.stats().steps > 500);
    assert_eq!(after - before, 0, "allocations during advance");
}

// ---------------------------------------------------------------- circuit-like stiff problem

#[test]
fn dead_volume_behind_large_valve_fills_chamber() {
    // Isothermal mock circuit: supply ps → (large valve) → dead volume V1 = 0.1 cm³
    // → (small orifice) → chamber V2 = 1 l. Orifice mass flow k·sign(Δp)·√|Δp| with a
    // linear (laminar) region |Δp| < 100 Pa, continuous at the join. The dead volume
    // gives an eigenvalue ≈ −(RT/V1)·k1/√100 ≈ −8e5 1/s; the chamber fills in ~100 s.
    const RT: f64 = 287.0 * 293.15;
    const PS: f64 = 6e5;
    let (v1, v2, k1, k2, dp_lam) = (1e-7, 1e-3, 1e-5, 1e-7, 100.0);
    let flow = move |k: f64, dp: f64| {
        if dp.abs() < dp_lam {
            k * dp / dp_lam.sqrt()
        } else {
            k * dp.signum() * dp.abs().sqrt()
        }
    };
    let mut sys = Sys {
        n: 2,
        f: move |_t, y: &[f64], d: &mut [f64]| {
            let q_in = flow(k1, PS - y[0]);
            let q_out = flow(k2, y[0] - y[1]);
            d[0] = RT / v1 * (q_in - q_out);
            d[1] = RT / v2 * q_out;
            Ok(())
        },
        m: 1,
        // Event: chamber reaches 5 bar.
        g: Some(|_t: f64, y: &[f64], g: &mut [f64]| g[0] = y[1] - 5e5),
    };
    let opts = Options { rtol: 1e-6, atol: vec![1.0, 1.0], ..Options::default() };
    let mut int = Rosenbrock::new(opts, 2);
    let (mut t, mut y) = (0.0, vec![1e5, 1e5]);
    let mut monotone = true;
    let mut last_p2 = y[1];
    let mut buf = [0.0; 2];
    let r = int
        .advance(&mut sys, &mut t, &mut y, 1000.0, &mut |d: &dyn Dense| {
            for k in 1..=4 {
                d.eval(d.t_start() + (d.t_end() - d.t_start()) * k as f64 / 4.0, &mut buf);
                monotone &= buf[1] >= last_p2 - 1.0 && buf[0] >= buf[1] - 1.0 && buf[0] <= PS + 1.0;
                last_p2 = buf[1];
            }
        })
        .expect("circuit");
    let s = int.stats();
    eprintln!("mock circuit: event at t = {t:.4} s, y = {y:?}, {s:?}");
    assert_eq!(r, Advance::Root { indices: vec![0] });
    assert!(monotone, "pressures must rise monotonically and stay ordered");
    // Quasi-steady check at the event: the dead volume sits where inflow = outflow.
    let q_in = flow(k1, PS - y[0]);
    let q_out = flow(k2, y[0] - y[1]);
    assert!((q_in - q_out).abs() < 1e-3 * q_out, "q_in {q_in}, q_out {q_out}");
    // Fill time: with p1 ≈ ps (k1 ≫ k2; the laminar drop across the valve is
    // ps − p1 = 10·k2/k1·√(p1 − p2) ≤ 70 Pa, i.e. < 3e-4 relative), dp2/dt =
    // (RT/V2)·k2·√(ps − p2), so t = 2·V2/(RT·k2)·(√(ps − p0) − √(ps − 5e5)).
    let t_exact_approx = 2.0 * v2 / (RT * k2) * ((PS - 1e5_f64).sqrt() - (PS - 5e5_f64).sqrt());
    eprintln!("fill time {t} vs approximation {t_exact_approx}");
    assert!((t - t_exact_approx).abs() < 1e-3 * t_exact_approx, "t = {t}, approx {t_exact_approx}");
    assert!(s.steps < 300, "{} steps", s.steps);
}

/// A decaying state with its running integral declared as a quadrature.
struct WithQuadrature {
    declare: bool,
}

impl OdeSystem for WithQuadrature {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&mut self, _t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
        d[0] = -2.0 * y[0];
        d[1] = y[0];
        Ok(())
    }
    fn n_quadrature(&self) -> usize {
        usize::from(self.declare)
    }
}

#[test]
fn quadrature_columns_are_not_differenced_and_results_agree() {
    let run = |declare: bool| {
        let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 2), 2);
        let (mut t, mut y) = (0.0, vec![1.0, 0.0]);
        int.advance(&mut WithQuadrature { declare }, &mut t, &mut y, 2.0, &mut |_| {}).unwrap();
        (y, int.stats())
    };
    let (y_plain, s_plain) = run(false);
    let (y_quad, s_quad) = run(true);
    // ∫0^2 e^{-2t} dt = (1 - e^{-4})/2
    let exact = (1.0 - (-4.0f64).exp()) / 2.0;
    assert!((y_quad[1] - exact).abs() < 1e-8, "{}", y_quad[1]);
    assert!((y_quad[1] - y_plain[1]).abs() < 1e-10);
    assert_eq!(s_plain.steps, s_quad.steps);
    // one column fewer per Jacobian
    assert_eq!(s_plain.rhs_evals - s_quad.rhs_evals, s_plain.jacobians);
}

/// y' = -y declared autonomous: same result, one evaluation fewer per Jacobian.
struct Decay {
    declare: bool,
}

impl OdeSystem for Decay {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&mut self, _t: f64, y: &[f64], d: &mut [f64]) -> Result<(), RhsError> {
        d[0] = -y[0];
        Ok(())
    }
    fn autonomous(&self) -> bool {
        self.declare
    }
}

#[test]
fn autonomous_systems_skip_the_time_column() {
    let run = |declare: bool| {
        let mut int = Rosenbrock::new(Options::with_tolerances(1e-8, 1e-10, 1), 1);
        let (mut t, mut y) = (0.0, vec![1.0]);
        int.advance(&mut Decay { declare }, &mut t, &mut y, 1.0, &mut |_| {}).unwrap();
        (y[0], int.stats())
    };
    let (y0, s0) = run(false);
    let (y1, s1) = run(true);
    assert!((y1 - (-1.0f64).exp()).abs() < 1e-8);
    assert!((y0 - y1).abs() < 1e-12);
    assert_eq!(s0.rhs_evals - s1.rhs_evals, s0.jacobians);
}

// ---------------------------------------------------------------- ROS34PW2 (W-method)

fn ros34pw2(rtol: f64, atol: f64, n: usize) -> Rosenbrock {
    Rosenbrock::with_method(Options::with_tolerances(rtol, atol, n), n, crate::Method::Ros34pw2)
}

#[test]
fn ros34pw2_keeps_order_three_with_a_reused_jacobian() {
    // Fixed steps reuse one Jacobian over up to 20 steps: a classical Rosenbrock
    // method would drop to order 1-2 with it; a W-method keeps its order 3.
    let run = |h: f64| {
        let mut sys = plain(3, smooth_rhs);
        let mut int = ros34pw2(1e-6, 1e-6, 3);
        int.set_fixed_step(Some(h));
        let (mut t, mut y) = (0.0, smooth_exact(0.0).to_vec());
        let mut dense_err: f64 = 0.0;
        let mut buf = [0.0; 3];
        int.advance(&mut sys, &mut t, &mut y, 2.0, &mut |d: &dyn Dense| {
            let tm = 0.5 * (d.t_start() + d.t_end());
            d.eval(tm, &mut buf);
            dense_err = dense_err.max(max_err(&buf, &smooth_exact(tm)));
        })
        .expect("fixed-step run");
        let s = int.stats();
        (max_err(&y, &smooth_exact(2.0)), dense_err, s.jacobians, s.steps)
    };
    let hs = [0.1, 0.05, 0.025, 0.0125];
    let errs: Vec<_> = hs.iter().map(|&h| run(h)).collect();
    for k in 1..hs.len() {
        let p = (errs[k - 1].0 / errs[k].0).log2();
        let pd = (errs[k - 1].1 / errs[k].1).log2();
        eprintln!(
            "ROS34PW2 h = {}: err {:.3e} order {p:.2}; dense {:.3e} order {pd:.2}; {} Jacobians for {} steps",
            hs[k], errs[k].0, errs[k].1, errs[k].2, errs[k].3
        );
        assert!(p >= 3.0 - 0.3, "order {p}");
        assert!(pd >= 3.0 - 0.4, "dense order {pd}");
        assert!(errs[k].2 * 10 <= errs[k].3, "{} Jacobians for {} steps: not reused", errs[k].2, errs[k].3);
    }
}

#[test]
fn ros34pw2_is_l_stable_and_solves_stiff_references() {
    let mut sys = plain(1, |_t, y: &[f64], d: &mut [f64]| {
        d[0] = -1e12 * y[0];
        Ok(())
    });
    let mut int = ros34pw2(1e-6, 1e-9, 1);
    int.set_fixed_step(Some(1.0));
    let (mut t, mut y) = (0.0, vec![1.0]);
    int.advance(&mut sys, &mut t, &mut y, 1.0, &mut no_obs()).expect("step");
    // exact: R(−1e12) = −2.87e-12 (R(z) ~ 1/z); a W-method's R(∞) also carries the
    // relative error of its finite-difference Jacobian (ε/δ ≈ 1e-8 here)
    assert!(y[0].abs() < 1e-7, "R(-1e12) = {}", y[0]);

    let reference = [0.0178659211422, 7.27475146849e-8, 0.982134006110];
    let mut sys = plain(3, robertson);
    let opts = Options { rtol: 1e-6, atol: vec![1e-10, 1e-14, 1e-10], ..Options::default() };
    let mut int = Rosenbrock::with_method(opts, 3, crate::Method::Ros34pw2);
    let (mut t, mut y) = (0.0, vec![1.0, 0.0, 0.0]);
    int.advance(&mut sys, &mut t, &mut y, 1e5, &mut no_obs()).expect("Robertson");
    let s = int.stats();
    eprintln!("Robertson with ROS34PW2: {y:?}, {s:?}");
    for i in 0..3 {
        let rel = (y[i] - reference[i]).abs() / reference[i];
        assert!(rel < 1e-3, "component {i}: {} vs {} (rel {rel:e})", y[i], reference[i]);
    }
    assert!(s.jacobians < s.steps, "{s:?}");

    let mut sys = plain(2, van_der_pol);
    let mut int = ros34pw2(1e-6, 1e-6, 2);
    let (mut t, mut y) = (0.0, vec![2.0, 0.0]);
    int.advance(&mut sys, &mut t, &mut y, 3000.0, &mut no_obs()).expect("Van der Pol");
    eprintln!("Van der Pol with ROS34PW2: {y:?}, {:?}", int.stats());
    assert!((y[0] + 1.5106069362).abs() < 1e-3 * 1.5106069362, "y1 = {}", y[0]);
}

#[test]
fn ros34pw2_locates_roots_on_its_hermite_dense_output() {
    // ball falling from 10 m: impact at √(2·10/9.81) s
    let mut sys = ball_system(1, |_t, y, g| g[0] = y[0]);
    let mut int = ros34pw2(1e-8, 1e-10, 2);
    let (mut t, mut y) = (0.0, vec![10.0, 0.0]);
    let r = int.advance(&mut sys, &mut t, &mut y, 5.0, &mut no_obs()).expect("ball");
    assert!(matches!(r, Advance::Root { .. }), "{r:?}");
    let exact = (2.0 * 10.0 / 9.81_f64).sqrt();
    assert!((t - exact).abs() < 1e-7, "impact at {t}, exact {exact}");
}
