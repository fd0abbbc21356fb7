"""The generated pages match their sources: docs/validation.md (validation/render.py, from the tests'
constants and validation/results/) and docs/performance.md (benchmarks/render.py, from
benchmarks/results/). Cheap: files are parsed, nothing is simulated."""

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = {
    "validation": (ROOT / "validation" / "render.py", ROOT / "docs" / "validation.md"),
    "performance": (ROOT / "benchmarks" / "render.py", ROOT / "docs" / "performance.md"),
}
MAX_LINES = 200  # issue 34: a page a user reads


def _renderer(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(f"{name}_render", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look themselves up there
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", sorted(PAGES))
def test_the_committed_page_is_what_its_generator_writes(name):
    script, page = PAGES[name]
    text = _renderer(name, script).render()
    assert page.read_text() == text, f"{page.name} is stale: run python {script.relative_to(ROOT)}"
    assert len(text.splitlines()) <= MAX_LINES


def test_every_check_reads_a_tolerance_and_a_measured_value():
    """Each row's constants exist in its test module, and each has a 'measured' note beside it."""
    render = _renderer("validation", PAGES["validation"][0])
    for _, _, module, names, source in render.CHECKS:
        found = render.constants(module)
        assert all(n in found for n in names), (module, names)
        assert render.measured(module, source or names[0])
