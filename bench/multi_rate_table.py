#!/usr/bin/env python3
"""The table of bench/multi_rate_mill.sh: per run its time stepping (the sum of the phase
seconds, without the gas spin-up), its mean particle count (particle-steps over steps, the ones
waited included), product d10/d50/d90, breakage events by generation and the share of
particle-steps waited, and per variant the KS distance of its product (outlet + dust, by mass)
to the single-rate run of the same seed, against the single-rate runs' own scatter (KS between
seeds). REFERENCE names the reference variant (default "single"): speed-ups and KS distances are
against its run of the same seed. The speed-up is given for the window and per simulated
particle-millisecond (time stepping over mean particles x simulated time: the runs diverge and
hold different numbers of particles), with each variant's medians at the end.

    python3 bench/multi_rate_table.py OUT_DIR [REFERENCE]
"""
import itertools
import json
import pathlib
import statistics
import sys


def load(path):
    r = json.loads(path.read_text())
    return r


def ks(a, b):
    fa, fb = a["outlet_psd"]["cumulative_mass"], b["outlet_psd"]["cumulative_mass"]
    return max(abs(x - y) for x, y in zip(fa, fb))


def um(x):
    """A diameter in um, or a dash where the product is empty."""
    return "-" if x is None else f"{x * 1e6:.2f}"


def stepping_s(r):
    """A run's time stepping: the sum of its phase seconds without the output's."""
    phases = r["phase_seconds"]
    return sum(phases.values()) - phases.get("output", 0.0)


def mean_particles(r):
    """Particles per step over the run: the particle-steps taken (and, under multi-rate stepping,
    waited) over the steps. A run reports steps taken per second of time stepping."""
    m = r.get("multi_rate") or {}
    if m.get("particle_steps_taken"):
        particle_steps = m["particle_steps_taken"] + m["particle_steps_waited"]
    else:
        particle_steps = r["particle_steps_per_second"] * stepping_s(r)
    return particle_steps / r["steps"]


def seconds_per_particle_ms(r):
    """Time stepping per simulated particle-millisecond."""
    return stepping_s(r) / (mean_particles(r) * r["simulated_time_s"] * 1e3)


def load_runs(out):
    """Each run directory NAME-sSEED of `out` with a result.json, by (NAME, SEED)."""
    runs = {}
    for d in sorted(out.iterdir()):
        if d.is_dir() and (d / "result.json").exists():
            name, seed = d.name.rsplit("-s", 1)
            runs[(name, int(seed))] = load(d / "result.json")
    return runs


def print_seed_scatter(runs, name, label):
    """The KS distance between every two seeds' runs of variant `name`, with their largest."""
    same = [r for (variant, _), r in runs.items() if variant == name]
    scatter = [ks(a, b) for a, b in itertools.combinations(same, 2)]
    if scatter:
        print(f"\n{label} seed-to-seed KS: {', '.join(f'{x:.4f}' for x in scatter)} "
              f"(max {max(scatter):.4f})")


def main():
    out = pathlib.Path(sys.argv[1])
    reference = sys.argv[2] if len(sys.argv) > 2 else "single"
    runs = load_runs(out)
    print(f"\nAgainst {reference}:\n")
    print("| run | seed | time stepping s | mean particles | speed-up | per particle-ms "
          f"| d10 / d50 / d90 um | events by generation | waited share | KS to {reference} |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    speed_ups = {}
    for (name, seed), r in sorted(runs.items()):
        single = runs.get((reference, seed))
        t = stepping_s(r)
        window = stepping_s(single) / t if single else float("nan")
        per_particle = (seconds_per_particle_ms(single) / seconds_per_particle_ms(r)
                        if single else float("nan"))
        if single:
            speed_ups.setdefault(name, []).append((window, per_particle))
        p = r["outlet_psd"]
        gens = r["breakage"].get("events_by_generation", [])
        waited = r.get("multi_rate", {}).get("waited_share", 0.0)
        print(f"| {name} | {seed} | {t:.1f} | {mean_particles(r):.0f} | {window:.2f} "
              f"| {per_particle:.2f} | {p['d10_m'] * 1e6:.1f} / "
              f"{p['d50_m'] * 1e6:.1f} / {p['d90_m'] * 1e6:.1f} | {'/'.join(str(g) for g in gens)} "
              f"| {waited:.3f} | {ks(r, single) if single else float('nan'):.4f} |")
    print()
    for name, ups in sorted(speed_ups.items()):
        if name == reference:
            continue
        print(f"{name}: speed-up median {statistics.median(u[0] for u in ups):.2f} (window), "
              f"{statistics.median(u[1] for u in ups):.2f} (per particle-ms) over {len(ups)} seeds")
    print_seed_scatter(runs, reference, reference)


if __name__ == "__main__":
    main()
