#!/usr/bin/env python3
"""Fit the gas-model coefficients of crates/gas and write the CoolProp fixtures.

Usage (from the repository root):

    pip install CoolProp scipy numpy
    python3 tests/data/make_gas_fixture.py            # fit, write CSVs, print Rust
    python3 tests/data/make_gas_fixture.py --no-write # fit and report only
    python3 tests/data/make_gas_fixture.py --alternatives # gas_alternative_fits.csv only

What it does, for 'Air' (CoolProp's pseudo-pure air) and 'Nitrogen':

1. Ideal-gas heat capacity (SemiPerfectGas). CoolProp's ideal-gas cp0(T)
   (`Cp0mass`) is sampled every 5 K over 200-1000 K and the NASA 7-coefficient
   form cp/R = a1 + a2 T + a3 T^2 + a4 T^3 + a5 T^4 is fitted to it so as to
   minimise the largest *relative* error (a minimax fit, solved as a linear
   programme with scipy.optimize.linprog, in the scaled variable T/1000 to
   keep the problem well conditioned).

2. Real-gas part (VirialGas). The residual Helmholtz energy is
       a_r / (R T) = B rho + C rho^2 / 2 + D rho^3 / 3,
   each coefficient a short series in tau = T0 / T (T0 = 300 K):
       B = sum_i b_i tau^i,  C = sum_i c_i tau^i,  D = sum_i d_i tau^i,  i = 0..3.
   Z - 1, the enthalpy departure (h - h0)/(R T) and the residual heat capacity
   (cv - cv0)/R are all *linear* in the 12 coefficients, so they are fitted
   together by one weighted linear least-squares problem (scipy.linalg.lstsq)
   to CoolProp data on a grid T = 200..500 K (31 values) x p = 0.1..310 bar
   (40 log-spaced values). Z residuals are relative (divided by Z).

3. Fixture CSVs (tests/data/coolprop_<gas>.csv): a coarse grid of CoolProp
   states that the Rust tests read; see the '#' header lines of each file for
   the columns and the enthalpy reference.

4. Fine-grid CSVs (tests/data/coolprop_<gas>_fine.csv): the CoolProp values
   of the accuracy tables' grids below (the ideal-gas cp0 and h0 every 1 K
   over 200-1000 K; the real-gas states of the two check grids), so that
   crates/gas/src/doc_numbers.rs recomputes docs/gas.md's tables "Fit" and
   "Accuracy reached" from the Rust models without Python.

5. tests/data/gas_alternative_fits.csv: the errors of the fits docs/gas.md
   compares the joint fit with (Z alone; B and C alone) and CoolProp's second
   virial coefficient at 300 K, which doc_numbers.rs compares with the page.

The script prints the Rust constants to paste into crates/gas/src and a
Markdown table of the accuracy reached (used in docs/gas.md).
"""

import argparse
import os
import sys

import numpy as np
import scipy
import scipy.linalg
import scipy.optimize
import CoolProp
import CoolProp.CoolProp as CP

# Specific gas constants used by the Rust models [J/(kg K)] (air: the value of
# IdealGas::air(), so that all air models share one R).
GASES = {
    "air": ("Air", 287.05),
    "nitrogen": ("Nitrogen", 296.8),
}
T_REF = 298.15  # enthalpy reference: h(rho -> 0, T_REF) = 0
P_IDEAL = 1.0  # [Pa] pressure at which CoolProp's state is taken as ideal gas
T0 = 300.0  # reduced temperature tau = T0 / T in the virial series
N_TAU = 4  # terms per virial coefficient (tau^0 .. tau^3)
N_RHO = 3  # B, C, D
W_HDEP = 1.0  # weight of (h - h0)/(R T) residuals relative to Z residuals
W_CV = 1.0  # weight of (cv - cv0)/R residuals

FIT_T = np.linspace(200.0, 500.0, 31)
FIT_P = np.geomspace(1.0e4, 3.1e7, 40)

# Fixture grid.
FIX_T = [200, 225, 250, 275, 300, 325, 350, 375, 400, 450, 500, 600, 700, 800, 900, 1000]
FIX_P_BAR = [1, 2, 5, 10, 20, 50, 100, 150, 200, 250, 300]

HERE = os.path.dirname(os.path.abspath(__file__))


# --------------------------------------------------------------------------
# CoolProp reference values
# --------------------------------------------------------------------------
def cp0(fluid, t):
    return CP.PropsSI("Cp0mass", "T", t, "P", 1.0e3, fluid)


def h_ideal(fluid, t):
    """Ideal-gas enthalpy relative to T_REF [J/kg]."""
    return CP.PropsSI("Hmass", "T", t, "P", P_IDEAL, fluid) - CP.PropsSI(
        "Hmass", "T", T_REF, "P", P_IDEAL, fluid
    )


def reference_state(fluid, r, t, p):
    rho = CP.PropsSI("D", "T", t, "P", p, fluid)
    h = CP.PropsSI("Hmass", "T", t, "P", p, fluid) - CP.PropsSI(
        "Hmass", "T", T_REF, "P", P_IDEAL, fluid
    )
    h0 = h_ideal(fluid, t)
    return dict(
        T=t,
        p=p,
        rho=rho,
        Z=p / (rho * r * t),
        cp=CP.PropsSI("Cpmass", "T", t, "P", p, fluid),
        cv=CP.PropsSI("Cvmass", "T", t, "P", p, fluid),
        h=h,
        h_dep=h - h0,
        cp0=cp0(fluid, t),
        h0=h0,
    )


# --------------------------------------------------------------------------
# 1. NASA polynomial for cp0(T)
# --------------------------------------------------------------------------
def fit_nasa(fluid, r):
    """Minimax fit of the relative cp0 error: min e s.t. |cp_fit/cp0 - 1| <= e.

    Solved as a linear programme (scipy.optimize.linprog, HiGHS) in the scaled
    variable x = T/1000; the coefficients are converted back to T in K.
    """
    t = np.arange(200.0, 1000.0 + 1e-9, 5.0)
    y = np.array([cp0(fluid, x) for x in t]) / r
    v = np.vander(t / 1000.0, 5, increasing=True) / y[:, None]
    n, m = v.shape[1], len(t)
    cost = np.r_[np.zeros(n), 1.0]
    a_ub = np.vstack([np.c_[v, -np.ones(m)], np.c_[-v, -np.ones(m)]])
    b_ub = np.r_[np.ones(m), -np.ones(m)]
    res = scipy.optimize.linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * n + [(0.0, None)])
    if res.status != 0:
        raise RuntimeError(f"NASA fit failed: {res.message}")
    a = res.x[:n] / 1000.0 ** np.arange(n)
    rel = (np.vander(t, 5, increasing=True) @ a) / y - 1.0
    return a, rel, t


def nasa_cp(a, r, t):
    """cp0 with the same extension rules as the Rust code."""
    t = np.asarray(t, dtype=float)
    poly = lambda x: r * (a[0] + x * (a[1] + x * (a[2] + x * (a[3] + x * a[4]))))
    dpoly = lambda x: r * (a[1] + x * (2 * a[2] + x * (3 * a[3] + x * 4 * a[4])))
    return np.where(
        t < 200.0, poly(200.0), np.where(t > 1000.0, poly(1000.0) + dpoly(1000.0) * (t - 1000.0), poly(t))
    )


def nasa_h(a, r, t):
    """h0(T) - h0(T_REF) with the same extension rules as the Rust code."""

    def prim(x):
        return r * x * (a[0] + x * (a[1] / 2 + x * (a[2] / 3 + x * (a[3] / 4 + x * a[4] / 5))))

    def raw(x):
        if x < 200.0:
            return prim(200.0) + nasa_cp(a, r, 200.0) * (x - 200.0)
        if x > 1000.0:
            d = x - 1000.0
            slope = r * (a[1] + 1000.0 * (2 * a[2] + 1000.0 * (3 * a[3] + 1000.0 * 4 * a[4])))
            return prim(1000.0) + nasa_cp(a, r, 1000.0) * d + 0.5 * slope * d * d
        return prim(x)

    return np.array([raw(x) - raw(T_REF) for x in np.atleast_1d(t)])


# --------------------------------------------------------------------------
# 2. Virial fit
# --------------------------------------------------------------------------
def basis(t, rho, kind):
    """Columns multiplying the coefficients (k = 1..3 for B, C, D; i = 0..3)."""
    tau = T0 / t
    cols = []
    for k in range(1, N_RHO + 1):
        for i in range(N_TAU):
            b = rho**k * tau**i
            if kind == "z":  # Z - 1
                cols.append(b)
            elif kind == "hdep":  # (h - h0) / (R T) = u_r/(RT) + Z - 1
                cols.append(b * (1.0 + i / k))
            elif kind == "cvr":  # (cv - cv0) / R
                cols.append(-b * i * (i - 1) / k)
            elif kind == "tpt":  # T (dp/dT)_rho / (rho R T) - 1
                cols.append(b * (1.0 - i))
            elif kind == "prho":  # (dp/drho)_T / (R T) - 1
                cols.append(b * (k + 1.0))
            else:
                raise ValueError(kind)
    return np.array(cols).T


def fit_virial(fluid, r, n_rho=N_RHO, z_only=False):
    """The joint fit; `n_rho` = 2 keeps B and C only (D = 0), `z_only` fits Z alone."""
    pts = [reference_state(fluid, r, t, p) for t in FIT_T for p in FIT_P]
    t = np.array([s["T"] for s in pts])
    rho = np.array([s["rho"] for s in pts])
    z = np.array([s["Z"] for s in pts])
    hdep = np.array([s["h_dep"] for s in pts]) / (r * t)
    cvr = np.array([s["cv"] - (s["cp0"] - r) for s in pts]) / r
    a = np.vstack(
        [basis(t, rho, "z") / z[:, None], W_HDEP * basis(t, rho, "hdep"), W_CV * basis(t, rho, "cvr")]
    )
    b = np.concatenate([(z - 1.0) / z, W_HDEP * hdep, W_CV * cvr])
    if z_only:
        a, b = a[: len(z)], b[: len(z)]
    kept = n_rho * N_TAU
    coef, *_ = scipy.linalg.lstsq(a[:, :kept], b)
    return np.concatenate([coef, np.zeros(N_RHO * N_TAU - kept)]).reshape(N_RHO, N_TAU)


def virial_props(coef, a, r, t, rho):
    """Model Z, cp, h (reference T_REF) and h departure, as in the Rust code."""
    c = coef.ravel()
    t = np.asarray(t, float)
    rho = np.asarray(rho, float)
    z = 1.0 + basis(t, rho, "z") @ c
    tpt = rho * r * t * (1.0 + basis(t, rho, "tpt") @ c)
    prho = r * t * (1.0 + basis(t, rho, "prho") @ c)
    cv = nasa_cp(a, r, t) - r + r * (basis(t, rho, "cvr") @ c)
    cp = cv + tpt**2 / (t * rho**2 * prho)
    hdep = r * t * (basis(t, rho, "hdep") @ c)
    h = nasa_h(a, r, t) + hdep
    return z, cp, h, hdep


# --------------------------------------------------------------------------
# Output helpers
# --------------------------------------------------------------------------
def rust_f64(x):
    """Shortest literal that round-trips to the same f64."""
    return repr(float(x))


def write_fixture(name, fluid, r, rows):
    path = os.path.join(HERE, f"coolprop_{name}.csv")
    cols = ["T_K", "p_Pa", "rho_kg_m3", "Z", "cp_J_kgK", "cv_J_kgK", "h_J_kg", "h_dep_J_kg", "cp0_J_kgK", "h0_J_kg"]
    keys = ["T", "p", "rho", "Z", "cp", "cv", "h", "h_dep", "cp0", "h0"]
    with open(path, "w", newline="\n") as f:
        f.write(f"# CoolProp {CoolProp.__version__} reference data for '{fluid}', written by tests/data/make_gas_fixture.py\n")
        f.write(f"# Z = p / (rho R T) with R = {r} J/(kg K) (the R of the Rust models)\n")
        f.write(f"# h, h0: enthalpy relative to the ideal-gas state at T = {T_REF} K (CoolProp state at p = {P_IDEAL} Pa)\n")
        f.write("# h_dep = h - h0 (enthalpy departure at the same T); cp0, h0: ideal-gas values at T\n")
        f.write(",".join(cols) + "\n")
        for s in rows:
            f.write(",".join(f"{s[k]:.10g}" for k in keys) + "\n")
    return path


# The accuracy tables' grids: 1 K steps over 200-1000 K for the ideal-gas part
# (h0 compared every 10 K); for the real gas, 5 K steps and 30 log-spaced
# pressures plus those of the fixture, on two grids: 250-400 K x 1-10 bar and
# 200-500 K x 1-300 bar (whose 250-400 K part is the 1-300 bar row's grid).
IDEAL_CHECK_T = np.linspace(200.0, 1000.0, 801)
CHECK_GRIDS = {10: (250.0, 400.0, 1e5, 1e6), 300: (200.0, 500.0, 1e5, 3e7)}


def check_grid(tlo, thi, plo, phi):
    ts = np.arange(tlo, thi + 1e-9, 5.0)
    ps = np.union1d(np.geomspace(plo, phi, 30), [x * 1e5 for x in FIX_P_BAR if plo <= x * 1e5 <= phi])
    return ts, ps


def write_fine(name, fluid, r):
    """tests/data/coolprop_<name>_fine.csv: CoolProp on the accuracy tables' grids."""
    path = os.path.join(HERE, f"coolprop_{name}_fine.csv")
    with open(path, "w", newline="\n") as f:
        f.write(f"# CoolProp {CoolProp.__version__} values for '{fluid}' on the grids of docs/gas.md's tables 'Fit' and\n")
        f.write("# 'Accuracy reached', written by tests/data/make_gas_fixture.py (enthalpies as in coolprop_<gas>.csv).\n")
        f.write("# grid 0: the ideal gas, T = 200..1000 K by 1 K (p, rho, cp, h, h_dep empty); grid 10 or 300: the real\n")
        f.write("# gas on the check grid of 5 K steps x 30 log-spaced pressures up to 10 or 300 bar plus the fixture's\n")
        f.write("# (cp0, h0 empty)\n")
        f.write("grid,T_K,p_Pa,rho_kg_m3,cp_J_kgK,h_J_kg,h_dep_J_kg,cp0_J_kgK,h0_J_kg\n")
        for t in IDEAL_CHECK_T:
            f.write(f"0,{t:.10g},,,,,,{cp0(fluid, t):.10g},{h_ideal(fluid, t):.10g}\n")
        for grid, rng in CHECK_GRIDS.items():
            ts, ps = check_grid(*rng)
            for t in ts:
                for p in ps:
                    s = reference_state(fluid, r, t, p)
                    f.write(f"{grid}," + ",".join(f"{s[k]:.10g}" for k in ["T", "p", "rho", "cp", "h", "h_dep"]) + ",,\n")
    return path


ALTERNATIVES = os.path.join(HERE, "gas_alternative_fits.csv")


def accuracy(fluid, r, coef, a, tlo, thi, plo, phi):
    """Largest |Z|, |cp| relative errors and |h - h0|, |h| errors [J/kg] on a check grid."""
    # 5 K steps and 30 log-spaced pressures plus those of the fixture,
    # so that the maxima bound what the Rust tests see on the fixture.
    ts, ps = check_grid(tlo, thi, plo, phi)
    st = [reference_state(fluid, r, t, p) for t in ts for p in ps]
    t = np.array([s["T"] for s in st])
    rho = np.array([s["rho"] for s in st])
    z, cp, h, hdep = virial_props(coef, a, r, t, rho)
    ez = np.abs(z / np.array([s["Z"] for s in st]) - 1).max()
    ecp = np.abs(cp / np.array([s["cp"] for s in st]) - 1).max()
    ehd = np.abs(hdep - np.array([s["h_dep"] for s in st])).max()
    eh = np.abs(h - np.array([s["h"] for s in st])).max()
    return ez, ecp, ehd, eh


def write_alternatives():
    """tests/data/gas_alternative_fits.csv: the fits docs/gas.md compares the joint fit with
    (Z alone; B and C alone) on the 250-400 K x 1-300 bar check grid, and CoolProp's second
    virial coefficient at 300 K, which crates/gas/src/doc_numbers.rs compares with the page."""
    with open(ALTERNATIVES, "w", newline="\n") as f:
        f.write(f"# CoolProp {CoolProp.__version__}, scipy {scipy.__version__}, numpy {np.__version__}; written by\n")
        f.write("# tests/data/make_gas_fixture.py (--alternatives). fit: joint (the shipped fit), z_alone (Z residuals\n")
        f.write("# only), b_and_c (the joint fit without D); errors: largest over 250-400 K x 1-300 bar (the check\n")
        f.write("# grid), Z and cp in %, h - h0 and h in J/kg. coolprop_b_300k: CoolProp's Bvirial at 300 K in m3/kg\n")
        f.write("gas,fit,z_percent,cp_percent,h_dep_J_kg,h_J_kg,coolprop_b_300k_m3_kg\n")
        for name, (fluid, r) in GASES.items():
            a, _, _ = fit_nasa(fluid, r)
            b_cp = CP.PropsSI("Bvirial", "T", 300.0, "Dmolar", 1.0e-3, fluid) / CP.PropsSI("molarmass", fluid)
            for fit, kw in [("joint", {}), ("z_alone", {"z_only": True}), ("b_and_c", {"n_rho": 2})]:
                coef = fit_virial(fluid, r, **kw)
                ez, ecp, ehd, eh = accuracy(fluid, r, coef, a, 250, 400, 1e5, 3e7)
                f.write(f"{name},{fit},{100*ez:.4g},{100*ecp:.4g},{ehd:.4g},{eh:.4g},{b_cp:.6g}\n")
    return ALTERNATIVES


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-write", action="store_true", help="do not write the CSV fixtures")
    ap.add_argument("--fine-only", action="store_true", help="only write the fine-grid CSVs (no fit)")
    ap.add_argument("--alternatives", action="store_true", help="only write gas_alternative_fits.csv")
    args = ap.parse_args()
    if args.alternatives:
        print("# wrote", write_alternatives())
        return 0
    if args.fine_only:
        for name, (fluid, r) in GASES.items():
            print("# wrote", write_fine(name, fluid, r))
        return 0

    print(f"# CoolProp {CoolProp.__version__}, scipy {scipy.__version__}, numpy {np.__version__}")
    table = []
    for name, (fluid, r) in GASES.items():
        a, rel, _ = fit_nasa(fluid, r)
        coef = fit_virial(fluid, r)

        rows = [reference_state(fluid, r, float(t), p * 1e5) for t in FIX_T for p in FIX_P_BAR]
        if not args.no_write:
            print("# wrote", write_fixture(name, fluid, r, rows))
            print("# wrote", write_fine(name, fluid, r))
            if name == "nitrogen":
                print("# wrote", write_alternatives())

        # ---- Rust constants
        print(f"\n// {name}: NASA cp/R coefficients a1..a5 (T in K), fit 200-1000 K")
        print(f"const NASA_{name.upper()}: [f64; 5] = [")
        for x in a:
            print(f"    {rust_f64(x)},")
        print("];")
        print(f"// {name}: virial coefficients [B; C; D], each sum_i c_i (T0/T)^i, T0 = {T0} K")
        print(f"const VIRIAL_{name.upper()}: [[f64; {N_TAU}]; {N_RHO}] = [")
        for k in range(N_RHO):
            print("    [" + ", ".join(rust_f64(x) for x in coef[k]) + "],")
        print("];")

        # ---- accuracy on a dense check grid (not the training grid)
        tt = IDEAL_CHECK_T
        cp_ref = np.array([cp0(fluid, x) for x in tt])
        e_cp0 = nasa_cp(a, r, tt) / cp_ref - 1.0
        dcp_abs = np.abs(nasa_cp(a, r, tt) - cp_ref).max()
        h0_ref = np.array([h_ideal(fluid, x) for x in tt[::10]])
        e_h0 = np.abs(nasa_h(a, r, tt[::10]) - h0_ref).max()
        print(
            f"// {name} cp0 fit 200-1000 K: max rel {np.abs(e_cp0).max():.4e}, rms rel "
            f"{np.sqrt(np.mean(e_cp0**2)):.2e}, max abs {dcp_abs:.4f} J/(kg K); max |h0 err| {e_h0:.1f} J/kg"
        )

        for label, rng in [
            ("250-400 K, 1-10 bar", (250, 400, 1e5, 1e6)),
            ("250-400 K, 1-300 bar", (250, 400, 1e5, 3e7)),
            ("200-500 K, 1-300 bar", (200, 500, 1e5, 3e7)),
        ]:
            ez, ecp, ehd, eh = accuracy(fluid, r, coef, a, *rng)
            table.append(f"| {name} | {label} | {100*ez:.3f} % | {100*ecp:.2f} % | {ehd:.0f} | {eh:.0f} |")

    print("\n| gas | range | max abs Z error | max abs cp error | max abs h departure error [J/kg] | max abs h error [J/kg] |")
    print("|---|---|---|---|---|---|")
    for line in table:
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
