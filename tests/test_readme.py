"""The README's commands and Python code run, on tiny sizes, so the front door cannot drift.

The shell lines of the README's ```bash blocks and its ```python blocks are taken as written.
They run in a temporary folder that holds small copies of the specs in sweeps/ (the same keys,
two values of each swept parameter, 1 s of driving) and a link to notebooks/: the main job's
command runs the main job's spec, small. `python` at the start of a command is this interpreter.
The Markdown pages' local links and the specs they show are checked too.
"""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from batchveh import spec_from_mapping
from batchveh.model.scenarios import scenario_from_mapping

pytestmark = pytest.mark.xdist_group("readme")  # one test worker: the module's shared fixtures run once

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
PAGES = [README, *sorted((ROOT / "docs").glob("*.md")), ROOT / "CHANGELOG.md"]
SETUP = "python3 -m venv .venv && . .venv/bin/activate && "
MAX_LINES = 200  # issue 34
# words of a history, which belongs in CHANGELOG.md (issue 21)
HISTORY = ("retired", "fused solver", "before issue", "earlier measurement", "older peer", "superseded", "no longer")
TINY_TIME_S = 1.0  # s of driving per variant, after the settle
RUN_TIMEOUT_S = 120


def blocks(path: Path, language: str) -> list[str]:
    """The fenced code blocks of `language` in a Markdown file, in order."""
    return [m.group(1) for m in re.finditer(rf"^```{language}\n(.*?)^```", path.read_text(), re.M | re.S)]


def shell_lines() -> list[str]:
    """Every command line of the README's bash blocks (comment lines left out)."""
    return [ln.strip() for b in blocks(README, "bash") for ln in b.splitlines() if ln.strip() and ln[0] != "#"]


def two_commands() -> tuple[str, str]:
    """(main job, tests): the README's two lines that set up a fresh machine."""
    setup = [ln for ln in shell_lines() if ln.startswith(SETUP)]
    assert len(setup) == 2, f"the README should have exactly two set-up commands, found {setup}"
    main = [ln for ln in setup if "batchveh.sweep" in ln]
    test = [ln for ln in setup if ln.endswith("python -m pytest")]
    assert len(main) == 1 and len(test) == 1, setup
    return main[0], test[0]


def tiny(spec: dict) -> dict:
    """A spec with the same keys on a few variants: two values of each swept parameter (or 4 random
    rows), and TINY_TIME_S of driving with the ramp scaled alike (a mission keeps its segments)."""
    sweep = spec["sweep"]
    if sweep.get("method", "grid") in ("grid", "zip"):
        for name, values in sweep["params"].items():
            if isinstance(values, dict):
                values["num"] = 2
            else:
                sweep["params"][name] = [values[0], values[-1]]
    else:
        sweep["n"] = 4
    fixed = spec.get("fixed") or {}
    if "total_time" in fixed:
        scale = TINY_TIME_S / fixed["total_time"]
        fixed["total_time"] = TINY_TIME_S
        if "ramp_time" in fixed:
            fixed["ramp_time"] *= scale
        spec.pop("window", None)
    return spec


def tiny_folder(tmp_path_factory, name: str):
    """A folder to run documented commands in: tiny sweeps/, the notebooks' catalogue; environment for the runs."""
    here = tmp_path_factory.mktemp(name)
    (here / "sweeps").mkdir()
    for path in (ROOT / "sweeps").glob("*.yaml"):
        (here / "sweeps" / path.name).write_text(yaml.safe_dump(tiny(yaml.safe_load(path.read_text()))))
    (here / "notebooks").symlink_to(ROOT / "notebooks")
    env = {
        **os.environ,
        "MPLBACKEND": "Agg",
        "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
    }
    return here, env


@pytest.fixture(scope="module")
def tour(tmp_path_factory):
    """A folder to run the README in (`tiny_folder`)."""
    return tiny_folder(tmp_path_factory, "readme")


def test_readme_is_a_front_door():
    text = README.read_text()
    assert len(text.splitlines()) <= MAX_LINES, f"README.md has {len(text.splitlines())} lines; at most {MAX_LINES}"
    found = [w for w in HISTORY if w in text.lower()]
    assert not found, f"history in README.md (it belongs in CHANGELOG.md): {found}"
    assert "<!-- tyres -->" in text and "## Two commands" in text


def test_ci_runs_the_readme_test_command():
    """.ci/run runs exactly the README's test command (and the README says so)."""
    _, test = two_commands()
    ci = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines() if ln.strip() and ln[0] != "#"]
    assert test in ci, f".ci/run does not run the README's test command {test!r}: {ci}"


def test_readme_commands_and_tour_run(tour):
    """The main job's command, every other shell line, then the Python blocks as one script."""
    here, env = tour
    main, _ = two_commands()
    commands = [main.rpartition("&& ")[2]] + [ln for ln in shell_lines() if not ln.startswith(SETUP)]
    for line in commands:
        assert line.startswith("python -m batchveh."), f"a README command this test cannot run small: {line!r}"
        cmd = shlex.quote(sys.executable) + line.removeprefix("python")
        done = subprocess.run(cmd, shell=True, cwd=here, env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
        assert done.returncode == 0, f"{line}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    script = "\n".join(blocks(README, "python"))
    assert "batchveh.load" in script and "sizing.screen" in script and "plot.envelope" in script
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=here, env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT_S
    )
    assert done.returncode == 0, f"README Python blocks:\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
    assert (here / "envelope.png").stat().st_size > 0
    assert "smallest motor that covers the envelope:" in done.stdout


def test_the_specs_the_pages_show_are_valid():
    """A ```yaml block that is a whole sweep spec validates; one that is the README's main job equals
    sweeps/slope.yaml; a scenario block (a `kind`) validates as a scenario."""
    checked = 0
    for page in PAGES:
        for k, text in enumerate(blocks(page, "yaml")):
            data = yaml.safe_load(text)
            where = f"{page.name}, yaml block {k}"
            if {"name", "sweep"} <= set(data):
                spec_from_mapping(data, where)
                checked += 1
                if page == README:
                    assert data == yaml.safe_load((ROOT / "sweeps" / f"{data['name']}.yaml").read_text()), where
            elif "kind" in data:
                scenario_from_mapping(data, where)
                checked += 1
    assert checked >= 3


def _anchor(heading: str) -> str:
    """The id a code host gives a Markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def test_local_links_resolve():
    """Every relative link of the pages points to a file, and its #anchor to a heading there."""
    broken = []
    for page in PAGES:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"[a-z]+://", target):
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if not dest.exists():
                broken.append(f"{page.name}: {target}")
            elif anchor and dest.suffix == ".md":
                headings = re.findall(r"^#+ (.*)$", dest.read_text(), re.M)
                if anchor not in {_anchor(h) for h in headings}:
                    broken.append(f"{page.name}: {target} (no such heading)")
    assert not broken, "broken links: " + "; ".join(broken)
