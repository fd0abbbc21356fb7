"""Not a benchmark: the helper that writes docs/performance.md, today's figures read from benchmarks/results/*.json
and the text of benchmarks/NOTES.md around them.

    python benchmarks/render.py            # rewrite docs/performance.md
    python benchmarks/render.py --check    # exit 1 if docs/performance.md is not what this writes

Each row of the table is one figure: it names what was measured, reads the figure from its result file (so
the page cannot drift from the file), names the machine and gives the one command (script and mode) that
repeats it. A row
kind that matches files by a pattern (`*-motors*.json`) gives one row per file,
so that a new run of the same benchmark shows up without an edit here. Earlier runs are kept in
benchmarks/results/archive.json (told in benchmarks/ARCHIVE.md); a result file that no row reads
is named under the table, so that none goes unseen.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
OUT = HERE.parent / "docs" / "performance.md"
RAW = "../benchmarks/results"  # the result files, as seen from docs/
MARK = "<!-- table -->"  # where NOTES.md takes the table
ARCHIVE = "archive.json"


def g(x: float) -> str:
    """A rate or a size, three significant figures."""
    return f"{x:.3g}".replace("e+0", "e").replace("e-0", "e-")


def bench_row(d: dict, name: str) -> dict:
    """The row of a bench.py file whose name starts with `name`."""
    return next(r for r in d["rows"] if r["name"].startswith(name))


def p99(row: dict, key: str) -> str:
    return f"{row['accuracy'][key]['p99']:.1e}"


def gpu_of(machine: dict) -> str:
    """'one H200, 16 cores' from structural.py's machine dict (the GPU name as nvidia-smi gives it)."""
    gpus = [x.split(",")[0].replace("NVIDIA ", "") for x in machine.get("gpus", [])]
    if not gpus:
        return f"{machine['cpus']} CPU cores"
    count = f"{len(gpus)} x" if len(gpus) > 1 else "one"
    return f"{count} {gpus[0]}, {machine['cpus']} cores"


@dataclass
class Row:
    what: str
    files: list[str]  # result file names; a name with '*' is a pattern: one row per matching file
    figure: Callable[..., str]  # the figure, from the loaded files (in the order of `files`)
    machine: Callable[..., str] | str  # the machine: from the files where they record it
    command: Callable[..., str] | str  # the one command that repeats it


def _tyres(d: dict) -> str:
    slip, rigid = bench_row(d, "[slip] batchveh warp"), bench_row(d, "[rigid] batchveh warp")
    peer, direct = bench_row(d, "raw mujoco.batch"), bench_row(d, "[slip] MuJoCo Warp direct")
    return (
        f"**{g(slip['rate'])}** variant-steps/s, {slip['vs_raw_batch']:.0f}x raw `mujoco.batch` of the same run "
        f"(16 threads, rigid contact: {g(peer['rate'])}, its two runs {g(min(peer['peer_runs']))}-"
        f"{g(max(peer['peer_runs']))}); p99 error: wheel mean {p99(slip, 'noslip_wheel_mean')}, wheel peak "
        f"{p99(slip, 'noslip_wheel_peak')}; rigid contact {g(rigid['rate'])}; MuJoCo Warp alone {g(direct['rate'])}"
    )


def _mjx(d: dict) -> str:
    slip, rigid = bench_row(d, "[slip] batchveh mjx"), bench_row(d, "[rigid] batchveh mjx")
    return (
        f"slip **{g(slip['rate'])}** (p99 wheel mean {p99(slip, 'noslip_wheel_mean')}), rigid {g(rigid['rate'])} "
        f"(p99 {p99(rigid, 'noslip_wheel_mean')})"
    )


def _fast(d: dict) -> str:
    warp, direct = bench_row(d, "batchveh warp default"), bench_row(d, "MuJoCo Warp direct (CUDA graph of 50 steps, no")
    return (
        f"**{g(warp['rate'])}** (MuJoCo Warp alone {g(direct['rate'])}); median / p99 wheel mean "
        f"{warp['accuracy']['noslip_wheel_mean']['median']:.1e} / {p99(warp, 'noslip_wheel_mean')}"
    )


def _courses(d: dict) -> str:
    rate = {r["course"]: r["rate"] for r in d["rows"]}
    return (
        f"flat {g(rate['flat'])}, a step {g(rate['step'])} ({rate['step'] / rate['flat']:.2f}x), "
        f"4 cm bumps {g(rate['terrain'])} ({rate['terrain'] / rate['flat']:.2f}x)"
    )


def _soil(d: dict) -> str:
    b = d["best_rate"]
    acc = d["accuracy"]["ok, steady, not slipping"]
    return (
        f"soil **{g(b['soil'])}**, slip {g(b['slip'])}, rigid {g(b['rigid'])} (soil {d['soil_over_slip']:.2f}x slip, "
        f"{d['soil_over_rigid']:.2f}x rigid); float32 against C p99 {acc['p99']:.1e} ({acc['variants']} variants)"
    )


def _e2e(*ds: dict) -> str:
    trees = ("new", "new", "old")  # the committed code of each file (-ab-cross: 'new' was not kept)
    meds = [d["summary"][t]["wall_median_s"] for d, t in zip(ds, trees, strict=True)]
    runs = [w for d, t in zip(ds, trees, strict=True) for w in d["summary"][t]["wall_s"]]
    return (
        f"medians **{meds[0]:.1f} / {meds[1]:.1f} / {meds[2]:.1f} s** on three machines ({len(runs)} runs, "
        f"{min(runs):.1f}-{max(runs):.1f} s; the sweep itself {ds[0]['summary']['new']['sweep_median_s']:.1f} s)"
    )


def _prepare(d: dict) -> str:
    us = [r["us_per_variant"] for r in d["rows"]]
    comp = [r["compile_per_variant_us"] for r in d["rows"]]
    return (
        f"**{min(us):.2f}-{max(us):.2f} us** a variant ({d['rows'][0]['n']:,} variants; a compile per variant "
        f"{min(comp):,.0f}-{max(comp):,.0f} us)"
    )


def _ray1m(d: dict) -> str:
    one, two = d["steps"]["1m_local_1gpu"], d["steps"]["1m_ray_2gpu"]
    return (
        f"two GPUs **{two['process_s']:.1f} s** against one {one['process_s']:.1f} s "
        f"({d['ray_over_one_gpu_process']:.3f}x); steady {g(two['steady_rate'])} against {g(one['steady_rate'])}"
    )


def _overhead(d: dict) -> str:
    pairs = d["pairs"]
    mine = next(k for k in pairs[0] if k.startswith("batchveh_"))
    setting = mine.removeprefix("batchveh_")

    def med(key):
        return statistics.median(p[key] for p in pairs)

    return (
        f"**{med('ratio_vs_rigid_' + setting):.2f}x** the rigid contact's peer, {med('ratio_' + setting):.2f}x the "
        f"frictionless one (medians of {len(pairs)} pairs; batchveh {g(med(mine))}, peers {g(med('raw_rigid'))} and "
        f"{g(med('raw'))} variant-steps/s)"
    )


def _small_ray(d: dict) -> str:
    steps = d["steps"]
    ray = [v["process_s"] for k, v in steps.items() if k.startswith("100k_ray")]
    local = [v["process_s"] for k, v in steps.items() if k.startswith("100k_local")]
    pairs = [r / lo for r, lo in zip(ray, local, strict=True)]  # steps in the order run: ray, then local
    return (
        f"--executor ray median **{statistics.median(ray):.1f} s** ({min(ray):.1f}-{max(ray):.1f}) against in-process "
        f"{statistics.median(local):.1f} s ({min(local):.1f}-{max(local):.1f}), {len(ray)} pairs: "
        f"{statistics.median(ray) / statistics.median(local):.3f}x (each pair {min(pairs):.2f}-{max(pairs):.2f})"
    )


def _motors(d: dict) -> str:
    m = d["median_rate"]
    return (
        f"dcmotor / servo **{d['ratio']:.3f}** (median rates {g(m['dcmotor'])} / {g(m['servo'])}; "
        f"{d['size']:,} variants x {d['total_time']:g} s)"
    )


def _gpu_start(d: dict) -> str:
    """The first run on a fresh machine: the kernels built ahead against serial builds, one pair per call."""
    calls = sorted({r["call"] for r in d["runs"]})

    def run(call, way, kind):
        return next(r for r in d["runs"] if (r["call"], r["way"], r["kind"]) == (call, way, kind))

    def pair(c, kind):
        ahead = run(c, "ahead", kind)
        return f"{ahead['wall_s']:.1f} / {run(c, 'serial', kind)['wall_s']:.1f} s"

    out = [f"{run(c, 'ahead', 'first')['card']} ({run(c, 'ahead', 'first')['code']} code)" for c in calls]
    firsts = "; ".join(f"{o}: {pair(c, 'first')}" for o, c in zip(out, calls, strict=True))
    warms = ", ".join(pair(c, "warm") for c in calls)
    return f"first run on empty caches, built ahead / serial, one pair per call: **{firsts}**; warm runs {warms}"


def _gpu_processes(*docs: dict) -> str:
    """--executor gpus on two GPUs against one GPU in-process: the range and median of the 1M pairs. Each pair's
    walls, code and the environment set for its workers are in its file."""
    ratios = sorted(
        p["process_ratio"]
        for d in docs
        for p in d["pairs"]
        if p["what"] in ("1m", "1m_env") and d["steps"][p["gpus"]].get("process_s")
    )
    cards = docs[0]["machine"]["gpus"][0].split(",")[0].removeprefix("NVIDIA ").replace(" 80GB HBM3", "")
    return (
        f"1,000,000 x 10 s on two {cards}s: **{ratios[0]:.3f}-{ratios[-1]:.3f}x one GPU's time, median "
        f"{ratios[len(ratios) // 2]:.3f}x** ({len(ratios)} pairs)"
    )


H200 = "one H200 (nvidia-h200 kind), 16 cores"
DC_COMPARED = ("current_rms", "winding_temp_rise", "energy_drawn", "speed_shortfall")
H200_UNNAMED = "one H200 (nvidia-h200 kind; the file names no GPU)"
TWO_CORES = "this project's 2-core machine"


def _span(values) -> str:
    """'a-b s in n runs', or 'a s in one run'."""
    v = sorted(values)
    return f"{v[0]:.1f} s in one run" if len(v) == 1 else f"{v[0]:.1f}-{v[-1]:.1f} s in {len(v)} runs"


def _native(d: dict) -> str:
    """The warp engine against MuJoCo Warp alone, same process (benchmarks/warp_engine.py native)."""
    alone = bench_row(d, "MuJoCo Warp alone")["rate"]
    eng = [r for r in d["rows"] if r["name"].startswith("warp engine") and "rate" in r]
    others = "; ".join(f"{r['name'][12:]} {r['ratio_to_alone']:.3f}x" for r in eng[1:])
    return (
        f"**{eng[0]['ratio_to_alone']:.3f}x** MuJoCo Warp alone's rate (engine {g(eng[0]['rate'])}, alone {g(alone)}"
        + (f"; {others})" if others else ")")
    )


def _e2e_native(kind: str) -> Callable[..., str]:
    """The `first` or the `warm` runs of end_to_end.py's files: their range, then each host's."""

    def figure(*ds: dict) -> str:
        runs = [[r for r in d["runs"] if r["kind"] == kind] for d in ds]
        walls = [r["wall_s"] for rs in runs for r in rs]
        hosts = "; ".join(
            " / ".join(f"{r['wall_s']:.1f}" for r in rs) + " s (the sweep "
            + " / ".join(f"{r['sweep_wall_s']:.1f}" for r in rs) + " s)"
            for rs in runs
        )  # fmt: skip
        return f"**{min(walls):.1f}-{max(walls):.1f} s** ({len(walls)} runs; by host: {hosts})"

    return figure


def _ref(d: dict) -> str:
    """The engine's float32 against MuJoCo C float64 on bench.py's sample (warp_engine.py native --ref)."""
    acc = d["accuracy_vs_c"]
    return (
        f"wheel mean p99 **{acc['noslip_wheel_mean']['p99']:.2e}** (wheel peak p99 "
        f"{acc['noslip_wheel_peak']['p99']:.2e}, four-wheel sum mean p99 {acc['noslip_sum_mean']['p99']:.1e})"
    )


def _params_ab(d: dict) -> str:
    """The engine's ratio to MuJoCo Warp alone per tree of an alternated A/B (h100-params-ab-warp-profile.json)."""
    ratio = {"new": [], "old": []}
    for r in d["runs"]:
        ratio[r["tree"]] += [x["ratio_to_alone"] for x in r["rows"] if x["name"] == "warp engine"]
    now, before = sorted(ratio["new"]), sorted(ratio["old"])
    return f"now **{now[0]:.3f}-{now[-1]:.3f}x**, before {before[0]:.3f}-{before[-1]:.3f}x"


def _step_ms(d: dict) -> str:
    """A step of the engine against MuJoCo Warp alone and its own Warp calls in a scan (warp_engine.py profile)."""
    ms = {r["name"]: r["ms_per_step"] for r in d["rows"]}
    return (
        f"the engine **{ms['warp engine']:.2f} ms** a step, MuJoCo Warp alone {ms['MuJoCo Warp alone']:.2f} ms, "
        f"the engine's Warp calls in a scan {ms['physics in JAX']:.2f} ms"
    )


def _profile(d: dict) -> str:
    """The engine's device time per step by kind, from the profiler trace (warp_engine.py profile)."""
    p = d["profile warp engine"]
    kinds = p["by_kind_us_per_step"]
    idle = p["span_us_per_step"] - p["busy_us_per_step"]
    return (
        f"MuJoCo Warp's kernels **{kinds['warp'] / 1e3:.2f} ms** of the engine's step, XLA's (tyre, drive, "
        f"statistics) {kinds['xla'] / 1e3:.2f} ms, copies {kinds['copy'] / 1e3:.2f} ms, "
        f"the GPU idle {idle / 1e3:.2f} ms"
    )


def _copies_once(c: dict) -> str:
    """The copies a profile that names each copy's source finds made once a run, before its steps."""
    once = sum(v for k, v in c["profile warp engine"]["copies_us_per_step"].items() if "convert_element_type" in k)
    return (
        f"**{once * c['steps'] / 1e3:.0f} ms** a run: the parameters' conversions on the device, made once before "
        "the steps (most of the copies; now on the host)"
    )


def _first_native(*ds: dict) -> str:
    firsts: dict[str, list[float]] = {}
    for d in ds:
        for r in d["runs"]:
            if r["kind"] == "first":
                firsts.setdefault(r["way"], []).append(r["wall_s"])

    def span(v):
        return f"{min(v):.1f}{f'-{max(v):.1f}' if len(v) > 1 else ''} s"

    return (
        f"built ahead **{span(firsts['ahead'])}**, against "
        + ", ".join(f"{w} {span(v)}" for w in ("threads", "serial") if (v := firsts.get(w)))
        + f" ({sum(map(len, firsts.values()))} first runs, {len(ds)} calls)"
    )


def _reruns(native: dict) -> str:
    """Two runs of one chunk on the warp engine, column by column (warp_engine.py native's reruns)."""
    r = native["reruns"]["default"]
    big = r["largest"]
    torque = max(v for k, v in big.items() if k.startswith(("drive_", "steer_")) and "energy" not in k
                 and "power" not in k)  # fmt: skip
    energy = max(v for k, v in big.items() if k.endswith("_energy"))
    return (
        f"two runs of one {native['size']:,}-variant chunk: **{r['differ']} of {r['columns']} columns differ** "
        f"(torques by at most {torque:.1e} N m, energies {energy:.3f} J; status, slipping, steady and "
        "solver_limit_share equal)"
    )


def _reruns_alone(alone: dict) -> str:
    """Two runs of MuJoCo Warp alone, world by world (warp_engine.py determinism)."""
    a0 = alone["rows"][0]
    return (
        f"**{a0['qfrc_actuator_worlds_differ']:,} of {alone['size']:,} worlds differ** after {alone['steps']} steps "
        f"(qfrc_actuator by at most {a0['qfrc_actuator_largest']:.1e})"
    )


def _reruns_det(det: dict, xladet: dict) -> str:
    """The warp engine's reruns with MuJoCo Warp's Option.deterministic 7 (warp_engine.py native --modes)."""
    d7 = next(x for x in det["rows"] if x["name"] == "warp engine det=7")
    d0 = next(x for x in det["rows"] if x["name"] == "warp engine default")
    x7 = next(x for x in xladet["rows"] if x["name"] == "warp engine det=7")
    return (
        f"still **{det['reruns']['det=7']['differ']} columns differ**, at {d7['rate'] / d0['rate']:.3f}x the default "
        f"rate ({det['size']:,} worlds; {x7['rate'] / xladet['rows'][1]['rate']:.3f}x at {xladet['size']:,} with "
        "XLA's deterministic ops), and it cannot allocate at 32,768"
    )


def _sizing(kind: str) -> Callable[..., str]:
    """benchmarks/sizing.py's `first` or `warm` sessions: their walls, against the plain sweep's in the same call."""

    def figure(*ds: dict) -> str:
        walls, ratios, sweeps, loops = [], [], [], []
        for d in ds:
            sweep = next(r["wall_s"] for r in d["runs"] if r["kind"] == "sweep")
            sweeps.append(sweep)
            for r in (r for r in d["runs"] if r["kind"] == kind):
                walls.append(r["wall_s"])
                ratios.append(r["wall_s"] / sweep)
                loops.append(r["phases_s"]["in the loop"])

        def span(v: list[float], f: str = ".1f") -> str:
            return f"{min(v):{f}}" if min(v) == max(v) else f"{min(v):{f}}-{max(v):{f}}"

        runs = f"{len(walls)} run{'s' * (len(walls) > 1)}, {len(ds)} host{'s' * (len(ds) > 1)}"
        return (
            f"**{span(walls)} s** ({runs}); {span(ratios, '.2f')}x the plain sweep of the same conditions "
            f"({span(sweeps)} s); in the loop {span(loops)} s"
        )

    return figure


def _against(n_new: int, kinds: tuple[str, ...] = ("warm",)) -> Callable[..., str]:
    """benchmarks/sizing.py sessions of two codes on one machine: the first `n_new` files the new code's, the rest
    the code before's, alternated; each code's walls over its `kinds` runs, and the ratio of their medians."""

    def figure(*ds: dict) -> str:
        def walls(group: tuple[dict, ...]) -> list[float]:
            return [r["wall_s"] for d in group for r in d["runs"] if r["kind"] in kinds]

        new, old = walls(ds[:n_new]), walls(ds[n_new:])
        ratio = statistics.median(new) / statistics.median(old)
        screen = [r["phases_s"]["screen"] for d in ds[:n_new] for r in d["runs"] if r["kind"] in kinds]

        def spread(v: list[float]) -> str:
            if len(v) == 1:
                return f"{v[0]:.1f} s, 1 run"
            return f"median {statistics.median(v):.1f} s, {min(v):.1f}-{max(v):.1f} s over {len(v)} runs"

        return (
            f"**{ratio:.2f}x** the code before ({spread(new)}, against {spread(old)}); its screen "
            f"{min(screen):.1f}-{max(screen):.1f} s"
        )

    return figure


def _screen_ratios(d: dict) -> str:
    """benchmarks/screen_ratios.py: the screen of every (motor, ratio) against the pairings' alone, one run."""
    med, runs = d["median_s"], d["times_s"]["every (motor, ratio)"]
    return (
        f"**{med['every (motor, ratio)']:.2f} s** median ({min(runs):.2f}-{max(runs):.2f} s, {len(runs)} runs) for "
        f"{d['pairs']['every (motor, ratio)']} pairs of {d['motors']} motors, {d['ratio_of_medians']:.1f}x the "
        f"{d['pairs']['paired entries only']} pairings' screen in the same run ({med['paired entries only']:.2f} s)"
    )


def _layouts(d: dict) -> str:
    """validation/layouts_gpu.py: the warp engine's warm time per steering layout, against the four-wheel layout's."""
    rows = d["timing"]
    base = min(rows[0]["warm_s"])
    parts = [
        f"{r['layout']} {r['scenario']} {min(r['warm_s']):.3f} s ({min(r['warm_s']) / base:.3f}x)" for r in rows[1:]
    ]
    return (
        f"four-wheel pivot **{base:.3f} s** ({rows[0]['variant_steps_per_s'] / 1e6:.1f}e6 variant-steps/s); "
        + "; ".join(parts)
    )


ROWS = [
    Row(
        "The warp engine (MuJoCo Warp 4.0 as its physics: slip tyre, drive, statistics) against MuJoCo Warp alone "
        "(its step in CUDA graphs of 50 steps, no statistics), 131,072 variants x 1,100 steps, same model and process",
        ["h100-warp-native.json"],
        _native,
        lambda d: gpu_of(d["machine"]),
        "`python benchmarks/warp_engine.py native --size 131072 --modes default det=3`",
    ),
    Row(
        "Warp float32 (MuJoCo Warp 4.0) on a GPU against MuJoCo C 4.0 float64 (tolerance 1e-12), bench.py's "
        "256-variant sample, the variants that do not slip",
        ["h100-ref-warp-native.json"],
        _ref,
        "one H100 (warp), its 16 cores (C)",
        "`python benchmarks/warp_engine.py native --size 131072 --ref 256 --modes default`",
    ),
    Row(
        "The same with MuJoCo Warp on the CPU (JAX's CPU backend) against MuJoCo C float64",
        ["cpu-2core-ref-warp-native.json"],
        _ref,
        TWO_CORES,
        "`python benchmarks/warp_engine.py native --size 16 --steps 20 --ref 256 --modes default`",
    ),
    Row(
        "End to end on MuJoCo Warp 4.0: `python -m batchveh.sweep benchmarks/slope_100k.yaml` (100,000 x 10 s), "
        "fresh processes, warm caches",
        [
            "h100-end-to-end-slope_100k.json",
            "h100-end-to-end-slope_100k-2.json",
            "h100-end-to-end-slope_100k-review.json",
        ],
        _e2e_native("warm"),
        "three fresh H100 hosts, 16 cores each (the third after issue 46's review fixes)",
        "`python benchmarks/end_to_end.py benchmarks/slope_100k.yaml --warm 2`",
    ),
    Row(
        "The same command's first run on each of those fresh hosts (empty caches: Warp builds its kernels, JAX "
        "compiles)",
        [
            "h100-end-to-end-slope_100k.json",
            "h100-end-to-end-slope_100k-2.json",
            "h100-end-to-end-slope_100k-review.json",
        ],
        _e2e_native("first"),
        "three fresh H100 hosts, 16 cores each (the third after issue 46's review fixes)",
        "`python benchmarks/end_to_end.py benchmarks/slope_100k.yaml --warm 2` (its `first` run)",
    ),  # fmt: skip
    Row(
        "A sizing session, warm caches: `python -m batchveh.size` on the 60-80 kg robot (sweeps/delivery_robot.yaml, "
        "friction swept too), 100,000 LHS conditions x 5 s, one candidate in the loop, its hot run in closed form from "
        "its cold one (issue 52: at most 60 s)",
        ["h100-sizing-robot-100000-fresh.json", "h100-sizing-robot-100000-after-seed.json"],
        _sizing("warm"),
        "two H100 hosts, 16 cores each (the second had run the seed's sessions first)",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp --warm 1`",
    ),
    Row(
        "The same session's first run on a fresh host (Warp builds its kernels, JAX compiles; issue 52: at most 90 s)",
        ["h100-sizing-robot-100000-fresh.json"],
        _sizing("first"),
        "one fresh H100 host, 16 cores",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp --warm 1` (its `first` run)",
    ),
    Row(
        "A sizing session on the seed, warm caches: benchmarks/slope_100k.yaml (100,000 x 10 s) at `--share 0.9`, "
        "one candidate, its hot run in closed form from its cold one, run again for 1.7% of the conditions (issue 52: "
        "at most 45 s)",
        ["h100-sizing-seed-100000-3.json"],
        _sizing("warm"),
        "one H100 host, 16 cores (its caches warm from a profiled session before: the JSON's `first` run, 37.9 s, "
        "was warm too)",
        "`python benchmarks/sizing.py seed --n 100000 --backend warp --warm 3`",
    ),
    Row(
        "The seed's session with the screen's motors in threads and the battery judged apart in the loop (its "
        "power verdicts inside the closed form's bounds run hot too: 2.3% of the conditions), warm caches",
        ["h200-sizing-seed-100000-c.json"],
        _sizing("warm"),
        "one fresh H200 host, 16 cores (the default kind gave an H200)",
        "`python benchmarks/sizing.py seed --n 100000 --backend warp --warm 2`",
    ),
    Row(
        "The same session's first run on that fresh H200 host",
        ["h200-sizing-seed-100000-c.json"],
        _sizing("first"),
        "one fresh H200 host, 16 cores",
        "`python benchmarks/sizing.py seed --n 100000 --backend warp --warm 2` (its `first` run)",
    ),
    Row(
        "The robot's session (as above) with the same code, on the same host after the seed's",
        ["h200-sizing-robot-100000-c.json"],
        _sizing("warm"),
        "the same H200 host, 16 cores",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp --warm 1`",
    ),
    Row(
        "The same session, the same code, on two other H100 hosts, where the plain sweep itself took 19% longer",
        ["h100-sizing-seed-100000.json", "h100-sizing-seed-100000-2.json"],
        _sizing("warm"),
        "two H100 hosts, 16 cores each",
        "`python benchmarks/sizing.py seed --n 100000 --backend warp --warm 2`",
    ),
    Row(
        "The seed's session at 1,000,000 conditions (1,000,000 x 10 s; in the loop 1.8% run hot) on one GPU, its "
        "first run on a fresh host: the baseline of issue 52's four-GPU comparison (not run: no four-GPU machine "
        "was lent)",
        ["h100-sizing-seed-1000000.json"],
        _sizing("first"),
        "one fresh H100 host, 16 cores",
        "`python benchmarks/sizing.py seed --n 1000000 --backend warp --warm 0`",
    ),
    Row(
        "The same 1,000,000-condition session with the screen's motors in threads and the battery judged apart (in "
        "the loop 2.3% run hot; the screen 9.3 s, 16.8 s before), first run on another fresh host",
        ["h100-sizing-seed-1000000-b.json"],
        _sizing("first"),
        "one fresh H100 host, 16 cores",
        "`python benchmarks/sizing.py seed --n 1000000 --backend warp --warm 0`",
    ),
    Row(
        "Issue 61's size command (the screen of every (motor, ratio) of the catalogue, 186 pairs, each motor's window, "
        "the requirement sheet, the ratio figures) against the code before it (162e31c, nine pairings): the robot's "
        "400-condition session on MuJoCo C, first and warm runs, alternated (issue 61: at most 1.5x)",
        [
            "cpu-2core-sizing-robot-400-issue61-1.json",
            "cpu-2core-sizing-robot-400-issue61-2.json",
            "cpu-2core-sizing-robot-400-before-issue61-1.json",
            "cpu-2core-sizing-robot-400-before-issue61-2.json",
        ],
        _against(2, ("first", "warm")),
        "this project's 2-core machine, quiet (load 1.5-1.8)",
        "`python benchmarks/sizing.py robot --n 400 --backend mujoco --warm 1`, in each code's checkout",
    ),  # fmt: skip
    Row(
        "The same pair on two cores of the H100 hosts below (taskset), at ef64e84 and d4576c1 (before the sharing was "
        "read once and the threads followed the cores: 16 threads on the 2)",
        [
            "h100-host-2cores-sizing-robot-400-issue61-a.json",
            "h100-host-2cores-sizing-robot-400-issue61-b.json",
            "h100-host-2cores-sizing-robot-400-before-issue61-a.json",
            "h100-host-2cores-sizing-robot-400-before-issue61-b.json",
        ],
        _against(2, ("first", "warm")),
        "two cores of two H100 hosts",
        "`taskset -c 0,1 python benchmarks/sizing.py robot --n 400 --backend mujoco --warm 1`",
    ),  # fmt: skip
    Row(
        "Issue 64's steering layouts on the warp engine: a 50 kg robot, 16,384 variants x 1,300 steps (friction and "
        "payload), the fastest of two warm runs per layout and scenario; the layouts change the controls only",
        ["h100-layouts-warp.json"],
        _layouts,
        "one H100 host (a4a6f9b's working tree)",
        "`python validation/layouts_gpu.py OUT` (also MuJoCo C against warp per layout: validation/LAYOUTS.md)",
    ),
    Row(
        "Issue 61's screen at 100,000 conditions, as the size command runs it (every pair's counts, the windows, "
        "each motor's chosen ratio in detail; the ramp's verdict by its threshold, the sharing read once)",
        ["cpu-2core-screen-ratios-100000.json"],
        _screen_ratios,
        "this project's 2-core machine",
        "`python benchmarks/screen_ratios.py OUT/servo --spec SPEC --n 100000` (the robot's 400-condition servo sweep, "
        "friction swept, tiled)",
    ),
    Row(
        "The robot's 100,000-condition session (as above), issue 61's code at d4576c1 (the ramp's verdict by its "
        "threshold, before the sharing was read once) against 162e31c on one warm host: the screen of 186 pairs is "
        "still the difference",
        ["h100-sizing-robot-100000-issue61-b.json", "h100-sizing-robot-100000-before-issue61-b.json"],
        _against(1),
        "one H100 host, 16 cores",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp --warm 1`, in each code's checkout",
    ),
    Row(
        "The same at ef64e84 (the ramp still stepped for every pair and variant)",
        ["h100-sizing-robot-100000-issue61-a.json", "h100-sizing-robot-100000-before-issue61-a.json"],
        _against(1),
        "one H100 host of an earlier lease, 16 cores",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp --warm 1`, in each code's checkout",
    ),
    Row(
        "The robot's session with two runs in the loop (from ambient, then from the hot start), and MJX imported by "
        "the warp engine, warm caches",
        ["h200-sizing-robot-100000-b.json", "h200-sizing-robot-100000.json"],
        _sizing("warm"),
        "two fresh H200 hosts, 16 cores each",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp --warm 2`",
    ),
    Row(
        "The same two-run session's first run on each fresh host",
        ["h200-sizing-robot-100000-b.json", "h200-sizing-robot-100000.json"],
        _sizing("first"),
        "two fresh H200 hosts, 16 cores each",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp --warm 2` (its `first` run)",
    ),
    Row(
        "The robot's session before the loop started at the screen's choice and before the screen's 100,000-row "
        "speed-ups: two candidates in the loop's batch",
        ["h200-sizing-robot-100000-a-two-candidates.json"],
        _sizing("warm"),
        "one fresh H200 host, 16 cores",
        "`python benchmarks/sizing.py robot --n 100000 --backend warp` at dc72616",
    ),
    Row(
        "The seed's session (below) before the screen's 100,000-row speed-ups",
        ["h200-sizing-seed-100000-a.json"],
        _sizing("warm"),
        "one fresh H200 host, 16 cores",
        "`python benchmarks/sizing.py seed --n 100000 --backend warp` at dc72616",
    ),
    Row(
        "The seed's session with two runs in the loop, and MJX imported by the warp engine, warm caches",
        ["h200-sizing-seed-100000-b.json", "h200-sizing-seed-100000.json"],
        _sizing("warm"),
        "two fresh H200 hosts, 16 cores each",
        "`python benchmarks/sizing.py seed --n 100000 --backend warp --warm 2`",
    ),
    Row(
        "A sizing session on 2 cores: the robot (friction swept), 400 LHS conditions, MuJoCo C, the hot run in closed "
        "form (issue 52: within 4x its servo sweep)",
        ["cpu-2core-sizing-robot-400-closed.json"],
        _sizing("warm"),
        TWO_CORES,
        "`python benchmarks/sizing.py robot --n 400 --backend mujoco --warm 2`",
    ),
    Row(
        "The same with two runs in the loop (before the closed form)",
        ["cpu-2core-sizing-robot-400.json"],
        _sizing("warm"),
        TWO_CORES,
        "`python benchmarks/sizing.py robot --n 400 --backend mujoco --warm 2`",
    ),
    Row(
        "The warp engine against MuJoCo Warp alone after issue 46's review fixes, 131,072 variants x 400 steps, slip "
        "tyre: its parameters converted on the device (before) or on the host (now), alternated in one call",
        ["h100-params-ab-warp-profile.json"],
        _params_ab,
        "one fresh H100, 16 cores",
        "`python benchmarks/warp_engine.py profile --size 131072 --steps 400 --repeat 3`, each tree twice",
    ),
    Row(
        "A step of the warp engine (131,072 variants x 400 steps, slip tyre) against MuJoCo Warp alone and the "
        "engine's own Warp calls in a JAX scan without tyre, drive or statistics",
        ["h100-warp-profile.json"],
        _step_ms,
        "one fresh H100, 16 cores",
        "`python benchmarks/warp_engine.py profile --size 131072 --label h100`",
    ),
    Row(
        "Where that step goes on the GPU, from a JAX profiler trace of one run",
        ["h100-warp-profile.json"],
        _profile,
        "one fresh H100, 16 cores",
        "`python benchmarks/warp_engine.py profile --size 131072 --label h100`",
    ),
    Row(
        "The engine's copies on the device made once a run, before its steps, each named by its source "
        "(131,072 variants x 200 steps, the code before the parameters went to the host)",
        ["h100-copies-warp-profile.json"],
        _copies_once,
        "one H100, 16 cores",
        "`python benchmarks/warp_engine.py profile --size 131072 --steps 200` on that code",
    ),
    Row(
        "The first run on a fresh machine (the same sweep), each way on empty caches of its own: kernels built ahead "
        "by worker processes (`engines/warp_build.py`), by Warp's own parallel loading (threads), or at first launch",
        ["h100-first-gpu-run-native.json", "h100-first-gpu-run-native-2.json"],
        _first_native,
        "one H100, 16 cores (two hosts)",
        "`python benchmarks/end_to_end.py start benchmarks/slope_100k.yaml --fresh --ways serial,ahead,threads "
        "--warm-runs 0 --out FILE` (the second file: `--ways ahead,threads --warm-runs 1`, two rounds)",
    ),
    Row(
        "Reruns on a GPU: the warp engine's columns, two runs of one chunk compared bit for bit",
        ["h100-warp-native.json"],
        _reruns,
        "one H100",
        "`python benchmarks/warp_engine.py native --size 131072 --modes default det=3`",
    ),
    Row(
        "Reruns on a GPU: MuJoCo Warp alone, two runs of the same worlds compared bit for bit",
        ["h100-determinism.json"],
        _reruns_alone,
        "one H100",
        "`python benchmarks/warp_engine.py determinism --size 8192 --steps 400 --det 0 7`",
    ),
    Row(
        "Reruns on a GPU: the warp engine with MuJoCo Warp's Option.deterministic 7 (all of its bits)",
        ["h100-det-warp-native.json", "h100-det-xladet-warp-native.json"],
        _reruns_det,
        "one H100",
        "`python benchmarks/warp_engine.py native --size 8192 --steps 400 --modes default det=7` (the second "
        "file: 4,096 variants, with XLA's deterministic ops)",
    ),
    Row(
        "The README's main job, `sweeps/slope.yaml` (10,602 variants x 5 s, slip tyre, MuJoCo C), runs in a "
        "fresh clone",
        ["cpu-2core-slope-fresh-clone.json"],
        lambda d: (
            f"**{min(d['sweep_wall_s']):.1f}-{max(d['sweep_wall_s']):.1f} s** of sweep in "
            f"{len(d['sweep_wall_s'])} runs (code {d['code']})"
            + "".join(
                f"; later, {_span(r['sweep_wall_s'].values())} ({r['date'][:16]} UTC, code {r['code'].split()[0]}; "
                "the machine slower then)"
                for r in d.get("later", [])
            )
        ),
        TWO_CORES,
        "the README's first command, in a fresh clone",
    ),
    Row(
        "The main job, slip tyre against the rigid contact, alternated (code 7bf0a51)",
        ["cpu-2core-tyres-cpu-slope.json"],
        lambda d: (
            f"slip {d['summary']['slip']['sweep_best_s']:.1f} s, "
            f"rigid {d['summary']['rigid']['sweep_best_s']:.1f} s of sweep: "
            f"**{d['ratios']['sweep_best_slip_over_rigid']:.2f}x**"
        ),
        lambda d: f"{TWO_CORES} ({d['machine']})",
        "`python benchmarks/end_to_end.py sweeps/slope.yaml --tyres --rounds 2`",
    ),
    Row(
        "batchveh `mujoco` (slip tyre, statistics, Parquet written) against raw `mujoco.batch` of the same vehicle on "
        "MuJoCo's rigid contact, and on batchveh's own frictionless model with no tyre forces, alternated pairs",
        ["cpu-2core-overhead-slip.json"],
        _overhead,
        lambda d: f"{TWO_CORES} ({d['machine']})",
        "`python benchmarks/bench.py overhead --n 2048 --repeat 5 --peers same rigid --profile --out FILE`",
    ),
    Row(
        "The same on 16 cores of a GPU host (`taskset -c 0-15`, `JAX_PLATFORMS=cpu`), 4,096 variants, the parts in "
        "15 worker processes",
        ["h100-cpu16-overhead.json"],
        _overhead,
        "one H100 host's 16 cores, no GPU used",
        "`JAX_PLATFORMS=cpu taskset -c 0-15 python benchmarks/bench.py overhead --n 4096 --repeat 3 --peers same rigid "
        "--out FILE`",
    ),
    Row(
        "The warp engine, slip tyre (the default), 131,072 variants x 1,100 steps, with the CPU peer, the rigid "
        "contact and MuJoCo Warp driven directly in the same run",
        ["h200-tyres-indexing.json"],
        _tyres,
        lambda d: d["info"]["device"].split(";")[0],
        "`python benchmarks/bench.py --tyres rigid slip --no-peer-scan --peer-variants 4096 --mjx-sizes "
        "--warp-sizes 131072 --direct-sizes 131072`",
    ),
    Row(
        "MJX's JAX engine on a GPU, float32, 8,192 variants",
        ["h200-tyres-mjx.json"],
        _mjx,
        lambda d: d["info"]["device"].replace("1 x NVIDIA", "one"),
        "`python benchmarks/bench.py --tyres rigid slip --skip-cpu --mjx-sizes 8192`",
    ),
    Row(
        "The fast contact preset (pyramidal, impratio 1, impedance 0.9), warp engine, 131,072 variants",
        ["h200-warp-pyramidal1.json"],
        _fast,
        lambda d: d["info"]["device"].replace("1 x NVIDIA", "one"),
        "`python benchmarks/bench.py --contact pyramidal/1 --skip-cpu --mjx-sizes --warp-sizes 131072 "
        "--direct-sizes 131072`",
    ),
    Row(
        "The soil model (lunar soil preset) against slip and rigid, warp engine, 131,072 variants (52% slip)",
        ["h200-soil.json"],
        _soil,
        H200_UNNAMED,
        "`python benchmarks/bench.py soil --size 131072`",
    ),
    Row(
        "Obstacles on the warp engine, rigid contact, 131,072 variants",
        ["h200-warp-courses-warm.json"],
        _courses,
        lambda d: d["info"]["device"].replace("1 x NVIDIA", "one"),
        "`python benchmarks/bench.py --skip-cpu --mjx-sizes --courses flat step terrain`",
    ),
    Row(
        "End to end: `python -m batchveh.sweep benchmarks/slope_100k.yaml` (100,000 variants x 10 s, warp, "
        "Parquet written), fresh processes, warm caches",
        ["h200-end-to-end-ab-indexing.json", "h200-end-to-end-ab-indexing-2.json", "h200-end-to-end-ab-cross.json"],
        _e2e,
        "three H200s (nvidia-h200 kind), 16 cores each",
        "`python benchmarks/end_to_end.py benchmarks/slope_100k.yaml --tree new=. --rounds 4`",
    ),
    Row(
        "1,000,000 variants x 10 s through Ray, one worker per GPU, against one GPU in-process",
        ["h200x2-ray-scaling-1m.json"],
        _ray1m,
        "two H200s of one host, 32 cores",
        "`python benchmarks/ray_gpus.py --two-gpus OUT --only 1m_local_1gpu,1m_ray_2gpu`",
    ),
    Row(
        "Two GPUs through Ray: 400,000 x 10 s with a Ray worker killed (SIGKILL) in its first chunk",
        ["h200x2-ray-kill.json"],
        lambda d: (
            f"the sweep finished in **{d['steps']['400k_ray_worker_killed']['process_s']:.1f} s**, "
            f"{d['steps']['400k_ray_worker_killed']['rows']:,} rows, "
            f"{d['steps']['400k_ray_worker_killed']['part_files']} parts for "
            f"{d['steps']['400k_ray_worker_killed']['manifest_parts']} chunks (each once)"
        ),
        "two H200s of one host, 32 cores",
        "`python benchmarks/ray_gpus.py --two-gpus OUT --only 400k_ray_worker_killed`",
    ),
    Row(
        "Two GPUs on MuJoCo Warp 4.0: `--executor gpus` against one GPU in-process, 1,000,000 x 10 s, end to end",
        ["h100x2-gpu-processes-native.json"],
        lambda d: (
            f"**{d['pairs'][0]['process_ratio']:.3f}x** one GPU's time "
            f"({d['steps']['1m_gpus_2gpu_1']['process_s']:.1f} s against "
            f"{d['steps']['1m_local_1gpu_1']['process_s']:.1f} s; one pair)"
        ),
        "two H100s of one host, 32 cores",
        "`python benchmarks/ray_gpus.py --gpu-processes OUT --rounds-1m 1 --rounds-100k 0 --warm-chunks 125184,100096`",
    ),
    Row(
        "Two GPUs without Ray, the earlier warp engine: `--executor gpus` (one process per GPU; the default on a host "
        "with several) against one GPU in-process (CUDA_VISIBLE_DEVICES=0), end to end, alternated pairs",
        [
            "h100x2-gpu-processes-worker-start.json",
            "h100x2-gpu-processes-prestart-2.json",
            "h100x2-gpu-processes-prestart.json",
            "h100x2-gpu-processes-final.json",
            "h100x2-gpu-processes-own-gpu.json",
            "h100x2-gpu-processes-pipeline.json",
        ],
        _gpu_processes,
        "two H100s, six fresh hosts, 32 cores each",
        "`python benchmarks/ray_gpus.py --gpu-processes OUT --rounds-1m 2` (each file's `command`)",
    ),
    Row(
        "The worker started before the command line's imports (`prestart`) against at the executor's start, "
        "`--executor gpus` on two CPU worker slots (MuJoCo C), 200 variants in 8 chunks, alternated",
        ["cpu-2core-gpu-processes-prestart.json"],
        lambda d: (
            "worker ready after this process's engine: "
            + ", ".join(f"{v:.2f} s" for k, v in d["worker_ready_after_engine_s"].items() if "gpus_" in k)
            + " against "
            + ", ".join(f"{v:.2f} s" for k, v in d["worker_ready_after_engine_s"].items() if "gpusenv" in k)
            + f"; median ratio to one process **{d['median_process_ratio_1m']:.3f}x** against "
            f"{d['median_process_ratio_1m_env']:.3f}x"
        ),
        TWO_CORES,
        "`python benchmarks/ray_gpus.py --gpu-processes OUT --smoke --rounds-1m 3 --rounds-100k 0 "
        "--gpus-env BATCHVEH_PRESTART=0`",
    ),
    Row(
        "A small sweep on a two-GPU host: 100,000 x 10 s with --executor ray (below Ray's break-even it runs "
        "in-process) against in-process, alternated pairs",
        ["h100x2-ray-100k.json"],
        _small_ray,
        "two H100s of one host, 32 cores",
        "`python benchmarks/ray_gpus.py --two-gpus OUT --rounds-100k 3 --only "
        "100k_ray,100k_local,100k_ray_2,100k_local_2,100k_ray_3,100k_local_3`",
    ),
    Row(
        "A sweep over the vehicle itself: 1,000,000 variants x 10 s, random, with payload mass and wheel radius "
        "against without, warp (MuJoCo Warp 4.0), fresh processes",
        ["h100-structural-sweep.json"],
        lambda d: (
            f"**{d['ratio']:.3f}x** ({d['median_process_s']['structural']:.1f} s against "
            f"{d['median_process_s']['flat']:.1f} s)"
        ),
        lambda d: gpu_of(d["machine"]),
        "`python benchmarks/structural.py sweep --size 1000000 --time 10 --repeat 1 --backend warp`",
    ),
    Row(
        "The same on MuJoCo C: 3,000 random variants x 1 s, alternated",
        ["cpu-2core-structural-sweep.json"],
        lambda d: (
            f"**{d['ratio']:.3f}x** ({d['median_process_s']['structural']:.1f} s against "
            f"{d['median_process_s']['flat']:.1f} s)"
        ),
        lambda d: gpu_of(d["machine"]),
        "`python benchmarks/structural.py sweep --size 3000 --time 1 --repeat 3`",
    ),
    Row(
        "Preparing structural variants (`make_batch`: closed forms and `mj_setConst`), per variant",
        ["h200-cpu16-structural-prepare.json"],
        _prepare,
        "one H200 host's 16 cores",
        "`python benchmarks/structural.py prepare --size 100000`",
    ),
    Row(
        "The same on 2 cores",
        ["cpu-2core-structural-prepare.json"],
        _prepare,
        TWO_CORES,
        "`python benchmarks/structural.py prepare --size 4000`",
    ),
    Row(
        "Structural variants, warp float32 against MuJoCo C float64, 4,096 random variants x 10 s",
        ["h100-warp-vs-cpu-2core-c-structural-compare.json"],
        lambda d: (
            "per-wheel mean p99 **"
            + f"{max(v['p99'] for k, v in d['per_wheel'].items() if k.endswith('_mean')):.2%}**, low-pass peak p99 "
            + f"{max(v['p99'] for k, v in d['per_wheel'].items() if k.endswith('_lp_all')):.1e}"
        ),
        "one H100 (warp, MuJoCo Warp 4.0); 2 cores (C 4.0)",
        "`python benchmarks/structural.py compare WARP_RESULTS C_RESULTS` on two runs of "
        "`benchmarks/structural_warp_vs_c.yaml`",
    ),
    Row(
        "Motors in the loop near their limits, warp float32 against MuJoCo C float64, 2,048 random variants x 10 s "
        "on the slip tyre (current RMS, temperature rise, energy, speed shortfall per drive; bus energy)",
        ["h100-warp-vs-cpu-2core-c-dcmotor-compare.json"],
        lambda d: (
            "p99 **"
            + f"{max(d['per_drive'][k]['p99'] for k in DC_COMPARED):.1e}"
            + "** (the largest of the four, each variant against itself), "
            + f"{max(d['per_drive_of_largest'][k]['p99'] for k in DC_COMPARED):.1e} against the column's largest; "
            + "bus energy p99 "
            + f"{d['vehicle']['bus_energy_wh']['p99']:.1e}; motor_status agrees on "
            + f"{d['motor_status_agree']:.2%}"
        ),
        "one H100 (warp, MuJoCo Warp 4.0); 2 cores (C 4.0)",
        "`python benchmarks/motors.py compare WARP_RESULTS C_RESULTS` on two runs of "
        "`benchmarks/motors_warp_vs_c.yaml`",
    ),
    Row(
        "Motors in the loop: the same random sweep with the ideal servo and with dcmotors, alternated",
        ["*-motors*.json"],
        _motors,
        lambda d: gpu_of(d["machine"]),
        lambda d: (
            "`python benchmarks/motors.py --size 131072 --time 5 --repeat 2 --backend warp`"
            if d["machine"].get("gpus")
            else "`python benchmarks/motors.py --size 2048 --time 2 --repeat 3`"
        ),
    ),
    Row(
        "The first GPU run on a fresh machine, `benchmarks/slope_100k.yaml` end to end (100,000 x 10 s), each way on "
        "its own empty caches, then warm: MuJoCo Warp's kernels built ahead in worker processes "
        "(`engines/warp_build.py`) against each at its first launch (serial)",
        ["h200-first-gpu-run.json"],
        _gpu_start,
        "one H200, then one H100 twice, then another H200; 16 cores each",
        "`python benchmarks/end_to_end.py start benchmarks/slope_100k.yaml --fresh --rounds 1 --out FILE` (the last: "
        "`--warm-runs 2`)",
    ),
]


def _load(name: str) -> dict:
    return json.loads((RESULTS / name).read_text())


def _cell(value: Callable[..., str] | str, data: list[dict]) -> str:
    """A row's machine or command: given, or read from its files."""
    return value if isinstance(value, str) else value(*data)


def table() -> tuple[list[str], set[str]]:
    """The table's lines and the result files it read."""
    lines = [
        "| what was measured | figure | machine | result file | the command that repeats it |",
        "| --- | --- | --- | --- | --- |",
    ]
    used: set[str] = set()
    for row in ROWS:
        groups = [[f.name] for f in sorted(RESULTS.glob(row.files[0]))] if "*" in row.files[0] else [row.files]
        for names in groups:
            data = [_load(n) for n in names]
            links = ", ".join(f"[{n}]({RAW}/{n})" for n in names)
            what = row.what if len(groups) == 1 else f"{row.what} ({names[0].split('-motors')[0].split('-gpu')[0]})"
            cells = (what, row.figure(*data), _cell(row.machine, data), links, _cell(row.command, data))
            lines.append("| " + " | ".join(c.replace("|", "/") for c in cells) + " |")
            used.update(names)
    return lines, used


def render() -> str:
    lines, used = table()
    others = sorted(f.name for f in RESULTS.glob("*.json") if f.name not in used and f.name != ARCHIVE)
    if others:
        lines += ["", "Result files no row reads yet: " + ", ".join(f"[{n}]({RAW}/{n})" for n in others) + "."]
    notes = (HERE / "NOTES.md").read_text()
    assert MARK in notes, f"benchmarks/NOTES.md has no {MARK}"
    return notes.replace(MARK, "\n".join(lines)).rstrip() + "\n"


def publish(out: Path, text: str, script: str, doc: str) -> None:
    """Write a generated page, or with --check exit 1 where the committed one differs (validation/render.py too)."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help=f"exit 1 if {out.name} differs from what this writes")
    if ap.parse_args().check:
        if out.read_text() != text:
            sys.exit(f"{out} is not what {script} writes: run python {script}")
        print(f"{out} is up to date")
        return
    out.write_text(text)
    print(f"wrote {out} ({len(text.splitlines())} lines)")


def main() -> None:
    publish(OUT, render(), "benchmarks/render.py", __doc__)


if __name__ == "__main__":
    main()
