#!/usr/bin/env bash
# Installs rmpmarl into a temporary prefix and builds + runs a consumer that uses find_package(rmpmarl).
set -euo pipefail
build_dir=$1; source_dir=$2
prefix=$(mktemp -d); trap 'rm -rf "$prefix"' EXIT
cmake --install "$build_dir" --prefix "$prefix" >/dev/null
cmake -S "$source_dir/tests/install/consumer" -B "$prefix/consumer-build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$prefix/consumer-build" >/dev/null
RMPMARL_MODELS_DIR="$prefix/share/rmpmarl/models" "$prefix/consumer-build/consumer"
# the control-loop example of examples/ (docs/control-your-robot.md), built against the same installed package
cmake -S "$source_dir/examples/control_loop" -B "$prefix/example-build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$prefix/example-build" >/dev/null
RMPMARL_MODELS_DIR="$prefix/share/rmpmarl/models" "$prefix/example-build/control_loop"
