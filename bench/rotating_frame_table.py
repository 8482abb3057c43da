#!/usr/bin/env python3
"""The table of bench/rotating_frame.sh: per run its time stepping (the sum of the phase seconds,
without the gas spin-up and the output) and its speed-up against the base run beside it,
the neighbour search's and the contact forces' seconds, rebuilds, particles at the end, product
d10/d50/d90, breakage events by generation, and the KS distance of its product (outlet + dust, by
mass) to the base run of the same seed; then the base runs' own seed-to-seed KS (the base runs of
one seed are the same run three times: the same product, their times the timing's own noise).

    python3 bench/rotating_frame_table.py OUT_DIR
"""
import pathlib
import sys

from multi_rate_table import ks, load_runs, print_seed_scatter, stepping_s


def main():
    runs = load_runs(pathlib.Path(sys.argv[1]))
    print("| run | seed | time stepping s | against base | neighbours s | forces s | rebuilds "
          "| particles | d10 / d50 / d90 um | events by generation | KS to base |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    order = {"lab": 0, "turning": 1, "shares": 2}
    for (name, seed), r in sorted(runs.items(), key=lambda kv: (order.get(kv[0][0], 3), kv[0][1])):
        if name.startswith("base_"):
            continue
        base = runs.get((f"base_{name}", seed))
        t = stepping_s(r)
        against = stepping_s(base) / t if base else float("nan")
        phases, search = r["phase_seconds"], r["search"]
        p = r["outlet_psd"]
        gens = r["breakage"].get("events_by_generation", [])
        print(f"| {name} | {seed} | {t:.1f} | {against:.2f} | {phases['neighbors']:.1f} "
              f"| {phases['forces']:.1f} | {search['rebuilds']} | {r['particles']['final']} "
              f"| {p['d10_m'] * 1e6:.1f} / {p['d50_m'] * 1e6:.1f} / {p['d90_m'] * 1e6:.1f} "
              f"| {'/'.join(str(g) for g in gens)} | {ks(r, base) if base else float('nan'):.4f} |")
    for (name, seed), r in sorted(runs.items()):
        if name.startswith("base_"):
            print(f"\n{name} seed {seed}: {stepping_s(r):.1f} s", end="")
    print()
    print_seed_scatter(runs, "base_lab", "base")


if __name__ == "__main__":
    main()
