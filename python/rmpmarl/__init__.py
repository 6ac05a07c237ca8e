"""rmpmarl: reactive motion generation for robot manipulators with learned per-joint agents over Riemannian Motion
Policies, from Python.

    import numpy as np, rmpmarl
    robot = rmpmarl.Robot("panda")
    controller = rmpmarl.load_controller(rmpmarl.shipped_policy("marl-rmp-residual"), robot=robot)
    controller.reset(q)
    q_cmd, qd_cmd, info = controller.update(q, qd, target=p_target, boxes=np.array([[0.4, 0, 0.5, .04, .04, .04]]))

    envs = rmpmarl.make_vec_env("reach-avoid", num_envs=64, num_threads=2, seed=1)
    obs, info = envs.reset(seed=1)
    obs, rewards, terminated, truncated, info = envs.step(actions)   # float32 [64, agents, action_size]

Robots, controllers and the policy runtime are the C++ library's own (rmpmarl._core); the environments follow
Gymnasium's vector API (rmpmarl.envs) and PettingZoo's parallel API (rmpmarl.parallel_env), and are those packages'
own classes where they are installed (with one Gymnasium id per task: rmpmarl.gym). See docs/python.md.
"""
import os as _os

_share = _os.path.join(_os.path.dirname(__file__), "share")
if "RMPMARL_MODELS_DIR" not in _os.environ and _os.path.isdir(_os.path.join(_share, "models", "robots")):
    # a pip-installed package carries its models and configs; the C++ core finds them through this variable
    _os.environ["RMPMARL_MODELS_DIR"] = _os.path.join(_share, "models")

from ._core import (  # noqa: E402
    Controller,
    Policy,
    Robot,
    load_controller,
    models_directory,
    plan_and_react,
    read_motion_plan_request,
    read_planning_scene,
    read_point_cloud,
    rmpflow,
    shipped_robots,
    task_names,
)
from .envs import ParallelEnv, VectorEnv, make_vec_env, parallel_env  # noqa: E402
from .runs import read_run  # noqa: E402
from .spaces import Box  # noqa: E402

try:  # the tasks' Gymnasium ids (rmpmarl/ReachAvoid-v0, ...) where Gymnasium is installed (rmpmarl.gym)
    import gymnasium as _gymnasium  # noqa: F401
except ImportError:  # pragma: no cover - Debian 12 has no Gymnasium package
    pass
else:
    from . import gym as _gym  # noqa: E402

    _gym.register()

__all__ = [
    "Box",
    "Controller",
    "ParallelEnv",
    "Policy",
    "Robot",
    "VectorEnv",
    "load_controller",
    "make_vec_env",
    "models_directory",
    "parallel_env",
    "plan_and_react",
    "read_motion_plan_request",
    "read_planning_scene",
    "read_point_cloud",
    "read_run",
    "rmpflow",
    "shipped_policies",
    "shipped_policy",
    "shipped_robots",
    "task_names",
]


def shipped_policies():
    """The names of the shipped controller files (models/policies/*.rmpp), sorted."""
    directory = _os.path.join(models_directory(), "policies")
    return sorted(f[:-5] for f in _os.listdir(directory) if f.endswith(".rmpp"))


def shipped_policy(name="marl-rmp-residual"):
    """The path of a shipped controller file by name (default: the learned default, marl-rmp-residual)."""
    path = _os.path.join(models_directory(), "policies", name + ".rmpp")
    if not _os.path.isfile(path):
        raise ValueError(f"name: expected one of {', '.join(shipped_policies())}, got {name!r}")
    return path
