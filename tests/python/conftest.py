"""Shared helpers of the Python tests: the C++ reference executable (reference.cc) and the CLI, both built by the
normal build and passed by ctest through the environment."""
import os
import subprocess

import numpy as np
import pytest


def _tool(variable):
    path = os.environ.get(variable)
    if not path or not os.path.isfile(path):
        raise RuntimeError(f"{variable}: expected the path of the built executable (ctest sets it), got {path!r}")
    return path


@pytest.fixture(scope="session")
def reference():
    """runs `reference ARGS...` and fails the test with its stderr when it fails."""
    exe = _tool("RMPMARL_PYTHON_REFERENCE")

    def run(*args):
        r = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    return run


@pytest.fixture(scope="session")
def cli():
    return _tool("RMPMARL_CLI")


def random_actions(space, steps, seed):
    """`steps` batches of valid actions drawn from an ActionBox (whole option indices and flags)."""
    space.seed(seed)
    return np.stack([space.sample() for _ in range(steps)]).astype(np.float32)
