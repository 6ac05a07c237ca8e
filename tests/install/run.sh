#!/usr/bin/env bash
# Installs rmpmarl into a temporary prefix and builds + runs a consumer that uses find_package(rmpmarl).
set -euo pipefail
build_dir=$1; source_dir=$2
prefix=$(mktemp -d); trap 'rm -rf "$prefix"' EXIT
# a step's output is shown only when it fails
quiet() {
  local log="$prefix/step.log"
  if ! "$@" >"$log" 2>&1; then
    echo "failed: $*" >&2; cat "$log" >&2; return 1
  fi
}
quiet cmake --install "$build_dir" --prefix "$prefix"
quiet cmake -S "$source_dir/tests/install/consumer" -B "$prefix/consumer-build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix"
quiet cmake --build "$prefix/consumer-build"
RMPMARL_MODELS_DIR="$prefix/share/rmpmarl/models" "$prefix/consumer-build/consumer"
# the control-loop example of examples/ (docs/control-your-robot.md), built against the same installed package
quiet cmake -S "$source_dir/examples/control_loop" -B "$prefix/example-build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix"
quiet cmake --build "$prefix/example-build"
example="$prefix/example-build/control_loop"
# built against rmpmarl::control alone: no MuJoCo, libtorch, EGL or assimp library (ldd, used or not) or symbol in it
if ldd "$example" | grep -Ei 'mujoco|torch|c10|libEGL|assimp'; then
  echo "control_loop links a library rmpmarl::control must not bring (above)" >&2; exit 1
fi
if nm -C "$example" | grep -E ' (mj[a-z]*_[A-Za-z]+|egl[A-Z][A-Za-z]+|ai[A-Z][A-Za-z]+)$| (Assimp|c10|at|torch)::'; then
  echo "control_loop holds a MuJoCo, libtorch, EGL or assimp symbol (above)" >&2; exit 1
fi
# a planner user (rmpmarl::planning alone): no MuJoCo or EGL either
planner="$prefix/consumer-build/planner"
if ldd "$planner" | grep -Ei 'mujoco|libEGL|torch|c10'; then
  echo "planner links a library rmpmarl::planning must not bring (above)" >&2; exit 1
fi
RMPMARL_MODELS_DIR="$prefix/share/rmpmarl/models" "$planner"
RMPMARL_MODELS_DIR="$prefix/share/rmpmarl/models" "$example"
RMPMARL_MODELS_DIR="$prefix/share/rmpmarl/models" "$example" rmpflow
# the Python package as `make install` puts it (<prefix>/lib/python3/dist-packages), away from the source tree:
# a shipped controller on a shipped robot
if [[ -d "$prefix/lib/python3/dist-packages/rmpmarl" ]]; then
  # a sanitized build's module needs the sanitizer runtimes loaded first (tests/CMakeLists.txt sets the list)
  preload=(); [[ -n "${RMPMARL_SANITIZER_PRELOAD:-}" ]] && preload=(env LD_PRELOAD="$RMPMARL_SANITIZER_PRELOAD"
    ASAN_OPTIONS=halt_on_error=1:detect_leaks=0)
  (cd "$prefix" && RMPMARL_MODELS_DIR="$prefix/share/rmpmarl/models" PYTHONPATH="$prefix/lib/python3/dist-packages" \
    "${preload[@]}" /usr/bin/python3 -c "
import numpy as np, rmpmarl
assert rmpmarl.__file__.startswith('$prefix'), rmpmarl.__file__
c = rmpmarl.load_controller(rmpmarl.shipped_policy(), robot='panda')
q = np.array([0.0, -0.5, 0.0, -2.0, 0.0, 1.6, 0.8]); c.reset(q)
qdd = c.accelerations(q, np.zeros(7), target=c.robot.end_effector_position(q) + [0.1, 0, 0])
assert np.all(np.isfinite(qdd)) and np.linalg.norm(qdd) > 0, qdd
print('installed python package: ok')
")
fi
