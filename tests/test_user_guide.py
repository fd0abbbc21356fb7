"""docs/user-guide.md's Python runs as written, on tiny sizes, so the guide cannot drift from the API.

Each ```python block of the guide runs as its own script (a reader may start at any section) in a temporary
folder that holds small copies of the specs in sweeps/ (tests/test_readme.py's `tiny`: the same keys, two
values of each swept parameter or 4 sampled rows, 1 s of driving; a mission keeps its segments) and a link to
notebooks/. Every `batchveh.<name>` the guide writes, and every `sizing.<name>(...)` call, must exist.
"""

import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest
from test_readme import blocks, tiny_folder

pytestmark = pytest.mark.xdist_group("user_guide")  # one test worker: the module's shared fixtures run once

ROOT = Path(__file__).resolve().parent.parent
GUIDE = ROOT / "docs" / "user-guide.md"
RUN_TIMEOUT_S = 300
# the calls that sizing documents: each must run in one of the guide's Python blocks, not only be named
SIZING_CALLS = ("batchveh.load_spec(", "batchveh.load_catalogue(", "batchveh.load_battery(", "sizing.screen(")
SIZING_CALLS += ("sizing.in_loop(",)


@pytest.fixture(scope="module")
def guide(tmp_path_factory):
    """A folder to run the guide in (test_readme's `tiny_folder`)."""
    return tiny_folder(tmp_path_factory, "guide")


PYTHON = blocks(GUIDE, "python")


def test_the_guide_runs_the_sizing_calls_it_documents():
    assert PYTHON, "docs/user-guide.md has no ```python block"
    code = "\n".join(PYTHON)
    missing = [call for call in SIZING_CALLS if call not in code]
    assert not missing, f"documented but never run in a ```python block of the guide: {missing}"


@pytest.mark.parametrize("k", range(len(PYTHON)), ids=lambda k: f"block{k}")
def test_each_python_block_runs_as_written(guide, k):
    here, env = guide
    done = subprocess.run(
        [sys.executable, "-c", PYTHON[k]], cwd=here, env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT_S
    )
    assert done.returncode == 0, (
        f"user guide, python block {k}:\n{PYTHON[k]}\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
    )
    for line in PYTHON[k].splitlines():  # each print of a label shows the label: the block ran to its end
        label = re.match(r'print\("([^"{]+?):"', line.strip())
        if label:
            assert label.group(1) in done.stdout, (label.group(1), done.stdout[-2000:])
    if "sizing.in_loop(" in PYTHON[k]:  # a candidate ran in the loop: in_loop_lines has a line for it
        assert re.search(r"^\S+: covers \d", done.stdout, re.M), done.stdout[-2000:]


def _resolve(dotted: str):
    """batchveh.a.b.c as an attribute, importing the submodules on the way."""
    obj, prefix = importlib.import_module("batchveh"), "batchveh"
    for part in dotted.split(".")[1:]:
        prefix = f"{prefix}.{part}"
        if hasattr(obj, part):
            obj = getattr(obj, part)
        else:
            obj = importlib.import_module(prefix)  # ModuleNotFoundError names what the guide got wrong
    return obj


def test_every_name_the_guide_writes_exists():
    """`batchveh.x.y` anywhere in the guide (not a file name such as .batchveh.lock), and `sizing.f(` as a call
    of batchveh.sizing."""
    text = GUIDE.read_text()
    names = set(re.findall(r"(?<![\w./-])(batchveh(?:\.\w+)+)", text))
    assert {"batchveh.load_spec", "batchveh.load_catalogue", "batchveh.load_battery"} <= names
    missing = []
    for name in sorted(names):
        try:
            _resolve(name)
        except (AttributeError, ImportError):
            missing.append(name)
    from batchveh import sizing

    calls = set(re.findall(r"(?<![\w.])sizing\.(\w+)\(", text))
    assert {"screen", "in_loop"} <= calls
    missing += [f"sizing.{c}" for c in sorted(calls) if not hasattr(sizing, c)]
    assert not missing, f"the guide names what does not exist: {missing}"
