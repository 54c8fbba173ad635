//! Location of the first sign change of a set of root (event) functions inside
//! one accepted step, on the step's dense output.
//!
//! Method: a bracketing secant iteration with the Illinois modification (M. Dowell
//! & P. Jarratt, BIT 11 (1971) 168–174), applied jointly to all functions as in the
//! root finder of the SUNDIALS solvers (A. C. Hindmarsh et al., ACM TOMS 31 (2005)
//! 363–396, §"rootfinding"): the secant trial point comes from the function whose
//! secant estimate is earliest; the bracket `[t_lo, t_hi]` keeps the invariant
//! "no function has changed sign at `t_lo`, at least one has at `t_hi`", relative
//! to the signs at the step start. A bisection is forced whenever two iterations
//! fail to halve the bracket, so the iteration count is O(log(h/tol)) at worst.
//!
//! Sign rule: function `i` has changed when its start value `g0_i` is non-zero and
//! its current value is zero or of the other sign. A function that is exactly
//! zero at the step start is ignored for that step (the caller has just handled
//! that event). The returned point is `t_hi`, so the caller sees the new sign.

/// `true` if a root function has left the sign it had at the step start.
pub(crate) fn changed(g_start: f64, g: f64) -> bool {
    g_start != 0.0 && (g == 0.0 || (g > 0.0) != (g_start > 0.0))
}

/// Evaluator of the root functions at a time: `eval(t, g)`.
pub(crate) type RootEval<'a, E> = dyn FnMut(f64, &mut [f64]) -> Result<(), E> + 'a;

/// Buffers for the bracketing iteration (allocated once).
#[derive(Debug, Clone)]
pub(crate) struct RootFinder {
    g_lo: Vec<f64>,
    /// Root-function values at the returned point after [`RootFinder::locate`].
    pub g_hi: Vec<f64>,
    g_mid: Vec<f64>,
}

impl RootFinder {
    pub(crate) fn new(n_roots: usize) -> Self {
        Self { g_lo: vec![0.0; n_roots], g_hi: vec![0.0; n_roots], g_mid: vec![0.0; n_roots] }
    }

    /// Resize the buffers if the number of root functions changed (rare; allocates).
    pub(crate) fn ensure_len(&mut self, n_roots: usize) {
        if self.g_lo.len() != n_roots {
            *self = Self::new(n_roots);
        }
    }

    /// Narrow `[t_lo, t_hi]` (either orientation) to width ≤ `tol` around the first
    /// sign change. `g_start` are the values at the step start (= at `t_lo` on entry),
    /// `g_end` those at `t_hi` (at least one must have `changed`). `eval(t, g)` fills
    /// the root functions at `t`. Returns the final `t_hi`; its values are in `self.g_hi`.
    pub(crate) fn locate<E>(
        &mut self,
        t_lo: f64,
        t_hi: f64,
        g_start: &[f64],
        g_end: &[f64],
        tol: f64,
        eval: &mut RootEval<'_, E>,
    ) -> Result<f64, E> {
        let m = g_start.len();
        self.g_lo.copy_from_slice(g_start);
        self.g_hi.copy_from_slice(g_end);
        let (mut lo, mut hi) = (t_lo, t_hi);
        // Illinois weights on the two end values; `last` = which end moved last (+1 hi, −1 lo).
        let (mut w_lo, mut w_hi) = (1.0_f64, 1.0_f64);
        let mut last = 0_i32;
        let mut width_two_ago = (hi - lo).abs();
        let mut width_prev = width_two_ago;
        let mut force_bisect = false;
        for _ in 0..300 {
            let width = (hi - lo).abs();
            if width <= tol {
                break;
            }
            // Earliest secant estimate among functions bracketed by [lo, hi].
            let mut frac = -1.0_f64;
            for i in 0..m {
                if !changed(g_start[i], self.g_hi[i]) {
                    continue;
                }
                let a = w_lo * self.g_lo[i];
                let b = w_hi * self.g_hi[i];
                let denom = b - a;
                // a and b have opposite signs (or b == 0), so 0 ≤ b/(b − a) ≤ 1.
                let f = if denom != 0.0 { b / denom } else { 0.5 };
                if f > frac {
                    frac = f;
                }
            }
            if !(0.0..=1.0).contains(&frac) || force_bisect {
                frac = 0.5;
            }
            // Keep the trial point at least tol/2 inside the bracket.
            let margin = (0.5 * tol / width).min(0.5);
            let frac = frac.clamp(margin, 1.0 - margin);
            let mid = hi - frac * (hi - lo);
            if mid == lo || mid == hi {
                break; // no representable point left between the ends
            }
            eval(mid, &mut self.g_mid)?;
            let crossed = (0..m).any(|i| changed(g_start[i], self.g_mid[i]));
            if crossed {
                hi = mid;
                std::mem::swap(&mut self.g_hi, &mut self.g_mid);
                if last == 1 {
                    w_lo *= 0.5;
                } else {
                    w_lo = 1.0;
                    w_hi = 1.0;
                }
                last = 1;
            } else {
                lo = mid;
                std::mem::swap(&mut self.g_lo, &mut self.g_mid);
                if last == -1 {
                    w_hi *= 0.5;
                } else {
                    w_lo = 1.0;
                    w_hi = 1.0;
                }
                last = -1;
            }
            let new_width = (hi - lo).abs();
            force_bisect = new_width > 0.5 * width_two_ago;
            width_two_ago = width_prev;
            width_prev = new_width;
        }
        Ok(hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_rule() {
        assert!(changed(1.0, -1.0));
        assert!(changed(-1.0, 0.0));
        assert!(!changed(0.0, 1.0));
        assert!(!changed(2.0, 1.0));
        assert!(!changed(-2.0, -1e-300));
    }

    #[test]
    fn finds_earliest_of_two_roots_with_illinois() {
        // g0 = t^3 - 0.5 (root 0.7937…), g1 = 0.9 - t (root 0.9): the earlier one wins.
        let mut rf = RootFinder::new(2);
        let f = |t: f64, g: &mut [f64]| {
            g[0] = t * t * t - 0.5;
            g[1] = 0.9 - t;
        };
        let mut g_start = [0.0; 2];
        let mut g_end = [0.0; 2];
        f(0.0, &mut g_start);
        f(1.0, &mut g_end);
        let mut evals = 0;
        let t = rf
            .locate::<()>(0.0, 1.0, &g_start, &g_end, 1e-12, &mut |t, g| {
                evals += 1;
                f(t, g);
                Ok(())
            })
            .unwrap();
        let exact = 0.5_f64.cbrt();
        assert!(t >= exact && t - exact <= 1e-12, "t = {t}");
        assert!(changed(g_start[0], rf.g_hi[0]) && !changed(g_start[1], rf.g_hi[1]));
        assert!(evals < 30, "{evals} evaluations");
    }

    #[test]
    fn backward_bracket() {
        let mut rf = RootFinder::new(1);
        let f = |t: f64, g: &mut [f64]| g[0] = (t - 0.3).sin();
        let (mut gs, mut ge) = ([0.0], [0.0]);
        f(1.0, &mut gs);
        f(0.0, &mut ge);
        let t = rf
            .locate::<()>(1.0, 0.0, &gs, &ge, 1e-11, &mut |t, g| {
                f(t, g);
                Ok(())
            })
            .unwrap();
        assert!(t <= 0.3 && 0.3 - t <= 1e-11, "t = {t}");
    }
}
