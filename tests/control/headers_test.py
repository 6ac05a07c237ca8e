#!/usr/bin/env python3
"""The controller library's public headers, with every project header they include, reach no header of MuJoCo,
libtorch, EGL or assimp (a robot program compiles against rmpmarl::control without them)."""
import pathlib
import re
import sys

include = pathlib.Path(sys.argv[1]) / "include"
banned = re.compile(r'#include\s*[<"](mujoco/|torch/|ATen/|c10/|EGL/|assimp/)')
project = re.compile(r'#include\s*"(rmpmarl/[^"]+)"')
failures = []
for header in sorted((include / "rmpmarl" / "control").glob("*.h")):
    seen, todo = set(), [header.relative_to(include).as_posix()]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        text = (include / name).read_text()
        for m in banned.finditer(text):
            failures.append(f"{header.name} reaches {m.group(0)} through {name}")
        todo.extend(project.findall(text))
    if not seen:
        failures.append(f"{header.name}: nothing read")
print(f"{len(list((include / 'rmpmarl' / 'control').glob('*.h')))} control headers checked")
if failures:
    print("\n".join(failures))
    sys.exit(1)
