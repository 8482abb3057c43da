#!/usr/bin/env python3
"""The table of bench/scene_settings.sh: per run its time stepping (the sum of the phase seconds,
without the output), speed-up against the first variant's run of the same seed, the step,
product d10/d50/d90, breakage events by generation, the penetration limiter's events, the deepest
overlap at the end (in diameters) and the KS distance of its product (outlet + dust, by mass) to
the first variant's run of the same seed; then each variant's seed-to-seed scatter (KS between
every two seeds) and the medians.

    python3 bench/scene_settings_table.py OUT_DIR NAME [NAME ...]
"""
import pathlib
import statistics
import sys

from multi_rate_table import ks, load_runs, print_seed_scatter, stepping_s, um


def main():
    out, names = pathlib.Path(sys.argv[1]), sys.argv[2:]
    runs = load_runs(out)
    reference = names[0]
    print("| variant | seed | step ns | time stepping s | speed-up | d10 / d50 / d90 um "
          "| events by generation | limiter events | last max overlap / d | KS to "
          f"{reference} |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    speed_ups = {name: [] for name in names}
    for seed in sorted({seed for (_, seed) in runs}):
        ref = runs.get((reference, seed))
        for name in names:
            r = runs.get((name, seed))
            if r is None:
                continue
            p = r["outlet_psd"]
            gens = r["breakage"].get("events_by_generation", [])
            speed_up = stepping_s(ref) / stepping_s(r) if ref else float("nan")
            speed_ups[name].append(speed_up)
            print(f"| {name} | {seed} | {r['time_step_s'] * 1e9:.2f} | {stepping_s(r):.1f} "
                  f"| {speed_up:.2f} | {um(p['d10_m'])} / {um(p['d50_m'])} / {um(p['d90_m'])} "
                  f"| {'/'.join(str(g) for g in gens)} "
                  f"| {r['contacts'].get('penetration_limiter_events', 0)} "
                  f"| {r['contacts'].get('max_overlap_ratio', float('nan')):.4f} "
                  f"| {ks(r, ref) if ref else float('nan'):.4f} |")
    print()
    for name in names:
        ups = [u for u in speed_ups[name] if u == u]
        if ups:
            print(f"{name}: speed-up median {statistics.median(ups):.2f} "
                  f"(range {min(ups):.2f}-{max(ups):.2f}) over {len(ups)} seeds")
        print_seed_scatter(runs, name, f"{name}:")


if __name__ == "__main__":
    main()
