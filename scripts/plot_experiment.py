#!/usr/bin/env python3
"""Plots of an `rmpmarl experiment` from its CSVs (results.csv, summary.csv, curves.csv, frames).

usage: plot_experiment.py NAME OUT_DIR      (NAME: table3 | table4 | fig3 | fig5 | cluttered | mbm)
Reads only what the experiment wrote; writes PNGs into OUT_DIR. Needs Debian's python3-matplotlib.
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return float("nan")


def ordered(values):
    seen = []
    for v in values:
        if v not in seen:
            seen.append(v)
    return seen


def success_by_condition(out, title, png):
    """success rate (pooled, Wilson 95 % interval) per condition, one line per method."""
    rows = read(os.path.join(out, "summary.csv"))
    methods = ordered(r["method"] for r in rows)
    conditions = ordered(r["condition"] for r in rows)
    fig, ax = plt.subplots(figsize=(11, 5))
    x = list(range(len(conditions)))
    colors = plt.cm.tab20.colors
    for k, m in enumerate(methods):
        mine = {r["condition"]: r for r in rows if r["method"] == m}
        ys, lo, hi, xs = [], [], [], []
        for i, c in enumerate(conditions):
            if c not in mine:
                continue
            r = mine[c]
            y = 100 * num(r["success_rate"])
            xs.append(i + (k - len(methods) / 2) * 0.03)
            ys.append(y)
            lo.append(y - 100 * num(r["success_low"]))
            hi.append(100 * num(r["success_high"]) - y)
        ax.errorbar(xs, ys, yerr=[lo, hi], marker="os^Dv<>p"[k % 8], capsize=3, label=m,
                    color=colors[(2 * k) % 20 if k < 10 else (2 * k + 1) % 20],
                    linestyle="-" if k < 10 else "--")
    ax.set_xticks(x)
    ax.set_xticklabels(conditions)
    ax.set_ylabel("success rate [%] (95 % Wilson interval)")
    ax.set_ylim(-2, 102)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(os.path.join(out, png), dpi=110)
    plt.close(fig)


def bars(out, title, png):
    """success and settled tracking error per method × condition (bars with 95 % intervals)."""
    rows = read(os.path.join(out, "summary.csv"))
    labels = [f'{r["method"]}\n{r["condition"]}' for r in rows]
    fig, axes = plt.subplots(2, 1, figsize=(max(7, 0.8 * len(rows)), 7))
    for ax, key, lo, hi, scale, ylabel in (
        (axes[0], "success_rate", "success_low", "success_high", 100, "success [%]"),
        (axes[1], "settled_tracking_mm", "settled_low", "settled_high", 1, "settled tracking [mm]"),
    ):
        ys = [scale * num(r[key]) for r in rows]
        err = [[y - scale * num(r[lo]) for y, r in zip(ys, rows)], [scale * num(r[hi]) - y for y, r in zip(ys, rows)]]
        ax.bar(range(len(rows)), ys, yerr=err, capsize=3, color="tab:blue", alpha=0.8)
        ax.set_ylabel(ylabel)
        ax.set_xticks(range(len(rows)))
        ax.set_xticklabels(labels, fontsize=7, rotation=30, ha="right")
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_title(title)
    fig.tight_layout()
    fig.savefig(os.path.join(out, png), dpi=110)
    plt.close(fig)


def curves(out):
    rows = read(os.path.join(out, "curves.csv"))
    methods = ordered(r["method"] for r in rows)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for m in methods:
        by_update = {}
        for r in rows:
            if r["method"] == m:
                by_update.setdefault(int(r["update"]), []).append(r)
        updates = sorted(by_update)
        steps = [num(by_update[u][0]["env_steps"]) / 1e6 for u in updates]
        for ax, key, scale in ((axes[0], "mean_return", 1), (axes[1], "success_rate", 100)):
            vals = [[scale * num(r[key]) for r in by_update[u]] for u in updates]
            mean = [sum(v) / len(v) for v in vals]
            ax.plot(steps, mean, label=f"{m} ({len(vals[0])} seeds)")
            ax.fill_between(steps, [min(v) for v in vals], [max(v) for v in vals], alpha=0.2)
    axes[0].set_ylabel("training return (window mean)")
    axes[1].set_ylabel("training success [%] (window)")
    for ax in axes:
        ax.set_xlabel("env steps [M]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Fig. 3: reach-avoid training curves (mean over seeds, band = min–max)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig3_curves.png"), dpi=110)
    plt.close(fig)


def frames(out):
    import matplotlib.image as mpimg

    arms = sorted({f[len("fig5_"):-len("_start.png")] for f in os.listdir(out) if f.endswith("_start.png")})
    if not arms:
        return
    fig, axes = plt.subplots(len(arms), 2, figsize=(8, 3.2 * len(arms)), squeeze=False)
    for row, arm in enumerate(arms):
        start = mpimg.imread(os.path.join(out, f"fig5_{arm}_start.png"))
        early = mpimg.imread(os.path.join(out, f"fig5_{arm}_early.png"))
        late = mpimg.imread(os.path.join(out, f"fig5_{arm}_late.png"))
        axes[row][0].imshow(start)
        axes[row][0].set_title(f"{arm}: start", fontsize=9)
        axes[row][1].imshow(late)
        axes[row][1].imshow(early, alpha=0.4)  # the earlier frame translucent over the later one
        axes[row][1].set_title(f"{arm}: 0.3 s before (translucent) and at the closest approach", fontsize=9)
        for ax in axes[row]:
            ax.axis("off")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig5_frames.png"), dpi=100)
    plt.close(fig)


def wilson(k, n):
    """Wilson's 95 % interval of k successes in n, in percent."""
    if n == 0:
        return float("nan"), float("nan")
    z, p = 1.959963984540054, k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * (p * (1 - p) / n + z * z / (4 * n * n)) ** 0.5 / d
    return 100 * max(0.0, c - h), 100 * min(1.0, c + h)


def mbm(out):
    """`rmpmarl benchmark mbm`: success per family and method (valid problems, Wilson 95 % intervals)."""
    rows = [r for r in read(os.path.join(out, "results.csv")) if r["valid"] == "1"]
    families = ordered(r["family"] for r in rows) + ["all"]
    methods = ordered(r["method"] for r in rows)
    fig, ax = plt.subplots(figsize=(max(8, 1.3 * len(families) * len(methods) / 3), 4.5))
    width = 0.8 / max(1, len(methods))
    for m, method in enumerate(methods):
        xs, ys, lo, hi = [], [], [], []
        for f, family in enumerate(families):
            sel = [r for r in rows if r["method"] == method and (family == "all" or r["family"] == family)]
            if not sel:
                continue
            k = sum(r["success"] == "1" for r in sel)
            a, b = wilson(k, len(sel))
            y = 100 * k / len(sel)
            xs.append(f + (m - (len(methods) - 1) / 2) * width)
            ys.append(y)
            lo.append(max(0.0, y - a))
            hi.append(max(0.0, b - y))
        ax.bar(xs, ys, width, yerr=[lo, hi], capsize=2, label=method)
    ax.set_xticks(range(len(families)))
    ax.set_xticklabels(families, rotation=20)
    ax.set_ylabel("success [%] (valid problems, 95 % CI)")
    ax.set_ylim(0, 105)
    ax.set_title("MotionBenchMaker: success per family")
    ax.legend(fontsize=8, ncol=min(5, len(methods)))
    fig.tight_layout()
    fig.savefig(os.path.join(out, "mbm_success.png"), dpi=100)
    plt.close(fig)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    name, out = sys.argv[1], sys.argv[2]
    if name == "table4":
        success_by_condition(out, "Table 4: line-crossing success vs obstacle speed", "table4_success.png")
    elif name == "table3":
        bars(out, "Table 3: pre-training (two-link arm) by training budget", "table3_bars.png")
    elif name == "fig3":
        curves(out)
        bars(out, "Fig. 3: final policies on held-out reach-avoid episodes", "fig3_final.png")
    elif name == "fig5":
        bars(out, "Fig. 5: MARL-RMP (trained on the Panda) on every shipped arm", "fig5_arms.png")
        frames(out)
    elif name == "cluttered":
        bars(out, "Cluttered: static obstacles 20-50 cm", "cluttered_bars.png")
    elif name == "mbm":
        mbm(out)
    else:
        sys.exit(f"unknown experiment {name}")


if __name__ == "__main__":
    main()
