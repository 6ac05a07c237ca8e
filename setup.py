"""`pip install --no-build-isolation .` (Debian's python3-skbuild, python3-pybind11 via pybind11-dev): builds the
library and the Python module with CMake and packs them with the shipped models and configs. Training (libtorch),
the command-line tool, its viewer, tests and benchmarks are left out of this build; `make` builds everything."""
from skbuild import setup

setup(
    name="rmpmarl",
    version="0.1.0",
    description="Reactive motion generation for robot manipulators: learned per-joint agents over Riemannian Motion "
                "Policies, RMPflow, vectorised multi-agent environments",
    packages=["rmpmarl"],
    package_dir={"": "python"},
    package_data={"rmpmarl": ["py.typed", "*.pyi"]},
    python_requires=">=3.9",
    install_requires=["numpy"],
    cmake_args=[
        "-DRMPMARL_WITH_TORCH=OFF",
        "-DRMPMARL_BUILD_TESTS=OFF",
        "-DRMPMARL_BUILD_BENCH=OFF",
        "-DRMPMARL_BUILD_CLI=OFF",  # the command-line tool and its viewer: not the Python package's
        "-DRMPMARL_BUILD_WEB=OFF",
        "-DCMAKE_BUILD_TYPE=Release",
        "-GNinja",
    ],
    cmake_install_target="install/strip",
)
