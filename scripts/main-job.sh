#!/usr/bin/env bash
# Quick start, first command: set up, build, and run the main job — the
# simulated rig driven in real time for 4.8 s (configs/sim.toml), logged to a
# run directory with its plots, beside the paper's simulation and the
# section 5 sensitivity study in out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh default
piezo=build/default/host/piezo
run_dir="runs/$(date -u +%Y%m%dT%H%M%SZ)"
"$piezo" run --config configs/sim.toml --out "$run_dir"
"$piezo" report "$run_dir"
mkdir -p out
"$piezo" simulate --config configs/paper.toml --out out/paper-baseline.csv
"$piezo" sensitivity --config configs/paper.toml --out out/sensitivity
scripts/worked-example.sh
echo "main job done: $run_dir (run.h5, report/*.png), out/paper-baseline.csv, out/sensitivity/*.png, out/worked-example/"
