#!/usr/bin/env python3
"""Accuracy-cost study behind the solver defaults of models/meter_out.json.

For the paper's four throttle settings (Table 1) at 4 and 7 bar, simulates
CYCLES cycles at each (rtol = atol, max_step) pair and compares cycle 1 and
the last cycle with a converged run (rtol = atol = 1e-9, max_step 10 ms).
Prints one markdown row per setting: the worst relative error over the eight
operating points, and the summed steps and model evaluations.

Usage: python3 scripts/tolerance_study.py [path/to/pneumo] [cycles]
(build first: cargo build --release -p pneumo-cli)
"""
import json, os, subprocess, sys, tempfile

PNEUMO = sys.argv[1] if len(sys.argv) > 1 else "target/release/pneumo"
CYCLES = int(sys.argv[2]) if len(sys.argv) > 2 else 5
THROTTLES = [1.41, 2.68, 13.2, 210.0]  # flow_control.C [L/min/bar], Table 1 switches 4, 3, 2, 1
PRESSURES = [4.0, 7.0]
SETTINGS = [(r, m) for m in ["50 ms", "200 ms", "1 s"] for r in [1e-3, 3e-4, 1e-4, 1e-5, 1e-6]]


def run(c, ps, rtol, max_step):
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "s.json")
        subprocess.run([PNEUMO, "simulate", "models/meter_out.json", "--cycles", str(CYCLES),
                        "--set", f"supply.p={ps} bar", "--set", f"flow_control.C={c} L/min/bar",
                        "--set", f"simulation.rtol={rtol}", "--set", f"simulation.atol={rtol}",
                        "--set", f"simulation.max_step={max_step}", "--summary", out],
                       check=True, stdout=subprocess.DEVNULL)
        s = json.load(open(out))
    cyc = s["cycles"]
    return cyc[0]["total_s"], cyc[-1]["total_s"], s["solver"]["steps"], s["solver"]["rhs_evaluations"]


ref = {(c, p): run(c, p, 1e-9, "10 ms") for c in THROTTLES for p in PRESSURES}
print(f"| rtol = atol | max_step | worst error, cycle 1 | worst error, cycle {CYCLES} | steps | evaluations |")
print("|---|---|---|---|---|---|")
for rtol, ms in SETTINGS:
    e1 = eN = 0.0
    steps = evals = 0
    for key, (r1, rN, _, _) in ref.items():
        t1, tN, st, ev = run(*key, rtol, ms)
        e1, eN = max(e1, abs(t1 / r1 - 1)), max(eN, abs(tN / rN - 1))
        steps += st
        evals += ev
    print(f"| {rtol:g} | {ms} | {e1:.1e} | {eN:.1e} | {steps} | {evals} |", flush=True)
