#!/usr/bin/python3
"""The steady state a mill run is heading for, projected from the rates it measured
(result.json's steady_projection, docs/spiral-jet-mill.md): for each run the window, whether a
steady state exists (and which classes would grow without end if not), the steady hold-up, the
time to steady from the run's end and its spread over redrawn rates, the product (d10/d50/d90
and its mass by size group), and by class the measured rates with their counts. Optionally an
SVG of each run's projected course: outflow over feed and hold-up against time.

    /usr/bin/python3 bench/steady_projection.py RUN_DIR [RUN_DIR ...] [--svg OUT.svg]
Needs python3-matplotlib for --svg (Debian).
"""
import argparse
import json

GROUPS_UM = [0, 1, 2, 5, 10, 20, 50, 100, 1e9]


def fmt(x, scale=1.0, digits=3):
    return "—" if x is None else f"{x * scale:.{digits}g}"


def by_group(lower_edges_m, values):
    out = [0.0] * (len(GROUPS_UM) - 1)
    for lo, v in zip(lower_edges_m, values):
        for g in range(len(out)):
            if GROUPS_UM[g] * 1e-6 <= lo < GROUPS_UM[g + 1] * 1e-6:
                out[g] += v
    return out


def report(run_dir):
    with open(f"{run_dir}/result.json") as f:
        r = json.load(f)
    p = r.get("steady_projection")
    print(f"## {run_dir}")
    if not p:
        print("no projection (no window with two hold-up rows)\n")
        return None
    threshold = r.get("breakage", {}).get("dust_threshold_diameter_m")
    print(f"simulated {r['simulated_time_s'] * 1e3:.1f} ms in {r['wall_time_s'] / 3600:.2f} h, "
          f"dust threshold {fmt(threshold, 1e6)} µm, window {p['window_s'][0] * 1e3:.1f}–"
          f"{p['window_s'][1] * 1e3:.1f} ms ({p['window_from']})")
    s = p["slots"]
    edges = s["lower_edge_m"]
    events = s["particles"]["events"]
    print(f"feed {fmt(p['feed_kg_per_s'], 1e3)} g/s; breakage events in the window "
          f"{int(sum(events))}; steady state exists: {p['steady_state_exists']}")
    for a in p["accumulating"]:
        print(f"  grows without end: {a['phase']} {fmt(a['lower_edge_m'], 1e6)}–"
              f"{fmt(a['upper_edge_m'], 1e6)} µm (receives mass, no event or exit measured)")
    held = p["holdup_kg"]
    spread = p["spread"]
    t = p["time_to_steady_s"]
    t_band = spread["time_to_steady_s"]
    print(f"steady hold-up: particles {fmt(held['particles'], 1e6)} mg, dust "
          f"{fmt(held['dust'], 1e6)} mg; time to steady from the run's end {fmt(t)} s"
          + (f" (5–95 %: {fmt(t_band[0])}–{fmt(t_band[2])} s over {spread['draws_steady']} of "
             f"{spread['draws']} draws)" if t_band else ""))
    prod = p["product"]
    print(f"product {fmt(prod['kg_per_s'], 1e3)} g/s, d10/d50/d90 = {fmt(prod['d10_m'], 1e6)} / "
          f"{fmt(prod['d50_m'], 1e6)} / {fmt(prod['d90_m'], 1e6)} µm"
          + (f" (d50 5–95 %: {fmt(spread['d50_m'][0], 1e6)}–{fmt(spread['d50_m'][2], 1e6)} µm)"
             if spread["d50_m"] else ""))
    if prod["mass_fraction_by_slot"]:
        shares = by_group(edges, prod["mass_fraction_by_slot"])
        print("product by size (µm): " + ", ".join(
            f"{GROUPS_UM[g]}–{GROUPS_UM[g + 1] if GROUPS_UM[g + 1] < 1e9 else '∞'}: "
            f"{100 * x:.3g} %" for g, x in enumerate(shares) if x > 1e-6))
    area = p["cross_section_m2"]
    ev = p["breakage_events"]
    print(f"particles' cross-section {fmt(area['window_mean'], 1e6)} mm² in the window, "
          f"{fmt(area['steady'], 1e6)} mm² at steady state; {int(ev['by_wall_impact'])} of "
          f"{int(ev['all'])} breakage events by a wall impact")
    # (The hold-up's and cross-section's bands, from builds that report them.)
    bands = [(name, spread.get(key), scale, unit) for name, key, scale, unit in (
        ("particles held", "holdup_particles_kg", 1e6, "mg"), ("dust held", "holdup_dust_kg", 1e6, "mg"),
        ("cross-section", "cross_section_m2", 1e6, "mm²"))]
    if all(band for _, band, _, _ in bands):
        print("steady state's 5 / 50 / 95 % over the draws: " + "; ".join(
            f"{name} {fmt(band[0], scale)} / {fmt(band[1], scale)} / {fmt(band[2], scale)} {unit}"
            for name, band, scale, unit in bands))
    print("\n| class µm | particles held µg | breakage 1/s | events | steady µg | dust held µg "
          "| ground 1/s | at steady 1/s | leaves 1/s | steady µg |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    P, D = s["particles"], s["dust"]
    for k, lo in enumerate(edges):
        if max(P["mean_held_kg"][k], D["mean_held_kg"][k], P["steady_held_kg"][k],
               D["steady_held_kg"][k]) <= 0.0:
            continue
        print(f"| {fmt(lo, 1e6)} | {fmt(P['mean_held_kg'][k], 1e9)} | "
              f"{fmt(P['breakage_per_s'][k])} | {int(P['events'][k])} | "
              f"{fmt(P['steady_held_kg'][k], 1e9)} | {fmt(D['mean_held_kg'][k], 1e9)} | "
              f"{fmt(D['ground_per_s'][k])} | {fmt(D['steady_ground_per_s'][k])} | "
              f"{fmt(D['leave_per_s'][k])} | "
              f"{fmt(D['steady_held_kg'][k], 1e9)} |")
    print()
    return threshold, p


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dirs", nargs="+")
    ap.add_argument("--svg")
    args = ap.parse_args()
    runs = [x for x in (report(d) for d in args.run_dirs) if x]
    if not args.svg or not runs:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for threshold, p in runs:
        c = p["course"]
        if not c["time_s"]:
            continue
        label = f"threshold {fmt(threshold, 1e6)} µm"
        top.plot(c["time_s"][1:], c["outflow_to_feed"][1:], label=label)
        bottom.plot(c["time_s"][1:], [1e6 * x for x in c["held_kg"][1:]], label=label)
    for y in (0.9, 1.1):
        top.axhline(y, color="grey", lw=0.5, ls="--")
    top.set_ylabel("outflow / feed")
    top.set_xscale("log")
    top.legend(fontsize=8)
    bottom.set_ylabel("hold-up, mg (particles + dust)")
    bottom.set_xlabel("mill time after the run's end, s (projected)")
    fig.suptitle("The mill's projected course to steady state (4 barg, 0.1 g/s)", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.svg)


if __name__ == "__main__":
    main()
