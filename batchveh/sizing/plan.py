"""The loop's plan: which (motor, ratio) candidates run, in which batches, read in which order, and why the others
did not run; the steering motor to start with. Pure functions of the screen's tables (`sizing.windows.loop_table`)
and the loop's rows."""

from __future__ import annotations

from typing import Any

# the loop runs the motor below the screen's choice only where its screen lies within NEAR of the share, and,
# without a choice, the motors within NEAR of the best screen coverage: screen and loop agreed within 0.33 points on
# every vehicle and duty cycle validated (validation/results/sizing_vehicles.json, sizing_missions.json), and the
# issue's bound is 2, so a motor the screen puts further below cannot cover in the loop (5 points before issue 61,
# when screen and loop were 2 points apart on duty cycles)
NEAR = 0.02
BATCH = 2  # the loop's drives per batch where the screen cannot say which covers (`batch_of`)


def steering(table: Any, share: float) -> str:
    """The steering motor to start the loop with: the smallest that the steering's screen (`table`, the screen of
    group 'steer', whose `peak` reason holds the demand's low-pass peak against the current's bound) passes on
    `share` of the variants; else the largest. The loop then confirms it (`size`)."""
    ok = table[table["coverage"] >= share]
    return (ok if len(ok) else table)["motor"].iloc[0 if len(ok) else -1]


def not_run(table: Any, runs: list[str], ran: list[str], chosen: str | None, best: str | None) -> dict[str, str]:
    """Why each motor of the screen's `table` did not run in the loop: {name: why}."""
    ranked = list(table["motor"])
    cover = dict(zip(table["motor"], table["coverage"], strict=True))
    out = {}
    for name in ranked:
        if name in ran:
            continue
        if chosen is not None and ranked.index(name) > ranked.index(chosen):
            out[name] = f"a smaller motor ({chosen}) covers in the loop"
        elif name not in runs and best is None:
            out[name] = f"screen {cover[name]:.1%}, more than {NEAR * 100:.0f} points below the best screen coverage"
        elif name not in runs and best is not None and ranked.index(name) == ranked.index(best) - 1:
            out[name] = (
                f"screen {cover[name]:.1%}, more than {NEAR * 100:.0f} points below the share: the loop starts at "
                f"the screen's choice ({best})"
            )
        elif name not in runs:
            out[name] = f"screen {cover[name]:.1%}: below the loop's first, the one under the screen's {best}"
        else:
            out[name] = "not reached"
    return out


def batch_of(pending: list[str], best: str | None) -> list[str]:
    """The drives of the loop's next batch (run as one sweep, `in_loop`), from `pending` (smallest first): up
    to the screen's choice `best` where it is pending (the one below it and it, as the screen expects it to
    cover), else the next BATCH of them (the screen has no choice, or the loop found it short: it cannot tell
    which covers). The loop reads the batch in order and stops at the first that covers, so its verdicts are those of
    one candidate at a time; a batch's drives after the first that covers ran for nothing."""
    return pending[: pending.index(best) + 1] if best in pending else pending[:BATCH]


def read_batch(
    batch: list[str], table: Any, steer: str | None, ranked_steer: list[str], share: float
) -> dict[str, Any]:
    """A batch's loop table (`in_loop`'s, a row per drive of `batch`, in order) read as one drive at a time would
    be: each row is the steering's run (`steer_rows`); where the steering `steer` misses more than 1 - share and
    `ranked_steer` holds a larger one, the steering walks up and the batch stops there (that drive runs again with
    it; a skid-steered vehicle has none: `steer` None, `ranked_steer` empty); else the row is the drive's (`rows`,
    `judged`), and the first that covers `share` is `chosen`. `done`: the drives of the batch read to the end (the
    pending list goes on after them)."""
    out: dict[str, Any] = {"steer_rows": [], "rows": [], "judged": [], "chosen": None, "steer": steer}
    out["done"] = len(batch)
    for j, name in enumerate(batch):
        row = table.iloc[[j]].reset_index(drop=True)
        out["steer_rows"].append(row.assign(drive=name))
        # no steering motor (a skid layout: `ranked_steer` empty): nothing to walk up
        larger = ranked_steer[ranked_steer.index(out["steer"]) + 1 :] if out["steer"] in ranked_steer else []
        if row["steer_coverage"].iloc[0] < share and larger:
            out["steer"], out["done"] = larger[0], j  # the steering's own miss: the next larger, from this drive
            break
        out["rows"].append(row)
        out["judged"].append(name)
        if row["coverage"].iloc[0] >= share:
            out["chosen"] = name
            break
    return out


def candidates(screen_table: Any, best: str | None, share: float | None = None) -> list[str]:
    """The motors to run in the loop, smallest first: from the one next below the screen's choice (the screen is
    conservative: the loop may take it) upwards, that one only where its screen coverage lies within NEAR of
    `share` (None: always; screen and loop agree within 2 points on every vehicle validated, so a motor the screen
    puts further below cannot cover in the loop); without a screen choice, those within NEAR of the best screen
    coverage (the loop decides between them)."""
    ranked = list(screen_table["motor"])
    cover = dict(zip(ranked, screen_table["coverage"], strict=True))
    if best is None:
        top = screen_table["coverage"].max()
        return [m for m in ranked if cover[m] >= top - NEAR]
    i = ranked.index(best)
    below = i > 0 and (share is None or cover[ranked[i - 1]] >= share - NEAR)
    return ranked[i - 1 if below else i :]
