"""Reading the training CLI's runs (`rmpmarl train CONFIG --out DIR`): metrics, the training config and the exported
controller files."""
import csv
import glob
import os

import numpy as np


def read_run(directory):
    """A training run directory as a dict: 'metrics' (column -> float64 array, one row per update, from
    metrics.csv), 'config' (the training config as run: config.yaml, or train.yaml in an experiment's runs), 'policy' (the final controller file, or None), 'snapshots'
    (update -> controller file) and 'checkpoints' (the .ckpt files; `rmpmarl export` turns one into a .rmpp)."""
    if not os.path.isdir(directory):
        raise FileNotFoundError(f"directory: expected a training run directory, got {directory!r} (no such directory)")
    metrics_path = os.path.join(directory, "metrics.csv")
    metrics = {}
    if os.path.isfile(metrics_path):
        with open(metrics_path, newline="") as f:
            rows = list(csv.DictReader(f))
        for key in rows[0].keys() if rows else []:
            values = []
            for row in rows:
                try:
                    values.append(float(row[key]))
                except (TypeError, ValueError):
                    values.append(float("nan"))
            metrics[key] = np.asarray(values)
    config_path = os.path.join(directory, "config.yaml")
    if not os.path.isfile(config_path):
        config_path = os.path.join(directory, "train.yaml")
    policy = os.path.join(directory, "policy.rmpp")
    snapshots = {}
    for path in glob.glob(os.path.join(directory, "policy-u*.rmpp")):
        snapshots[int(os.path.basename(path)[len("policy-u"):-len(".rmpp")])] = path
    return {
        "metrics": metrics,
        "config": open(config_path).read() if os.path.isfile(config_path) else None,
        "policy": policy if os.path.isfile(policy) else None,
        "snapshots": dict(sorted(snapshots.items())),
        "checkpoints": sorted(glob.glob(os.path.join(directory, "*.ckpt"))),
    }
