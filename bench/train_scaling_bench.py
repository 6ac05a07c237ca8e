#!/usr/bin/env python3
"""Data-parallel training on this machine, in one run (`make bench` runs it; docs/learning.md):
  - throughput: env steps per second of `rmpmarl train CONFIG --nproc 2` (2 ranks x num_envs) against one process of
    num_envs and one process of 2 x num_envs, the same config otherwise; goal: 2 ranks >= 1.7x one process of
    num_envs (each rank does one process's work, so the ideal on 2 cores is 2x);
  - one process of num_envs against two ranks of num_envs/2 (an even num_envs): the same batch and episodes per update, in less time;
  - with --curve: the learning curve of 2 ranks x num_envs against 1 process x 2 num_envs (the same batch per update),
    windowed success and return every 10 % of the run.
The fps of a run is the median over its updates after the first (metrics.csv); the config's init_actor_from is left
out (the bench needs no earlier run; a pre-trained start changes no step's cost).
usage: train_scaling_bench.py BUILD_DIR [--config configs/train/mappo-reach-avoid.yaml] [--updates 12] [--rounds 3]
       [--curve N]"""
import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time


def machine():
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            return f"{line.split(':', 1)[1].strip()}, {os.cpu_count()} hardware threads"
    return platform.machine()


def run(cli, config, out, updates, nproc, num_envs):
    """trains CONFIG with num_envs per rank; returns (wall seconds, metrics rows)."""
    # the config with this run's output and env count (the CLI overrides updates; env count goes through a copy)
    text = open(config).read()
    # a pre-trained actor to start from changes no step's cost: left out, so the bench needs no earlier run
    lines = [line for line in text.splitlines()
             if not line.startswith(("num_envs:", "output_dir:", "init_actor_from:"))]
    lines += [f"num_envs: {num_envs}", f"output_dir: {out}"]
    path = os.path.join(out + ".yaml")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    start = time.monotonic()
    subprocess.run([cli, "train", path, "--updates", str(updates), "--nproc", str(nproc), "--quiet"], check=True)
    wall = time.monotonic() - start
    with open(os.path.join(out, "metrics.csv")) as f:
        rows = list(csv.DictReader(f))
    return wall, rows


def fps(rows):
    return statistics.median(float(r["fps"]) for r in rows[1:])


def main():
    p = argparse.ArgumentParser()
    p.add_argument("build", nargs="?", default="build")
    p.add_argument("--config", default="configs/train/mappo-reach-avoid.yaml")
    p.add_argument("--updates", type=int, default=12)
    p.add_argument("--rounds", type=int, default=3, help="interleaved repetitions of the runs")
    p.add_argument("--curve", type=int, default=0, help="also compare learning curves over this many updates")
    p.add_argument("--json", help="also write the medians here (speed_table.py reads them)")
    a = p.parse_args()
    cli = os.path.join(a.build, "rmpmarl")
    n = next(int(line.split(":")[1]) for line in open(a.config) if line.startswith("num_envs:"))
    print(f"train_scaling_bench: {a.config}, {a.updates} updates, {machine()}")
    with tempfile.TemporaryDirectory() as tmp:
        # the last: the same batch (and episodes) as one process of N, split over two ranks
        runs = (("1 process x N", 1, n), ("2 ranks x N", 2, n), ("1 process x 2N", 1, 2 * n))
        if n % 2 == 0:
            runs += (("2 ranks x N/2", 2, n // 2),)
        results = {name: [] for name, _, _ in runs}
        split = {name: [] for name, _, _ in runs}
        ratios = []
        for round_ in range(a.rounds):
            for name, nproc, envs in runs:
                _, rows = run(cli, a.config, os.path.join(tmp, name.replace(" ", "")), a.updates, nproc, envs)
                results[name].append(fps(rows))
                split[name].append((statistics.median(float(r["rollout_seconds"]) for r in rows[1:]),
                                    statistics.median(float(r["learn_seconds"]) for r in rows[1:])))
            ratios.append(results["2 ranks x N"][-1] / results["1 process x N"][-1])
        summary = {"config": os.path.basename(a.config), "updates": a.updates, "machine": machine()}
        for name, _, envs in runs:
            rollout = statistics.median(r for r, _ in split[name])
            learn = statistics.median(l for _, l in split[name])
            summary[name] = {"env_steps_per_second": statistics.median(results[name]), "rollout_seconds": rollout,
                             "learn_seconds": learn, "num_envs": envs,
                             "seconds_per_update": statistics.median(r + l for r, l in split[name])}
            print(f"  {name:<16} N = {n}: {statistics.median(results[name]):8.0f} env steps/s (median of {a.rounds} "
                  f"runs of the per-update medians; rollout {rollout:.3f} s + learning {learn:.3f} s per update)")
        print(f"  2 ranks / 1 process of N: {statistics.median(ratios):.2f}x, median of {a.rounds} interleaved rounds "
              f"({', '.join(f'{r:.2f}' for r in ratios)}; goal >= 1.7x); 2 ranks / 1 process of 2N: "
              f"{statistics.median(results['2 ranks x N']) / statistics.median(results['1 process x 2N']):.2f}x")
        if "2 ranks x N/2" in results:
            print(f"  the same batch on 2 ranks (N/2 envs each) / 1 process of N: "
                  f"{statistics.median(results['2 ranks x N/2']) / statistics.median(results['1 process x N']):.2f}x "
                  f"env steps per second")
        if a.json:
            with open(a.json, "w") as f:
                json.dump(summary, f, indent=1)
        if a.curve > 0:
            curves = {}
            for name, nproc, envs in (("2 ranks x N", 2, n), ("1 process x 2N", 1, 2 * n)):
                _, rows = run(cli, a.config, os.path.join(tmp, "curve" + str(nproc)), a.curve, nproc, envs)
                curves[name] = rows
            print("  learning curve (windowed success %, return):")
            print(f"  {'update':>7} | {'2 ranks x N':>22} | {'1 process x 2N':>22}")
            for k in range(1, 11):
                u = max(1, a.curve * k // 10)
                cells = []
                for name in ("2 ranks x N", "1 process x 2N"):
                    r = curves[name][u - 1]
                    cells.append(f"{100 * float(r['success_rate']):6.1f} % {float(r['mean_return']):10.1f}")
                print(f"  {u:>7} | {cells[0]:>22} | {cells[1]:>22}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
