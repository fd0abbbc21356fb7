"""Write docs/performance.md from benchmarks/NOTES.md, benchmarks/ARCHIVE.md and benchmarks/results/*.json.

    python benchmarks/render.py

Today's result files (CURRENT) come first, after NOTES.md; every other
file goes to the archive section, after ARCHIVE.md.
"""

import json
import statistics
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE.parent / "docs" / "performance.md"
RAW = "../benchmarks/results"  # the result files, as seen from docs/

# today's results: what each file measured. A file missing here is archived.
CURRENT = {
    "h200-structural-sweep.json": "",
    "cpu-2core-structural-sweep.json": "",
    "h200-cpu16-structural-prepare.json": "",
    "cpu-2core-structural-prepare.json": "",
    "h200-structural-spread.json": "",
    "h200-structural-resume.json": "",
    "h200-warp-vs-cpu-2core-c-fixed-structural-compare.json": "",
    "h200-motors.json": "",
    "h200-tyres.json": "The warp engine, slip tyre and rigid contact side by side",
    "h200-tyres-mjx.json": "MJX's JAX implementation on a GPU, slip tyre and rigid contact",
    "h200-warp-soft.json": "The warp engine, rigid contact (elliptic, impratio 100, impedance 0.25), "
    "the run beside the impratio-10 / impedance-0.9 one (h200-tyres.json is the newer rigid run)",
    "h200-warp-impedance09.json": "The warp engine, rigid contact with impratio 10 and impedance 0.9 "
    "(two settings changed from the default's 100 and 0.25)",
    "h200-warp-pyramidal1.json": "The warp engine, the fast contact preset",
    "h200-warp-courses-warm.json": "Obstacles on the warp engine, warmed up",
    "h200-warp-courses-cold.json": "Obstacles on the warp engine, first launch on a fresh machine",
    "cpu-tiny-courses.json": "Obstacles on MuJoCo C, 16 variants on 2 cores",
    "h200-warp-largest.json": "The largest warp batch",
    "cpu-2core-overhead-slip.json": "batchveh mujoco with the slip tyre against raw mujoco.batch on the same "
    "frictionless model without a tyre, 2 cores",
    "cpu-2core-wheel-ground-step.json": "The slip tyre's and the soil's step between MuJoCo C's steps, numpy and XLA",
    "cpu-2core-overhead.json": "batchveh mujoco against raw mujoco.batch on 2 cores (pyramidal contact, no tyre)",
    "h200-tyres-p95row.json": "The warp engine, slip tyre and rigid contact side by side, after the p95 buffer change",
    "h200-end-to-end-ab-p95row.json": "End to end, the p95 buffer change against the code before it, one H200",
    "h200-end-to-end-slope_100k-p95row.json": "End to end on one H200 after the p95 buffer change",
    "h200-warp-iterations.json": "The constraint solver's iterations on the warp engine",
    "h200-end-to-end-ab-unroll.json": "End to end, steps per iteration of the scan's loop, one H200",
    "h200-warp-unroll.json": "Steps per iteration of the warp engine's scan loop, one H200",
    "h200-warm-compile.json": "A warm sweep's steps before its simulation, one H200",
    "h200-end-to-end-slope_100k.json": "End to end on one H200, fresh machine",
    "h200-end-to-end-slope_100k-layout.json": "End to end on another H200, fresh machine, after the layout change",
    "cpu-2core-end-to-end-slope_100k.json": "End to end on 2 CPU cores",
    "h200-process-profile.json": "Where a warm 100,000-variant sweep process spends its time, one H200",
    "h200-gpu-start.json": "JAX's GPU memory reserved at start or grown on demand, one H200",
    "cpu-2core-tyres-cpu-slope.json": "The main job on MuJoCo C with the slip tyre and the rigid contact, 2 cores",
    "h200-soil.json": "The soil model on the warp engine against slip and rigid, one H200",
    "h200-ray-gpus-warp.json": "Ray against the in-process sweep, the warp engine, one H200",
    "h200x2-ray-gpus.json": "Ray against the in-process sweep, two H200",
    "cpu-2core-ray-gpus.json": "Ray against the in-process sweep, 2 cores",
}
# rows of a current file that measured code since removed (batchveh's fused solver on MJX)
ARCHIVED_ROWS = {"h200-warp-pyramidal1.json": "fused"}
# what a current file's own fields do not say
FILE_NOTES = {
    "h200-warp-soft.json": "Its contact label reads elliptic/10: bench.py then labelled the vehicle's default from a "
    "stale constant. The default it ran was elliptic, impratio 100, impedance 0.25; the impedance-0.9 run beside it "
    "names its contact from --contact.",
    "h200-warp-impedance09.json": "Its contact, elliptic/10/0.9, changes two settings from the default "
    "(impratio 100, impedance 0.25), so its difference from the default is not the impedance's alone.",
}
FILE_NOTES["h200-end-to-end-ab-p95row.json"] = (
    "Trees: `old` is 4ca06a8 (`git archive` of batchveh/), `new` the working tree of 8682147 less its gc.freeze "
    "(as committed in c60e91b): the p95 buffer's row written in place."
)
FILE_NOTES["h200-end-to-end-ab-gcfreeze.json"] = (
    "Trees: `old` is 4ca06a8, `new` 8682147 with the gc.freeze after the engine's import: every `new` run failed in "
    "MuJoCo Warp's FFI callback ('Warp error: unknown stream'), so its walls time a failure, not a sweep."
)
FILE_NOTES["h200-end-to-end-ab-command-buffers.json"] = (
    "Both trees are c60e91b's code; `nocb` runs with XLA's command buffers (CUDA graphs of XLA's own kernels) off."
)
FILE_NOTES["h200-end-to-end-ab-unroll.json"] = (
    "Trees: `u1` is the working tree after 502706d (one step per iteration of the scan's loop), `u2` and `u5` its "
    "copies with the warp engine's scan_unroll at 2 and 5."
)
FILE_NOTES["h200-warp-unroll.json"] = (
    "Unroll 1's trace + lower was the process's first (JAX's and MJX's first use of much of their code); the "
    "later rows' 1.2-1.8 s are the fairer comparison. The torque differences are float32's: a step's arithmetic "
    "grouped otherwise."
)
FILE_NOTES["cpu-2core-overhead.json"] = (
    "Contact: MuJoCo's pyramidal cone, impratio 1, the default of the code it ran (391ac0d), no tyre; the file "
    "does not record it. Today's default models (the slip tyre; the rigid contact's elliptic cone, impratio 100) "
    "are not measured this way: on this machine the raw peer ran 8.1e4-8.9e4 variant-steps/s on the elliptic cone "
    "(impratio 10) against 1.33e5-1.55e5 on the pyramidal one (`cpu-2core-contact-cost.json`)."
)
# the machine, where a file does not record it (these ran on the lent nvidia-h200 kind)
NO_GPU_NAME = "Machine: one H200 (nvidia-h200 kind; the file records no GPU name and no date)."
for _name in ("h200-soil.json", "h200-soil-mjx.json", "h200-soil-unforwarded.json", "h200-gpu-start.json"):
    FILE_NOTES[_name] = NO_GPU_NAME
for _name in ("h200-process-profile.json", "h200-process-profile-before.json"):
    FILE_NOTES[_name] = "Machine: one H200 (named only in the sweep's printed line; the file records no date)."
ERR_KEYS = ("noslip_sum_mean", "noslip_wheel_mean", "noslip_wheel_peak", "noslip_wheel_peak_lp")


def _err(a, k):
    return f"{a[k]['median']:.1e} / {a[k]['p99']:.1e}" if k in a else "-"


def bench_table(d):
    i = d["info"]
    lines = [
        f"### {i['device']}, {i['cpu_threads']} CPU threads, {i.get('wheel_collision', 'cylinder')} wheel contacts "
        f"({i['date']})",
        "",
        f"mujoco {i['mujoco']}, jax {i['jax']}, Python {i['python']}; {i['steps']} steps of "
        f"{i['time_step']} s per variant (sweeps/slope.yaml variants).",
        "",
        f"Command: `python {i['command']}`" + (f". {i['note']}" if i.get("note") else ""),
        "",
        "| row | variant-steps/s | sim s / wall s | x raw mujoco.batch | compile s | peak GPU GB | "
        "sum mean err | wheel mean err | wheel peak err | wheel peak_lp err |",
        "| --- | ---: | ---: | ---: | ---: | ---: | --- | --- | --- | --- |",
    ]
    for r in d["rows"]:
        if "rate" not in r:
            lines.append(f"| {r['name']} | failed: {r['error']} | | | | | | | | |")
            continue
        a = r.get("accuracy", {})
        ratio = f"{r['vs_raw_batch']:.2f}" if r.get("vs_raw_batch") else "-"
        ok = f" (ok share {r['ok_share']:.4f})" if "ok_share" in r else ""
        lines.append(
            f"| {r['name']}{ok} | {r['rate']:.3g} | "
            f"{r['sim_s_per_s']:.3g} | {ratio} | "
            f"{r.get('compile_s', 0):.1f} | {r.get('peak_mem_gb', 0):.2f} | "
            + " | ".join(_err(a, k) for k in ERR_KEYS)
            + " |"
        )
    return "\n".join(lines)


def scaling_table(files):
    rows = [json.loads(f.read_text().strip().splitlines()[-1]) for f in files]
    lines = [
        "| GPUs | variants | solver | solver code | variant-steps/s | compile s |",
        "| ---: | ---: | --- | --- | ---: | ---: |",
    ]
    for r in sorted(rows, key=lambda r: (r.get("solver_impl", "mjx"), r["devices"], r["variants"])):
        lines.append(
            f"| {r['devices']} x {r['kind']} | {r['variants']} | {r['solver']} | {r.get('solver_impl', 'mjx')} | "
            f"{r['variant_steps_per_s']:.3g} | {r['compile_s']:.1f} |"
        )
    return "\n".join(lines)


def profile_section(d, name):
    lines = [
        f"`python benchmarks/profile_step.py` on {d['device']}, {d['n']} variants, one vmapped step from a settled "
        f"state (best of 10); kernels from a JAX profiler trace of 3 steps (raw data: [{name}]({RAW}/{name})).",
        "",
        "| solver | code | ms per step | variant-steps/s | compile s | kernels per step | kernel ms per step |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in d["rows"]:
        lines.append(
            f"| {r['solver']} | {r['mode']} | {r['ms']:.2f} | {r['rate']:.3g} | {r.get('compile_s', 0):.1f} | "
            f"{r.get('kernels_per_step', '-')} | {r.get('kernel_ms_per_step', 0):.2f} |"
        )
    for r in d["rows"]:
        if r.get("kernels"):
            lines += ["", f"Largest kernels, {r['solver']} / {r['mode']}:", "", "| kernel | ms per step | calls |"]
            lines.append("| --- | ---: | ---: |")
            lines += [f"| `{k['kernel'][:70]}` | {k['us'] / 3e3:.3f} | {k['calls'] // 3} |" for k in r["kernels"][:10]]
    if d.get("hessians"):
        lines += ["", "Formulations of J' diag(w) J (48 x 14 Jacobians), jit(vmap), best of 20:", ""]
        lines += ["| formulation | ms | max rel. error |", "| --- | ---: | ---: |"]
        lines += [f"| {h['hessian']} | {h['ms']:.3f} | {h['max_rel_err']:.1e} |" for h in d["hessians"]]
    return "\n".join(lines)


def peer_note(peer):
    """How the raw peer ran, and the scan that chose it."""
    text = (
        f"Peer: {peer['api']}; {peer['variants']} variants per batch, blocks of {peer['block']} steps, "
        f"{peer['threads']} threads"
    )
    if peer.get("scan"):
        scan = ", ".join(f"{r['variants']}/{r['block']}/{r['threads']}: {r['rate']:.3g}" for r in peer["scan"])
        text += f", the best of a scan (variants/block/threads: variant-steps/s): {scan}"
    else:
        text += " (settings given, no scan in this run)"
    return text + "."


def overhead_section(d, name):
    """One cpu_overhead.py run: the ratio per alternated pair, the median over every pair, and the profile."""
    keys = [k for k in d["pairs"][0] if k.startswith("ratio")]
    if "peer" in d:  # run_sweep against the peer at its best
        cmd = d["command"].split(" --note ")[0].split(" --out ")[0]
        head = (
            f"`python {cmd}` on {d['machine']}, {d['date']}: {d['variants']} variants x {d['steps']} steps, "
            f"{d['solver']}. Peer: {d['peer']['api']}, {d['peer']['variants_per_batch']} variants per batch, "
            f"blocks of {d['peer']['block']}, {d['peer']['threads']} threads. batchveh: {d['batchveh']}. "
            f"{d['note']}. {('Code: ' + d['code'] + '. ') if 'code' in d else ''}"
            f"(load average before/after: {d['load_average_before_after']}; "
            f"raw data: [{name}]({RAW}/{name}))."
        )
        cols = [k[6:].replace("chunk", "chunk ").replace("_threads", ", threads ") for k in keys]
    else:  # the older format: engine.run against one Batch.step per step
        head = (
            f"`python benchmarks/cpu_overhead.py` (an earlier version): {d['variants']} variants x {d['steps']} "
            f"steps, {d['cpu_threads']} CPU threads; measured against the older peer (one Batch.step per step, "
            f"{d['variants']} variants, {d['mujoco_threads']} threads), batchveh's engine.run without make_batch "
            f"or Parquet; columns: batchveh's MuJoCo threads (raw data: [{name}]({RAW}/{name}))."
        )
        cols = [f"{k[6:]} threads" for k in keys]
    lines = [
        head,
        "",
        "| pair | raw variant-steps/s | " + " | ".join(f"x raw, {c}" for c in cols) + " |",
        "| ---: | ---: | " + " | ".join("---:" for _ in keys) + " |",
    ]
    for i, p in enumerate(d["pairs"]):
        lines.append(f"| {i + 1} | {p['raw']:.3g} | " + " | ".join(f"{p[k]:.3f}" for k in keys) + " |")
    med = {k: statistics.median(p[k] for p in d["pairs"]) for k in keys}  # every pair, the first too
    lines.append("| median, all pairs | | " + " | ".join(f"**{med[k]:.3f}**" for k in keys) + " |")
    prof = d.get("profile")
    if prof:
        lines += [
            "",
            "Where one instrumented batchveh run's time went (first setting; worker rows are CPU time of the "
            "fold and control threads, which run beside the stepping):",
            "",
            "| part | s | ns per variant-step |",
            "| --- | ---: | ---: |",
        ]
        lines += [f"| {k} | {v['s']:.3f} | {v['ns_per_variant_step']:.0f} |" for k, v in prof.items()]
    return "\n".join(lines)


def ray_section(d, name):
    """The in-process sweep against Ray workers, side by side (benchmarks/ray_gpus.py)."""
    hours = ", ".join(f"{s / 3600:.2f} h on {n}" for n, s in d["ten_million_x_2100_steps_s"].items())
    out = [
        f"### In-process against Ray: {d['machine']}, backend {d['backend']}",
        "",
        f"Command: `{d['command'].split(' --note')[0]}`, {d['date']}. {d['note']}",
        "",
        "| executor | repeat | wall s | compile s | variant-steps/s after compile | process s | device |",
        "| --- | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    out += [
        f"| {r['executor']} | {r['repeat']} | {r['wall_s']:.1f} | {r['compile_s']:.1f} | "
        f"{r['rate_after_compile']:.3g} | {r['process_s']:.1f} | {r['device']} |"
        for r in d["rows"]
    ]
    out += [
        "",
        f"Ray / in-process, best after the compile: **{d['ray_over_local']:.3f}**. 10 million variants x 2,100 "
        f"steps at the Ray rate per worker: {hours} workers. (raw data: [{name}]({RAW}/{name}))",
    ]
    return "\n".join(out)


def end_to_end_section(d: dict, name: str) -> str:
    """One benchmarks/end_to_end.py file: each fresh process's wall time, the sweep's own clock and the caches."""
    device = ", ".join(d["gpus"]) or d["machine"]
    out = [
        f"### End to end: `{d['command']}` on {device}",
        "",
        f"{d['date']}, code {d['code']}, {d['machine']}. {d['note'].rstrip('.')}. First run on fresh caches "
        f"(no Warp kernel, no JAX program cached): {'yes' if d['first_run_on_fresh_caches'] else 'no'}.",
        "",
        "| run | wall s | the sweep's own s | compile s | outside the sweep s | variant-steps/s (sweep clock) | "
        "backend (device) | JAX cache entries before | Warp kernel cache entries before | load average |",
        "| --- | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: | --- |",
    ]
    for r in d["runs"]:
        c = r["caches_before"] or {"jax_compile_cache_entries": "-", "warp_kernel_cache_entries": "-"}  # not recorded
        load = " / ".join(f"{x:.1f}" for x in r["load_average_before_after"] or ()) or "-"
        if "sweep_wall_s" not in r:
            out.append(f"| {r['kind']} | {r['wall_s']:.1f} | failed (exit {r['returncode']}) | | | | | | | {load} |")
            continue
        out.append(
            f"| {r['kind']} | {r['wall_s']:.1f} | {r['sweep_wall_s']:.1f} | {r['compile_s']:.1f} | "
            f"{r['outside_sweep_s']:.1f} | {r['variant_steps_per_s']:.3g} | {r['backend']} ({r['device']}) | "
            f"{c['jax_compile_cache_entries']} | {c['warp_kernel_cache_entries']} | {load} |"
        )
    status = d["runs"][-1].get("status", "")
    out += ["", f"Status of the last run: {status}. (raw data: [{name}]({RAW}/{name}))"]
    return "\n".join(out)


def bench_section(d: dict, name: str) -> list[str]:
    """A bench.py file: its table, the peer it ran against, and what its own fields do not say."""
    drop = ARCHIVED_ROWS.get(name) if name in CURRENT else None
    if drop:
        d = {**d, "rows": [r for r in d["rows"] if drop not in r["name"]]}
    table = bench_table(d)
    if name in CURRENT:  # its heading says what it measured, then on what
        table = f"### {CURRENT[name]}: " + table.removeprefix("### ")
    out = [table, ""]
    if d["info"].get("peer"):
        out += [peer_note(d["info"]["peer"]), ""]
        out += [f"Code: {d['info']['code']}.", ""] if "code" in d["info"] else []
    elif "peer" not in d["info"] and not d["info"].get("command", "").count("--skip-cpu"):
        cmd = d["info"]["command"].split()
        n = cmd[cmd.index("--cpu-variants") + 1] if "--cpu-variants" in cmd else "512"
        out += [
            f"Ratios measured against the older peer (one Batch.step per step, {n} variants, nothing "
            "recorded): bench.py before the peer was measured at its best.",
            "",
        ]
    if drop:
        out += [f"Rows of this file that ran batchveh's {drop} solver are in the archive's notes.", ""]
    if name in FILE_NOTES:
        out += [FILE_NOTES[name], ""]
    return out + [f"(raw data: [{name}]({RAW}/{name}))", ""]


def structural_section(d: dict, name: str) -> list[str]:
    """benchmarks/structural.py's parts: a sweep over the vehicle itself (issue 30)."""
    where = d["machine"].get("gpus") or [f"{d['machine']['cpus']} CPUs"]
    head = [f"### Sweeps over the vehicle, `structural.py {d['part']}`: {where[0]} ({d['when'][:10]})", ""]
    link = f"[{name}]({RAW}/{name})"
    if d["part"] == "prepare":
        rows = [
            "| parameters | variants | us a variant | compile per variant (old path), us |",
            "| --- | --- | --- | --- |",
        ]
        for r in d["rows"]:
            us, old = r["us_per_variant"], r["compile_per_variant_us"]
            rows.append(f"| {' + '.join(r['params'])} | {r['n']:,} | {us:.1f} | {old:.0f} |")
    elif d["part"] == "motors":
        rows = ["| vehicle | round | process s | variant-steps/s |", "| --- | --- | --- | --- |"]
        rows += [f"| {r['kind']} | {r['round']} | {r['process_s']:.1f} | {r.get('rate', 0):.3g} |" for r in d["runs"]]
        rows += [
            "",
            f"{d['size']:,} variants x {d['total_time']:g} s; dcmotor / servo (median rate): {d['ratio']:.3f}.",
        ]
    elif d["part"] == "sweep":
        rows = ["| sweep | round | process s | sweep s | dry-run estimate s |", "| --- | --- | --- | --- | --- |"]
        rows += [
            f"| {r['kind']} | {r['round']} | {r['process_s']:.1f} | {r.get('sweep_s', float('nan')):.1f} | "
            f"{r['estimate_s']} |"
            for r in d["runs"]
        ]
        rows += [
            "",
            f"{d['size']:,} variants x {d['total_time']:g} s; structural / flat (median process): {d['ratio']:.3f}.",
        ]
    else:
        diff = d.get("run_to_run") or d.get("against_uninterrupted") or d.get("per_wheel")
        keys = [k for k in diff if k.startswith("drive_") and k.endswith(("_mean", "_peak_lp_all", "_rms"))][:12]
        rows = ["| column | p99 | max |", "| --- | --- | --- |"]
        rows += [f"| {k} | {diff[k]['p99']:.2g} | {diff[k]['max']:.2g} |" for k in keys]
        if d["part"] == "resume":
            rows += [
                "",
                f"Killed after {d['parts_at_kill']} parts; the resume ran {d['resume'].get('ran'):,} variants.",
            ]
    return [*head, *rows, "", f"Raw: {link}.", ""]


def mainjob_section(d: dict, name: str) -> list[str]:
    out = [
        "### The main job, end to end (by the earlier mainjob.py)",
        "",
        f"`{d['command']}` (10,602 variants x 1000 steps, MuJoCo C) as a fresh process, on {d['machine']}, "
        f"{d['date']}. {d['note']} (raw data: [{name}]({RAW}/{name}))",
        "",
        "| run | wall s | load average before / after | the sweep's summary |",
        "| ---: | ---: | --- | --- |",
    ]
    for i, r in enumerate(d["runs"]):
        load = " / ".join(f"{x:.1f}" for x in r["load_average_before_after"])
        out.append(f"| {i + 1} | {r['wall_s']:.1f} | {load} | {' '.join(r['summary'])[:200]} |")
    return out + [""]


def largest_section(d: dict, name: str) -> list[str]:
    out = [f"### The largest warp batch: {d['info']['device']}", "", f"Command: `{d['info']['command']}`", ""]
    out += ["| variants | variant-steps/s | peak GB | result |", "| ---: | ---: | ---: | --- |"]
    for r in d["rows"]:
        if "error" in r:
            out.append(f"| {r['variants']:,} | - | - | {r['error'][:80]} |")
        else:
            out.append(f"| {r['variants']:,} | {r['rate']:.3g} | {r['peak_mem_gb']:.1f} | ok |")
    return out + ["", f"(raw data: [{name}]({RAW}/{name}))", ""]


def stages_section(files: list[Path]) -> list[str]:
    out = [
        "### Where a step's time goes",
        "",
        "`python benchmarks/stages.py --n 65536 --solver S`: cumulative prefixes of mjx.step, jit(vmap) over "
        "65,536 slope variants from a settled state, best of 10; 'delta' is the stage's own cost.",
        "",
    ]
    for f in files:
        d = json.loads(f.read_text())
        total = d["rows"][-1]["ms"]
        out += [
            f"**{d['solver']}**, {d.get('wheel_collision', 'cylinder')} wheels, on {d['device']}: one step "
            f"{total:.2f} ms ({d['n'] / total * 1e3:.3g} variant-steps/s; raw data: [{f.name}]({RAW}/{f.name}))",
            "",
            "| stage | cumulative ms | delta ms | share |",
            "| --- | ---: | ---: | ---: |",
        ]
        out += [
            f"| {r['stage']} | {r['ms']:.2f} | {r['delta_ms']:.2f} | {100 * r['delta_ms'] / total:.0f}% |"
            for r in d["rows"]
        ]
        out.append("")
    return out


def process_profile_section(d: dict, name: str) -> list[str]:
    """benchmarks/process_profile.py: where a sweep process's time goes."""
    out = [f"### Where a sweep process spends its time: `{d['spec']}`", ""]
    walls = ", ".join(f"{r['wall_s']:.1f} s" for r in d["plain"])
    key = "interpreter_start_and_exit_s"
    rest = ", ".join(f"{r[key]:.2f} s" for r in d["plain"] if key in r)
    out += [f"Plain runs: {walls}" + (f"; interpreter start and exit {rest}." if rest else "."), ""]
    if "pyspy" in d:
        out += ["py-spy, main thread, seconds by the innermost batchveh frame (and what it called):", ""]
        out += ["| s | where |", "| ---: | --- |"]
        out += [f"| {r['seconds']:.2f} | `{r['where'][:110]}` |" for r in d["pyspy"]["top"][:14]]
    else:
        out += ["cProfile, cumulative (misplaces time inside XLA's callbacks):", ""]
        out += ["| cumulative s | function |", "| ---: | --- |"]
        out += [f"| {r['cumtime_s']:.2f} | `{r['function']}` |" for r in d["cprofile_cumulative_top"][:14]]
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def ab_section(d: dict, name: str) -> list[str]:
    """benchmarks/end_to_end_ab.py: source trees (and environments) alternated, fresh processes."""
    info = d["info"]
    env = "; ".join(f"{k}: {' '.join(f'{a}={b}' for a, b in v.items())}" for k, v in info.get("env", {}).items() if v)
    out = [
        f"### End to end, alternated: `{info['spec']}`" + (f", --limit {info['limit']}" if info.get("limit") else ""),
        "",
        f"{', '.join(info['gpus']) or str(info['cpus']) + ' CPUs'}, {info['date']}"
        + (f"; environment {env}" if env else "")
        + ". Trees: "
        + ", ".join(f"{k} `{v}`" for k, v in info["trees"].items())
        + (". Code: " + ", ".join(f"{k} {v}" for k, v in info["code"].items()) if "code" in info else "")
        + (f". {info['device']}" if "device" in info else ""),
        "",
        "| tree | process s, round by round | median | the sweep, median s | compile, median s |",
        "| --- | --- | ---: | ---: | ---: |",
    ]
    for k, v in d["summary"].items():
        walls = ", ".join(f"{w:.2f}" for w in v["wall_s"])
        out.append(
            f"| {k} | {walls} | {v['wall_median_s']:.2f} | {v['sweep_median_s']:.2f} | {v['compile_median_s']:.2f} |"
        )
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def iterations_section(d: dict, name: str) -> list[str]:
    """benchmarks/warp_iterations.py: solver iterations, rate and accuracy per setting."""
    info = d["info"]
    out = [
        f"### Solver iterations on the warp engine: `{info['spec']}`",
        "",
        f"{info['device']}, {info['date']}; reference: {info['reference']['variants']:,} variants, "
        f"{info['reference']['engine']}.",
        "",
        "| tolerance | contacts / world | variants x steps | variant-steps/s | batch's largest iterations, mean / max "
        "| a world's mean | wheel mean, median / p99 |",
        "| ---: | ---: | --- | ---: | --- | ---: | --- |",
    ]
    for r in d["rows"]:
        it, w = r["iterations"], r["accuracy_vs_c"].get("noslip_wheel_mean", {})
        out.append(
            f"| {r['tolerance']:.0e} | {r['contacts_per_world']} | {r['variants']:,} x {r['steps']:,} "
            f"| {r['variant_steps_per_s']:.3g} | {it['batch_largest_mean']:.2f} / {it['batch_largest_max']} "
            f"| {it['world_mean']:.2f} | {w.get('median', float('nan')):.1e} / {w.get('p99', float('nan')):.1e} |"
        )
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def probe_section(d: dict, name: str) -> list[str]:
    """A probe's runs: what was done before and what came of it."""
    out = [f"### Probe: {name}", "", f"{d['device']}, {d['date']}, code {d['code']}. {d['what']}.", ""]
    out += ["| before | outcome |", "| --- | --- |"]
    out += [f"| {r['before main']} | {r['outcome']} |" for r in d["runs"]]
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def step_profile_section(d: dict, name: str) -> list[str]:
    """benchmarks/warp_profile.py runs: a scan step's device time by kind of kernel, per run."""
    out = [
        f"### Where a step of the warp engine's scan spends its GPU time: {name}",
        "",
        f"{d['device']}, {d['date']}. {d['what']}.",
        "",
        "| run | code | wall per step, us | device busy | Warp kernels | XLA kernels | copies | XLA launches "
        "| largest XLA kernel, us |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for r in d["runs"]:
        if "error" in r:
            out.append(f"| {r['label']} | {r['code']} | {r['error']} |||||||")
            continue
        us, n = r["per_step_us"], r["launches_per_step"]
        top = next((k for k in r["kernels"] if k["kind"] == "xla"), None)
        out.append(
            f"| {r['label']} | {r['code']} | {r['wall_per_step_us']:.0f} | {r['device_busy_per_step_us']:.0f} "
            f"| {us.get('warp', 0):.0f} | {us.get('xla', 0):.0f} | {us.get('copy', 0):.0f} | {n.get('xla', 0):.1f} "
            + (f"| {top['kernel']} {top['us_per_step']:.0f} |" if top else "| - |")
        )
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def warm_compile_section(d: dict, name: str) -> list[str]:
    """benchmarks/warm_compile.py's printed lines: a sweep's steps before its simulation, apart."""
    keys = ("imports_s", "batch_s", "upload_s", "program_s", "trace_s", "lower_s", "compile_s", "total_s")
    out = [
        "### A sweep's steps before its simulation, apart (`benchmarks/warm_compile.py`)",
        "",
        f"{d['device']}, {d['date']}, code {d['code']}. {d['what']}.",
        "",
        "| environment | cache files before | " + " | ".join(k[:-2] + " s" for k in keys) + " |",
        "| --- | ---: | " + " | ".join("---:" for _ in keys) + " |",
    ]
    for r in d["runs"]:
        out.append(
            f"| {r['env'] or '-'} | {r['cache_files_before']} | " + " | ".join(f"{r[k]:.2f}" for k in keys) + " |"
        )
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def unroll_section(d: dict, name: str) -> list[str]:
    """benchmarks/warp_unroll.py: steps per iteration of the warp engine's scan loop."""
    info = d["info"]
    out = [
        f"### Steps per iteration of the scan's loop, warp engine: `{info['spec']}`",
        "",
        f"{info['device']}, {info['date']}.",
        "",
        "| unroll | variants x steps | trace + lower s | compile s (cold) | run s | variant-steps/s | largest torque "
        "difference to unroll 1 |",
        "| ---: | --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in d["rows"]:
        out.append(
            f"| {r['unroll']} | {r['variants']:,} x {r['steps']:,} | {r['trace_lower_s']:.2f} | {r['compile_s']:.2f} "
            f"| {r['run_s']:.2f} | {r['variant_steps_per_s']:.3g} | {r['largest_torque_difference_vs_first']:.1e} |"
        )
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def summary_section(d: dict, name: str, title: str) -> list[str]:
    """A file whose 'summary' maps a way of running to its best and median wall (and 'ratios')."""
    out = [f"### {title}", "", "| run | best wall s | median wall s |", "| --- | ---: | ---: |"]
    out += [f"| {k} | {v['wall_best_s']:.1f} | {v['wall_median_s']:.1f} |" for k, v in d["summary"].items()]
    ratios = "; ".join(f"{k} {v:.3f}" for k, v in d.get("ratios", {}).items())
    return [*out, "", (f"Ratios: {ratios}. " if ratios else "") + f"(raw data: [{name}]({RAW}/{name}))", ""]


def soil_section(d: dict, name: str) -> list[str]:
    """benchmarks/soil.py: each wheel-ground model's best rate on one table, and float32 against C."""
    out = [
        f"### Wheel-ground models on the {d['backend']} engine, {d['size']:,} variants x {d['steps']:,} steps",
        "",
        "| model | best variant-steps/s | against rigid |",
        "| --- | ---: | ---: |",
    ]
    best = d["best_rate"]
    out += [f"| {m} | {r:.3g} | {r / best['rigid']:.2f} |" for m, r in best.items()]
    acc = "; ".join(
        f"{k}: {v['variants']} variants, median {v['median']:.2g}, p99 {v['p99']:.2g}"
        for k, v in d["accuracy"].items()
        if "p99" in v
    )
    return [
        *out,
        "",
        f"Soil, float32 against C float64, per-wheel drive means: {acc}. (raw data: [{name}]({RAW}/{name}))",
        "",
    ]


def wheel_ground_section(d: dict, name: str) -> list[str]:
    """benchmarks/cpu_wheel_ground.py: MuJoCo C's step against the wheel-ground step, numpy and XLA."""
    out = [
        f"### The wheel-ground models' step on MuJoCo C: {d['machine']}",
        "",
        f"Command: `{d['command']}`, {d['date']}",
        "",
        "| model | variants | Batch.step ms | numpy ms | XLA float64 ms | numpy / XLA | largest wrench difference, N |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    out += [
        f"| {r['model']} | {r['variants']:,} | {r['batch_step_ms']:.2f} | {r['numpy_ms']:.2f} | {r['xla_ms']:.2f} "
        f"| {r['numpy_over_xla']:.2f} | {r['max_abs_wrench_difference']:.1e} of {r['max_abs_wrench']:.0f} |"
        for r in d["rows"]
    ]
    return [*out, "", f"(raw data: [{name}]({RAW}/{name}))", ""]


def render_files(files: list[Path]) -> list[str]:
    """The tables of `files`, each file by its kind (from its name)."""
    out: list[str] = []
    kind = {f: next((k for k in KINDS if k in f.name), "bench") for f in files}
    for f in files:
        k = kind[f]
        if k in ("stages", "scaling", "contact-cost"):
            continue  # grouped below
        d = json.loads(f.read_text())
        if k in ("structural", "motors"):
            out += structural_section({"part": k, **d}, f.name)
        elif k == "end-to-end-ab":
            out += ab_section(d, f.name)
        elif k == "end-to-end":
            out += [end_to_end_section(d, f.name), ""]
        elif k == "iterations":
            out += iterations_section(d, f.name)
        elif k == "unroll":
            out += unroll_section(d, f.name)
        elif k == "step-profile":
            out += step_profile_section(d, f.name)
        elif k == "warm-compile":
            out += warm_compile_section(d, f.name)
        elif k == "probe":
            out += probe_section(d, f.name)
        elif k == "process-profile":
            out += process_profile_section(d, f.name)
        elif k == "gpu-start":
            out += summary_section(d, f.name, f"Starting a sweep process on a GPU, alternated: `{d['spec']}`")
        elif k == "tyres-cpu":
            title = f"The main job on MuJoCo C, slip against rigid, alternated: `{d['spec']}`"
            out += summary_section(d, f.name, title)
        elif k == "profile":
            out += ["### Kernel profile: MJX's solver against the fused one", "", profile_section(d, f.name), ""]
        elif k == "overhead":
            out += ["### batchveh mujoco against raw mujoco.batch, alternated", "", overhead_section(d, f.name), ""]
        elif k == "mainjob":
            out += mainjob_section(d, f.name)
        elif k == "largest":
            out += largest_section(d, f.name)
        elif k == "ray-gpus":
            out += [ray_section(d, f.name), ""]
        elif k == "soil":
            out += soil_section(d, f.name)
        elif k == "wheel-ground":
            out += wheel_ground_section(d, f.name)
        elif k == "ray-scaling" or "info" not in d:  # a kind this page has no table for: named, with its link
            out += [f"### `{f.name}`", "", f"Not tabulated here; raw: [{f.name}]({RAW}/{f.name}).", ""]
        else:
            out += bench_section(d, f.name)
            continue  # bench_section adds the file's note itself
        if f.name in FILE_NOTES:
            out += [FILE_NOTES[f.name], ""]
    stages = [f for f in files if kind[f] == "stages"]
    out += stages_section(stages) if stages else []
    scaling = [f for f in files if kind[f] == "scaling"]
    if scaling:
        out += [
            "### Several GPUs of one host",
            "",
            "`python benchmarks/scaling.py --n N --solver S`, one GPU with CUDA_VISIBLE_DEVICES=0, then both; "
            "float32 (raw data: " + ", ".join(f"[{f.name}]({RAW}/{f.name})" for f in scaling) + ").",
            "",
            scaling_table(scaling),
            "",
        ]
    others = [f for f in files if kind[f] == "contact-cost"]
    if others:
        out += ["Not tabulated here: " + ", ".join(f"[{f.name}]({RAW}/{f.name})" for f in others) + ".", ""]
    return out


KINDS = (
    "structural",
    "motors",
    "ray-scaling",
    "probe",
    "step-profile",
    "warm-compile",
    "end-to-end-ab",
    "iterations",
    "unroll",
    "wheel-ground",
    "soil",
    "process-profile",
    "gpu-start",
    "tyres-cpu",
    "end-to-end",
    "stages",
    "scaling",
    "profile",
    "overhead",
    "mainjob",
    "largest",
    "ray-gpus",
    "contact-cost",
)
ERRORS = (
    "Errors in the tables: median / p99 over non-slipping variants of |x - ref| / max(|ref|, 1 N m), against "
    "MuJoCo C in float64 with tolerance 1e-12 (and 200 iterations) on the file's reference variants. 'sum' is the "
    "four-wheel drive sum (fixed by physics); 'wheel' pools the four drive motors (their split is ill-conditioned); "
    "'peak_lp' is the peak after the 50 ms low-pass filter."
)


def demote(markdown: str) -> str:
    """Headings one level down, for a page included under a heading of its own."""
    return "\n".join("#" + line if line.startswith("#") else line for line in markdown.splitlines())


def main():
    files = sorted((HERE / "results").glob("*.json"))
    current = [f for f in files if f.name in CURRENT]
    current.sort(key=lambda f: (f.name not in CURRENT, list(CURRENT).index(f.name) if f.name in CURRENT else f.name))
    archived = [f for f in files if f not in current]
    out = [
        (HERE / "NOTES.md").read_text().rstrip(),
        "",
        "## Today's tables",
        "",
        ERRORS,
        "",
        *render_files(current),
        "## Archive",
        "",
        demote((HERE / "ARCHIVE.md").read_text().rstrip()),
        "",
        "### The archive's tables",
        "",
        demote("\n".join(render_files(archived))),
    ]
    OUT.write_text("\n".join(out).rstrip() + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
