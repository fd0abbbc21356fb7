"""`python -m batchveh.size`: sizing in one command (issue 45) on MuJoCo C, small.

The command's choice equals what `screen` and `in_loop` give when called by hand on the same rows; its report's
HTML is well-formed and every figure it names exists; bad input is one line and exit 2."""

import json
import shutil
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import schema_misses

from batchveh.size import EXIT_EXISTS, EXIT_INPUT, EXIT_OK, main
from batchveh.sizing.plan import candidates

pytestmark = pytest.mark.xdist_group("size")  # one test worker: the module's shared fixtures run once

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "sweeps" / "delivery_robot.yaml"
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
LIMIT = 12  # variants: the first of the robot's LHS


class _Balanced(HTMLParser):
    """Counts unclosed and mismatched tags (void elements aside) and collects <img src>."""

    VOID = {"meta", "img", "br", "hr", "link", "input"}

    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.images = [], [], []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(tag)
        else:
            self.stack.pop()


@pytest.fixture(scope="module")
def sized(tmp_path_factory):
    out = tmp_path_factory.mktemp("size") / "robot"
    args = [str(SPEC), "--catalogue", str(CATALOGUE), "--limit", str(LIMIT), "--out", str(out), "--quiet"]
    return out, args, main(args)


def test_the_command_chooses_and_writes_its_report(sized, capsys):
    out, args, rc = sized
    assert rc == EXIT_OK
    html = (out / "report.html").read_text()
    parser = _Balanced()
    parser.feed(html)
    assert parser.errors == [] and parser.stack == [], (parser.errors, parser.stack)
    # the torque-speed plane, the misses, the hottest variant, coverage against ratio (drive, steering)
    assert len(parser.images) == 5
    for src in parser.images:
        assert (out / src).is_file() and (out / src).stat().st_size > 10_000, src
    md = (out / "report.md").read_text()
    for src in parser.images:
        assert f"]({src})" in md
    summary = json.loads((out / "sizing.json").read_text())
    assert summary["variants"] == LIMIT and summary["chosen"] in md and "## Verdict" in md
    assert schema_misses(out / "verdicts.parquet") == {} and schema_misses(out / "servo") == {}
    verdicts = pd.read_parquet(out / "verdicts.parquet")
    assert set(verdicts["motor"]) == {row["motor"] for row in summary["loop"]}
    assert (verdicts.groupby("motor").size() == LIMIT).all()
    chosen = verdicts[verdicts["motor"] == summary["chosen"]]
    coverage = next(r["coverage"] for r in summary["loop"] if r["motor"] == summary["chosen"])
    assert chosen["fits"].sum() / chosen["steer_held"].sum() == pytest.approx(coverage)
    # the chosen motor's screen reads the variants its loop run judged (simulated, its steering held)
    screened = next(r for r in summary["screen"] if r["motor"] == summary["chosen"])
    assert screened["judged"] == int((chosen["simulated"] & chosen["steer_held"]).sum())
    assert main(args) == EXIT_EXISTS  # a report there: not replaced without --overwrite
    assert "give --overwrite" in capsys.readouterr().err


def test_the_choice_is_what_screen_and_in_loop_give_by_hand(sized):
    """The same rows (the servo sweep the command ran), the same calls by hand."""
    import batchveh
    from batchveh.model.motors import load_catalogue
    from batchveh.sizing import in_loop, screen
    from batchveh.sizing.ramps import ramp_of, wheel_accel
    from batchveh.sizing.windows import best_of, loop_table, windows

    out, _, _ = sized
    summary = json.loads((out / "sizing.json").read_text())
    spec = batchveh.load_spec(SPEC)
    df = batchveh.load(out / "servo")
    cat = load_catalogue(CATALOGUE)
    arm, accel, ramp = spec.vehicle.motors.armature, wheel_accel(spec, df), ramp_of(spec, df)
    _, ratios, _ = screen(df, cat, share=0.99, armature=arm, accel=accel, duty=spec.duty, ramp=ramp)
    wins = windows(ratios, cat, 0.99)  # each motor's ratio window; the loop walks one ratio a motor
    table, best = loop_table(ratios, wins), best_of(wins)
    assert [r["coverage"] for r in summary["screen"]] == list(table["coverage"])
    assert [r["chosen"] for r in summary["windows"]] == list(table["motor"])
    chosen = None
    for name in candidates(table, best):
        got, _, _ = in_loop(spec, df, CATALOGUE, [name], steer=summary["steer"], share=0.99)
        if got is not None:
            chosen = got
            break
    assert chosen == summary["chosen"] and chosen is not None


@pytest.mark.parametrize(
    "extra, words",
    [
        (["--steer", "maxon-EC45"], "--steer: 'maxon-EC45' is not in the catalogue"),
        (["--share", "1.5"], "--share: 1.5 is not allowed"),
    ],
)
def test_bad_arguments_are_one_line(tmp_path, capsys, extra, words):
    rc = main([str(SPEC), "--catalogue", str(CATALOGUE), "--out", str(tmp_path / "o"), "--quiet", *extra])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_INPUT and words in err and "\n" not in err and "Traceback" not in err


def test_a_missing_or_empty_catalogue_is_one_line(tmp_path, capsys):
    rc = main([str(SPEC), "--catalogue", str(tmp_path / "none.yaml"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_INPUT and "none.yaml: file not found" in err and "\n" not in err
    empty = tmp_path / "empty.yaml"
    empty.write_text("motors: []\n")
    rc = main([str(SPEC), "--catalogue", str(empty), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_INPUT and "motors: no motor" in err and "\n" not in err
    spec = tmp_path / "bad.yaml"
    spec.write_text(SPEC.read_text().replace("payload.mass:", "payload.mas:"))
    rc = main([str(spec), "--catalogue", str(CATALOGUE), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_INPUT and "payload.mas" in err and "\n" not in err
    spec.write_text(SPEC.read_text() + "duty: 1.5\n")  # the share of the time the run repeats: 0 < duty <= 1
    rc = main([str(spec), "--catalogue", str(CATALOGUE), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_INPUT and "bad.yaml: duty: 1.5" in err and "<= 1" in err and "\n" not in err


def test_a_span_a_straight_line_has_not_is_one_line(sized, capsys):
    """--span on a straight line's results (the servo sweep the fixture ran): no such span, one line, exit 2."""
    out, _, _ = sized
    rc = main([str(SPEC), "--catalogue", str(CATALOGUE), "--out", str(out), "--overwrite", "--quiet",
               "--limit", str(LIMIT), "--span", "seg2_climb"])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_INPUT and "--span: 'seg2_climb'" in err and "allowed: none" in err and "\n" not in err


def test_the_dry_run_estimates_every_phase(capsys):
    assert main([str(SPEC), "--catalogue", str(CATALOGUE), "--dry-run"]) == EXIT_OK
    line = capsys.readouterr().out.strip()
    # notebooks/motors.yaml by hand: its paired entries, and each motor's series' ratios once per motor
    raw = yaml.safe_load(CATALOGUE.read_text())
    ratios = {s["name"]: len(s["ratios"]) for s in raw["gearhead_series"]}
    motors = {m.get("motor", m["name"]): set(m.get("series", [])) for m in raw["motors"]}
    for m in raw["motors"]:
        motors[m.get("motor", m["name"])] |= set(m.get("series", []))
    pairs = len(raw["motors"]) + sum(ratios[s] for series in motors.values() for s in series)
    assert "400 variants" in line and f"the screen of {pairs} (motor, ratio) pairs of {len(motors)} motors" in line
    assert "in the loop" in line


def test_the_loop_starts_below_the_screens_choice():
    table = pd.DataFrame({"motor": ["a", "b", "c", "d"], "coverage": np.array([0.2, 0.5, 0.99, 1.0])})
    assert candidates(table, "c") == ["b", "c", "d"]
    assert candidates(table, "a") == ["a", "b", "c", "d"]
    assert candidates(table, None) == ["c", "d"]  # within 2 points of the best coverage
    near = table.assign(coverage=[0.2, 0.96, 0.5, 0.945])
    assert candidates(near, None) == ["b", "d"]
    assert candidates(table.assign(coverage=[0.2, 0.96, 0.5, 0.93]), None) == ["b"]  # d: 3 points below


def test_the_loop_batches_up_to_the_screens_choice():
    """The loop's first batch: the motor below the screen's choice and the choice; without a choice, or once
    the choice has run short, every motor left."""
    from batchveh.sizing.plan import batch_of

    assert batch_of(["a", "b", "c", "d"], "b") == ["a", "b"]
    assert batch_of(["b", "c", "d"], "b") == ["b"]
    assert batch_of(["c", "d"], "b") == ["c", "d"]
    assert batch_of(["a", "b"], None) == ["a", "b"]


def test_a_killed_session_resumes_from_its_finished_chunks(sized, tmp_path):
    """The loop's runs are sweeps in OUT/loop, one folder per run's inputs. Run again (as after a kill) with
    one part of a loop run gone: that chunk alone runs again, the others (the servo sweep's too) are read (their
    files untouched), and the verdicts are the same rows."""
    import shutil

    out, args, _ = sized
    again = tmp_path / "again"
    shutil.copytree(out, again)
    runs = sorted(p for p in (again / "loop").iterdir() if p.is_dir())
    assert runs  # from ambient (the hot run in closed form from it, run only where that cannot say)
    parts = sorted(runs[-1].glob("part-*.parquet"))
    done = [*runs, again / "servo"]  # every finished chunk but the one removed: the loop's and the servo sweep's
    kept = {p: p.stat().st_mtime_ns for r in done for p in sorted(r.glob("part-*.parquet")) if p != parts[0]}
    assert parts and kept
    parts[0].unlink()
    (again / "report.md").unlink()
    before = pd.read_parquet(again / "verdicts.parquet")
    argv = [a if a != str(out) else str(again) for a in args]
    assert main(argv) == EXIT_OK
    assert parts[0].exists()
    assert {p: p.stat().st_mtime_ns for p in kept} == kept
    after = pd.read_parquet(again / "verdicts.parquet")
    pd.testing.assert_frame_equal(before, after)


def test_the_loop_runs_the_motor_below_the_choice_only_where_its_screen_is_near_the_share():
    """The motor below the screen's choice runs in the loop where its screen coverage lies within 2 points of the
    share (the loop may take it); further below, the loop starts at the choice, and the report says why."""
    from batchveh.sizing.plan import not_run

    table = pd.DataFrame({"motor": ["a", "b", "c", "d"], "coverage": np.array([0.2, 0.5, 0.99, 1.0])})
    assert candidates(table, "c", 0.99) == ["c", "d"]  # b: 50%, 49 points below
    assert candidates(table.assign(coverage=[0.2, 0.98, 0.99, 1.0]), "c", 0.99) == ["b", "c", "d"]  # b: 1 below
    assert candidates(table.assign(coverage=[0.2, 0.96, 0.99, 1.0]), "c", 0.99) == ["c", "d"]  # b: 3 below
    assert candidates(table, "a", 0.99) == ["a", "b", "c", "d"]
    why = not_run(table, ["c", "d"], ["c"], "c", "c")
    assert "more than 2 points below the share" in why["b"] and "smaller motor (c) covers" in why["d"]


def test_a_loop_run_whose_inputs_change_gets_another_folder():
    """A run in the loop resumes from OUT/loop/<digest>: the digest changes with the catalogue's bytes, a table
    value, the table's names, the backend and the spec's YAML, and not otherwise."""
    import dataclasses

    import batchveh
    from batchveh.size import inputs_digest

    spec = batchveh.load_spec(SPEC)
    cat = CATALOGUE.read_bytes()
    table = {"payload.mass": np.array([1.0, 2.0]), "motors.drive_start_rise": np.zeros(2)}
    base = inputs_digest(cat, spec, table, "mujoco")
    assert inputs_digest(cat, spec, {k: v.copy() for k, v in table.items()}, "mujoco") == base
    assert inputs_digest(cat + b"\n# edited", spec, table, "mujoco") != base
    assert inputs_digest(cat, spec, {**table, "payload.mass": np.array([1.0, 2.5])}, "mujoco") != base
    assert inputs_digest(cat, spec, {**table, "motors.steer_start_rise": np.zeros(2)}, "mujoco") != base
    assert inputs_digest(cat, spec, table, "warp") != base
    raw = {**spec.raw, "solver": {"iterations": 3}}
    assert inputs_digest(cat, dataclasses.replace(spec, raw=raw), table, "mujoco") != base


def test_the_loop_batches_at_most_two_where_the_screen_cannot_say():
    from batchveh.sizing.plan import batch_of

    assert batch_of(["c", "d", "e"], None) == ["c", "d"]
    assert batch_of(["c", "d", "e"], "b") == ["c", "d"]  # the choice ran short: the next two


def test_a_sweep_that_left_chunks_unwritten_is_one_line(tmp_path):
    """An executor whose chunks kept failing writes the rest: the sizing refuses to go on with fewer variants."""
    from batchveh.config import ConfigError
    from batchveh.size import unwritten

    unwritten({"failed": {}}, tmp_path)
    with pytest.raises(ConfigError, match=r"chunks not written: 3 \(worker died\); run the command again"):
        unwritten({"failed": {3: "worker died"}}, tmp_path)


def test_a_batch_is_read_as_one_drive_at_a_time():
    """The loop's batch read in order: a steering miss walks the steering up and stops the batch at that drive (it
    runs again); a drive that covers is chosen and the drives after it are not reported; with the steering given
    (no larger to walk to), its miss is reported and the drive judged."""
    from batchveh.sizing.plan import read_batch

    table = pd.DataFrame({"coverage": [0.5, 0.995, 1.0], "steer_coverage": [1.0, 0.9, 1.0]})
    got = read_batch(["a", "b", "c"], table, "s1", ["s1", "s2"], 0.99)
    assert (got["steer"], got["done"], got["judged"], got["chosen"]) == ("s2", 1, ["a"], None)
    assert [r["drive"].iloc[0] for r in got["steer_rows"]] == ["a", "b"]
    again = read_batch(["b", "c"], table.iloc[1:].assign(steer_coverage=1.0), "s2", ["s1", "s2"], 0.99)
    assert (again["chosen"], again["judged"], again["done"]) == ("b", ["b"], 2)
    given = read_batch(["a", "b", "c"], table, "s1", ["s1"], 0.99)
    assert (given["steer"], given["judged"], given["chosen"]) == ("s1", ["a", "b"], "b")


def test_a_choice_over_the_runs_the_steering_held_says_how_many_it_lost(tmp_path, capsys):
    """The 250 kg AGV with a 1.9 N m steering motor given: the steering loses most runs, and the drive is judged
    on the rest. The last line and the report's verdict count them: judged plus lost make the variants."""
    import json

    out = tmp_path / "agv"
    argv = [str(ROOT / "sweeps" / "warehouse_agv.yaml"), "--catalogue", str(CATALOGUE), "--limit", "12",
            "--steer", "faulhaber-3564K024B_NPT015-i40", "--out", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == EXIT_OK
    summary = json.loads((out / "sizing.json").read_text())
    loop, chosen = pd.DataFrame(summary["loop"]).set_index("motor"), summary["chosen"]
    assert chosen is not None
    lost = 12 - int(loop.loc[chosen, "not_simulated"]) - int(loop.loc[chosen, "judged"])
    assert lost > 0  # the small steering loses runs here
    assert f", {lost} the steering lost (not counted for the drive)" in capsys.readouterr().out.strip().splitlines()[-1]
    head = (out / "report.md").read_text()
    judged = int(loop.loc[chosen, "judged"])
    assert (
        f"of the {judged} variant{'s' * (judged != 1)} judged in the loop (the other {lost} the steering lost" in head
    )


def test_a_steering_that_loses_every_run_is_named_as_the_reason_no_drive_was_judged(tmp_path, capsys):
    """The same AGV on its first 6 conditions: the 1.9 N m steering loses all six, so no drive is judged. The last
    line and the report say that it is the steering's, and name its misses, never a drive's coverage of 0%."""
    out = tmp_path / "agv"
    argv = [str(ROOT / "sweeps" / "warehouse_agv.yaml"), "--catalogue", str(CATALOGUE), "--limit", "6",
            "--steer", "faulhaber-3564K024B_NPT015-i40", "--out", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == EXIT_OK
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert "no drive could be judged: the steering (faulhaber-3564K024B_NPT015-i40) lost every run" in last
    head = (out / "report.md").read_text().splitlines()[2]
    assert head.startswith("No drive motor could be judged: the steering motor faulhaber-3564K024B_NPT015-i40 lost")
    assert "lost " in head.split("loop (")[1] and "covers 0.0%" not in head, head


def test_the_battery_is_judged_apart_never_against_a_drive(sized, tmp_path, capsys):
    """The robot's 12 conditions again, with the catalogue's battery cut to a continuous discharge current whose
    power, (V - I R) I, sits at the median of the chosen motor's peak bus powers run hot by hand (`in_loop` with
    no battery, every variant run hot): about half the runs pass it. The choice and its coverage stay the first
    run's (the battery is not a motor's miss); the loop's row, the last line, the report and verdicts.parquet
    count the runs past it: those whose hot bus power passes (V - I R) I, worked out here."""
    import batchveh
    from batchveh.sizing import in_loop

    out0, _, _ = sized
    first = json.loads((out0 / "sizing.json").read_text())
    chosen = first["chosen"]
    spec, df = batchveh.load_spec(SPEC), batchveh.load(out0 / "servo")
    _, _, detail = in_loop(spec, df, CATALOGUE, [chosen], steer=first["steer"], share=0.99, closed=False)
    d = detail[chosen]
    power_hot = d["bus_power_peak"].to_numpy(float)[d["judged"].to_numpy(bool)]
    raw = yaml.safe_load(CATALOGUE.read_text())
    v, r = raw["battery"]["nominal_voltage"], raw["battery"]["internal_resistance"]
    p_mid = float(np.median(power_hot))
    current = (v - np.sqrt(v * v - 4 * r * p_mid)) / (2 * r)  # (V - I R) I = p_mid, the smaller root
    raw["battery"]["max_continuous_discharge_current"] = float(current)
    cat = tmp_path / "motors.yaml"
    cat.write_text(yaml.safe_dump(raw, sort_keys=False))
    expected = int((power_hot > (v - current * r) * current).sum())
    assert 0 < expected < len(power_hot)  # the median cuts the runs: some pass, some do not

    out = tmp_path / "robot"
    shutil.copytree(out0 / "servo", out / "servo")  # the servo sweep is the first run's (resumed: not run again)
    argv = [str(SPEC), "--catalogue", str(cat), "--limit", str(LIMIT), "--out", str(out), "--quiet"]
    assert main(argv) == EXIT_OK
    last = capsys.readouterr().out.strip().splitlines()[-1]
    summary = json.loads((out / "sizing.json").read_text())
    assert summary["chosen"] == chosen
    row = next(q for q in summary["loop"] if q["motor"] == chosen)
    assert row["coverage"] == next(q["coverage"] for q in first["loop"] if q["motor"] == chosen)
    assert row["battery_over"] == expected
    assert f", {expected} past the battery's energy or power (the battery's, not counted)" in last
    verdicts = pd.read_parquet(out / "verdicts.parquet")
    assert int(verdicts.loc[verdicts["motor"] == chosen, "battery_over"].sum()) == expected
    assert schema_misses(out / "verdicts.parquet") == {}
    md = (out / "report.md").read_text()
    assert "## The battery" in md and f"is passed in {expected} of them" in md


def test_the_requirement_sheet_is_the_servo_sweeps_by_hand(sized):
    """sizing.json's requirement sheet against the servo sweep's Parquet, computed here with numpy's inverted-CDF
    percentile (nearest rank) on the worst of the four wheels: the RMS at the duty, the window's low-pass peak,
    the top speed, the peak mechanical power; at the chosen motor's shaft, torque / (eta N) and speed x N. Each
    figure's variant is a row whose own value is the figure."""
    import batchveh
    from batchveh.model.motors import load_catalogue

    out, _, _ = sized
    summary = json.loads((out / "sizing.json").read_text())
    df = batchveh.load(out / "servo")
    duty = summary["duty"]
    wheels = ("lf", "rf", "lr", "rr")

    def worst(stat):
        return df[[f"drive_{w}_{stat}" for w in wheels]].abs().max(axis=1).to_numpy()

    by_hand = {
        "rms_torque": np.sqrt(duty) * worst("rms"),
        "peak_torque": worst("peak_lp"),
        "top_speed": df["wheel_speed"].abs().to_numpy(),
        "peak_power": worst("power_peak"),
    }
    sheet = summary["requirements"]["drive"]
    motor = load_catalogue(CATALOGUE)[summary["chosen"]]
    for key, values in by_hand.items():
        fig = sheet["at_wheel"][key]
        expect = np.percentile(values, 99, method="inverted_cdf")
        assert fig["value"] == pytest.approx(expect, rel=1e-9), key
        assert values[fig["row"]] == pytest.approx(expect, rel=1e-12), key
        assert fig["variant"] == {p: pytest.approx(df[p].iloc[fig["row"]]) for p in fig["variant"]}
    shaft = sheet["at_shaft"]
    assert shaft["motor"] == summary["chosen"]
    scale = motor.gear_efficiency * motor.gear_ratio
    assert shaft["rms_torque"]["value"] == pytest.approx(sheet["at_wheel"]["rms_torque"]["value"] / scale)
    assert shaft["top_speed"]["value"] == pytest.approx(sheet["at_wheel"]["top_speed"]["value"] * motor.gear_ratio)
