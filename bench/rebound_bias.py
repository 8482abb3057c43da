#!/usr/bin/env python3
"""The rebound error a run's own impacts carry at its steps per contact N (docs/contact-model.md,
"Steps per contact as an error budget"). N resolves the shortest contact only (the smallest
particle on the stiffest wall at the impact speed bound); an impact of a particle of diameter d at
normal speed V has M = N · (d / d_min) · (V_max / V)^{1/5} steps (t_c ∝ d V^{-1/5}), more for a
pair of salt spheres than for salt on steel (t_c 1.146 times as long, bench/impact_resolution.cpp).
Its rebound is low by b_N · (N / M)², with b_N the measured mean at N steps (−5.5 % at 8, −2.5 % at
12, −0.87 % at 20 for e = 0.5; the error falls as dt²). Weighted by the run's impact spectrum
(result.json impact_spectrum: impacts by size and normal specific energy V²/2), over all impacts
and over those whose mass-specific energy times size exceeds the breakage threshold x·W_min.

    python3 bench/rebound_bias.py RUN_DIR... [--n N] [--d-min M] [--v-max V] [--x-w-min J_M_PER_KG]
defaults: the shipped mill (N 8, d_min 10 um, V_max 60 m/s, x W_min 0.003 J m/kg).
"""
import argparse
import json
import math
import pathlib

MEAN_REBOUND_ERROR = {8: -5.5, 10: -3.5, 12: -2.5, 16: -1.4, 20: -0.87, 40: -0.22}  # %, e = 0.5
PAIR_CONTACT_TIME_RATIO = 1.146  # salt on salt against salt on steel, same size and speed


def bias(run, n, d_min, v_max, x_w_min):
    spectrum = json.loads((pathlib.Path(run) / "result.json").read_text())["impact_spectrum"]
    energy, size = spectrum["energy_edges_j_per_kg"], spectrum["size_edges_m"]
    at_n = MEAN_REBOUND_ERROR[n]
    sums = {"all": [0.0, 0.0], "breakage": [0.0, 0.0]}
    for group in spectrum["groups"]:
        ratio = PAIR_CONTACT_TIME_RATIO if group["kind"] == "particle-particle" else 1.0
        for i, row in enumerate(group["normal_counts"]):
            d = math.sqrt(size[i] * size[i + 1])
            for j, count in enumerate(row):
                if not count:
                    continue
                w = math.sqrt(energy[j] * energy[j + 1])
                steps = max(n, n * ratio * (d / d_min) * (v_max / math.sqrt(2 * w)) ** 0.2)
                error = at_n * (n / steps) ** 2
                for key in ("all", "breakage") if w * d >= x_w_min else ("all",):
                    sums[key][0] += count * error
                    sums[key][1] += count
    return {k: (s / c if c else float("nan"), int(c)) for k, (s, c) in sums.items()}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--n", type=int, default=8, choices=sorted(MEAN_REBOUND_ERROR))
    parser.add_argument("--d-min", type=float, default=10e-6)
    parser.add_argument("--v-max", type=float, default=60.0)
    parser.add_argument("--x-w-min", type=float, default=0.003)
    a = parser.parse_args()
    print(f"| run | impacts | mean rebound error at N = {a.n} | impacts above x W_min | their mean |")
    print("| --- | --- | --- | --- | --- |")
    for run in a.runs:
        b = bias(run, a.n, a.d_min, a.v_max, a.x_w_min)
        print(f"| {pathlib.Path(run).name} | {b['all'][1]} | {b['all'][0]:+.3f} % | {b['breakage'][1]} "
              f"| {b['breakage'][0]:+.3f} % |")


if __name__ == "__main__":
    main()
