"""The environments against the real packages: PettingZoo's own API and seed tests on rmpmarl.parallel_env, unpatched,
for every task. The packages' pure-Python sources come from the folder RMPMARL_PYTHON_DEPS names (default: the
project's shared python-deps beside the checkout); without it the tests are skipped with a message. Each check runs in
its own interpreter with that folder on PYTHONPATH, so rmpmarl picks the real base classes at import, as it does for
a user who installed the packages."""
import os
import pathlib
import subprocess
import sys

import pytest

DEPS = pathlib.Path(os.environ.get("RMPMARL_PYTHON_DEPS",
                                   pathlib.Path(__file__).resolve().parents[3] / "shared" / "python-deps"))


def run_with_deps(code):
    if not (DEPS / "pettingzoo").is_dir():
        pytest.skip(f"PettingZoo's sources are not at {DEPS} (set RMPMARL_PYTHON_DEPS to a folder holding them)")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(DEPS), env.get("PYTHONPATH", "")])
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)


def test_pettingzoo_parallel_api_and_seed_tests_pass_on_every_task():
    r = run_with_deps("""
import pettingzoo
import rmpmarl
from pettingzoo.test import parallel_api_test, parallel_seed_test
for task in rmpmarl.task_names():
    env = rmpmarl.parallel_env(task)
    assert isinstance(env, pettingzoo.ParallelEnv), type(env).__mro__
    parallel_api_test(env, num_cycles=60)
    parallel_seed_test(lambda: rmpmarl.parallel_env(task), num_cycles=60)
    print('passed', task)
""")
    assert r.returncode == 0, r.stdout + r.stderr
    for task in ("pretrain-2link", "reach-avoid", "line-crossing", "cluttered", "cells"):
        assert f"passed {task}" in r.stdout, r.stdout + r.stderr


def test_reset_options_must_be_a_dict():
    import rmpmarl
    env = rmpmarl.parallel_env("reach-avoid")
    env.reset(seed=1, options={"anything": 1})  # accepted, no effect (PettingZoo's API passes some)
    with pytest.raises(ValueError, match="options: expected a dict or None"):
        env.reset(options=3)


def test_the_vector_env_is_gymnasiums_and_its_vector_wrappers_run_on_it():
    r = run_with_deps("""
import numpy as np
import gymnasium
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.wrappers.vector import ClipAction, NormalizeObservation, NormalizeReward, RecordEpisodeStatistics
import rmpmarl
envs = rmpmarl.make_vec_env("reach-avoid", 4, overrides={"episode": {"max_steps": 30}}, seed=3)
assert isinstance(envs, VectorEnv), type(envs).__mro__
assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
assert isinstance(envs.single_action_space, gymnasium.spaces.Box) and envs.single_action_space.integer.any()
assert envs.unwrapped is envs and envs.render_mode is None
wrapped = RecordEpisodeStatistics(NormalizeReward(NormalizeObservation(ClipAction(envs))))
obs, info = wrapped.reset(seed=3)
ended = 0
for _ in range(70):
    # ClipAction lets an agent act outside the bounds (its action space is unbounded): valid actions come from the
    # environment's own space, whose option index is a whole number
    obs, rewards, terminated, truncated, info = wrapped.step(envs.action_space.sample())
    assert np.isfinite(obs).all() and np.isfinite(rewards).all()
    if "episode" in info:
        ended += int(info["_episode"].sum())
        assert np.all(info["episode"]["l"][info["_episode"]] == 30), info["episode"]
        assert np.array_equal(info["_episode"], info["_metrics"])
print("episodes", ended)
""")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "episodes 8" in r.stdout, r.stdout + r.stderr  # two 30-step episodes per environment in 70 steps


def test_every_task_has_a_gymnasium_id_whose_env_passes_check_env():
    r = run_with_deps("""
import warnings
import numpy as np
import gymnasium
from gymnasium.utils.env_checker import check_env
import rmpmarl
from rmpmarl.gym import TASK_IDS
for task, env_id in TASK_IDS.items():
    env = gymnasium.make(env_id, overrides={"episode": {"max_steps": 40}})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    # the checker's only remarks may be on the observations' infinite bounds: the features (velocities, distances,
    # the look-ahead's times) have no finite bound to state
    remarks = [str(w.message) for w in caught if "infinity" not in str(w.message)]
    assert not remarks, remarks
    obs, info = env.reset(seed=1)
    assert obs.shape == env.observation_space.shape and "state" in info
    steps = 0
    while True:
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        steps += 1
        if terminated or truncated:
            break
    assert steps <= 40 and "metrics" in info, (steps, info.keys())
    envs = gymnasium.make_vec(env_id, num_envs=3)
    assert isinstance(envs.unwrapped, rmpmarl.VectorEnv) and envs.num_envs == 3, type(envs)
    print("passed", env_id)
""")
    assert r.returncode == 0, r.stdout + r.stderr
    for env_id in ("PretrainTwoLink", "ReachAvoid", "LineCrossing", "Cluttered"):
        assert f"passed rmpmarl/{env_id}-v0" in r.stdout, r.stdout + r.stderr
