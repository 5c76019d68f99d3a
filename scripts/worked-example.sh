#!/usr/bin/env bash
# The worked example of docs/analysis.md: a simulated rig whose motor differs from
# Table 1 is run, its log identified, and the Coulomb and LuGre models
# compared on it. Writes out/worked-example/. Expects a built tree
# (scripts/setup.sh); the run uses the virtual clock so the figures repeat.
set -euo pipefail
cd "$(dirname "$0")/.."
piezo=build/default/host/piezo
out=out/worked-example
rm -rf "$out"
mkdir -p "$out"
# The "rig": a plant with its own sigma0, F_N and d_e; the host's model stays at Table 1.
"$piezo" run --config configs/sim.toml --set run.clock=virtual \
  --set plant.sigma0=2100 --set plant.F_N=5.4e-3 --set plant.d_e=0.5e-6 --out "$out/run"
"$piezo" report "$out/run"
"$piezo" identify --log "$out/run/run.h5" --out "$out/fitted.toml"
"$piezo" compare --log "$out/run/run.h5" --out "$out/compare"
echo "worked example: $out/run/report/*.png, $out/fitted.toml, $out/compare/compare.png"
