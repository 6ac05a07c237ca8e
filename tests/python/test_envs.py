"""rmpmarl.make_vec_env and rmpmarl.parallel_env: the same rollouts as the C++ engine, Gymnasium's next-step autoreset,
seeding, the arrays' lifetime, and bad input refused before anything is stepped."""
import numpy as np
import pytest

import rmpmarl
from conftest import random_actions


@pytest.mark.parametrize("task, robot, interface", [
    ("reach-avoid", "panda", "per-joint-rmp"),
    ("pretrain-2link", "planar2", "per-joint-rmp"),
    ("line-crossing", "ur5e", "direct"),
    ("cluttered", "gen3", "per-joint-direct"),
])
def test_a_python_rollout_is_bit_identical_to_the_cpp_engine(tmp_path, reference, task, robot, interface):
    n, steps, seed = 3, 250, 17
    overrides = '{"episode": {"max_steps": 70}}'  # short episodes: the autoreset path is compared too
    envs = rmpmarl.make_vec_env(task, n, robot=robot, interface=interface, overrides=overrides, num_threads=2, seed=0)
    actions = random_actions(envs.action_space, steps, seed=5)
    actions.tofile(tmp_path / "actions.f32")
    reference("rollout", task, robot, interface, n, seed, steps, tmp_path / "actions.f32", tmp_path / "out.f32",
              overrides)
    a, d, s = envs.num_agents, envs.task_spec["local_obs_dim"], envs.task_spec["global_state_dim"]
    row = n * a * d + n * s + n + 2 * n
    expected = np.fromfile(tmp_path / "out.f32", dtype=np.float32).reshape(steps + 1, row)

    def flat(obs, state, rewards, terminated, truncated):
        flags = np.stack([terminated, truncated], axis=1).astype(np.float32)
        return np.concatenate([obs.ravel(), state.ravel(), rewards, flags.ravel()])

    obs, info = envs.reset(seed=seed)
    np.testing.assert_array_equal(flat(obs, info["state"], np.zeros(n, np.float32), np.zeros(n), np.zeros(n)),
                                  expected[0])
    ended = 0
    for t in range(steps):
        obs, rewards, terminated, truncated, info = envs.step(actions[t])
        np.testing.assert_array_equal(flat(obs, info["state"], rewards, terminated, truncated), expected[t + 1])
        ended += int(np.sum(terminated | truncated))
    assert ended > 0, "no episode ended: the autoreset path was not compared"


def test_next_step_autoreset_returns_the_last_observation_then_the_new_episode():
    envs = rmpmarl.make_vec_env("pretrain-2link", 2, seed=3)
    horizon = envs.task_spec["max_episode_steps"]
    obs, _ = envs.reset()
    actions = np.zeros(envs.action_space.shape, np.float32)  # option 0 (target), unit scales: nothing ends early
    for t in range(horizon):
        obs, rewards, terminated, truncated, info = envs.step(actions)
    assert np.all(truncated | terminated) and "metrics" in info and np.all(info["_metrics"])
    assert np.all(info["metrics"]["length"] == horizon) or np.any(terminated)
    last = obs.copy()
    obs, rewards, terminated, truncated, info = envs.step(np.full_like(actions, np.float32(7.0)))  # ignored
    assert np.all(rewards == 0) and not terminated.any() and not truncated.any() and "episode" not in info
    assert not np.array_equal(obs, last)
    # the new episode is the one a fresh env draws second: env k's generator continues
    fresh = rmpmarl.make_vec_env("pretrain-2link", 2, seed=3)
    fresh.reset()
    fresh._env.reset()  # a second reset without a seed continues each env's generator: its next episode
    np.testing.assert_array_equal(obs, fresh._env.obs)


def test_seeds_reproduce_and_threads_do_not_matter():
    runs = []
    for threads in (1, 2):
        envs = rmpmarl.make_vec_env("reach-avoid", 4, num_threads=threads, seed=0)
        actions = random_actions(envs.action_space, 30, seed=1)
        obs, _ = envs.reset(seed=11)
        trace = [obs]
        for a in actions:
            trace.append(envs.step(a)[0])
        runs.append(np.stack(trace))
    np.testing.assert_array_equal(runs[0], runs[1])
    envs = rmpmarl.make_vec_env("reach-avoid", 4, seed=0)
    first, _ = envs.reset(seed=12)
    assert not np.array_equal(first, runs[0][0])
    again, _ = envs.reset(seed=11)
    np.testing.assert_array_equal(again, runs[0][0])


def test_views_are_overwritten_by_the_next_step_copies_are_not():
    views = rmpmarl.make_vec_env("reach-avoid", 2, seed=0, copy=False)
    copies = rmpmarl.make_vec_env("reach-avoid", 2, seed=0)
    v, _ = views.reset()
    c, _ = copies.reset()
    v0 = v.copy()
    assert not v.flags.writeable and c.flags.writeable
    actions = random_actions(views.action_space, 1, seed=0)[0]
    v1 = views.step(actions)[0]
    copies.step(actions)
    assert v1 is not v and np.shares_memory(v, v1)  # the same buffer, overwritten
    np.testing.assert_array_equal(v, v1)
    assert not np.array_equal(v0, v)
    np.testing.assert_array_equal(c, v0)  # the copy kept the reset's observation
    del views
    np.testing.assert_array_equal(v, v1)  # a view keeps the engine's buffers alive


def test_spaces_describe_the_arrays():
    envs = rmpmarl.make_vec_env("reach-avoid", 3, seed=0)
    obs, info = envs.reset()
    assert obs.dtype == np.float32 and obs.shape == envs.observation_space.shape == (3, 7, envs.task_spec["local_obs_dim"])
    assert info["state"].shape == envs.state_space.shape
    space = envs.single_action_space
    assert space.shape == (7, envs.action_layout["size"]) and space.dtype == np.float32
    sample = envs.action_space.sample()
    assert envs.action_space.contains(sample)
    assert not envs.action_space.contains(sample + 0.5)  # a half option index is not an action
    assert envs.task_spec["autoreset"] == "next-step" and str(envs.metadata["autoreset_mode"]) in ("NextStep", "AutoresetMode.NEXT_STEP")


@pytest.mark.parametrize("make_actions, message", [
    (lambda s: np.zeros(s, np.float64), "actions: expected a float32[2, 7, 6] array, got float64[2, 7, 6]"),
    (lambda s: np.zeros((2, 7, 5), np.float32), "actions: expected shape float32[2, 7, 6], got float32[2, 7, 5]"),
    (lambda s: np.zeros((2, 7, 12), np.float32)[:, :, ::2], "actions: expected a C-contiguous array"),
    (lambda s: np.full(s, np.nan, np.float32), "actions: expected finite values"),
    (lambda s: "go", "actions: expected a float32[2, 7, 6] array, got str"),
])
def test_bad_actions_raise_and_step_nothing(make_actions, message):
    envs = rmpmarl.make_vec_env("reach-avoid", 2, seed=0)
    obs, _ = envs.reset()
    with pytest.raises(ValueError) as e:
        envs.step(make_actions(envs.action_space.shape))
    assert message in str(e.value)
    np.testing.assert_array_equal(envs._env.obs, obs)  # nothing stepped
    envs.step(np.zeros(envs.action_space.shape, np.float32))  # and it still steps


def test_bad_construction_arguments_raise():
    with pytest.raises(ValueError, match="task: expected one of pretrain-2link, reach-avoid, line-crossing, cluttered"):
        rmpmarl.make_vec_env("fly", 2)
    with pytest.raises(ValueError, match="num_envs: expected 1 ... 65536, got 0"):
        rmpmarl.make_vec_env("reach-avoid", 0)
    with pytest.raises(ValueError, match="interface: expected per-joint-rmp, direct or per-joint-direct, got 'x'"):
        rmpmarl.make_vec_env("reach-avoid", 1, interface="x")
    with pytest.raises(FileNotFoundError, match="robot: expected a .urdf file, got 'arm.urdf'"):
        rmpmarl.make_vec_env("reach-avoid", 1, robot="arm.urdf")
    with pytest.raises(ValueError, match="no_such_key"):
        rmpmarl.make_vec_env("reach-avoid", 1, overrides={"no_such_key": 1})
    with pytest.raises(ValueError, match="step: the environments need reset"):
        rmpmarl.make_vec_env("reach-avoid", 1).step(np.zeros((1, 7, 6), np.float32))
    with pytest.raises(ValueError, match="seed: expected a non-negative int"):
        rmpmarl.make_vec_env("reach-avoid", 1).reset(seed=-1)


def test_overrides_and_robots_reach_the_task():
    envs = rmpmarl.make_vec_env("reach-avoid", 1, robot="ur5e", overrides={"episode": {"max_steps": 7}})
    assert envs.num_agents == 6 and envs.task_spec["max_episode_steps"] == 7
    envs.reset()
    for _ in range(7):
        _, _, terminated, truncated, info = envs.step(np.zeros(envs.action_space.shape, np.float32))
    assert truncated[0] or terminated[0]


def test_parallel_env_speaks_pettingzoo():
    env = rmpmarl.parallel_env("reach-avoid", seed=2)
    assert env.possible_agents == [f"joint_{i}" for i in range(7)]
    observations, infos = env.reset(seed=4)
    assert set(observations) == set(env.agents) == set(infos)
    assert env.state().shape == env.state_space.shape
    steps = 0
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        assert len(set(rewards.values())) == 1  # the team reward
        steps += 1
    assert any(terminations.values()) or any(truncations.values())
    assert "metrics" in infos["joint_0"] and steps == infos["joint_0"]["metrics"]["length"]
    with pytest.raises(ValueError, match="the episode has ended"):
        env.step(actions)
    env.reset()
    with pytest.raises(ValueError, match="actions: expected a dict with one action per agent"):
        env.step({"joint_0": actions["joint_0"]})
    assert rmpmarl.parallel_env("reach-avoid", interface="direct").possible_agents == ["agent_0"]
