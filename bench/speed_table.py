#!/usr/bin/env python3
"""The speed table (docs/performance.md): each row's measurement beside its anchor and goal, in one run, on this
machine. `make bench` runs it last, after the Google Benchmark binaries have written their JSON (medians of their
repetitions) into BUILD_DIR/bench-results/ and train_scaling_bench.py its own JSON there. It measures itself:
  - the control step of the shipped learned default against RMPflow and RMPflow-tuned (and the hand gate, the same
    layer with unit scales): `rmpmarl experiment table4 --shipped` on the held-out episodes (evaluation seed
    20231001), one thread, the experiments' own step column, per speed the median of --rounds runs of each method
    (each method in its own runs, the methods in turn);
  - the anchor of the VecEnv row: one env_bench process of BM_VecEnvStep/threads:1 alone, then two side by side.
usage: speed_table.py BUILD_DIR [--episodes 10] [--rounds 5]"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile

from train_scaling_bench import machine  # this directory's: the machine's name, as that bench prints it


def medians(path):
    """benchmark name -> (median real time in microseconds, counters) of a Google Benchmark JSON file."""
    out = {}
    if not os.path.exists(path):
        return out
    for b in json.load(open(path))["benchmarks"]:
        if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "median":
            continue
        scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b.get("time_unit", "ns")]
        out[b.get("run_name", b["name"])] = (b["real_time"] * scale, b)
    return out


def find(results, prefix):
    hits = [k for k in results if k.startswith(prefix)]
    if not hits:
        return None
    return results[sorted(hits, key=len)[0]]


METHODS = ["marl-rmp-residual", "hand-gate", "rmpflow", "rmpflow-tuned"]


def control_steps(build, episodes, rounds):
    """(method -> [step µs per speed], the speeds): per speed the median over `rounds` table4 runs of the shipped policies on one
    thread. Each run evaluates one method, the methods in turn and in a rotated order from round to round, so that a
    stretch of contention on a virtual machine (one run's speeds differ from the next's by 5–10 %) falls on every
    method alike."""
    runs = {}
    for r in range(rounds):
        for m in METHODS[r % len(METHODS):] + METHODS[:r % len(METHODS)]:
            with tempfile.TemporaryDirectory() as out:
                subprocess.run([os.path.join(build, "rmpmarl"), "experiment", "table4", "--shipped", "--methods", m,
                                "--episodes", str(episodes), "--jobs", "1", "--out", out, "--no-plots"], check=True,
                               stdout=subprocess.DEVNULL)
                for row in csv.DictReader(open(os.path.join(out, "summary.csv"))):
                    runs.setdefault(row["method"], {}).setdefault(row["condition"], []).append(
                        float(row["control_step_us"]))
    speeds = list(next(iter(runs.values())))
    return {m: [statistics.median(by_speed[c]) for c in speeds] for m, by_speed in runs.items()}, speeds


def vecenv_processes(build):
    """env steps/s of one process of BM_VecEnvStep/threads:1 alone, and of two such processes side by side."""
    cmd = [os.path.join(build, "bench", "env_bench"), "--benchmark_filter=BM_VecEnvStep/threads:1/",
           "--benchmark_format=json", "--benchmark_min_time=2"]

    def rate(text):
        b = json.loads(text)["benchmarks"][0]
        return b["env_steps/s"]
    alone = rate(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True) for _ in range(2)]
    both = sum(rate(p.communicate()[0]) for p in procs)
    return alone, both


def main():
    p = argparse.ArgumentParser()
    p.add_argument("build", nargs="?", default="build")
    p.add_argument("--episodes", type=int, default=10, help="table4 episodes per speed for the control-step row")
    p.add_argument("--rounds", type=int, default=5, help="table4 runs per method whose per-speed medians the row shows")
    a = p.parse_args()
    res = os.path.join(a.build, "bench-results")
    env = medians(os.path.join(res, "env_bench.json"))
    rmp = medians(os.path.join(res, "rmp_bench.json"))
    rows = []

    steps, speeds = control_steps(a.build, a.episodes, a.rounds)
    learned = steps.get("MARL-RMP residual (ours)", [])
    flow = steps.get("RMPflow", [])
    tuned = steps.get("RMPflow-tuned", [])
    gate = steps.get("Hand gate (ours)", [])
    if learned and flow:
        ratio = max(l / f for l, f in zip(learned, flow))
        anchor = f"RMPflow {min(flow):.1f}–{max(flow):.1f} µs"
        if tuned:
            anchor += f", RMPflow-tuned {min(tuned):.1f}–{max(tuned):.1f} µs"
        if gate:
            anchor += (f"; the hand gate (the same layer, unit scales) {min(gate):.1f}–{max(gate):.1f} µs, "
                       f"{max(g / f for g, f in zip(gate, flow)):.2f}×")
        rows.append((f"control step, shipped learned default (table4 held-out episodes, per speed, median of "
                     f"{a.rounds} runs)", f"{min(learned):.1f}–{max(learned):.1f} µs", anchor,
                     f"{ratio:.2f}× RMPflow (worst speed)", "≤ 1.00×"))

    layer, flow_same = (find(rmp, "BM_CoupledLayerEvaluate/default_layer_arm7_allcaps_20boxes"),
                        find(rmp, "BM_RmpflowEvaluate/arm7_allcaps_20boxes"))
    if layer and flow_same:
        rows.append(("the learned default's layer (RMPflow structure + coupled layer), Panda all capsules × 20 boxes",
                     f"{layer[0]:.1f} µs", f"RMPflow on the same states {flow_same[0]:.1f} µs",
                     f"{layer[0] / flow_same[0]:.2f}× RMPflow", "≤ 1.00×"))

    ctrl = medians(os.path.join(res, "control_bench.json"))
    for suffix, scene in (("", "the demo's scene"), ("/cells", "a work cell (the cells task)")):
        for arm in ("panda", "ur5e", "xarm6"):
            learned_update, flow_update = ctrl.get(f"BM_ControllerUpdate/{arm}/learned{suffix}"), ctrl.get(
                f"BM_ControllerUpdate/{arm}/rmpflow{suffix}")
            if learned_update and flow_update:
                rows.append((f"a user's loop: the learned default's update() (sensing, observations, network, "
                             f"layer), {arm}, {scene}", f"{learned_update[0]:.1f} µs",
                             f"RMPflow's update() on the same states {flow_update[0]:.1f} µs",
                             f"{learned_update[0] / flow_update[0]:.2f}× RMPflow", "≤ 1.00×"))

    flow_bench = find(rmp, "BM_RmpflowEvaluate/arm7_7caps_20boxes")
    if flow_bench:
        rows.append(("RMPflow evaluation, Panda 7 capsules × 20 boxes", f"{flow_bench[0]:.1f} µs",
                     "the pairs' arithmetic ≈ 2 µs (not measured)", "–", "≤ 3 µs"))

    bare, bare_default = env.get("BM_BareMjStep"), env.get("BM_BareMjStepLearnedDefault")
    for label, name, floor in (("env step, reach-avoid 100 Hz, obstacles per physics step, look-ahead on",
                                "BM_EnvStep/mode:0/update:0/physics:5/lookahead:1", bare),
                               ("env step, reach-avoid 100 Hz, obstacles per control step",
                                "BM_EnvStep/mode:0/update:1/physics:5/lookahead:0", bare),
                               ("env step, the learned default's own task (BM_EnvStepLearnedDefault)",
                                "BM_EnvStepLearnedDefault", bare),
                               ("the same against its own model's physics",
                                "BM_EnvStepLearnedDefault", bare_default)):
        r = env.get(name)
        if r and floor:
            physics = 5 * floor[0]
            rows.append((label, f"{r[0]:.1f} µs",
                         f"5 × bare mj_step = {physics:.1f} µs ({floor[1]['contacts']:.0f} contact"
                         f"{'' if round(floor[1]['contacts']) == 1 else 's'} per step)",
                         f"{r[0] / physics:.2f}× physics", "≤ 1.5×"))

    one, two = find(env, "BM_VecEnvStep/threads:1"), find(env, "BM_VecEnvStep/threads:2")
    if one and two:
        alone, both = vecenv_processes(a.build)
        anchor = f"two processes of 1 thread / one: {both / alone:.2f}×"
        rows.append(("VecEnv, 32 envs (1 physics step each), 2 threads / 1 thread", f"{one[0] / two[0]:.2f}×", anchor,
                     f"{(one[0] / two[0]) / (both / alone):.2f} of the anchor", "≥ 1.9×"))
        one, two = find(env, "BM_VecEnvReachAvoid64/threads:1"), find(env, "BM_VecEnvReachAvoid64/threads:2")
        if one and two:
            rows.append(("VecEnv, 64 reach-avoid envs (5 physics steps each), 2 threads / 1 thread",
                         f"{one[0] / two[0]:.2f}×", anchor, f"{(one[0] / two[0]) / (both / alone):.2f} of the anchor",
                         "≥ 1.9×"))

    scaling = os.path.join(res, "train_scaling.json")
    if os.path.exists(scaling):
        s = json.load(open(scaling))
        one, split = s["1 process x N"], s.get("2 ranks x N/2")
        rows.append((f"MARL-RMP training run, 600 updates ({s['config']}, 600 × the median update of a "
                     f"{s['updates']}-update run)", f"{600 * one['seconds_per_update'] / 60:.1f} min",
                     f"rollout {one['rollout_seconds']:.3f} s + learning {one['learn_seconds']:.3f} s per update, "
                     "one after the other",
                     f"2 ranks × {split['num_envs']} envs (the same batch): "
                     f"{600 * split['seconds_per_update'] / 60:.1f} min" if split else "–", "≤ 3 min"))

    print(f"speed table: {machine()}; Google Benchmark medians (make bench: 5 repetitions)")
    print("| what | now | anchor (this machine unless said) | ratio | goal |")
    print("|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")
    if learned and flow:
        print("\ncontrol step per speed, µs (" + ", ".join(speeds) + "):")
        for name, values in (("learned default", learned), ("hand gate", gate), ("RMPflow", flow),
                             ("RMPflow-tuned", tuned)):
            if values:
                print(f"  {name}: " + " / ".join(f"{v:.1f}" for v in values))
        print("  learned ÷ RMPflow: " + " / ".join(f"{l / f:.2f}" for l, f in zip(learned, flow)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
