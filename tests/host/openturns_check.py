#!/usr/bin/python3
"""An independent implementation checks our Sobol' indices: OpenTURNS
(python3-openturns from Debian) reads the very design and outputs that
`piezo sensitivity --method sobol --out DIR` wrote (DIR/design.csv, in
OpenTURNS's own A, B, E_1..E_k order) and its Saltelli first-order and
Jansen total indices must lie inside our bootstrap 95 % intervals. On the
Ishigami function, OpenTURNS on its own Sobol'-sequence design must find
the analytic indices.
usage: openturns_check.py DIR"""
import csv
import math
import sys

import openturns as ot

out_dir = sys.argv[1]
failures = []

with open(f"{out_dir}/design.csv") as f:
    rows = list(csv.reader(f))
names, data = rows[0][:-1], [[float(v) for v in r] for r in rows[1:]]
k = len(names)
n = len(data) // (k + 2)
inputs = ot.Sample([r[:-1] for r in data])
outputs = ot.Sample([[r[-1]] for r in data])
first = ot.SaltelliSensitivityAlgorithm(inputs, outputs, n).getFirstOrderIndices()
total = ot.JansenSensitivityAlgorithm(inputs, outputs, n).getTotalOrderIndices()

with open(f"{out_dir}/sobol.csv") as f:
    ours = {r["name"]: r for r in csv.DictReader(f)}
for i, name in enumerate(names):
    o = ours[name]
    for label, theirs, lo, hi, est in (("S1", first[i], o["S1_low"], o["S1_high"], o["S1"]),
                                       ("ST", total[i], o["ST_low"], o["ST_high"], o["ST"])):
        inside = float(lo) <= theirs <= float(hi)
        print(f"{name:>6} {label}: piezo {float(est):+.4f} [{float(lo):+.4f}, {float(hi):+.4f}], "
              f"OpenTURNS {theirs:+.4f} {'inside' if inside else 'OUTSIDE'}")
        if not inside:
            failures.append(f"{name} {label}")

# Ishigami (a = 7, b = 0.1): S = (0.3139, 0.4424, 0), ST = (0.5576, 0.4424, 0.2437).
ot.RandomGenerator.SetSeed(1)
ishigami = ot.SymbolicFunction(["x1", "x2", "x3"], ["sin(x1) + 7 * sin(x2)^2 + 0.1 * x3^4 * sin(x1)"])
distribution = ot.ComposedDistribution([ot.Uniform(-math.pi, math.pi)] * 3)
size = 8192
design = ot.SobolIndicesExperiment(distribution, size).generate()
values = ishigami(design)
s1 = ot.SaltelliSensitivityAlgorithm(design, values, size).getFirstOrderIndices()
st = ot.JansenSensitivityAlgorithm(design, values, size).getTotalOrderIndices()
for i, (a1, at) in enumerate(((0.3139, 0.5576), (0.4424, 0.4424), (0.0, 0.2437))):
    ok = abs(s1[i] - a1) < 0.03 and abs(st[i] - at) < 0.03
    print(f"Ishigami x{i + 1}: OpenTURNS S1 {s1[i]:.4f} (analytic {a1}), ST {st[i]:.4f} (analytic {at})")
    if not ok:
        failures.append(f"Ishigami x{i + 1}")

for f in failures:
    print("FAIL:", f)
print("OpenTURNS agrees" if not failures else "OpenTURNS disagrees")
sys.exit(1 if failures else 0)
