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
echo "figures written to $F"
