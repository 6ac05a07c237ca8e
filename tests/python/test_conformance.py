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
    for task in ("pretrain-2link", "reach-avoid", "line-crossing", "cluttered"):
        assert f"passed {task}" in r.stdout, r.stdout + r.stderr


def test_reset_options_must_be_a_dict():
    import rmpmarl
    env = rmpmarl.parallel_env("reach-avoid")
    env.reset(seed=1, options={"anything": 1})  # accepted, no effect (PettingZoo's API passes some)
    with pytest.raises(ValueError, match="options: expected a dict or None"):
        env.reset(options=3)
