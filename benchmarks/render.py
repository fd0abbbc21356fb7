"""Write benchmarks/RESULTS.md from benchmarks/results/*.json and benchmarks/NOTES.md.

python benchmarks/render.py
"""

import json
import statistics
from pathlib import Path

HERE = Path(__file__).resolve().parent
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
        f"state (best of 10); kernels from a JAX profiler trace of 3 steps (raw data: `benchmarks/results/{name}`).",
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
            f"raw data: `benchmarks/results/{name}`)."
        )
        cols = [k[6:].replace("chunk", "chunk ").replace("_threads", ", threads ") for k in keys]
    else:  # the older format: engine.run against one Batch.step per step
        head = (
            f"`python benchmarks/cpu_overhead.py` (an earlier version): {d['variants']} variants x {d['steps']} "
            f"steps, {d['cpu_threads']} CPU threads; measured against the older peer (one Batch.step per step, "
            f"{d['variants']} variants, {d['mujoco_threads']} threads), batchveh's engine.run without make_batch "
            f"or Parquet; columns: batchveh's MuJoCo threads (raw data: `benchmarks/results/{name}`)."
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
        f"## In-process against Ray: {d['machine']}, backend {d['backend']}",
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
        f"steps at the Ray rate per worker: {hours} workers. (raw data: `benchmarks/results/{name}`)",
    ]
    return "\n".join(out)


def main():
    out = [
        (HERE / "NOTES.md").read_text().rstrip(),
        "",
        "## Speed and accuracy tables",
        "",
        "Errors: median / p99 over non-slipping variants of |x - ref| / max(|ref|, 1 N m), against MuJoCo C "
        "in float64 with tolerance 1e-12 and 200 iterations on 256 variants. 'sum' is the four-wheel drive "
        "sum (fixed by physics); 'wheel' pools the four drive motors (their split is ill-conditioned); "
        "'peak_lp' is the peak after the 50 ms low-pass filter.",
        "",
    ]
    for f in sorted((HERE / "results").glob("*.json")):
        if any(
            k in f.name
            for k in ("scaling", "stages", "profile", "overhead", "mainjob", "contact-cost", "largest", "ray-gpus")
        ):
            continue
        d = json.loads(f.read_text())
        out += [bench_table(d), ""]
        if d["info"].get("peer"):
            out += [peer_note(d["info"]["peer"]), ""]
            out += [f"Code: {d['info']['code']}.", ""] if "code" in d["info"] else []
        elif "peer" not in d["info"]:  # files from before the peer at its best
            cmd = d["info"]["command"].split()
            n = cmd[cmd.index("--cpu-variants") + 1] if "--cpu-variants" in cmd else "512"
            out += [
                f"Ratios measured against the older peer (one Batch.step per step, {n} variants, nothing "
                "recorded): bench.py before the peer was measured at its best.",
                "",
            ]
        out += [f"(raw data: `benchmarks/results/{f.name}`)", ""]
    stages = sorted((HERE / "results").glob("*stages*.json"))
    if stages:
        out += [
            "## Where a step's time goes",
            "",
            "`python benchmarks/stages.py --n 65536 --solver S`: "
            "cumulative prefixes of mjx.step, jit(vmap) over 65,536 slope variants from a settled state, "
            "best of 10; 'delta' is the stage's own cost.",
            "",
        ]
        for f in stages:
            d = json.loads(f.read_text())
            total = d["rows"][-1]["ms"]
            out += [
                f"**{d['solver']}**, {d.get('wheel_collision', 'cylinder')} wheels, on {d['device']}: "
                f"one step {total:.2f} ms "
                f"({d['n'] / total * 1e3:.3g} variant-steps/s)",
                "",
                "| stage | cumulative ms | delta ms | share |",
                "| --- | ---: | ---: | ---: |",
            ]
            out += [
                f"| {r['stage']} | {r['ms']:.2f} | {r['delta_ms']:.2f} | {100 * r['delta_ms'] / total:.0f}% |"
                for r in d["rows"]
            ]
            out.append("")
    for f in sorted((HERE / "results").glob("*profile*.json")):
        out += [
            "## Kernel profile: MJX's solver against the fused one",
            "",
            profile_section(json.loads(f.read_text()), f.name),
            "",
        ]
    overhead = sorted((HERE / "results").glob("*overhead*.json"))
    if overhead:
        out += ["## batchveh mujoco against raw mujoco.batch, alternated", ""]
    for f in overhead:
        out += [overhead_section(json.loads(f.read_text()), f.name), ""]
    for f in sorted((HERE / "results").glob("*mainjob*.json")):
        d = json.loads(f.read_text())
        out += [
            "## The main job, end to end",
            "",
            f"`python benchmarks/mainjob.py`: `{d['command']}` (10,602 variants x 1000 steps, MuJoCo C) as a fresh "
            f"process, on {d['machine']}, {d['date']}. {d['note']} (raw data: `benchmarks/results/{f.name}`)",
            "",
            "| run | wall s | load average before / after | the sweep's summary |",
            "| ---: | ---: | --- | --- |",
        ]
        for i, r in enumerate(d["runs"]):
            load = " / ".join(f"{x:.1f}" for x in r["load_average_before_after"])
            out.append(f"| {i + 1} | {r['wall_s']:.1f} | {load} | {' '.join(r['summary'])[:200]} |")
        out.append("")
    for f in sorted((HERE / "results").glob("*largest*.json")):
        d = json.loads(f.read_text())
        out += [f"## The largest warp batch: {d['info']['device']}", "", f"Command: `{d['info']['command']}`", ""]
        out += ["| variants | variant-steps/s | peak GB | result |", "| ---: | ---: | ---: | --- |"]
        for r in d["rows"]:
            if "error" in r:
                out.append(f"| {r['variants']:,} | - | - | {r['error'][:80]} |")
            else:
                out.append(f"| {r['variants']:,} | {r['rate']:.3g} | {r['peak_mem_gb']:.1f} | ok |")
        out += ["", f"(raw data: `benchmarks/results/{f.name}`)", ""]
    for f in sorted((HERE / "results").glob("*ray-gpus*.json")):
        out += [ray_section(json.loads(f.read_text()), f.name), ""]
    scaling = sorted((HERE / "results").glob("*scaling*.json"))
    if scaling:
        out += [
            "## Several GPUs of one host",
            "",
            "`python benchmarks/scaling.py --n N --solver S`, one GPU with CUDA_VISIBLE_DEVICES=0, then both; float32.",
            "",
            scaling_table(scaling),
            "",
        ]
    (HERE / "RESULTS.md").write_text("\n".join(out) + "\n")
    print(f"wrote {HERE / 'RESULTS.md'}")


if __name__ == "__main__":
    main()
