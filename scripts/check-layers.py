#!/usr/bin/env python3
"""Checks every #include of libmr, tests/ and bench/ against the layer order.

The order is the mr_layer(NAME DEPS ...) lines of libmr/CMakeLists.txt; a
folder may include itself and what it links, transitively.  A test may
include what its mr_test(... LAYERS ...) line links (tests/CMakeLists.txt).
The build enforces the same order (each folder's include root is handed on
only by linking); this check names every offending line at once, and
also finds cycles.  Exit 0: clean; 1: violations, printed one a line.
"""
import pathlib
import re
import sys

root = pathlib.Path(__file__).resolve().parent.parent
libmr = root / "libmr"


def calls(text, func):
    """The argument lists of every call of `func` in a CMake file."""
    for m in re.finditer(r"^\s*" + func + r"\(([^)]*)\)", text, re.M):
        yield m.group(1).split()


def keyword_args(args, key, stops):
    out, on = [], False
    for a in args:
        if a == key:
            on = True
        elif a in stops:
            on = False
        elif on:
            out.append(a)
    return out


deps = {}
for args in calls((libmr / "CMakeLists.txt").read_text(), "mr_layer"):
    if args[0] == "name":  # the function's own definition
        continue
    deps[args[0]] = keyword_args(args, "DEPS", {"PRIVATE"})

problems = []
closure = {}


def reach(name, path=()):
    if name in path:
        problems.append("cycle: " + " -> ".join(path + (name,)))
        return set()
    if name not in closure:
        s = {name}
        for d in deps.get(name, []):
            if d not in deps:
                problems.append(f"libmr/CMakeLists.txt: {name} links {d}, which is not a layer")
                continue
            s |= reach(d, path + (name,))
        closure[name] = s
    return closure[name]


for name in deps:
    reach(name)
    for d in deps[name]:
        if d in deps and name in reach(d):
            problems.append(f"cycle: {name} <-> {d}")

include = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/')


def check(path, allowed, who):
    for lineno, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
        m = include.match(line)
        if m and m.group(1) in deps and m.group(1) not in allowed:
            problems.append(f"{path.relative_to(root)}:{lineno}: {who} includes {m.group(1)}/, "
                            f"which it does not link ({', '.join(sorted(allowed))})")


folders = {p.name for p in libmr.iterdir() if p.is_dir()}
for f in sorted(folders - set(deps)):
    problems.append(f"libmr/{f}/ is not declared by mr_layer() in libmr/CMakeLists.txt")
for name in deps:
    for src in sorted((libmr / name).glob("*")):
        if src.suffix in (".h", ".cpp", ".in"):
            check(src, reach(name), f"layer {name}")

tests = root / "tests"
covered = set()
for args in calls((tests / "CMakeLists.txt").read_text(), "mr_test"):
    if args[0] == "name":
        continue
    allowed = set()
    for l in keyword_args(args, "LAYERS", {"SOURCES", "RELEASE_ONLY"}):
        allowed |= reach(l)
    for s in keyword_args(args, "SOURCES", {"LAYERS", "RELEASE_ONLY"}):
        covered.add(s)
        check(tests / s, allowed, args[0])
        if not (tests / s).exists():
            problems.append(f"tests/{s}: named by mr_test({args[0]}) but missing")
            continue
        check(tests / s, allowed, args[0])
        # Headers beside a test that it includes belong to it.
        text = (tests / s).read_text(errors="replace")
        for h in sorted((tests / s).parent.glob("*.h")):
            if f'/{h.name}"' in text:
                check(h, allowed, args[0])
for src in sorted(tests.glob("*/*_test.cpp")):
    if str(src.relative_to(tests)) not in covered:
        problems.append(f"{src.relative_to(root)}: not built by any mr_test() in tests/CMakeLists.txt")

for p in problems:
    print(p)
print(f"check-layers: {len(deps)} layers, {len(problems)} problems")
sys.exit(1 if problems else 0)
