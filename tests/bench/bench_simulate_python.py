#!/usr/bin/env python3
"""Bench: piezo_rig.model.simulate() at its defaults (4.8 s, 48,001 samples
of eight columns) beside its integration alone (the same call sampling the
end only, dt = 4.8 s) and beside the samples of theta alone
(columns=("theta",)), best of N calls each, interleaved, in rounds.
Figures, not assertions.

Usage: PYTHONPATH=build/ci/python bench_simulate_python.py [N] [ROUNDS]
"""
import sys
import time

from piezo_rig import model


def best_ms(calls, n):
    """Best of n calls each, the calls interleaved: the machine's slow and
    fast spells (seconds long on a shared host) fall on all of them alike."""
    best = [float("inf")] * len(calls)
    for _ in range(n):
        for i, call in enumerate(calls):
            start = time.perf_counter()
            call()
            best[i] = min(best[i], time.perf_counter() - start)
    return [1e3 * b for b in best]


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    print(f"piezo_rig.model.simulate(), best of {n} calls each, interleaved, {rounds} rounds")
    print(f"{'whole call':>12} {'integration':>12} {'ratio':>6} {'theta only':>11} {'ratio':>6}")
    for _ in range(rounds):
        whole, alone, theta = best_ms([
            model.simulate,
            lambda: model.simulate(dt=4.8),
            lambda: model.simulate(columns=("theta",)),
        ], n)
        print(f"{whole:>9.2f} ms {alone:>9.2f} ms {whole / alone:>5.2f}x {theta:>8.2f} ms "
              f"{theta / alone:>5.2f}x")


if __name__ == "__main__":
    main()
