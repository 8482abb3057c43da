#!/usr/bin/env python3
"""The table of bench/multi_rate_mill.sh: per run its time stepping (the sum of the phase
seconds, without the gas spin-up), product d10/d50/d90, breakage events by generation and the
share of particle-steps waited, and per variant the KS distance of its product (outlet + dust,
by mass) to the single-rate run of the same seed, against the single-rate runs' own scatter
(KS between seeds). REFERENCE names the reference variant (default "single"): speed-ups and KS
distances are against its run of the same seed.

    python3 bench/multi_rate_table.py OUT_DIR [REFERENCE]
"""
import itertools
import json
import pathlib
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
    print("| run | seed | time stepping s | speed-up | d10 / d50 / d90 um | events by generation "
          f"| waited share | KS to {reference} |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for (name, seed), r in sorted(runs.items()):
        single = runs.get((reference, seed))
        t = stepping_s(r)
        t_single = stepping_s(single) if single else float("nan")
        p = r["outlet_psd"]
        gens = r["breakage"].get("events_by_generation", [])
        waited = r.get("multi_rate", {}).get("waited_share", 0.0)
        print(f"| {name} | {seed} | {t:.1f} | {t_single / t:.2f} | {p['d10_m'] * 1e6:.1f} / "
              f"{p['d50_m'] * 1e6:.1f} / {p['d90_m'] * 1e6:.1f} | {'/'.join(str(g) for g in gens)} "
              f"| {waited:.3f} | {ks(r, single) if single else float('nan'):.4f} |")
    print_seed_scatter(runs, reference, reference)


if __name__ == "__main__":
    main()
