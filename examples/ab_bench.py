#!/usr/bin/env python3
"""Times two cuberay binaries against each other with `cuberay bench`, alternating them.

    examples/ab_bench.py [--rounds N] [--runs R] [--out DIR] BEFORE AFTER SCENE... [-- BENCH ARGS]

Each round runs, for every scene, `BIN bench --json --runs R [BENCH ARGS] SCENE` with one
binary and then the other (the order swaps every round, so that a machine speeding up or
slowing down meets both alike), and keeps every JSON report in DIR. The table it prints
gives, per scene and accelerator, each binary's medians over the rounds and the median over
the rounds of the after/before ratio taken within each round (with the rounds' range):
whole kernel time, the kernel time of depths 2+ (`surface_depths_s`), and µs per eye ray and
per surface ray. Figures below 1 mean AFTER is faster. Timings on lavapipe vary by tens of
percent between runs: quote the within-round ratios, not the seconds.

Example (docs/performance.md):
    examples/ab_bench.py --rounds 3 cuberay-old target/release/cuberay \\
        ../shared/scenes/spd/nff/balls_s4.nff -- --accel cube,bvh
"""
import argparse
import json
import os
import statistics
import subprocess
import sys


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default="ab-bench")
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("scenes", nargs="+")
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    bins = {"before": a.before, "after": a.after}
    # rows[(scene, accel)][who] = list of rows, one a round
    rows = {}
    for r in range(a.rounds):
        order = ["before", "after"] if r % 2 == 0 else ["after", "before"]
        for scene in a.scenes:
            for who in order:
                cmd = [bins[who], "bench", "--json", "--runs", str(a.runs), *extra, scene]
                out = subprocess.run(cmd, capture_output=True, text=True)
                if out.returncode != 0:
                    sys.exit(f"{' '.join(cmd)} failed:\n{out.stderr}")
                name = os.path.splitext(os.path.basename(scene))[0]
                with open(os.path.join(a.out, f"{name}-{who}-{r}.json"), "w") as f:
                    f.write(out.stdout)
                for row in json.loads(out.stdout)["rows"]:
                    rows.setdefault((row["scene"], row["accel"]), {}).setdefault(who, []).append(row)
            print(f"round {r + 1} of {a.rounds}: {scene} done", file=sys.stderr)
    keys = [("kernel_s", "kernel s"), ("surface_depths_s", "depths 2+ s"), ("eye_ray_us", "µs/eye ray"),
            ("surface_ray_us", "µs/surface ray")]
    print("| scene | accel | " + " | ".join(f"{label} before → after (ratio, rounds)" for _, label in keys) + " |")
    print("|---|---|" + "---|" * len(keys))
    summary = {k: [] for k, _ in keys}
    for (scene, accel), by in rows.items():
        cells = []
        for k, _ in keys:
            b = [x[k] for x in by.get("before", []) if x.get(k) is not None]
            f = [x[k] for x in by.get("after", []) if x.get(k) is not None]
            if not b or not f or len(b) != len(f):
                cells.append("–")
                continue
            ratios = [y / x for x, y in zip(b, f) if x > 0]
            m = statistics.median(ratios)
            summary[k].append(m)
            cells.append(f"{statistics.median(b):.4g} → {statistics.median(f):.4g} "
                         f"({m:.3f}, {min(ratios):.2f}–{max(ratios):.2f})")
        print(f"| {scene} | {accel} | " + " | ".join(cells) + " |")
    for k, label in keys:
        if summary[k]:
            print(f"median over rows of the after/before {label} ratio: {statistics.median(summary[k]):.3f}",
                  file=sys.stderr)


if __name__ == "__main__":
    main()
