"""The learning environments from Python: Gymnasium-style vector environments and a PettingZoo-style parallel
multi-agent environment, both on the batched C++ engine (rmpmarl._core.VecEnv), which steps N environments on T
threads with the GIL released.

Arrays are float32 and shaped [num_envs, num_agents, ...]: one agent per joint for the per-joint interfaces
(per-joint-rmp, per-joint-direct), one agent for `direct`. Autoreset follows Gymnasium 1.x's default, next-step: the
step in which an episode ends returns its last observation with terminated or truncated set; the next step() resets
that environment, ignores its action and returns the new episode's first observation with reward 0 and both flags
clear.

Lifetime of the arrays: with copy=True (the default) reset() and step() return new arrays. With copy=False they return
read-only numpy views onto the engine's buffers, valid until the next reset() or step() overwrites them (as MuJoCo's
MjData arrays are views): copy what you keep.
"""
import json

import numpy as np

from . import _core
from .spaces import ActionBox, Box

__all__ = ["VectorEnv", "ParallelEnv", "make_vec_env", "parallel_env"]

try:  # Gymnasium's vector base class and autoreset mode where Gymnasium is installed (its wrappers check for them)
    from gymnasium.vector import AutoresetMode as _AutoresetMode
    from gymnasium.vector import VectorEnv as _VectorEnvBase
    _NEXT_STEP = _AutoresetMode.NEXT_STEP
except ImportError:  # pragma: no cover - Debian 12 has no Gymnasium package
    _VectorEnvBase = object
    _NEXT_STEP = "NextStep"

try:  # PettingZoo's base class where PettingZoo is installed (its API tests and wrappers check for it)
    from pettingzoo.utils.env import ParallelEnv as _ParallelEnvBase
except ImportError:  # pragma: no cover - Debian 12 has no PettingZoo package
    _ParallelEnvBase = object


def _overrides_text(overrides):
    if overrides is None:
        return ""
    if isinstance(overrides, str):
        return overrides
    if isinstance(overrides, dict):
        return json.dumps(overrides)  # JSON is YAML: the task loader reads it as a mapping
    raise ValueError(f"overrides: expected a dict or YAML text, got {type(overrides).__name__}")


def _robot_argument(robot):
    if robot is None or isinstance(robot, str):
        return robot
    if isinstance(robot, _core.Robot):
        return robot.urdf_path if robot.urdf_path else robot.name
    raise ValueError(f"robot: expected a robot name, a .urdf path or an rmpmarl.Robot, got {type(robot).__name__}")


def _action_bounds(action):
    """per-element bounds of one agent's flat action [option?, continuous..., terminate?] and its whole-number
    elements."""
    low, high, whole = [], [], []
    if action["num_options"] > 0:
        low.append(0.0)
        high.append(float(action["num_options"] - 1))
        whole.append(True)
    low += list(action["low"])
    high += list(action["high"])
    whole += [False] * len(action["low"])
    if action["has_termination"]:
        low.append(0.0)
        high.append(1.0)
        whole.append(True)
    return np.asarray(low, np.float32), np.asarray(high, np.float32), np.asarray(whole, bool)


class VectorEnv(_VectorEnvBase):
    """N environments of one task stepped as a batch: a gymnasium.vector.VectorEnv where Gymnasium is installed (its
    spaces, its autoreset mode, its vector wrappers), the same API duck-typed where it is not.

    reset(seed=None) -> (obs, info); step(actions) -> (obs, rewards, terminated, truncated, info):
    obs float32 [num_envs, num_agents, obs_dim], actions float32 [num_envs, num_agents, action_size],
    rewards float32 [num_envs] (the team reward), terminated and truncated bool [num_envs].
    info: 'state' float32 [num_envs, state_dim] (the centralised critic's input), 'reward_terms'
    [num_envs, terms], 'option_started' [num_envs, num_agents] (1 where the action started a new option: the only
    steps whose option index took effect), and 'metrics' with the metrics of the episodes that ended in this step
    (arrays [num_envs] and the mask '_metrics'; Gymnasium's RecordEpisodeStatistics adds its own 'episode' beside
    them). `task_spec` describes the task's layout (a Gymnasium env's `spec` is its registration, None unless made by
    gymnasium.make_vec).

    The flat action of one agent is [option index (as a float)?, continuous values..., terminate flag?] as
    `action_layout` describes; the environment clips continuous values to their bounds and rounds the option index.
    """

    metadata = {"autoreset_mode": _NEXT_STEP}
    render_mode = None

    def __init__(self, task, num_envs=1, *, robot=None, collision=None, interface=None, overrides=None,
                 num_threads=1, seed=0, copy=True):
        self._env = _core.VecEnv(task, int(num_envs), robot=_robot_argument(robot), collision=collision,
                                 interface=interface, overrides=_overrides_text(overrides),
                                 num_threads=int(num_threads), seed=int(seed))
        spec = self._env.spec
        self.task_spec = spec
        self.num_envs = spec["num_envs"]
        self.num_agents = spec["num_agents"]
        self.copy = copy
        self.action_layout = spec["action"]
        low, high, whole = _action_bounds(spec["action"])
        a, d, n = self.num_agents, spec["local_obs_dim"], self.num_envs
        self.single_observation_space = Box(-np.inf, np.inf, (a, d), np.float32)
        self.single_action_space = ActionBox(np.broadcast_to(low, (a, low.size)), np.broadcast_to(high, (a, low.size)),
                                             np.broadcast_to(whole, (a, low.size)), (a, low.size), np.float32)
        self.observation_space = Box(-np.inf, np.inf, (n, a, d), np.float32)
        self.action_space = ActionBox(np.broadcast_to(low, (n, a, low.size)), np.broadcast_to(high, (n, a, low.size)),
                                      np.broadcast_to(whole, (n, a, low.size)), (n, a, low.size), np.float32)
        self.state_space = Box(-np.inf, np.inf, (self.num_envs, spec["global_state_dim"]), np.float32)
        self.closed = False

    def _out(self, array):
        return array.copy() if self.copy else array

    def _info(self):
        info = {"state": self._out(self._env.state), "reward_terms": self._out(self._env.reward_terms),
                "option_started": self._out(self._env.option_started)}
        if self._env.terminated.any() or self._env.truncated.any():  # the metrics only when an episode ended
            metrics = self._env.episode_metrics()
            info["_metrics"] = metrics.pop("ended")
            info["metrics"] = metrics
        return info

    def reset(self, *, seed=None, options=None):
        """resets every environment: with a seed, environment k's generator is seeded with seed + k; without one, the
        first reset uses the constructor's seed and later ones continue (new episodes). Returns (obs, info). No reset
        options are defined (make_vec_env configures the task): a dict is accepted and has no effect, except
        'reset_mask', which is refused (every environment resets; the ended ones reset themselves at the next step)."""
        if options is not None and not isinstance(options, dict):
            raise ValueError(f"options: expected a dict or None, got {type(options).__name__}")
        if options and "reset_mask" in options:
            raise ValueError("options['reset_mask']: expected none: reset() resets every environment, and an "
                             "environment whose episode ended resets itself at the next step (next-step autoreset)")
        if seed is not None and (not isinstance(seed, (int, np.integer)) or seed < 0):
            raise ValueError(f"seed: expected a non-negative int or None, got {seed!r}")
        self._env.reset(None if seed is None else int(seed))
        return self._out(self._env.obs), {"state": self._out(self._env.state)}

    def step(self, actions):
        """one step of every environment; returns (obs, rewards, terminated, truncated, info)."""
        self._env.step(actions)
        return (self._out(self._env.obs), self._out(self._env.rewards), self._out(self._env.terminated),
                self._out(self._env.truncated), self._info())

    def close(self):
        self.closed = True

    def __repr__(self):
        return (f"VectorEnv({self.task_spec['task']!r} on {self.task_spec['robot']!r}, {self.num_envs} envs x "
                f"{self.num_agents} agents, interface {self.task_spec['interface']!r})")


def make_vec_env(task, num_envs=1, *, robot=None, collision=None, interface=None, overrides=None, num_threads=1,
                 seed=0, copy=True):
    """N environments of `task` (rmpmarl.task_names(): pretrain-2link, reach-avoid, line-crossing, cluttered, cells, or a
    task .yaml) on `robot` (default: the task's; a shipped arm, a .urdf path or an rmpmarl.Robot) with `interface`
    (default: the task's; per-joint-rmp, direct or per-joint-direct), task `overrides` (a dict or YAML text merged
    over the task file), stepped on `num_threads` threads. Environment k draws from seed + k."""
    return VectorEnv(task, num_envs, robot=robot, collision=collision, interface=interface, overrides=overrides,
                     num_threads=num_threads, seed=seed, copy=copy)


class ParallelEnv(_ParallelEnvBase):
    """One environment of a task as a PettingZoo parallel environment (a pettingzoo.ParallelEnv where PettingZoo is
    installed, duck-typed otherwise): agents 'joint_0' ... 'joint_{n-1}' (one 'agent_0' for the direct interface);
    reset(seed, options) -> (observations, infos), step(actions) -> (observations, rewards, terminations,
    truncations, infos), all dicts keyed by agent; state() is the centralised critic's input. Every agent gets the
    team reward. After an episode ends `agents` is empty until reset(). No reset options are defined (the task
    configures the episodes, the seed draws them): a dict of options is accepted and has no effect."""

    metadata = {"name": "rmpmarl", "is_parallelizable": True}

    def __init__(self, task, *, robot=None, collision=None, interface=None, overrides=None, seed=0):
        self._vec = VectorEnv(task, 1, robot=robot, collision=collision, interface=interface, overrides=overrides,
                              seed=seed, copy=True)
        n = self._vec.num_agents
        per_joint = self._vec.task_spec["interface"] != "direct"
        self.possible_agents = [f"joint_{i}" if per_joint else f"agent_{i}" for i in range(n)]
        self.agents = []
        low, high, whole = _action_bounds(self._vec.task_spec["action"])
        d = self._vec.task_spec["local_obs_dim"]
        self._observation_space = Box(-np.inf, np.inf, (d,), np.float32)
        self._action_space = ActionBox(low, high, whole, (low.size,), np.float32)
        self.state_space = Box(-np.inf, np.inf, (self._vec.task_spec["global_state_dim"],), np.float32)
        self._state = None
        self._actions = np.zeros((1, n, low.size), np.float32)

    def observation_space(self, agent):
        self._check_agent(agent)
        return self._observation_space

    def action_space(self, agent):
        self._check_agent(agent)
        return self._action_space

    def _check_agent(self, agent):
        if agent not in self.possible_agents:
            raise ValueError(f"agent: expected one of {self.possible_agents}, got {agent!r}")

    def state(self):
        """the global state [state_dim] of the last reset or step."""
        if self._state is None:
            raise ValueError("state: call reset() first")
        return self._state.copy()

    @property
    def unwrapped(self):
        return self

    @property
    def num_agents(self):
        return len(self.agents)

    @property
    def max_num_agents(self):
        return len(self.possible_agents)

    def reset(self, seed=None, options=None):
        obs, info = self._vec.reset(seed=seed, options=options)
        self.agents = list(self.possible_agents)
        self._state = info["state"][0]
        return ({a: obs[0, i] for i, a in enumerate(self.agents)}, {a: {} for a in self.agents})

    def step(self, actions):
        if not self.agents:
            raise ValueError("step: the episode has ended (agents is empty); call reset()")
        if not isinstance(actions, dict) or set(actions) != set(self.agents):
            got = sorted(actions) if isinstance(actions, dict) else type(actions).__name__
            raise ValueError(f"actions: expected a dict with one action per agent {self.agents}, got {got}")
        for i, agent in enumerate(self.possible_agents):
            a = np.asarray(actions[agent])
            if a.shape != self._action_space.shape:
                raise ValueError(f"actions[{agent!r}]: expected shape {self._action_space.shape}, got {a.shape}")
            self._actions[0, i] = a
        obs, rewards, terminated, truncated, info = self._vec.step(self._actions)
        self._state = info["state"][0]
        agents = self.agents
        out = ({a: obs[0, i] for i, a in enumerate(agents)}, {a: float(rewards[0]) for a in agents},
               {a: bool(terminated[0]) for a in agents}, {a: bool(truncated[0]) for a in agents},
               {a: ({"metrics": {k: v[0] for k, v in info["metrics"].items()}} if "metrics" in info else {})
                for a in agents})
        if terminated[0] or truncated[0]:
            self.agents = []
        return out

    def close(self):
        self._vec.close()


def parallel_env(task, *, robot=None, collision=None, interface=None, overrides=None, seed=0):
    """One environment of `task` as a PettingZoo-style parallel multi-agent environment (see ParallelEnv)."""
    return ParallelEnv(task, robot=robot, collision=collision, interface=interface, overrides=overrides, seed=seed)
