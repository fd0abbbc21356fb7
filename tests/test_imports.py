"""The package's own imports: no circles, and no layer imports a higher one.

Every `import batchveh...` counts, at the top of a module, inside a function or under
TYPE_CHECKING: a circle through a function-level import is still a circle. Read from the source
with `ast`; nothing is imported.
"""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "batchveh"

# The data flow, lowest first: each module may import its own layer and the ones below it. A layer
# is a folder of the package (test_each_folder_is_one_layer), but for the base and the top.
LAYERS = {
    "base": ("config", "cli"),  # cli: the one error path of every command line
    # what is simulated: the vehicle, the wheel-ground models, the ground, the motion laws, the scenario
    # kinds and the registry of sweepable parameters
    "model": tuple(
        f"model.{m}"
        for m in (
            "",
            "gearheads",
            "motors",
            "battery",
            "drive",
            "vehicle",
            "indexing",
            "tyres",
            "soil",
            "wheels",
            "laws",
            "course",
            "scenarios",
            "missions",
            "params",
            "reference",
        )
    ),
    # a chunk of variants -> the batched model; the pure step and scan bodies; the reductions in the carry
    "stepping": tuple(
        f"stepping.{m}" for m in ("", "fields", "batch", "rollout", "stats", "mission_stats", "motor_stats")
    ),
    "engines": (
        "engines", "engines.common", "engines.mujoco", "engines.mjx", "engines.warp_build", "engines.warp_physics",
        "engines.warp",
    ),  # fmt: skip
    # how many variants run, where, and where the results go
    "sweeping": tuple(
        f"sweeping.{m}" for m in ("", "storage", "spec", "results", "prestart", "chunks", "retry", "cluster", "gpus")
    ),
    "analysis": tuple(f"analysis.{m}" for m in ("", "demand", "plot", "sensitivity")),
    # sizing a motor and its gear ratio from a servo sweep: the screen, the windows, the requirement sheet, the loop
    "sizing": tuple(
        f"sizing.{m}"
        for m in ("", "screening", "ramps", "plan", "windows", "requirements", "thermal", "loop", "figures", "report")
    ),
    "face": ("",),  # batchveh/__init__.py: the public names
    "cli": ("sweep", "run", "render", "sensitivity", "size"),
}
LAYERS = {k: tuple(m.rstrip(".") for m in v) for k, v in LAYERS.items()}
# set at the top of batchveh/__init__.py before it imports any submodule, so any module may read them
FACE_CONSTANTS = {"__version__", "GL_PROBLEM"}


def _modules() -> dict[str, Path]:
    """'engines.mjx' -> its file; '' is the package's __init__."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that module `name` (in file `path`) imports: `from batchveh.x import y`
    names x.y where y is a module, else x ('' is batchveh/__init__.py)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:  # relative: from the package of `name`, up level - 1
                base = ["batchveh", *filter(None, package.split("."))]
                module = ".".join([*base[: len(base) - node.level + 1], *filter(None, [node.module])])
            if module == "batchveh" and all(a.name in FACE_CONSTANTS for a in node.names):
                continue
            subs = [f"{module}.{a.name}" for a in node.names]
            targets = [t for t in subs if t.removeprefix("batchveh.") in modules] or [module]
        else:
            continue
        for t in targets:
            if t == "batchveh" or t.startswith("batchveh."):
                inner = t.removeprefix("batchveh").removeprefix(".")
                if inner in modules:
                    found.add(inner)
    found.discard(name)
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _layer_of() -> dict[str, int]:
    return {m: i for i, names in enumerate(LAYERS.values()) for m in names}


def test_every_module_has_a_layer():
    layer = _layer_of()
    missing = sorted(m or "__init__" for m in _graph() if m not in layer)
    assert not missing, f"modules without a layer: {missing}; add each to LAYERS in tests/test_imports.py"


def test_no_import_circles():
    graph = _graph()
    circles, state = [], {}

    def visit(m, path):
        state[m] = "open"
        for d in sorted(graph[m]):
            if state.get(d) == "open":
                circles.append(" -> ".join([*path[path.index(d) :], d]) or "__init__")
            elif d not in state:
                visit(d, [*path, d])
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert not circles, "import circles: " + "; ".join(circles)


def test_no_layer_imports_a_higher_one():
    layer, names = _layer_of(), list(LAYERS)
    upward = [
        f"{m or '__init__'} ({names[layer[m]]}) imports {d or '__init__'} ({names[layer[d]]})"
        for m, deps in sorted(_graph().items())
        for d in sorted(deps)
        if m in layer and d in layer and layer[d] > layer[m]
    ]
    assert not upward, "imports against the flow: " + "; ".join(upward)


def test_the_graph_sees_function_level_and_relative_imports(tmp_path):
    """The reader itself: a function-level import and a TYPE_CHECKING import are edges."""
    src = tmp_path / "mod.py"
    src.write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from batchveh.model.scenarios import Scenario\n"
        "def f():\n    from batchveh.engines import mjx\n    from batchveh import __version__\n"
    )
    modules = {"model.scenarios": src, "engines": src, "engines.mjx": src, "": src}
    assert _imports("model.course", src, modules) == {"model.scenarios", "engines.mjx"}


def test_each_folder_is_one_layer():
    """The folders show the flow: each subpackage is named after a layer and holds exactly that layer's
    modules, and the layers without a folder (base, face, cli) hold only top-level modules."""
    layer, names = _layer_of(), list(LAYERS)
    folders = {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    strays = sorted(f for f in folders if f not in LAYERS)
    assert not strays, f"folders that are not a layer: {strays}; name each after its layer in tests/test_imports.py"
    graph = _graph()  # parsed once: each call reads and parses every module
    for module in graph:
        folder = module.split(".")[0] if module.split(".")[0] in folders else None
        home = names[layer[module]] if module in layer else None
        if folder is not None:
            assert home == folder, f"{module} is in the folder {folder}/ but in the layer {home}"
        else:
            assert home not in folders, f"{module or '__init__'} is in the layer {home} but not in the folder {home}/"
    assert all(m in graph for names_ in LAYERS.values() for m in names_), "LAYERS names a module that is gone"
