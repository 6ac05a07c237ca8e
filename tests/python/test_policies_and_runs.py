"""rmpmarl.Policy on the shipped controller files and rmpmarl.read_run on a run the training CLI writes: the run's
exported policy acts in the Python environments as the C++ engine's observations ask."""
import os
import subprocess

import numpy as np
import pytest

import rmpmarl


def test_shipped_policies_load_with_their_cards():
    assert rmpmarl.shipped_policies() == ["hrl-rmp-2link", "marl-rmp", "marl-rmp-gated", "marl-rmp-residual"]
    for name in rmpmarl.shipped_policies():
        policy = rmpmarl.Policy(rmpmarl.shipped_policy(name))
        assert policy.obs_dim > 0 and policy.action_size > 0 and "task" in policy.task_yaml
        assert name in policy.card
    with pytest.raises(ValueError, match="name: expected one of hrl-rmp-2link, marl-rmp, marl-rmp-gated, marl-rmp-residual"):
        rmpmarl.shipped_policy("best")


def test_a_policy_acts_on_the_environments_observations_and_batches_of_any_size():
    policy = rmpmarl.Policy(rmpmarl.shipped_policy("hrl-rmp-2link"))
    envs = rmpmarl.make_vec_env("pretrain-2link", 9, seed=4)
    obs, _ = envs.reset()
    flat = obs.reshape(-1, policy.obs_dim)  # 18 rows: more than the runtime's batch, so it runs in chunks
    actions = policy.act(flat)
    assert actions.shape == (18, policy.action_size) and actions.dtype == np.float32
    np.testing.assert_array_equal(actions[5:6], policy.act(flat[5:6]))  # row by row the same
    assert envs.action_space.contains(actions.reshape(envs.action_space.shape))
    for _ in range(20):
        obs, rewards, terminated, truncated, info = envs.step(policy.act(obs.reshape(-1, policy.obs_dim)).reshape(
            envs.action_space.shape))
    with pytest.raises(ValueError, match=f"obs: expected shape float32\\[any, {policy.obs_dim}\\]"):
        policy.act(np.zeros((2, 3), np.float32))
    with pytest.raises(FileNotFoundError, match="policy_file: expected a controller file"):
        rmpmarl.Policy("none.rmpp")


def test_a_training_run_of_the_cli_reads_back(tmp_path, cli):
    out = tmp_path / "run"
    config = os.path.join(os.path.dirname(__file__), "..", "..", "configs", "train", "pretrain-2link.yaml")
    subprocess.run([cli, "train", config, "--updates", "2", "--output", str(out), "--quiet"], check=True,
                   capture_output=True)
    run = rmpmarl.read_run(str(out))
    assert list(run["metrics"]["update"]) == [1.0, 2.0]
    assert run["metrics"]["env_steps"][-1] == 2 * 16 * 128
    assert "total_updates: 2" in run["config"]
    policy = rmpmarl.Policy(run["policy"])
    envs = rmpmarl.make_vec_env("pretrain-2link", 2, seed=0)
    obs, _ = envs.reset()
    assert policy.act(obs.reshape(-1, policy.obs_dim)).shape == (4, policy.action_size)
    with pytest.raises(FileNotFoundError, match="directory: expected a training run directory"):
        rmpmarl.read_run(str(tmp_path / "none"))
