"""docs/vehicle.md, the vehicle reference, is what batchveh.model.reference writes from the code, and lists
every vehicle key of the dataclasses and of the parameter registry. Cheap: nothing is compiled."""

import dataclasses
from pathlib import Path

import pytest

from batchveh.model import params, reference
from batchveh.model.motors import SWEEPABLE
from batchveh.model.vehicle import Chassis, Vehicle, Wheel, numeric_paths

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "vehicle.md"
MAX_LINES = 200  # issue 34: a page a user reads


@pytest.fixture(scope="module")
def page() -> str:
    return reference.render()


def _leaf_paths(obj, prefix=""):
    """Every key a vehicle YAML can set, numeric or not, by dotted path."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            yield from _leaf_paths(value, f"{prefix}{f.name}.")
        else:
            yield f"{prefix}{f.name}"


def _row(page: str, key: str) -> list[str]:
    """The cells of the table row of `key`."""
    rows = [line for line in page.splitlines() if line.startswith(f"| `{key}` |")]
    assert len(rows) == 1, f"{key}: {len(rows)} rows on the page"
    return [c.strip() for c in rows[0].strip("|").split(" | ")]


def test_the_committed_page_is_what_the_code_writes(page):
    assert PAGE.read_text() == page, "docs/vehicle.md is stale: run python -m batchveh.model.reference"
    assert len(page.splitlines()) <= MAX_LINES


def test_every_key_of_the_vehicle_has_a_row(page):
    """Each leaf of Vehicle() (numeric_paths and the categorical keys) and each registry name of a vehicle
    group, a dcmotor vehicle's motor names included."""
    keys = set(_leaf_paths(Vehicle()))
    assert set(numeric_paths(Vehicle())) <= keys
    for key in keys:
        _row(page, key)
    groups = tuple(f"{f.name}." for f in dataclasses.fields(Vehicle))
    for name, spec in {**params.parameter_specs(Vehicle()), **reference.dcmotor_registry()}.items():
        if not name.startswith(groups):
            continue
        group, _, field = name.removeprefix("motors.").partition(".")
        if name.startswith("motors.") and group in params.GROUPS and field:  # motors.drive.<field>: by field
            assert field in SWEEPABLE and f"| `{field}` | {spec['unit']} |" in page, name
        else:
            assert _row(page, name)[1] == spec["unit"], name


def test_the_page_gives_the_seeds_defaults_bounds_and_sweepability(page):
    """Literals from vehicle.py, not read back from the renderer."""
    assert Chassis().mass == 88.4 and Wheel().radius == 0.195
    assert _row(page, "chassis.mass")[1:6] == ["kg", "`88.4`", "> 0", "yes", "structure"]
    assert _row(page, "wheel.radius")[1:6] == ["m", "`0.195`", "> 0", "yes", "structure"]
    assert _row(page, "wheel.rolling_resistance")[3] == "0 to 1"
    assert _row(page, "tyre.model")[2:5] == ["`slip`", "`rigid` \\| `slip` \\| `soil`", "no"]
    assert _row(page, "contact_model.impratio")[4] == "no (a model option)"
    assert _row(page, "motors.drive")[4:6] == ["grid or zip; dcmotor", "structure"]
    assert _row(page, "motors.dc_drive_kp")[4:6] == ["yes; dcmotor", "control"]
    assert _row(page, "motors.drive_kp")[4:6] == ["yes; servo", "model field"]
    assert "| `gear_efficiency` | 1 | `1` | > 0 and <= 1 |" in page


def test_a_new_vehicle_group_must_be_placed(monkeypatch):
    """A group added to Vehicle that the page does not place stops the renderer, naming it."""
    monkeypatch.setattr(reference, "SECTIONS", tuple(s for s in reference.SECTIONS if s != "payload"))
    with pytest.raises(RuntimeError, match="payload"):
        reference.render()


def test_check_exits_1_on_a_stale_page(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(reference, "OUT", tmp_path / "vehicle.md")
    (tmp_path / "vehicle.md").write_text("# stale\n")
    with pytest.raises(SystemExit) as exit_:
        reference.main(["--check"])
    assert "run python -m batchveh.model.reference" in str(exit_.value.code)
    reference.main([])
    reference.main(["--check"])
    assert "up to date" in capsys.readouterr().out
