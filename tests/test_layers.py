"""The package's shape, checked: every module imports alone, no module
imports another that imports it back (no cycle), imports point down the
layers `cli/serve -> api/worker/bench -> argand.farm ->
render/frames/media/scene -> argand.core` (LAYERS), only argand.serve and
argand.cli import both the API and the workers, argand.farm imports at the
top only, no function of the farm, the API or the workers is longer than 60
lines, and only the edges read the environment (ENVIRONMENT_READERS)."""

from __future__ import annotations

import ast
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: The `argand` package is src/argand: every module argand.X.Y is the file src/argand/X/Y.py.
ROOTS = {"argand": REPO / "src" / "argand"}
#: Layer of each part: a module may import its own layer and the ones below.
LAYERS = {"argand.cli": 4, "argand.serve": 4, "argand.bench": 3, "argand.api": 3, "argand.worker": 3, "argand.farm": 2,
          "argand.render": 1, "argand.frames": 1, "argand.media": 1, "argand.scene": 1, "argand.core": 0, "argand": 0}
MAX_FUNCTION_LINES = 60


def modules() -> dict[str, Path]:
    found: dict[str, Path] = {}
    for prefix, root in ROOTS.items():
        for path in sorted(root.rglob("*.py")):
            rel = path.relative_to(root).with_suffix("")
            if "tests" not in rel.parts and "migrations" not in rel.parts:
                found[".".join([prefix, *[p for p in rel.parts if p != "__init__"]])] = path
    return found


MODULES = modules()


def layer(name: str) -> int:
    return max((v, len(k)) for k, v in LAYERS.items() if name == k or name.startswith(k + "."))[0]


def imports(name: str, path: Path, top_level_only: bool) -> set[str]:
    """The argand modules that ``name`` imports (at the top, or anywhere)."""
    tree = ast.parse(path.read_text())
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    out: set[str] = set()
    for node in nodes:
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            base = node.module
            out.add(base)
            out |= {f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in MODULES}
    return {m for m in out if m in MODULES}


def test_the_layout_is_found():
    assert {"argand.farm.states", "argand.api.app", "argand.worker.tasks", "argand.render.frames", "argand.core.roots",
            "argand.cli"} <= set(MODULES)


def test_each_module_imports_alone():
    """Each module of the farm, the API and the workers in a fresh interpreter
    (an import that only works after another module was imported fails)."""
    names = [m for m in MODULES if m.startswith(("argand.farm", "argand.api", "argand.worker"))]

    def run(name: str) -> tuple[str, subprocess.CompletedProcess]:
        return name, subprocess.run([sys.executable, "-c", f"import {name}"], capture_output=True, text=True,
                                    cwd=REPO / "tests")

    with ThreadPoolExecutor(4) as pool:
        failed = {name: r.stderr[-400:] for name, r in pool.map(run, names) if r.returncode != 0}
    assert len(names) > 20 and failed == {}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """A cycle of the graph as a list of nodes (first == last), or None."""
    state: dict[str, int] = {}  # 1: on the path, 2: done
    path: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        path.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return path[path.index(m):] + [m]
            if m not in state and (found := visit(m)):
                return found
        path.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state and (found := visit(n)):
            return found
    return None


def test_the_cycle_finder_finds_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_no_import_cycles():
    graph = {name: imports(name, path, top_level_only=True) - {name} for name, path in MODULES.items()}
    # A package's __init__ importing its own modules is not a cycle with them.
    for name in graph:
        graph[name] = {m for m in graph[name] if not name.startswith(m + ".")}
    assert find_cycle(graph) is None, find_cycle(graph)


def test_imports_point_down_the_layers():
    wrong = [(name, m) for name, path in MODULES.items() for m in imports(name, path, top_level_only=False)
             if layer(m) > layer(name)]
    assert wrong == []
    farm = [n for n in MODULES if n.startswith("argand.farm")]
    assert len(farm) > 10
    for name in farm:
        assert not {m for m in imports(name, MODULES[name], False) if m.startswith(("argand.api", "argand.worker"))}


def test_only_serve_and_the_cli_import_both_api_and_worker():
    """argand.serve is the composition root: the API and the workers never
    import each other, and nothing else imports both."""
    both = []
    for name, path in MODULES.items():
        found = imports(name, path, top_level_only=False)
        if name.startswith("argand.api") and any(m.startswith("argand.worker") for m in found):
            both.append((name, "worker"))
        if name.startswith("argand.worker") and any(m.startswith("argand.api") for m in found):
            both.append((name, "api"))
    assert both == []
    packages = {name.split(".")[1] for name in MODULES if name.count(".") >= 1}
    importers = {p for p in packages
                 if any(m.startswith("argand.api") for n, path in MODULES.items() if n.split(".")[1:2] == [p]
                        for m in imports(n, path, False))
                 and any(m.startswith("argand.worker") for n, path in MODULES.items() if n.split(".")[1:2] == [p]
                         for m in imports(n, path, False))}
    assert importers <= {"serve", "cli"}, importers
    # The supervisor composes the farm: it serves the API itself and starts the workers as processes.
    assert "argand.api.app" in imports("argand.serve.supervisor", MODULES["argand.serve.supervisor"], False)


def reached(name: str) -> set[str]:
    """The argand modules ``name`` imports, directly or through others."""
    seen: set[str] = set()
    todo = [name]
    while todo:
        m = todo.pop()
        if m not in seen:
            seen.add(m)
            todo += imports(m, MODULES[m], top_level_only=False)
    return seen


def test_submission_and_the_api_do_not_import_the_workers_run_of_tiles():
    """A job is planned at submission by argand.farm.planning, which the
    worker's run of tiles (argand.farm.tile_work) uses too: the API side
    never loads the worker's module."""
    assert "argand.farm.tile_work" in reached("argand.worker.tasks")
    for name in ["argand.farm.submission"] + [n for n in MODULES if n.startswith("argand.api")]:
        assert "argand.farm.tile_work" not in reached(name), name


def test_the_farm_imports_at_the_top_only():
    for name in [n for n in MODULES if n.startswith("argand.farm")]:
        assert imports(name, MODULES[name], True) == imports(name, MODULES[name], False), name


def test_no_function_of_the_farm_api_or_workers_is_long():
    long = []
    for name, path in MODULES.items():
        if name.startswith(("argand.farm", "argand.api", "argand.worker")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    n = node.end_lineno - node.lineno + 1
                    if n > MAX_FUNCTION_LINES:
                        long.append(f"{name}.{node.name}: {n} lines")
    assert long == []


#: The only modules that read the process's environment: the engine's
#: options, the farm's settings (which also build a worker's environment
#: from this process's) and the CLI.
ENVIRONMENT_READERS = {"argand.render.options", "argand.farm.settings", "argand.cli"}


def reads_environment(path: Path) -> bool:
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Attribute) and node.attr in ("environ", "getenv", "environb", "putenv"):
            return True
        if isinstance(node, ast.ImportFrom) and node.module == "os" and {a.name for a in node.names} & {"environ", "getenv"}:
            return True
    return False


def test_only_the_edges_read_the_environment():
    readers = {name for name, path in MODULES.items() if reads_environment(path) and not name.startswith("argand.bench")}
    assert readers <= ENVIRONMENT_READERS, readers - ENVIRONMENT_READERS
    assert "argand.render.options" in readers
    core = REPO / "core"
    getenv = [str(p.relative_to(REPO)) for p in core.rglob("*") if p.suffix in (".cpp", ".h") and "getenv" in p.read_text()]
    assert getenv == []
