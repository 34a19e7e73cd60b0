#!/usr/bin/env python3
"""One name per type: fails when two different classes share a qualified name in libmr.

Every tool links all of libmr, so two definitions of mr::X (two headers, or a
header and a .cpp outside an anonymous namespace) break the one-definition
rule, and neither the compiler nor the linker says so (classes have no
symbols of their own: the first member function or vtable wins, silently).
This reads every file of libmr/ and lists each class, struct, union or enum
defined at namespace scope, with its namespace, outside anonymous namespaces
(those have internal linkage).  Nested classes are qualified by their outer
class, which is unique when the outer ones are.  A forward declaration
("struct X;") is not a definition.

The code is clang-formatted (scripts/check-format.sh), so braces and
namespaces are read line by line: a namespace opens with "namespace N {" and
a type with "struct X ... {" or "class X ... {" at the start of a line.
Exit 1 with every clash listed; 0 with a one-line count.
"""
import pathlib
import re
import sys

root = pathlib.Path(__file__).resolve().parent.parent
libmr = root / "libmr"

ns_open = re.compile(r"^\s*namespace\s*([A-Za-z_][\w:]*)?\s*\{")
type_def = re.compile(
    r"^\s*(?:template\s*<[^>]*>\s*)?(?:struct|class|union|enum(?:\s+class|\s+struct)?)\s+"
    r"(?:alignas\([^)]*\)\s*)?([A-Za-z_]\w*(?:::[A-Za-z_]\w*)*)\s*(?:final\s*)?(?::(?!:)[^;{]*)?\{")


def definitions(path):
    """(qualified name, line) of each type defined at namespace scope outside anonymous namespaces."""
    stack = []  # ("ns", name) or ("type", name) or ("block", None), one per open brace
    out = []
    text = path.read_text(encoding="utf-8", errors="replace")
    # Comments and string literals cannot open or close scopes.
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    text = re.sub(r'"(?:\\.|[^"\\\n])*"', '""', text)
    text = re.sub(r"'(?:\\.|[^'\\\n])'", "''", text)
    for n, line in enumerate(text.splitlines(), 1):
        opened = None
        m = ns_open.match(line)
        if m:
            opened = ("ns", m.group(1) or "")
        else:
            m = type_def.match(line)
            if m and all(kind in ("ns", "type") for kind, _ in stack):
                opened = ("type", m.group(1))
                if all(name for kind, name in stack if kind == "ns"):
                    qual = "::".join(name for _, name in stack if name) + "::" + m.group(1)
                    out.append((qual.lstrip(":"), n))
        for i, ch in enumerate(line):
            if ch == "{":
                stack.append(opened if opened and i == line.index("{") else ("block", None))
            elif ch == "}" and stack:
                stack.pop()
    return out


def main():
    seen = {}
    for path in sorted(libmr.rglob("*")):
        if path.suffix not in (".h", ".cpp", ".in"):
            continue
        for qual, line in definitions(path):
            seen.setdefault(qual, []).append(f"{path.relative_to(root)}:{line}")
    clashes = {q: where for q, where in seen.items() if len(where) > 1}
    for q, where in sorted(clashes.items()):
        print(f"check-odr: {q} is defined {len(where)} times: {', '.join(where)}")
    if clashes:
        print(f"check-odr: {len(clashes)} qualified names name more than one class (rename one of each)")
        return 1
    print(f"check-odr: {len(seen)} classes at namespace scope in libmr, each name defined once")
    return 0


if __name__ == "__main__":
    sys.exit(main())
