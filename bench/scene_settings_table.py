#!/usr/bin/env python3
"""The table of bench/scene_settings.sh: per run its time stepping (the sum of the phase seconds,
without the output), speed-up against the first variant's run of the same seed, the step,
product d10/d50/d90, breakage events by generation, the penetration limiter's events, the deepest
overlap at the end (in diameters) and the KS distance of its product (outlet + dust, by mass) to
the first variant's run of the same seed; then each variant's seed-to-seed scatter (KS between
every two seeds) and the medians; then, per variant against the first, the breakage counts
(events by generation, crushes, limiter events) and the product (its mass, d10 and d50) as the
mean of the paired per-seed differences with its 95 % interval (Student's t), beside the first
variant's own seed-to-seed spread; and the same figures unpaired, every seed of each variant
(difference of the means, Welch's 95 % interval), for variants run at different seed counts.

    python3 bench/scene_settings_table.py OUT_DIR NAME [NAME ...]
"""
import pathlib
import statistics
import sys

from multi_rate_table import ks, load_runs, print_seed_scatter, stepping_s, um


# Two-sided 95 % quantiles of Student's t by degrees of freedom (1-30; beyond, the normal's).
T95 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
       2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060,
       2.056, 2.052, 2.048, 2.045, 2.042]


def counts(r):
    """The figures compared between variants: events of generation 0, 1, 2 and >= 3, all events,
    crushes, limiter events; the product's mass (ng), d10 and d50 (um)."""
    b = r["breakage"]
    gens = list(b.get("events_by_generation", [])) + [0, 0, 0]
    p = r["outlet_psd"]
    return {"gen 0": gens[0], "gen 1": gens[1], "gen 2": gens[2], "gen >= 3": sum(gens[3:]),
            "events": b.get("events", 0), "crushes": b.get("crush_events", 0),
            "limiter": r["contacts"].get("penetration_limiter_events", 0),
            "product ng": p["total_mass_kg"] * 1e9, "product d10 um": p["d10_m"] * 1e6,
            "product d50 um": p["d50_m"] * 1e6}


def print_paired_counts(runs, reference, name):
    seeds = sorted(seed for (n, seed) in runs if n == name and (reference, seed) in runs)
    if len(seeds) < 2:
        return
    print(f"\n{name} against {reference}, paired over {len(seeds)} seeds "
          "(mean difference, 95 % interval; the reference's mean and seed-to-seed sd):")
    print(f"| figure | {reference} mean (sd) | {name} mean | difference | 95 % interval |")
    print("| --- | --- | --- | --- | --- |")
    for key in counts(runs[(reference, seeds[0])]):
        ref = [counts(runs[(reference, s)])[key] for s in seeds]
        var = [counts(runs[(name, s)])[key] for s in seeds]
        diff = [v - r for v, r in zip(var, ref)]
        mean = statistics.mean(diff)
        half = T95[min(len(diff) - 2, len(T95) - 1)] * statistics.stdev(diff) / len(diff) ** 0.5
        print(f"| {key} | {statistics.mean(ref):.2f} ({statistics.stdev(ref):.2f}) "
              f"| {statistics.mean(var):.2f} | {mean:+.2f} "
              f"| {mean - half:+.2f} to {mean + half:+.2f} |")


def t95(degrees_of_freedom):
    """Student's two-sided 95 % quantile at (the whole part of) the degrees of freedom."""
    if degrees_of_freedom > len(T95):
        return 1.960
    return T95[max(int(degrees_of_freedom), 1) - 1]


def print_unpaired_counts(runs, reference, name):
    a_runs = [r for (n, _), r in sorted(runs.items()) if n == reference]
    b_runs = [r for (n, _), r in sorted(runs.items()) if n == name]
    if len(a_runs) < 2 or len(b_runs) < 2:
        return
    print(f"\n{name} ({len(b_runs)} seeds) against {reference} ({len(a_runs)} seeds), unpaired "
          "(difference of the means, Welch's 95 % interval; each variant's mean and sd):")
    print(f"| figure | {reference} mean (sd) | {name} mean (sd) | difference | 95 % interval |")
    print("| --- | --- | --- | --- | --- |")
    for key in counts(a_runs[0]):
        a = [counts(r)[key] for r in a_runs]
        b = [counts(r)[key] for r in b_runs]
        va, vb = statistics.variance(a) / len(a), statistics.variance(b) / len(b)
        diff = statistics.mean(b) - statistics.mean(a)
        if va + vb == 0.0:
            print(f"| {key} | {statistics.mean(a):.2f} (0) | {statistics.mean(b):.2f} (0) "
                  f"| {diff:+.2f} | - |")
            continue
        dof = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1))
        half = t95(dof) * (va + vb) ** 0.5
        print(f"| {key} | {statistics.mean(a):.2f} ({statistics.stdev(a):.2f}) "
              f"| {statistics.mean(b):.2f} ({statistics.stdev(b):.2f}) | {diff:+.2f} "
              f"| {diff - half:+.2f} to {diff + half:+.2f} |")


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
    for name in names[1:]:
        print_paired_counts(runs, reference, name)
        print_unpaired_counts(runs, reference, name)


if __name__ == "__main__":
    main()
