#!/usr/bin/env python3
"""The longest update() of rmpmarl.plan_and_react in a real-time loop (one update per control period), with the plan
inside the update that starts it and beside the loop (plan_beside_loop=True), over MotionBenchMaker problems.
usage: plan_latency.py PROBLEMS [--families cage_panda bookshelf_tall_panda] [--problems 10] [--seconds 0.5]
(PROBLEMS: the unpacked problems folder of the MBM Panda set; run with PYTHONPATH=BUILD_DIR/python)"""
import argparse
import os
import time

import numpy as np

import rmpmarl


def run(robot, folder, k, beside, seconds):
    """(longest update [ms], the last plan's planning_ms, planned) of one problem"""
    scene = rmpmarl.read_planning_scene(os.path.join(folder, f"scene{k:04d}.yaml"))
    request = rmpmarl.read_motion_plan_request(os.path.join(folder, f"request{k:04d}.yaml"), robot)
    n = sum(len(v) for key, v in scene.items() if key in ("boxes", "cylinders", "spheres"))
    controller = rmpmarl.plan_and_react(robot, "rmpflow", max_obstacles=n, seed=1, plan_beside_loop=beside)
    q, qd = request["start"].copy(), np.zeros(robot.nq)
    controller.reset(q, qd)
    period, longest, info = 1.0 / controller.control_rate, 0.0, None
    for _ in range(int(seconds * controller.control_rate)):
        start = time.perf_counter()
        q, qd, info = controller.update(q, qd, joint_target=request["joint_target"], **scene)
        spent = time.perf_counter() - start
        longest = max(longest, spent)
        time.sleep(max(0.0, period - spent))
    return 1e3 * longest, info["plan"]["planning_ms"], info["plan"]["status"] == "planned"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("problems")
    parser.add_argument("--families", nargs="+", default=["cage_panda", "bookshelf_tall_panda"])
    parser.add_argument("--problems-per-family", type=int, default=10, dest="count")
    parser.add_argument("--seconds", type=float, default=0.5)
    args = parser.parse_args()
    robot = rmpmarl.Robot("panda")
    print("| family | plans (median, max) | longest update(), plan inside the call (median, max) | plan beside the "
          "loop (median, max) | planned |")
    print("|---|---|---|---|---|")
    for family in args.families:
        folder = os.path.join(args.problems, family)
        if not os.path.isdir(folder):
            raise SystemExit(f"{folder}: no such folder (unpack the set's problems.tar.bz2 into PROBLEMS)")
        rows = {beside: [run(robot, folder, k, beside, args.seconds) for k in range(1, args.count + 1)]
                for beside in (False, True)}
        plans = [r[1] for r in rows[False]]
        cells = [f"{np.median([r[0] for r in rows[b]]):.2f}, {max(r[0] for r in rows[b]):.2f} ms" for b in (False, True)]
        planned = "/".join(str(sum(r[2] for r in rows[b])) for b in (False, True))
        print(f"| {family.removesuffix('_panda')} | {np.nanmedian(plans):.1f}, {np.nanmax(plans):.1f} ms | {cells[0]} | "
              f"{cells[1]} | {planned} of {args.count} |")


if __name__ == "__main__":
    main()
