"""The house rules, checked: one source for every list of choices, no private names imported
across modules, no oversized files. (The layers are import-linter's contract in
pyproject.toml, run by `make test`'s lint step.)"""

import ast
from pathlib import Path

import pytest

from rrr4.contact.friction import FRICTION_LAWS
from rrr4.contact.lubrication import LUBRICATION_LAWS
from rrr4.contact.normal import NORMAL_LAWS
from rrr4.integrators import METHODS
from rrr4.integrators.implicit import ImplicitIntegrator
from rrr4.preload.qp import QP_OPTIONS
from rrr4.preload.solve import PRELOAD_METHODS
from rrr4.scene import vocabulary as v

PACKAGE = Path(__file__).resolve().parents[1] / "rrr4"


@pytest.mark.parametrize("registry,names", [
    (NORMAL_LAWS, v.CONTACT_LAWS),
    (FRICTION_LAWS, v.FRICTION_LAWS),
    (LUBRICATION_LAWS, v.LUBRICATION_LAWS),
    (METHODS, v.INTEGRATORS),
    (PRELOAD_METHODS, v.PRELOAD_METHODS),
    (QP_OPTIONS, v.QP_SOLVERS),
], ids=["contact law", "friction law", "lubrication law", "integrator", "preload method", "qp solver"])
def test_every_registry_holds_exactly_the_names_of_the_vocabulary(registry, names):
    assert tuple(registry) == tuple(names)


def test_a_registry_refuses_names_and_implementations_that_differ():
    with pytest.raises(RuntimeError, match="differ"):
        v.registry(("a", "b"), {"a": 1})
    with pytest.raises(RuntimeError, match="differ"):
        v.registry(("a",), {"a": 1, "b": 2})
    assert list(v.registry(("b", "a"), {"a": 1, "b": 2})) == ["b", "a"]


def test_error_control_names_the_implicit_methods():
    assert v.ERROR_CONTROLLED == tuple(k for k, m in METHODS.items() if issubclass(m, ImplicitIntegrator))


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path, ast.parse(path.read_text(), str(path))


def test_no_module_imports_another_modules_private_names():
    bad = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                bad += [f"{path.relative_to(PACKAGE.parent)}:{node.lineno} {a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
    assert not bad, "private names imported across modules:\n" + "\n".join(bad)


def test_no_package_file_is_over_700_lines():
    long = {str(p.relative_to(PACKAGE.parent)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > 700}
    assert not long, long


def test_the_import_graph_has_no_circle():
    """No module reaches itself through imports (function-level imports included): Tarjan's
    strongly connected components of grimp's graph of the package are all single modules."""
    import grimp
    graph = grimp.build_graph("rrr4")
    edges = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in graph.modules}
    index, low, stack, on, circles = {}, {}, [], set(), []

    def visit(v):  # iterative Tarjan: (module, next edge) frames
        frames = [(v, 0)]
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        while frames:
            u, k = frames.pop()
            if k < len(edges[u]):
                frames.append((u, k + 1))
                w = edges[u][k]
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    frames.append((w, 0))
                elif w in on:
                    low[u] = min(low[u], index[w])
                continue
            if frames:
                parent = frames[-1][0]
                low[parent] = min(low[parent], low[u])
            if low[u] == index[u]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == u:
                        break
                if len(comp) > 1:
                    circles.append(sorted(comp))

    for m in sorted(edges):
        if m not in index:
            visit(m)
    assert not circles, circles


def test_no_function_outside_the_command_line_is_over_100_lines_of_code():
    """Functions stay readable: at most 100 lines each, not counting the docstring (cli.py's
    argument tables are exempt)."""
    long = {}
    for path, tree in _modules():
        if path.name == "cli.py":
            continue
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                first = node.body[0]
                doc = first.end_lineno - first.lineno + 1 if (
                    isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
                    and isinstance(first.value.value, str)) else 0
                if (n := node.end_lineno - node.lineno + 1 - doc) > 100:
                    long[f"{path.relative_to(PACKAGE.parent)}:{node.name}"] = n
    assert not long, long
