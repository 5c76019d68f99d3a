#!/usr/bin/env bash
# Quick start, first command: set up, build, and run the main job — a paper
# simulation and the section 5 sensitivity study with its plots in out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh default
piezo=build/default/host/piezo
mkdir -p out
"$piezo" simulate --config configs/paper.toml --out out/paper-baseline.csv
"$piezo" sensitivity --config configs/paper.toml --out out/sensitivity
echo "main job done: out/paper-baseline.csv, out/sensitivity/*.png"
