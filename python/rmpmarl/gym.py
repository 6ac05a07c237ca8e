"""The tasks as Gymnasium environments, where Gymnasium is installed: one id per task,

    env = gymnasium.make("rmpmarl/ReachAvoid-v0", robot="ur5e")            # one environment (TaskEnv)
    envs = gymnasium.make_vec("rmpmarl/ReachAvoid-v0", num_envs=64)        # the batched engine (rmpmarl.VectorEnv)

registered when rmpmarl is imported: rmpmarl/PretrainTwoLink-v0, rmpmarl/ReachAvoid-v0, rmpmarl/LineCrossing-v0,
rmpmarl/Cluttered-v0, rmpmarl/Cells-v0. Keyword arguments are make_vec_env's (robot, collision, interface, overrides, seed, ...).
A single environment is the batched engine with one environment: every agent's observation at once
[num_agents, obs_dim], every agent's flat action at once [num_agents, action_size], the team reward.
"""
import numpy as np
import gymnasium

from .envs import VectorEnv

__all__ = ["TaskEnv", "TASK_IDS", "register"]

# the Gymnasium id of each task
TASK_IDS = {
    "pretrain-2link": "rmpmarl/PretrainTwoLink-v0",
    "reach-avoid": "rmpmarl/ReachAvoid-v0",
    "line-crossing": "rmpmarl/LineCrossing-v0",
    "cluttered": "rmpmarl/Cluttered-v0",
    "cells": "rmpmarl/Cells-v0",
}


class TaskEnv(gymnasium.Env):
    """One environment of a task (gymnasium.Env): observations [num_agents, obs_dim] float32, actions
    [num_agents, action_size] float32 (an rmpmarl ActionBox: the option index and the terminate flag are whole
    numbers), the team reward. info: 'state' (the centralised critic's input), 'reward_terms', 'option_started' and,
    when the episode ended, 'metrics' (rmpmarl.VectorEnv's, for this environment). Call reset() after an episode
    ends."""

    metadata = {"render_modes": []}

    def __init__(self, task, *, robot=None, collision=None, interface=None, overrides=None, seed=0,
                 render_mode=None):
        if render_mode is not None:
            raise ValueError(f"render_mode: expected None (rmpmarl renders with `rmpmarl demo --video` and "
                             f"`rmpmarl view`), got {render_mode!r}")
        self._vec = VectorEnv(task, 1, robot=robot, collision=collision, interface=interface, overrides=overrides,
                              seed=seed, copy=True)
        self.task_spec = self._vec.task_spec
        self.action_layout = self._vec.action_layout
        self.observation_space = self._vec.single_observation_space
        self.action_space = self._vec.single_action_space
        self.render_mode = None
        self._ended = True

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        obs, info = self._vec.reset(seed=seed, options=options)
        self._ended = False
        return obs[0], {"state": info["state"][0]}

    def step(self, action):
        if self._ended:
            raise ValueError("step: the episode has ended (or not started); call reset()")
        action = np.asarray(action, dtype=np.float32)
        if action.shape != self.action_space.shape:
            raise ValueError(f"action: expected shape {self.action_space.shape} (num_agents, action_size), got "
                             f"{action.shape}")
        obs, rewards, terminated, truncated, info = self._vec.step(action[None])
        out = {"state": info["state"][0], "reward_terms": info["reward_terms"][0],
               "option_started": info["option_started"][0]}
        if "metrics" in info:
            out["metrics"] = {k: v[0] for k, v in info["metrics"].items()}
        self._ended = bool(terminated[0] or truncated[0])
        return obs[0], float(rewards[0]), bool(terminated[0]), bool(truncated[0]), out

    def close(self):
        self._vec.close()


def register():
    """registers every task's id with Gymnasium (once; rmpmarl's import does it)."""
    for task, env_id in TASK_IDS.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(id=env_id, entry_point="rmpmarl.gym:TaskEnv",
                           vector_entry_point="rmpmarl.envs:make_vec_env", kwargs={"task": task})
