#!/usr/bin/python3
"""Two or more mill runs' products side by side (issue 31, item 3: the dust-threshold scan at
steady state). Per run, from its result.json: whether its window was steady, the hold-up at the
end, the product that crossed the outlet over the product window (outlet_psd: tracked particles
and ledger dust) and the dust its window made (what the paper's "dust exits at once" would count
as product); then the Kolmogorov–Smirnov distance between each pair of runs' mass distributions,
max |F_a − F_b| over the shared class edges, for both products.

    /usr/bin/python3 bench/product_pair.py RUN_A RUN_B [RUN_C ...]
"""
import argparse
import json
import sys

from multi_rate_table import ks as outlet_ks
from steady_mill import made_in_window, quantiles


def load(run_dir):
    r = json.load(open(f"{run_dir}/result.json"))
    scene = json.load(open(f"{run_dir}/scene.json"))
    psd = r["outlet_psd"]
    h = r["holdup_history"]
    s = r.get("steady_state") or {}
    window = r.get("product_window_s") or s.get("window_s")
    if not window:
        sys.exit(f"{run_dir}: no product window (product_window_s) in result.json")
    made = made_in_window(h, window[0])
    return {
        "result": r,
        "name": run_dir.rstrip("/").split("/")[-1],
        "threshold_um": scene.get("dust", {}).get("threshold_diameter_m", float("nan")) * 1e6,
        "window_ms": [w * 1e3 for w in window],
        "steady": s,
        "particles": r["particles"]["final"],
        "particles_ug": h["particles_kg"][-1] * 1e9,
        "ledger_ug": h["dust_held_kg"][-1] * 1e9,
        "edges_m": psd["edges_m"],
        "out_kg": psd["mass_kg"],  # by class, over the window, as it left
        "out_under_kg": psd.get("under_range_mass_kg", 0.0),
        "made_kg": made[1:-1],  # by class (no under/overflow), made in the window
        "wall_h": r.get("wall_time_total_s", r["wall_time_s"]) / 3600.0,
    }


def cumulative(masses):
    total = sum(masses)
    acc, out = 0.0, [0.0]
    for m in masses:
        acc += m
        out.append(acc / total if total > 0 else 0.0)
    return out


def made_ks(a, b):
    """KS distance of two runs' dust made in their windows (the outlet's: multi_rate_table.ks)."""
    return max(abs(x - y) for x, y in zip(cumulative(a["made_kg"]), cumulative(b["made_kg"])))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("runs", nargs="+")
    runs = [load(d) for d in ap.parse_args().runs]
    edges = runs[0]["edges_m"]
    for r in runs[1:]:
        if r["edges_m"] != edges:
            sys.exit(f"{r['name']}: its PSD classes differ from {runs[0]['name']}'s")
    print("| run | threshold (µm) | window (ms) | out / fed | particles held Δ / fed "
          "| ledger Δ / fed | steady | particles | held (µg) | ledger (µg) | wall (h) |")
    print("| --- " * 11 + "|")
    for r in runs:
        s = r["steady"]
        fed = s.get("fed_kg") or float("nan")
        print(f"| {r['name']} | {r['threshold_um']:g} | {r['window_ms'][0]:g}–{r['window_ms'][1]:g} "
              f"| {s.get('outflow_to_feed', float('nan')):.3f} "
              f"| {s.get('particles_change_kg', float('nan')) / fed:+.3f} "
              f"| {s.get('dust_held_change_kg', float('nan')) / fed:+.3f} | {s.get('steady')} "
              f"| {r['particles']} | {r['particles_ug']:.0f} | {r['ledger_ug']:.0f} "
              f"| {r['wall_h']:.2f} |")
    print()
    print("| run | product at the outlet (µg) | d10 / d50 / d90 (µm) "
          "| dust made in the window (µg) | d10 / d50 / d90 (µm) |")
    print("| --- " * 5 + "|")
    for r in runs:
        out = quantiles(edges, r["out_kg"])
        made = quantiles(edges, r["made_kg"])
        print(f"| {r['name']} | {(sum(r['out_kg']) + r['out_under_kg']) * 1e9:.1f} "
              f"| {' / '.join(f'{x:.2f}' for x in out)} | {sum(r['made_kg']) * 1e9:.1f} "
              f"| {' / '.join(f'{x:.2f}' for x in made)} |")
    print()
    print("Kolmogorov–Smirnov distance between the mass distributions (outlet; dust made):")
    print()
    for i, a in enumerate(runs):
        for b in runs[i + 1:]:
            print(f"- {a['name']} – {b['name']}: {outlet_ks(a['result'], b['result']):.3f}; "
                  f"{made_ks(a, b):.3f}")


if __name__ == "__main__":
    main()
