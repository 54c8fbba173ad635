//! Scalar root finding on a bracket.
//!
//! * [`brent`] — Brent's method (R. P. Brent, *Algorithms for Minimization
//!   without Derivatives*, 1973, ch. 4: inverse quadratic interpolation,
//!   secant and bisection, with the guarantee of bisection). Used for the
//!   pressure of the volume-less junction between the 5/2 valve and the
//!   speed-control valve, whose flow balance is monotone in that pressure but
//!   has an unbounded slope where a restriction's pressure ratio tends to 1
//!   (ISO 6358 ellipse), which defeats a plain Newton iteration.
//! * [`illinois`] — the Illinois variant of regula falsi (Dowell & Jarratt,
//!   BIT 11, 1971), used to locate discrete events, where every function
//!   value is an integration step and may carry small jumps (Newton
//!   iteration counts change with the step size); a bracketing method that
//!   always keeps a sign change is robust to that.

/// Brent's root finder on `[a, b]` with `f(a)`, `f(b)` of opposite signs (or
/// one of them zero). Stops when the bracket is narrower than
/// `2·ε·|x| + xtol` or a function value is exactly zero. Returns the best
/// estimate. If the signs do not differ, returns the end point with the
/// smaller |f| (the caller guarantees a bracket; this is only a guard).
pub(crate) fn brent<F: FnMut(f64) -> f64>(mut f: F, a0: f64, b0: f64, fa0: f64, fb0: f64, xtol: f64) -> f64 {
    let (mut a, mut b, mut fa, mut fb) = (a0, b0, fa0, fb0);
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    if (fa > 0.0) == (fb > 0.0) {
        return if fa.abs() < fb.abs() { a } else { b };
    }
    // c is the previous iterate on the other side of the root from b
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..200 {
        if (fb > 0.0) == (fc > 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + 0.5 * xtol;
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            // interpolation: secant if a == c, else inverse quadratic
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * m * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol { d } else { tol.copysign(m) };
        fb = f(b);
    }
    b
}

/// Result of [`illinois`]: the bracket that still contains the sign change.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Bracket {
    /// Last abscissa with `g < 0`.
    pub lo: f64,
    /// First abscissa with `g ≥ 0` (the event has happened here).
    pub hi: f64,
}

/// Locates the first point where `g` becomes non-negative on `[lo, hi]`,
/// given `g(lo) < 0 ≤ g(hi)`, by the Illinois method. `g` may fail (returns
/// `None`), in which case the bisection point is used instead. Stops when
/// `hi − lo ≤ xtol` or `g(hi) ≤ gtol`.
pub(crate) fn illinois<G: FnMut(f64) -> Option<f64>>(mut g: G, lo0: f64, hi0: f64, glo0: f64, ghi0: f64, xtol: f64, gtol: f64) -> Bracket {
    let (mut lo, mut hi, mut glo, mut ghi) = (lo0, hi0, glo0, ghi0);
    // which end was kept last time (for the Illinois halving)
    let mut side = 0i8;
    for _ in 0..100 {
        if hi - lo <= xtol || ghi <= gtol {
            break;
        }
        let mut x = if ghi - glo > 0.0 { hi - ghi * (hi - lo) / (ghi - glo) } else { 0.5 * (lo + hi) };
        // keep the trial point strictly inside, away from the ends by a little
        let margin = 0.01 * (hi - lo);
        if !(x > lo + margin && x < hi - margin) {
            x = x.clamp(lo + margin, hi - margin);
        }
        let gx = match g(x) {
            Some(v) => v,
            None => {
                let xm = 0.5 * (lo + hi);
                match g(xm) {
                    Some(v) => {
                        x = xm;
                        v
                    }
                    None => break,
                }
            }
        };
        if gx >= 0.0 {
            hi = x;
            ghi = gx;
            if side == 1 {
                glo *= 0.5;
            }
            side = 1;
        } else {
            lo = x;
            glo = gx;
            if side == -1 {
                ghi *= 0.5;
            }
            side = -1;
        }
    }
    Bracket { lo, hi }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brent_finds_a_cusp_root() {
        // f has an unbounded slope at its root, like the ISO ellipse at r → 1
        let f = |x: f64| (x - 0.3).signum() * (x - 0.3).abs().sqrt();
        let x = brent(f, 0.0, 1.0, f(0.0), f(1.0), 1e-14);
        assert!((x - 0.3).abs() < 1e-13, "{x}");
    }

    #[test]
    fn brent_smooth() {
        let f = |x: f64| x * x * x - 2.0;
        let x = brent(f, 0.0, 2.0, f(0.0), f(2.0), 1e-15);
        assert!((x - 2f64.powf(1.0 / 3.0)).abs() < 1e-14);
    }

    #[test]
    fn illinois_keeps_a_sign_change() {
        let g = |x: f64| Some(x.exp() - 2.0);
        let br = illinois(g, 0.0, 1.0, -1.0, 1f64.exp() - 2.0, 1e-13, 0.0);
        assert!(br.lo <= 2f64.ln() && br.hi >= 2f64.ln() - 1e-15);
        // either the bracket is narrow or g(hi) = 0 exactly ended the search
        assert!(br.hi - br.lo < 1e-12 || br.hi.exp() - 2.0 == 0.0, "{br:?}");
        assert!((br.hi - 2f64.ln()).abs() < 1e-12, "{br:?}");
    }
}
