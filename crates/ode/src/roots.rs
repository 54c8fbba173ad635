//! Location of the first sign change of a set of root (event) functions inside
//! one accepted step, on the step's dense output.
//!
//! Method: a bracketing secant iteration with the Illinois modification (M. Dowell
//! & P. Jarratt, BIT 11 (1971) 168–174), applied jointly to all functions as in the
//! root finder of the SUNDIALS solvers (A. C. Hindmarsh et al., ACM TOMS 31 (2005)
//! 363–396, §"rootfinding"): the secant trial point comes from the function whose
//! secant estimate is earliest; the bracket `[t_lo, t_hi]` keeps the invariant
//! "no watched function has changed at `t_lo`, at least one has at `t_hi`". A
//! bisection is forced whenever two iterations fail to halve the bracket, so the
//! iteration count is O(log(h/tol)) at worst.
//!
//! Sign rule. Each function is watched during a step from one side, its
//! *watch* `w`: `w = +1` watches for it to become negative, `w = −1` for it to
//! become positive, `w = 0` not at all (see [`watch`]). It has changed when its
//! value is strictly on the other side, `w·g < 0`; a value of exactly zero is
//! not a change. So the point returned is strictly on the new side, and a caller
//! whose own test of the condition is strict (`F > F_s`, say) always agrees with
//! the integrator about whether the event happened. (SUNDIALS counts a zero as a
//! root; a function that only touches zero is then an event here and a
//! non-event in a strict mode test, which is the disagreement this rule avoids.)

use crate::RootDirection;

/// The side from which a root function is watched during one step: `+1.0`
/// (now positive or on its positive "no event" side), `−1.0`, or `0.0` (not
/// watched this step).
///
/// `g0` is its value at the step start. A non-zero value gives the side. An
/// exact zero is taken, for a directional function, to be on its "no event"
/// side (negative for [`RootDirection::Rising`]), so that a function left at
/// its threshold by the caller and then moving into the event side is
/// reported at once; for [`RootDirection::Either`] the caller supplies
/// `zero_side` (the sign the function had before, or its sign just after the
/// start). A directional function that starts strictly on its event side is not
/// watched until it has come back (the meaning of a direction in SUNDIALS'
/// `CVodeSetRootDirection`).
pub(crate) fn watch(direction: RootDirection, g0: f64, zero_side: f64) -> f64 {
    let sign = |v: f64| {
        if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        }
    };
    let side = match (sign(g0), direction) {
        (s, _) if s != 0.0 => s,
        (_, RootDirection::Rising) => -1.0,
        (_, RootDirection::Falling) => 1.0,
        (_, RootDirection::Either) => sign(zero_side),
    };
    match direction {
        RootDirection::Either => side,
        RootDirection::Rising if side < 0.0 => -1.0,
        RootDirection::Falling if side > 0.0 => 1.0,
        _ => 0.0,
    }
}

/// `true` if a function watched from side `w` (see [`watch`]) is now strictly on the other side.
pub(crate) fn changed(w: f64, g: f64) -> bool {
    w * g < 0.0
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
    /// sign change. `watch` holds the side each function is watched from (see
    /// [`watch`]), `g_start` the values at the step start (= at `t_lo` on entry),
    /// `g_end` those at `t_hi` (at least one must have `changed`). `eval(t, g)` fills
    /// the root functions at `t`. Returns the final `t_hi`; its values are in `self.g_hi`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn locate<E>(
        &mut self,
        t_lo: f64,
        t_hi: f64,
        watch: &[f64],
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
                if !changed(watch[i], self.g_hi[i]) {
                    continue;
                }
                let a = w_lo * self.g_lo[i];
                let b = w_hi * self.g_hi[i];
                let denom = b - a;
                // a and b have opposite signs (or a == 0 for a function that starts
                // at zero), so 0 ≤ b/(b − a) ≤ 1.
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
            let crossed = (0..m).any(|i| changed(watch[i], self.g_mid[i]));
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
    fn sign_rule_is_strict() {
        assert!(changed(1.0, -1.0));
        assert!(changed(-1.0, 1e-300));
        assert!(!changed(-1.0, 0.0), "reaching zero is not yet a change");
        assert!(!changed(0.0, 1.0) && !changed(0.0, -1.0), "not watched");
        assert!(!changed(1.0, 2.0));
        assert!(!changed(-2.0, -1e-300));
    }

    #[test]
    fn watch_sides() {
        use RootDirection::*;
        // non-zero start: its own sign, unless a direction says it cannot fire
        assert_eq!(watch(Either, 3.0, 0.0), 1.0);
        assert_eq!(watch(Rising, -3.0, 0.0), -1.0);
        assert_eq!(watch(Rising, 3.0, 0.0), 0.0);
        assert_eq!(watch(Falling, 3.0, 0.0), 1.0);
        assert_eq!(watch(Falling, -3.0, 0.0), 0.0);
        // zero start: the "no event" side of a directional function, whatever the
        // value just after the start; the supplied side for Either
        assert_eq!(watch(Rising, 0.0, 1.0), -1.0);
        assert_eq!(watch(Falling, 0.0, -1.0), 1.0);
        assert_eq!(watch(Either, 0.0, -1e-9), -1.0);
        assert_eq!(watch(Either, 0.0, 0.0), 0.0);
    }

    #[test]
    fn function_starting_at_zero_is_located_just_after_the_start() {
        // g = t − 0.25 on [0.25, 1] with a Rising watch: the change is at the start;
        // the point returned is within tol after it and strictly positive.
        let mut rf = RootFinder::new(1);
        let f = |t: f64, g: &mut [f64]| g[0] = t - 0.25;
        let (mut gs, mut ge) = ([0.0], [0.0]);
        f(0.25, &mut gs);
        f(1.0, &mut ge);
        assert_eq!(gs[0], 0.0);
        let w = [watch(RootDirection::Rising, gs[0], 0.0)];
        let t = rf
            .locate::<()>(0.25, 1.0, &w, &gs, &ge, 1e-12, &mut |t, g| {
                f(t, g);
                Ok(())
            })
            .unwrap();
        assert!(t > 0.25 && t - 0.25 <= 1e-12 && rf.g_hi[0] > 0.0, "t = {t}, g = {}", rf.g_hi[0]);
    }

    #[test]
    fn located_point_is_strictly_past_an_exactly_representable_root() {
        // g = 0.5 − t has its root at a representable point: the secant step lands
        // on it (g = 0 exactly), which must not end the search.
        let mut rf = RootFinder::new(1);
        let f = |t: f64, g: &mut [f64]| g[0] = 0.5 - t;
        let (mut gs, mut ge) = ([0.0], [0.0]);
        f(0.0, &mut gs);
        f(1.0, &mut ge);
        let t = rf
            .locate::<()>(0.0, 1.0, &[1.0], &gs, &ge, 1e-12, &mut |t, g| {
                f(t, g);
                Ok(())
            })
            .unwrap();
        assert!(t > 0.5 && t - 0.5 <= 1e-12 && rf.g_hi[0] < 0.0, "t = {t}, g = {}", rf.g_hi[0]);
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
        let w = [g_start[0].signum(), g_start[1].signum()];
        let t = rf
            .locate::<()>(0.0, 1.0, &w, &g_start, &g_end, 1e-12, &mut |t, g| {
                evals += 1;
                f(t, g);
                Ok(())
            })
            .unwrap();
        let exact = 0.5_f64.cbrt();
        assert!(t >= exact && t - exact <= 1e-12, "t = {t}");
        assert!(changed(w[0], rf.g_hi[0]) && !changed(w[1], rf.g_hi[1]));
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
            .locate::<()>(1.0, 0.0, &[gs[0].signum()], &gs, &ge, 1e-11, &mut |t, g| {
                f(t, g);
                Ok(())
            })
            .unwrap();
        assert!(t <= 0.3 && 0.3 - t <= 1e-11, "t = {t}");
    }
}
