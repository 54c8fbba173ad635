#!/usr/bin/env python3
"""Black-box value fuzzing of the `pneumo` binary (docs/reliability.md,
"Mutations by value").

Where `crates/cli/tests/mutants.rs` edits the structure of a netlist, this
script replaces the *values* of a file with hostile ones — a 400-digit
string, text with control characters, 1e308, 5e-324, a quantity of the
wrong dimension, a list where a word belongs, null — and runs the binary on
the result:

  netlists       each shipped model of models/, one to three leaves replaced
                 (or deleted), through the commands given (check, simulate
                 --t-end 0.5, draw, report, linearize);
  discrepancy    the three measured vessel tests of models/examples/vessels/:
                 their manifest's leaves replaced or a sensor/set/time_origin
                 entry added, and one to three CSV cells made hostile, then a
                 whole `pneumo discrepancy` run (a few seconds each).

A run fails the check when it exits other than 0, 1 or 2, prints "panicked",
does not end in exactly one `error:` line when it fails, prints a line
longer than 1000 bytes or a number spelled out in 30 or more digits, or runs
longer than the time limit. Failing inputs are kept in --keep.

    cargo build --release --locked -p pneumo-cli
    python3 scripts/fuzz_values.py netlists --seed 1 --runs 300
    python3 scripts/fuzz_values.py discrepancy --seed 1 --runs 80
"""

import argparse
import copy
import json
import os
import random
import re
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "pneumo")
VESSELS = os.path.join(ROOT, "models", "examples", "vessels")

HOSTILE = [0, -1, -0.0, 1e308, -1e308, 5e-324, 1e20, 0.5, 2, 10**30, "", "x", "nan", "inf", "-inf",
           "1e400 bar", "0 bar", "-5 bar", "3 m", "1e-30 s", "\u00e9\u2603\x01" * 50, "7 bar bar", None, True,
           [], {}, [1, 2], {"a": 1}, "9" * 400, "1 L/min/bar", "0 K", "1e6 bar", "1 mm", "0 s", "1e9 s",
           "tank.p", "../../etc/passwd", "/dev/zero", "0.25 %FS", "1.5 K", "10 bar"]
CSV_HOSTILE = ["nan", "inf", "-inf", "1e308", "-1", "0", "", "x", "1e-320", "9" * 400, "\"a,b\"", "1,2"]
MANIFEST_EXTRAS = [("sensors", {"tank.T": {"accuracy": "1.5 K"}}), ("set", {"orifice.C": "1 L/min/bar"}),
                   ("time_origin", "1 s")]


def leaves(o, path=()):
    if isinstance(o, dict):
        for k, v in o.items():
            yield from leaves(v, path + (k,))
    elif isinstance(o, list):
        for i, v in enumerate(o):
            yield from leaves(v, path + (i,))
    if path:
        yield path


def mutate(rng, doc, edits):
    for _ in range(edits):
        path = rng.choice(list(leaves(doc)))
        parent = doc
        for p in path[:-1]:
            parent = parent[p]
        if rng.random() < 0.15:
            del parent[path[-1]]
        else:
            parent[path[-1]] = copy.deepcopy(rng.choice(HOSTILE))


def verdict(args, cwd, limit):
    """None when the run ended cleanly, else what was wrong."""
    try:
        run = subprocess.run(args, capture_output=True, text=True, timeout=limit, cwd=cwd)
    except subprocess.TimeoutExpired:
        return f"no end within {limit} s"
    err = run.stderr.strip()
    errors = [line for line in err.splitlines() if line.startswith("error")]
    # 3: a simulation or report that ended before its cycles, outputs
    # written (docs/netlist.md, docs/report.md); no other command exits 3
    allowed = (0, 1, 2, 3) if args[1] in ("simulate", "report") else (0, 1, 2)
    if run.returncode not in allowed:
        return f"exit status {run.returncode}"
    if "panicked" in err:
        return "panic"
    if run.returncode != 0 and len(errors) != 1:
        return f"{len(errors)} error lines"
    if any(len(line.encode()) > 1000 for line in err.splitlines()):
        return "a line longer than 1000 bytes"
    if re.search(r"\d{30,}", err):
        return "a number in 30 or more digits"
    return None


def netlists(rng, args, keep):
    models = sorted(os.path.join(ROOT, "models", m) for m in os.listdir(os.path.join(ROOT, "models")) if m.endswith(".json"))
    bad = 0
    for k in range(args.runs):
        model = rng.choice(models)
        doc = json.load(open(model))
        mutate(rng, doc, rng.choice([1, 1, 2, 3]))
        text = json.dumps(doc)
        with tempfile.TemporaryDirectory() as td:
            f = os.path.join(td, "m.json")
            open(f, "w").write(text)
            for c in args.commands.split(","):
                extra = {"check": [], "simulate": ["--t-end", "0.5", "--summary", os.path.join(td, "s.json")],
                         "draw": ["--out", os.path.join(td, "d.svg")], "report": ["--out", os.path.join(td, "r.html")],
                         "linearize": []}[c]
                wrong = verdict([BIN, c, f] + extra, os.path.dirname(model), args.limit)
                if wrong:
                    bad += 1
                    kept = os.path.join(keep, f"netlist_{args.seed}_{k}_{c}.json")
                    open(kept, "w").write(text)
                    print(f"{wrong}: {c} on a mutant of {os.path.basename(model)} (kept as {kept})")
    return bad


def discrepancy(rng, args, keep):
    bad = 0
    for k in range(args.runs):
        case = rng.choice(["air_discharge", "air_filling", "nitrogen_discharge"])
        doc = json.load(open(os.path.join(VESSELS, f"{case}_experiments.json")))
        if rng.random() < 0.4:
            key, value = rng.choice(MANIFEST_EXTRAS)
            doc["experiments"][0][key] = copy.deepcopy(value)
        mutate(rng, doc, rng.choice([0, 1, 1, 2]))
        rows = open(os.path.join(VESSELS, f"{case}.csv")).read().splitlines()
        if rng.random() < 0.5:
            for _ in range(rng.randint(1, 3)):
                i = rng.randrange(len(rows))
                cells = rows[i].split(",")
                cells[rng.randrange(len(cells))] = rng.choice(CSV_HOSTILE)
                rows[i] = ",".join(cells)
        with tempfile.TemporaryDirectory() as td:
            open(os.path.join(td, f"{case}.json"), "w").write(open(os.path.join(VESSELS, f"{case}.json")).read())
            open(os.path.join(td, f"{case}.csv"), "w").write("\n".join(rows) + "\n")
            manifest = os.path.join(td, "e.json")
            open(manifest, "w").write(json.dumps(doc))
            run = [BIN, "discrepancy", os.path.join(td, f"{case}.json"), "--experiments", manifest, "--report", os.path.join(td, "rep")]
            wrong = verdict(run, td, args.limit)
            if wrong:
                bad += 1
                stem = os.path.join(keep, f"discrepancy_{args.seed}_{k}")
                open(stem + ".json", "w").write(json.dumps(doc))
                open(stem + ".csv", "w").write("\n".join(rows) + "\n")
                print(f"{wrong}: discrepancy on a mutant of {case} (kept as {stem}.json/.csv)")
    return bad


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("kind", choices=["netlists", "discrepancy"])
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--runs", type=int, default=100)
    p.add_argument("--commands", default="check,simulate", help="netlists: commands to run, comma-separated")
    p.add_argument("--limit", type=float, default=60.0, help="time limit of one run [s]")
    p.add_argument("--keep", default=None, help="folder for failing inputs (default: a new temporary folder)")
    args = p.parse_args()
    keep = args.keep or tempfile.mkdtemp(prefix="pneumo-fuzz-")
    os.makedirs(keep, exist_ok=True)
    rng = random.Random(args.seed)
    bad = (netlists if args.kind == "netlists" else discrepancy)(rng, args, keep)
    print(f"{args.runs} mutants, {bad} failed the check")
    raise SystemExit(1 if bad else 0)


if __name__ == "__main__":
    main()
