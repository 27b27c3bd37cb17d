"""No import circle between modules of puppet.

The graph is read from the source with ``ast``: every ``import``/``from ... import``
of a ``puppet`` module, at module level or inside a function (a lazy import still
ties the two modules together), relative imports resolved; an ``if TYPE_CHECKING:``
block is left out. ``from puppet.pkg import name`` is an edge to ``puppet.pkg.name``
when that is a module, else to ``puppet.pkg``.
"""
from __future__ import annotations

import ast
import os


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def find_modules(src_dir: str, package: str) -> dict[str, str]:
    """``{dotted module name: file path}`` for every .py file under ``src_dir/package``."""
    modules = {}
    top = os.path.join(src_dir, package)
    for folder, dirs, files in os.walk(top):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        rel = os.path.relpath(folder, src_dir).replace(os.sep, ".")
        for f in sorted(files):
            if not f.endswith(".py"):
                continue
            name = rel if f == "__init__.py" else f"{rel}.{f[:-3]}"
            modules[name] = os.path.join(folder, f)
    return modules


def _is_type_checking(test: ast.expr) -> bool:
    if isinstance(test, ast.Name):
        return test.id == "TYPE_CHECKING"
    return isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"


def _import_nodes(tree: ast.AST):
    """Import statements anywhere in the tree, skipping ``if TYPE_CHECKING:`` bodies."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
            continue
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            stack.extend(node.orelse)
            continue
        stack.extend(ast.iter_child_nodes(node))


def _known(name: str, modules) -> str | None:
    """``name`` or its longest prefix that is a module of the package."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def module_imports(name: str, path: str, modules) -> set[str]:
    """The package's modules that module ``name`` (file ``path``) imports."""
    with open(path, encoding="utf-8") as fh:
        tree = ast.parse(fh.read(), path)
    is_pkg = os.path.basename(path) == "__init__.py"
    here = name if is_pkg else name.rpartition(".")[0]
    out = set()
    for node in _import_nodes(tree):
        if isinstance(node, ast.Import):
            targets = [_known(a.name, modules) for a in node.names]
        else:
            if node.level:
                base = here.split(".")
                base = base[: len(base) - (node.level - 1)]
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            targets = []
            for a in node.names:
                sub = f"{base}.{a.name}"
                targets.append(sub if sub in modules else _known(base, modules))
        out.update(t for t in targets if t and t != name)
    return out


def import_graph(src_dir: str, package: str) -> dict[str, set[str]]:
    modules = find_modules(src_dir, package)
    return {m: module_imports(m, p, modules) for m, p in modules.items()}


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components, iteratively (no recursion limit)."""
    index, low, on_stack = {}, {}, set()
    stack, comps, counter = [], [], 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    comps.append(sorted(comp))
    return comps


def _shortest_circle(graph, comp: list[str]) -> list[str]:
    """A shortest path from the component's first module back to itself, inside it."""
    start, members = comp[0], set(comp)
    came = {start: None}
    queue = [start]
    for v in queue:
        for w in sorted(graph[v]):
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(came[path[-1]])
                return path[::-1] + [start]
            if w in members and w not in came:
                came[w] = v
                queue.append(w)
    raise AssertionError(f"not a circle: {comp}")


def circle_components(graph: dict[str, set[str]]) -> list[list[str]]:
    return sorted(c for c in strongly_connected(graph) if len(c) > 1)


def circles(graph: dict[str, set[str]]) -> list[str]:
    """One line per import circle: ``a -> b -> c -> a`` (and the component if larger)."""
    lines = []
    for comp in circle_components(graph):
        path = _shortest_circle(graph, comp)
        line = " -> ".join(path)
        if len(path) - 1 < len(comp):
            line += f"   (all of: {', '.join(comp)})"
        lines.append(line)
    return lines


# -- the checker on tiny packages ------------------------------------------------------

def _write(tmp_path, files: dict[str, str]):
    for rel, text in files.items():
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return str(tmp_path)


def test_checker_finds_a_circle_through_a_lazy_and_a_relative_import(tmp_path):
    src = _write(tmp_path, {
        "pkg/__init__.py": "",
        "pkg/a.py": "from pkg.b import f\n",
        "pkg/b.py": "def f():\n    from .c import g\n    return g\n",
        "pkg/c.py": "import pkg.a\n",
        "pkg/d.py": "from pkg import a\n",
    })
    graph = import_graph(src, "pkg")
    assert graph["pkg.d"] == {"pkg.a"}
    assert graph["pkg.b"] == {"pkg.c"}
    assert circles(graph) == ["pkg.a -> pkg.b -> pkg.c -> pkg.a"]


def test_checker_package_init_and_submodule_circle(tmp_path):
    src = _write(tmp_path, {
        "pkg/__init__.py": "",
        "pkg/sub/__init__.py": "from .x import X\n",
        "pkg/sub/x.py": "from pkg.sub import helper\n",
    })
    assert circles(import_graph(src, "pkg")) == ["pkg.sub -> pkg.sub.x -> pkg.sub"]


def test_checker_no_circle(tmp_path):
    src = _write(tmp_path, {
        "pkg/__init__.py": "from pkg.a import f\n",
        "pkg/a.py": "from typing import TYPE_CHECKING\nfrom pkg import b\n"
                    "if TYPE_CHECKING:\n    from pkg.c import C\n",
        "pkg/b.py": "import os\n",
        "pkg/c.py": "from pkg.a import f\n",
    })
    graph = import_graph(src, "pkg")
    assert graph["pkg.a"] == {"pkg.b"}
    assert circles(graph) == []
    assert len(strongly_connected(graph)) == 4


def test_tarjan_on_a_long_chain_needs_no_recursion():
    n = 5000
    graph = {f"m{i}": {f"m{i + 1}"} for i in range(n)}
    graph[f"m{n}"] = {"m0"}
    (comp,) = strongly_connected(graph)
    assert len(comp) == n + 1


# -- the real package ------------------------------------------------------------------

def test_puppet_has_no_import_circle():
    found = circles(import_graph(ROOT, "puppet"))
    assert not found, "import circles:\n" + "\n".join(found)

