#!/usr/bin/env python3
"""Whole-process wall time of `pneumo simulate` against the hand-written
C + CVODE meter-out model, measured side by side in one run.

The C program is not part of this project: build it from
../shared/anchors/cvode_meter_out.c (SUNDIALS CVODE) and pass its path.
Each round runs every command once, in turn, so that machine load affects
all of them alike; the table shows medians and the ratio to CVODE at rtol 1e-5.

Usage: python3 scripts/vs_cvode.py path/to/cvode_meter_out [rounds] [path/to/pneumo]
"""
import statistics, subprocess, sys, tempfile, time, os

CVODE = sys.argv[1]
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 11
PNEUMO = sys.argv[3] if len(sys.argv) > 3 else "target/release/pneumo"
SUMMARY = os.path.join(tempfile.mkdtemp(), "s.json")
BASE = [PNEUMO, "simulate", "models/meter_out.json", "--cycles", "20", "--summary", SUMMARY]
COMMANDS = {
    "CVODE rtol 1e-5 (the issue's reference)": [CVODE, "4", "13.2", "20", "1e-5", "1"],
    "CVODE rtol 1e-4 (loosest within 0.1 %)": [CVODE, "4", "13.2", "20", "1e-4", "1"],
    "pneumo, model defaults": BASE,
    "pneumo rtol = atol = 1e-3 (loosest within 0.1 %)": BASE + ["--set", "simulation.rtol=1e-3", "--set", "simulation.atol=1e-3"],
}
wall = {k: [] for k in COMMANDS}
for _ in range(ROUNDS):
    for name, cmd in COMMANDS.items():
        t0 = time.perf_counter()
        subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        wall[name].append(time.perf_counter() - t0)
ref = statistics.median(wall["CVODE rtol 1e-5 (the issue's reference)"])
print(f"| command ({ROUNDS} rounds) | median wall | ratio to CVODE 1e-5 |")
print("|---|---|---|")
for name in COMMANDS:
    m = statistics.median(wall[name])
    print(f"| {name} | {1e3 * m:.1f} ms | {m / ref:.2f} |")
