#!/usr/bin/python3
"""A mill run towards steady state, from its result.json (holdup_history, steady_state and, with
the dust ledger, dust_ledger.history): per interval the feed, what left (outlet particles and
dust carried out), the dust made (what the paper's "dust exits at once" counts as product),
the tracked hold-up by size and the ledger's, breakage events by generation (a hold-up fill,
time.fill_to_projection_s, shown on its own and left out of the feed); then the steady
window and the product PSD over it, as it left (outlet + dust out) and as the dust table would
have counted it (outlet + dust made). Optionally an SVG of the hold-up by size over time.

    /usr/bin/python3 bench/steady_mill.py RUN_DIR [--every-ms 5] [--svg OUT.svg]
Needs python3-matplotlib for --svg (Debian).
"""
import argparse
import json
import math


SIZE_GROUPS_UM = [0, 10, 20, 50, 100, 200, 1e9]


def groups(edges_m, by_class):
    """Masses by class (under, classes..., over) summed into SIZE_GROUPS_UM by class centre."""
    centres = [0.5 * edges_m[0]]
    centres += [math.sqrt(a * b) for a, b in zip(edges_m, edges_m[1:])]
    centres += [2.0 * edges_m[-1]]
    out = [0.0] * (len(SIZE_GROUPS_UM) - 1)
    for c, m in zip(centres, by_class):
        for g in range(len(out)):
            if SIZE_GROUPS_UM[g] * 1e-6 <= c < SIZE_GROUPS_UM[g + 1] * 1e-6:
                out[g] += m
    return out


def quantiles(edges_m, masses):
    """d10, d50, d90 (µm) of masses per class (no under/overflow), log-linear in the class."""
    total = sum(masses)
    if total <= 0:
        return [None] * 3
    out = []
    for q in (0.1, 0.5, 0.9):
        acc = 0.0
        for k, m in enumerate(masses):
            if acc + m >= q * total and m > 0:
                f = (q * total - acc) / m
                out.append(1e6 * edges_m[k] * (edges_m[k + 1] / edges_m[k]) ** f)
                break
            acc += m
        else:
            out.append(1e6 * edges_m[-1])
    return out


def made_in_window(h, t_start):
    """Dust made by class (under, classes..., over; kg) from the history row nearest t_start to
    the last row."""
    t = h["time_s"]
    i0 = min(range(len(t)), key=lambda i: abs(t[i] - t_start))
    return [b - a for a, b in zip(h["dust_made_by_class_kg"][i0], h["dust_made_by_class_kg"][-1])]


def selection_rates(run_dir, names):
    """Breakage events per particle and second by size (run.h5: the event log against the
    particles in each size group, integrated over the snapshots): 1/S is a particle's mean
    time before it breaks, which sets how long the hold-up takes to settle."""
    try:
        import h5py
        import numpy as np
        from rates_by_interval import particle_seconds, snapshot_counts
        f = h5py.File(f"{run_dir}/run.h5", "r")
    except (ImportError, OSError):
        return
    edges = [x * 1e-6 for x in SIZE_GROUPS_UM]
    times, counts, _ = snapshot_counts(f, edges, 1.0)  # counts only: the masses are not used
    exposure = particle_seconds(times, counts)  # particle-seconds per group
    if "breakage_events" not in f:
        return
    ev = f["breakage_events"]
    t_end = times[-1]
    parents = ev["parent_diameter_m"][:][ev["time_s"][:] <= t_end]
    events = np.histogram(parents, bins=edges)[0]
    print()
    print("Breakage rate by size over the snapshots (events, particle-seconds, S = events per "
          "particle-second, 1/S):")
    print()
    print("| size (µm) | events | particle-s | S (1/s) | 1/S (ms) |")
    print("| --- | --- | --- | --- | --- |")
    for n, e, x in zip(names, events, exposure):
        rate = e / x if x > 0 else None
        print(f"| {n} | {e} | {x:.3g} | {fmt(rate, 1, 1)} | "
              f"{fmt(1e3 / rate if rate else None, 1, 1)} |")


def gas_and_loading(r):
    """The dust's weight on the gas and the mill's vortex at the end."""
    ledger, gas, mill = r.get("dust_ledger"), r.get("gas", {}), r.get("mill", {})
    print()
    if ledger and "mass_loading" in ledger:
        impulse = gas.get("dust_impulse_n_s")
        print(f"Dust on the gas: {ledger['gas_coupling']}; dust held / gas mass at the end "
              f"{ledger['mass_loading']:.3g} ({ledger['held_kg'] * 1e6:.2f} mg in "
              f"{gas.get('mass_kg', 0) * 1e6:.2f} mg), largest cell loading "
              f"{ledger['max_cell_mass_loading']:.3g}"
              + (f"; impulse the gas gave the dust {[f'{x:.3g}' for x in impulse]} N s, work "
                 f"{gas['dust_work_j']:.3g} J" if impulse else ""))
    profile = mill.get("vortex_profile")
    if profile:
        print()
        print("Vortex at the end (mean gas speeds by radius, force-balance cut there):")
        print()
        print("| r (mm) | tangential (m/s) | radial (m/s) | cut (µm) |")
        print("| --- | --- | --- | --- |")
        for p in profile:
            cut = p.get("force_balance_cut_size_m")
            print(f"| {p['radius_m'] * 1e3:.2f} | {p['tangential_gas_m_per_s']:.1f} | "
                  f"{p['radial_gas_m_per_s']:.2f} | {fmt(cut, 1e6, 2)} |")


def fmt(x, scale=1.0, digits=1):
    return "—" if x is None else f"{x * scale:.{digits}f}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dir")
    ap.add_argument("--every-ms", type=float, default=5.0)
    ap.add_argument("--svg")
    a = ap.parse_args()
    r = json.load(open(f"{a.run_dir}/result.json"))
    h = r["holdup_history"]
    edges = r["outlet_psd"]["edges_m"]
    t = h["time_s"]
    # Hold-up fills (time.fill_to_projection_s) are in the rows' fed_kg (and the ledger's dust in
    # dust_made_kg) from their times on: the rates below leave them out; each is shown on its own.
    for fill in r.get("holdup_fills") or []:
        if fill.get("status") != "filled":
            print(f"Hold-up fill: {fill.get('status')}: {fill.get('reason', '')}")
            print()
            continue
        # Net of what a fill with time.fill_removes took away (absent before it existed).
        dust_net = fill["dust_kg"] - fill.get("dust_removed_kg", 0.0)
        filled = fill["particles_kg"] - fill.get("particles_removed_kg", 0.0) + dust_net
        after = [ti >= fill["time_s"] - 1e-12 for ti in t]
        h["fed_kg"] = [f - (filled if a else 0.0) for f, a in zip(h["fed_kg"], after)]
        h["dust_made_kg"] = [d - (dust_net if a else 0.0)
                             for d, a in zip(h["dust_made_kg"], after)]
        print(f"Hold-up fill at {fill['time_s'] * 1e3:.2f} ms from the window "
              f"{fill['window_s'][0] * 1e3:.2f}–{fill['window_s'][1] * 1e3:.2f} ms: "
              f"{fill['particles_added']} particles copied, "
              f"{fill.get('particles_removed', 0)} removed, particles "
              f"{fill['particles']['before_kg'] * 1e9:.0f} → {fill['particles']['after_kg'] * 1e9:.0f} µg "
              f"(target {fill['particles']['target_kg'] * 1e9:.0f}), ledger dust "
              f"{fill['dust']['before_kg'] * 1e9:.0f} → {fill['dust']['after_kg'] * 1e9:.0f} µg "
              f"(target {fill['dust']['target_kg'] * 1e9:.0f}); held as they were: "
              f"{fill.get('held_as_they_were')}")
        if "projected_kg" in fill["particles"]:
            print(f"  projected: particles {fill['particles']['projected_kg'] * 1e9:.0f} µg, "
                  f"ledger dust {fill['dust']['projected_kg'] * 1e9:.0f} µg; held for few counts "
                  f"(slots): {fill.get('held_for_few_counts')}")
        if "particle_rates_window_s" in fill:
            w = fill["particle_rates_window_s"]
            events = fill["particle_events_by_slot"]
            left = fill["particles_left_by_slot"]
            counted = [(s, int(e), int(n)) for s, (e, n) in enumerate(zip(events, left)) if e or n]
            print(f"  particle rates from {w[0] * 1e3:.2f}–{w[1] * 1e3:.2f} ms: "
                  f"{int(sum(events))} breakage events, {int(sum(left))} particles left; "
                  f"(slot, events, left): {counted}")
        print()
    rows = [0]
    for i in range(1, len(t)):
        if t[i] - t[rows[-1]] >= a.every_ms * 1e-3 - 1e-12 or i == len(t) - 1:
            rows.append(i)
    print(f"# {r['scene']}: {r['simulated_time_s'] * 1e3:.2f} ms, "
          f"{r['wall_time_s'] / 3600:.2f} h wall, {r['particles']['final']} particles at the end")
    print()
    print("| interval (ms) | fed (mg/s) | outlet (mg/s) | dust out (mg/s) | dust made (mg/s) "
          "| out/fed | made/fed | tracked hold-up (µg) | ledger hold-up (µg) "
          "| events by generation |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for i0, i1 in zip(rows, rows[1:]):
        dt = t[i1] - t[i0]
        rate = lambda key: (h[key][i1] - h[key][i0]) / dt * 1e6  # kg/s → mg/s
        fed = rate("fed_kg")
        out = rate("outlet_kg") + rate("dust_out_kg")
        made = rate("outlet_kg") + rate("dust_made_kg")
        e0, e1 = h["events_by_generation"][i0], h["events_by_generation"][i1]
        ev = [e1[g] - (e0[g] if g < len(e0) else 0) for g in range(len(e1))]
        print(f"| {t[i0] * 1e3:.1f}–{t[i1] * 1e3:.1f} | {fed:.1f} | {rate('outlet_kg'):.2f} "
              f"| {rate('dust_out_kg'):.2f} | {rate('dust_made_kg'):.1f} "
              f"| {fmt(out / fed if fed else None, 1, 3)} | {fmt(made / fed if fed else None, 1, 3)} "
              f"| {h['particles_kg'][i1] * 1e9:.0f} | {h['dust_held_kg'][i1] * 1e9:.0f} "
              f"| {' / '.join(str(int(x)) for x in ev)} |")
    print()
    names = [f"{lo:g}–{hi:g}" if hi < 1e8 else f"≥ {lo:g}"
             for lo, hi in zip(SIZE_GROUPS_UM, SIZE_GROUPS_UM[1:])]
    print("Tracked hold-up by size (µg), at the interval ends:")
    print()
    print("| t (ms) | " + " | ".join(f"{n} µm" for n in names) + " |")
    print("| --- " * (len(names) + 1) + "|")
    for i in rows:
        g = groups(edges, h["particles_by_class_kg"][i])
        print(f"| {t[i] * 1e3:.1f} | " + " | ".join(f"{x * 1e9:.1f}" for x in g) + " |")
    ledger = r.get("dust_ledger")
    if ledger:
        hist = ledger["history"]
        classes = ledger["classes"]
        print()
        print("Ledger hold-up by class at the end (µg), and what left (µg):")
        print()
        print("| class d (µm) | held | out |")
        print("| --- | --- | --- |")
        for k, c in enumerate(classes):
            held = hist["held_by_class_kg"][k][-1]
            out = hist["outflow_by_class_kg"][k][-1]
            if held > 0 or out > 0:
                print(f"| {c['diameter_m'] * 1e6:.2f} | {held * 1e9:.3f} | {out * 1e9:.3f} |")
    selection_rates(a.run_dir, names)
    gas_and_loading(r)
    s = r.get("steady_state")
    print()
    print("Steady state:", json.dumps(s))
    if s:
        # The product over the window: dust made by class (the table's view) from the history,
        # and what left (outlet_psd when the run declared the window as its product window).
        made = made_in_window(h, s["window_s"][0])
        d = quantiles(edges, made[1:-1])
        print(f"dust made in the window: {sum(made) * 1e9:.1f} µg, d10/d50/d90 "
              f"{' / '.join(fmt(x) for x in d)} µm (under the first edge: {made[0] * 1e9:.3f} µg)")
        if ledger:
            k0 = min(range(len(hist["time_s"])), key=lambda i: abs(hist["time_s"][i] - s["window_s"][0]))
            out = [hist["outflow_by_class_kg"][k][-1] - hist["outflow_by_class_kg"][k][k0]
                   for k in range(len(classes))]
            total = sum(out)
            mean = sum(o * c["diameter_m"] for o, c in zip(out, classes)) / total if total else 0
            print(f"dust out in the window: {total * 1e9:.3f} µg, mass-mean class size "
                  f"{mean * 1e6:.2f} µm")
    if a.svg:
        import matplotlib
        matplotlib.use("svg")
        import matplotlib.pyplot as plt
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ms = [x * 1e3 for x in t]
        stacks = list(zip(*[groups(edges, row) for row in h["particles_by_class_kg"]]))
        ax1.stackplot(ms, *[[m * 1e9 for m in s_] for s_ in stacks], labels=[n + " µm" for n in names])
        if ledger:
            ax1.plot(ms, [x * 1e9 for x in h["dust_held_kg"]], "k--", label="ledger dust")
        ax1.set_ylabel("hold-up (µg)")
        ax1.legend(loc="upper left", fontsize=7)
        fed = h["fed_kg"]
        ax2.plot(ms, [x * 1e9 for x in fed], label="fed")
        ax2.plot(ms, [(o + d) * 1e9 for o, d in zip(h["outlet_kg"], h["dust_made_kg"])],
                 label="outlet + dust made")
        ax2.plot(ms, [(o + d) * 1e9 for o, d in zip(h["outlet_kg"], h["dust_out_kg"])],
                 label="outlet + dust out")
        ax2.set_xlabel("time (ms)")
        ax2.set_ylabel("cumulative mass (µg)")
        ax2.legend(loc="upper left", fontsize=7)
        fig.tight_layout()
        fig.savefig(a.svg)


if __name__ == "__main__":
    main()
