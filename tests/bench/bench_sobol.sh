#!/usr/bin/env bash
# Bench: wall time of a Sobol' study over all fifteen parameters (default
# N = 1024: 17,408 runs of 4.8 s), on one core, on all cores, and under
# mpirun -n 2 (one thread per rank). Figures, not assertions.
# Usage: bench_sobol.sh PIEZO [N] [RUNTIME_S]
set -euo pipefail
piezo="$1" n="${2:-1024}" runtime="${3:-4.8}"
study=(sensitivity --method sobol --samples "$n" --runtime "$runtime" --seed 1 --json)
measure() {
  local label="$1"; shift
  local start end
  start=$(date +%s.%N)
  "$@" > /tmp/bench_sobol_$$.json 2>/dev/null
  end=$(date +%s.%N)
  printf "%-32s %8.1f s   %s\n" "$label" "$(echo "$end - $start" | bc)" \
    "$(python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print(j["runs"], "runs; top:", ", ".join(p["name"] for p in j["parameters"][:3]))' /tmp/bench_sobol_$$.json)"
}
echo "Sobol' study, all parameters, N = $n, ${runtime} s per run, $(nproc) cores"
measure "one core (PIEZO_THREADS=1)" env PIEZO_THREADS=1 "$piezo" "${study[@]}"
measure "all cores" "$piezo" "${study[@]}"
if command -v mpirun > /dev/null; then
  measure "mpirun -n 2, one thread each" mpirun -n 2 --oversubscribe --allow-run-as-root \
    -x PIEZO_THREADS=1 "$piezo" "${study[@]}"
fi
rm -f /tmp/bench_sobol_$$.json
