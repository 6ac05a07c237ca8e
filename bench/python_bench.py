#!/usr/bin/env python3
"""The Python package against the C++ core, in one run on this machine (`make bench` runs it):
  - 64 reach-avoid environments stepped from Python (rmpmarl.make_vec_env, copies and views) against the C++ VecEnv
    (env_bench's BM_VecEnvReachAvoid64): the same task, envs, seeds, threads and actions, two whole episodes (1200
    steps) from the reset on both sides, so both step identical episodes; goal >= 90 %;
  - a controller call from Python (Controller.update) against the C++ time of the same call (its compute_us, measured
    inside C++ with steady_clock); goal <= 2x the C++ call + 5 us.
Medians of 5 interleaved rounds (env steps; the ratio is the median of the rounds' ratios, Python with copies over
C++) and of 5 runs of 2000 calls (controllers).  usage: python_bench.py BUILD_DIR"""
import json
import os
import platform
import statistics
import subprocess
import sys
import time

build = sys.argv[1] if len(sys.argv) > 1 else "build"
sys.path.insert(0, os.path.join(build, "python"))
import numpy as np  # noqa: E402

import rmpmarl  # noqa: E402


def machine():
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            return f"{line.split(':', 1)[1].strip()}, {os.cpu_count()} hardware threads"
    return platform.machine()


def cpp_env_steps(threads):
    out = subprocess.run([os.path.join(build, "bench", "env_bench"),
                          f"--benchmark_filter=BM_VecEnvReachAvoid64/threads:{threads}/",
                          "--benchmark_format=json"],
                         capture_output=True, text=True, check=True).stdout
    runs = [b for b in json.loads(out)["benchmarks"] if b.get("run_type") == "iteration"]
    return statistics.median(b["env_steps/s"] for b in runs)


def python_env_steps(threads, copy):
    envs = rmpmarl.make_vec_env("reach-avoid", 64, num_threads=threads, seed=3, copy=copy)
    envs.reset()
    actions = np.zeros(envs.action_space.shape, np.float32)
    n, start = 1200, time.perf_counter()
    for _ in range(n):
        envs.step(actions)
    return n * 64 / (time.perf_counter() - start)


def controller_calls(make):
    controller = make()
    q = np.array([0.0, -0.5, 0.0, -2.0, 0.0, 1.6, 0.8])
    controller.reset(q)
    qd, target = np.zeros(7), controller.robot.end_effector_position(q) + [0.1, 0.05, 0.0]
    boxes = np.array([[0.45, 0.2, 0.45, 0.04, 0.04, 0.04]])
    python_us, cpp_us = [], []
    for _ in range(5):
        n, cpp, start = 2000, 0.0, time.perf_counter()
        for _ in range(n):
            q_cmd, qd_cmd, info = controller.update(q, qd, target=target, boxes=boxes)
            cpp += info["compute_us"]
        python_us.append((time.perf_counter() - start) / n * 1e6)
        cpp_us.append(cpp / n)
    return statistics.median(python_us), statistics.median(cpp_us)


print(f"python_bench on {machine()}; medians")
print(f"{'64 x reach-avoid env steps/s':40s} {'C++ VecEnv':>12s} {'Python copy':>12s} {'Python view':>12s} "
      f"{'ratio':>7s} {'goal':>6s}")
for threads in (1, 2):
    # interleaved rounds (C++, Python with copies, Python with views), so that drift of the machine hits all three
    rounds = [(cpp_env_steps(threads), python_env_steps(threads, True), python_env_steps(threads, False))
              for _ in range(5)]
    cpp, copy, view = (statistics.median(r[k] for r in rounds) for k in range(3))
    ratio = statistics.median(r[1] / r[0] for r in rounds)
    print(f"{f'  {threads} thread(s)':40s} {cpp:12.0f} {copy:12.0f} {view:12.0f} {ratio:7.2f} {'>=0.90':>6s}")
print(f"{'controller update, Panda, 1 box':40s} {'C++ us':>12s} {'Python us':>12s} {'limit us':>12s}")
for name, make in [("rmpflow", lambda: rmpmarl.rmpflow("panda", max_obstacles=1)),
                   ("marl-rmp-residual", lambda: rmpmarl.load_controller(rmpmarl.shipped_policy(), robot="panda",
                                                                         max_obstacles=1))]:
    python_us, cpp_us = controller_calls(make)
    print(f"{f'  {name}':40s} {cpp_us:12.1f} {python_us:12.1f} {2 * cpp_us + 5:12.1f}")
