"""The layering of the package, read from the source with `ast` (no import is executed).

Layers, bottom to top: model < io < vision < track < count < stream < sim < cli. A module may import
its own subpackage and any layer below; `rhythmjax.evaluation` (benchmark and study code) may
import the library, but nothing in the library imports it; `rhythmjax` never imports `fit`; no
module imports a private (underscore) name from another module; the module graph has no circle.
"""

from __future__ import annotations

import ast
import pathlib

import pytest


ROOT = pathlib.Path(__file__).resolve().parents[1]
LAYERS = ("model", "io", "vision", "track", "count", "stream", "sim", "cli")
TOP_LEVEL_OK = {"rhythmjax", "rhythmjax.evaluation"}  # re-exports / evaluation code


def module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imports_of(path: pathlib.Path) -> list[tuple[str, list[str], int]]:
    """(imported module, names, line) for every import in the file, relative ones resolved."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, [], node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            names = [a.name for a in node.names]
            # `from pkg import submodule` imports the submodule
            subs = [n for n in names if (ROOT / mod.replace(".", "/") / f"{n}.py").exists()
                    or (ROOT / mod.replace(".", "/") / n / "__init__.py").exists()]
            out += [(f"{mod}.{n}", [], node.lineno) for n in subs]
            rest = [n for n in names if n not in subs]
            if rest or not subs:
                out.append((mod, rest, node.lineno))
    return out


def private_attribute_uses(path: pathlib.Path) -> list[tuple[str, int]]:
    """`module._name` where `module` is a project module bound by an import in this file."""
    tree = ast.parse(path.read_text(), str(path))
    by_line: dict[int, list[str]] = {}
    for mod, _, line in imports_of(path):
        by_line.setdefault(line, []).append(mod)
    aliases = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for mod in by_line.get(node.lineno, []):
                for a in node.names:
                    if mod.endswith("." + a.name) and mod.split(".")[0] in ("rhythmjax", "fit"):
                        aliases.add(a.asname or a.name)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in ("rhythmjax", "fit") and a.asname:
                    aliases.add(a.asname)
    return [(f"{n.value.id}.{n.attr}", n.lineno) for n in ast.walk(tree)
            if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name)
            and n.value.id in aliases and n.attr.startswith("_") and not n.attr.endswith("__")]


def sources(package: str) -> list[pathlib.Path]:
    return sorted((ROOT / package).rglob("*.py"))


def layer(module: str) -> int | None:
    parts = module.split(".")
    if parts[0] != "rhythmjax" or len(parts) < 2 or parts[1] not in LAYERS:
        return None
    return LAYERS.index(parts[1])


def library_graph() -> dict[str, set[str]]:
    graph = {}
    for path in sources("rhythmjax"):
        graph[module_name(path)] = {m for m, _, _ in imports_of(path)
                                    if m.startswith("rhythmjax")}
    return graph


def test_imports_go_down_the_layers():
    bad = []
    for path in sources("rhythmjax"):
        me = module_name(path)
        if me in TOP_LEVEL_OK or me.startswith("rhythmjax.evaluation"):
            continue
        mine = layer(me)
        assert mine is not None, f"{me}: not in a layer {LAYERS}"
        for mod, _, line in imports_of(path):
            if mod.startswith("rhythmjax.evaluation") or mod.startswith("fit"):
                bad.append(f"{path}:{line}: imports {mod}")
            elif mod.startswith("rhythmjax"):
                theirs = layer(mod)
                if theirs is None and mod != "rhythmjax":
                    bad.append(f"{path}:{line}: imports {mod} (outside the layers)")
                elif theirs is not None and theirs > mine:
                    bad.append(f"{path}:{line}: {LAYERS[mine]} imports {mod} (a layer up)")
    assert not bad, "\n".join(bad)


def test_no_private_names_across_modules():
    bad = []
    for package in ("rhythmjax", "fit"):
        for path in sources(package):
            for mod, names, line in imports_of(path):
                if not (mod.startswith("rhythmjax") or mod.startswith("fit")):
                    continue
                priv = [n for n in names if n.startswith("_") and n != "__version__"]
                if priv or mod.rpartition(".")[2].startswith("_") and not mod.endswith("__"):
                    bad.append(f"{path}:{line}: from {mod} import {', '.join(priv)}")
            bad += [f"{path}:{line}: uses {name}" for name, line in private_attribute_uses(path)]
    assert not bad, "\n".join(bad)


def test_rhythmjax_never_imports_fit_or_cli_from_below():
    for path in sources("rhythmjax"):
        for mod, _, line in imports_of(path):
            assert not mod.startswith("fit"), f"{path}:{line}: rhythmjax imports {mod}"
            if mod.startswith("rhythmjax.cli"):
                assert module_name(path).startswith("rhythmjax.cli"), \
                    f"{path}:{line}: the library imports the command line ({mod})"


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    colour: dict[str, int] = {}
    stack: list[str] = []

    def visit(node):
        colour[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in graph:
                continue
            if colour.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if colour.get(nxt) is None:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        colour[node] = 2
        return None

    for node in sorted(graph):
        if colour.get(node) is None:
            found = visit(node)
            if found:
                return found
    return None


def test_no_import_circle():
    # a package's __init__ re-exporting its modules is not a circle with them
    graph = {m: {d for d in deps if not (m.startswith(d + ".") and
                                         (ROOT / d.replace(".", "/") / "__init__.py").exists())}
             for m, deps in library_graph().items()}
    cycle = find_cycle(graph)
    assert cycle is None, " -> ".join(cycle)


def test_find_cycle_finds_one():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


@pytest.mark.parametrize("package", ["rhythmjax", "fit"])
def test_module_sizes(package):
    sizes = {p: len(p.read_text().splitlines()) for p in sources(package)}
    big = {str(p): n for p, n in sizes.items() if n > 450}
    assert not big, f"modules over 450 lines: {big}"
