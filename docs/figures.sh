#!/usr/bin/env bash
# Regenerates every figure in docs/ from the models. Run from the repository root:
#   bash docs/figures.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p pneumo-cli
P=target/release/pneumo
[ -n "${CARGO_TARGET_DIR:-}" ] && P="$CARGO_TARGET_DIR/release/pneumo"
F=docs/figures
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT

# Meter-out, switch 2, 4 bar: one periodic cycle (the third) of velocity, temperatures, polytropic indices.
$P simulate models/meter_out.json --cycles 3 --out "$W/mo.csv" \
  --signals head.p,rod.p,head.T,rod.T,piston.x,piston.v,head.n,rod.n,head.n_est,rod.n_est,controller.command
# the third (periodic) cycle starts at the second return to 0 (t = 5.356 s, see the summary)
awk -F, 'NR==1 || ($1 >= 5.3560)' "$W/mo.csv" > "$W/mo3.csv"
$P plot "$W/mo3.csv" --signals piston.v -o $F/fig3_velocity.png --title "Piston velocity over a cycle (switch 2, 4 bar) — cf. paper Fig. 3"
$P plot "$W/mo3.csv" --signals head.T,rod.T -o $F/fig7_temperatures.png --title "Mean gas temperatures (switch 2, 4 bar) — cf. paper Fig. 7"
$P plot "$W/mo3.csv" --signals head.n,rod.n --y-range 0.6,2.2 -o $F/fig8_polytropic.png --title "Instantaneous polytropic index, Eq. 22 (switch 2, 4 bar) — cf. paper Fig. 8"
$P plot "$W/mo3.csv" --signals head.p,rod.p,piston.x -o $F/meter_out_cycle.png --title "Meter-out cycle (switch 2, 4 bar)"

# The tutorial's first plot (docs/tutorial.md, step 2): simulate --plot as the tutorial runs it.
$P simulate models/meter_out.json --cycles 3 --plot $F/tutorial_cycle.png > /dev/null

# Normalised trajectories for the four switch positions (paper Fig. 6): extend stroke of the first cycle.
for c in 1.41 2.68 13.2 210; do
  $P simulate models/meter_out.json --cycles 1 --set "flow_control.C=$c L/min/bar" --out "$W/sw_$c.csv" --signals piston.x,controller.command
  awk -F, 'NR==1 {print; next} $3 == 0 {exit} {print}' "$W/sw_$c.csv" > "$W/switch_C$c.csv"
done
$P plot "$W"/switch_C1.41.csv "$W"/switch_C2.68.csv "$W"/switch_C13.2.csv "$W"/switch_C210.csv --signals piston.x --normalize \
  -o $F/fig6_normalised.png --title "Normalised extend trajectories, C = 1.41 ... 210 L/min/bar, 4 bar — cf. paper Fig. 6"

# Cycle time against conductance at 4 and 7 bar (paper Fig. 4 and 5).
$P sweep models/meter_out.json --cycles 3 --jobs 2 \
  --vary "flow_control.C=1.41 L/min/bar,2.68 L/min/bar,13.2 L/min/bar,210 L/min/bar" --vary "supply.p=4 bar,7 bar" \
  --out docs/figures/table1_sweep.csv
$P plot --sweep docs/figures/table1_sweep.csv --x flow_control.C --y cycle_time_s --series supply.p -o $F/fig5_cycle_time.png \
  --title "Cycle time against speed-control conductance — cf. paper Fig. 5"

# The block library's example circuits (docs/circuits.md, "Circuits of the block library").
$P simulate models/mid_stop_5_3.json --out "$W/ms.csv"
$P plot "$W/ms.csv" --signals cyl.piston.x,cyl.head.p,cyl.rod.p -o $F/mid_stop_5_3.png --title "5/3 closed centre: stop in mid-stroke and hold"
$P simulate models/sequence_ab.json --out "$W/seq.csv"
$P plot "$W/seq.csv" --signals cyl_a.piston.x,cyl_b.piston.x -o $F/sequence_ab.png --title "Sequence A+ B+ A- B- from limit switches"
$P simulate models/vertical_lift.json --out "$W/lift.csv"
$P plot "$W/lift.csv" --signals line.p,cyl.head.p,cyl.piston.x -o $F/vertical_lift.png --title "Vertical lift of 50 kg: regulated line at 5 barg"
$P simulate models/hose_5m.json --cycles 1 --out "$W/hose.csv"
$P plot "$W/hose.csv" --signals valve_port.p,hose.p10,cyl.head.p -o $F/hose_5m.png --title "5 m hose: the pressure step at the valve, mid-hose and at the cylinder"
$P simulate models/quick_exhaust.json --out "$W/qev.csv"
$P plot "$W/qev.csv" --signals cyl.piston.x,cyl.head.p -o $F/quick_exhaust.png --title "Quick-exhaust valve at the head port"
$P simulate models/cushioning.json --cycles 1 --out "$W/cush.csv"
$P plot "$W/cush.csv" --signals cyl.piston.v,cyl.rod.p -o $F/cushioning.png --title "End-of-stroke cushioning: speed and cushion pressure"
$P simulate models/position_control.json --out "$W/servo.csv"
$P plot "$W/servo.csv" --signals setpoint.command,sensor.x -o $F/position_control.png --title "Servo-pneumatic position control: setpoint and position"
echo "figures written to $F"

# Circuit diagrams (docs/draw.md) and the symbol sheet.
for m in meter_out meter_in mid_stop_5_3 sequence_ab position_control; do
  $P draw models/$m.json --out $F/diagram_$m.png --scale 1.5
done
$P draw models/meter_out.json --out $F/diagram_meter_out.svg
cargo run --release -q -p pneumo-draw --example render -- "$W" --catalogue
cp "$W/symbols.png" $F/draw_symbols.png

# The report page in headless Chromium (docs/report.md, README); needs
# scripts/install-browser.
if command -v chromium >/dev/null; then
  PNEUMO_SCREENSHOT_DIR="$PWD/$F" scripts/browser-test
fi
