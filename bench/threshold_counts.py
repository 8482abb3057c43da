#!/usr/bin/python3
"""What a lower dust threshold would track, from a steady mill's result.json: the ledger's dust
held by PSD class over the steady window (steady_projection.slots.dust.mean_held_kg), the classes
at or above each threshold counted as the spheres they would become at their class's geometric
centre. With the tracked particles the run ended with, that is the population a run of the same
mill at that threshold starts from at its steady state (issue 31, item 3), and the smallest tracked
diameter sets its contact time step (Hertz: t_c scales with the diameter at a given speed).

    /usr/bin/python3 bench/threshold_counts.py RUN_DIR [--thresholds-um 25,10,5] [--density KG_M3]

The run's threshold and its feed material's density come from RUN_DIR/scene.json.
"""
import argparse
import json
import math

from impact_rates import feed_density


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dir")
    ap.add_argument("--density", type=float, help="particle density, kg/m3 (default: the feed's)")
    ap.add_argument("--thresholds-um", default="25,10,5")
    a = ap.parse_args()
    r = json.load(open(a.run_dir + "/result.json"))
    scene = json.load(open(a.run_dir + "/scene.json"))
    run_threshold_um = scene["dust"]["threshold_diameter_m"] * 1e6
    if a.density is None:
        a.density = feed_density(scene)
    proj = r["steady_projection"]
    lower = proj["slots"]["lower_edge_m"]  # 0, then the PSD edges: slot s is [lower[s], lower[s+1])
    held = proj["slots"]["dust"]["mean_held_kg"]
    tracked = r["particles"]["final"]
    print(f"window {proj['window_s'][0] * 1e3:.1f}-{proj['window_s'][1] * 1e3:.1f} ms; "
          f"ledger held {sum(held) * 1e9:.1f} ug; tracked particles at the end: {tracked}")
    print("| threshold (µm) | ledger dust at or above it (µg) | spheres it makes | "
          f"smallest tracked diameter / {run_threshold_um:g} µm |")
    print("| --- | --- | --- | --- |")
    for t_um in [float(x) for x in a.thresholds_um.split(",")]:
        mass = count = 0.0
        for s, m in enumerate(held):
            lo = lower[s]
            if s + 1 >= len(lower) or lo < 0.99 * t_um * 1e-6:
                continue  # below the threshold, or the overflow slot (no upper edge)
            d = math.sqrt(lo * lower[s + 1])
            mass += m
            count += m / (a.density * math.pi / 6.0 * d ** 3)
        print(f"| {t_um:g} | {mass * 1e9:.1f} | {count:,.0f} | {t_um / run_threshold_um:.2f} |")


if __name__ == "__main__":
    main()
