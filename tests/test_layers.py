"""The package's layout: imports go one way, from each layer to the layers below it, and modules stay small."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "contin"

#: the layers, lowest first (the table in contin/__init__.py)
LAYERS = ("util", "engine", "model", "hb", "stability", "timedomain", "modal", "bifurcation", "output", "scene",
          "analyses", "app", "api")
#: the continuation engine knows nothing about vibrations: it imports no other layer at all
ENGINE_MAY_USE = ("util", "engine")
#: a module of more lines than this holds more than one idea
MAX_LINES = 600


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        yield ".".join(("contin",) + rel.with_suffix("").parts), rel, path


def _layer(dotted: str) -> str | None:
    parts = dotted.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "contin" and parts[1] in LAYERS else None


def _imports(path: Path):
    """Every ``contin`` module a file imports, at any depth (function bodies and TYPE_CHECKING blocks too)."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}:{node.lineno}: relative import; write the absolute name"
            if node.module == "contin":
                for a in node.names:
                    yield node.lineno, f"contin.{a.name}"
            elif node.module:
                yield node.lineno, node.module


MODULES = list(_modules())


def test_every_module_lives_in_a_layer():
    loose = [str(rel) for _, rel, _ in MODULES if len(rel.parts) == 1 and rel.name not in ("__init__.py", "__main__.py")]
    assert not loose, f"modules outside the layer folders: {loose}"
    assert {p.name for p in PACKAGE.iterdir() if p.is_dir() and not p.name.startswith("__")} == set(LAYERS)


@pytest.mark.parametrize("name,rel,path", MODULES, ids=[str(m[1]) for m in MODULES])
def test_imports_go_down_the_layers(name, rel, path):
    own = _layer(name)
    if own is None:  # contin/__init__.py, contin/__main__.py: the entry points
        return
    rank = LAYERS.index(own)
    bad = []
    for line, target in _imports(path):
        layer = _layer(target)
        if target == "contin":  # the version
            continue
        if target.startswith("contin.models"):
            bad.append(f"line {line}: {target} (the built-in models are plug-ins, loaded by the catalogue)")
        elif layer is None:
            continue
        elif LAYERS.index(layer) > rank or (own == "engine" and layer not in ENGINE_MAY_USE):
            bad.append(f"line {line}: {target} ({layer} is above {own})")
    assert not bad, f"{rel} imports upwards:\n" + "\n".join(bad)


def _runtime_imports(path: Path):
    """The contin modules a file imports when it runs: at any depth, but not under ``if TYPE_CHECKING:``."""
    tree = ast.parse(path.read_text())
    typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
                   for n in ast.walk(node)}
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("contin"):
            yield node.module
            yield from (f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            yield from (a.name for a in node.names)


def test_no_import_cycles_between_modules():
    """No cycle among the modules, counting the imports inside functions: none of them hides a cycle."""
    names = {name.removesuffix(".__init__") for name, _, _ in MODULES}
    graph = {}
    for name, _, path in MODULES:
        name = name.removesuffix(".__init__")
        graph[name] = {d for d in _runtime_imports(path) if d in names and d != name}
    state, stack = {}, []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for d in sorted(graph[n]):
            if state.get(d) == 1:
                pytest.fail("import cycle: " + " -> ".join(stack[stack.index(d):] + [d]))
            if d not in state:
                visit(d)
        stack.pop()
        state[n] = 2

    for n in graph:
        if n not in state:
            visit(n)


@pytest.mark.parametrize("name,rel,path", MODULES, ids=[str(m[1]) for m in MODULES])
def test_modules_hold_one_idea(name, rel, path):
    n = len(path.read_text().splitlines())
    assert n <= MAX_LINES, f"{rel} has {n} lines (> {MAX_LINES}): split it along its ideas"
