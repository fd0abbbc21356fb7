"""Where a sweep process spends its time outside the sweep: imports, start, the sweep, exit.

    python benchmarks/process_profile.py benchmarks/slope_100k.yaml --out profile.json

Runs `python -m batchveh.sweep SPEC --quiet --overwrite --out TMP` in a child process several
ways: plain, twice (the wall a user sees, and the child's own clock around the module's run, so
that interpreter start and exit are the rest); under `-X importtime` (the slowest imports); under
cProfile (the top functions by cumulative time); and, with --pyspy PATH-TO-PY-SPY, sampled by
py-spy at 100 Hz (every thread, idle time included; no native frames, whose unwinding slowed the
run 3x). py-spy's main-thread samples are summed by the innermost batchveh frame and what it
called. cProfile misplaces time spent while XLA calls back into Python (Warp's kernels run from an
FFI callback); py-spy does not. Writes one JSON with all of it.
"""

import argparse
import collections
import json
import os
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# the child: `python -m batchveh.sweep` (its entry point included), with its clock from the first
# statement to the end of the module's run printed as the last line
CHILD = """
import time; t0 = time.perf_counter()
import runpy, sys
code = 0
try:
    runpy.run_module("batchveh.sweep", run_name="__main__", alter_sys=True)
except SystemExit as stop:
    code = stop.code
print(f"@@ {time.perf_counter() - t0:.3f}", flush=True)
sys.exit(code)
"""


def pyspy_summary(raw: Path, rate: int, top: int) -> dict:
    """The main thread's samples of a py-spy raw file, in seconds: by the innermost batchveh frame
    (and the function it called), by the innermost frame where no batchveh frame is on the stack."""
    by = collections.Counter()
    total = 0
    for line in raw.read_text().splitlines():
        stack, _, count = line.rpartition(" ")
        frames = stack.split(";")
        if "MainThread" not in frames[0]:
            continue
        n = int(count)
        total += n
        mine = [i for i, f in enumerate(frames) if "batchveh/" in f]
        if mine:
            i = mine[-1]
            callee = frames[i + 1].split(" (")[0] if i + 1 < len(frames) else ""
            key = f"{frames[i]} -> {callee}"
        elif not any(" (" in f and ".py:" in f for f in frames[1:]):
            key = "no Python frame (interpreter start or exit): " + ";".join(f.split(" (")[0] for f in frames[-3:])
        else:
            key = "outside batchveh: " + ";".join(f.split(" (")[0] for f in frames[-4:])
        by[key] += n
    return {
        "rate_hz": rate,
        "main_thread_s": total / rate,
        "top": [{"seconds": n / rate, "where": k} for k, n in by.most_common(top)],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("--limit", type=int)
    ap.add_argument("--out", required=True)
    ap.add_argument("--top", type=int, default=45)
    ap.add_argument("--pyspy", help="a py-spy executable: also sample one run with it")
    args = ap.parse_args()
    res = {"spec": args.spec, "limit": args.limit}
    with tempfile.TemporaryDirectory() as tmp:
        sweep = [args.spec, "--quiet", "--overwrite", "--out", str(Path(tmp) / "r")]
        sweep += ["--limit", str(args.limit)] if args.limit else []
        env = dict(os.environ)
        plain = []
        for _ in range(2):
            t = time.perf_counter()
            done = subprocess.run(
                [sys.executable, "-c", CHILD, *sweep], cwd=ROOT, env=env, capture_output=True, text=True
            )
            wall = time.perf_counter() - t
            last = [ln for ln in done.stdout.splitlines() if ln.startswith("@@")]
            inside = float(last[0].split()[1]) if last else None
            plain.append(
                {
                    "wall_s": wall,
                    "imports_and_main_s": inside,
                    "interpreter_start_and_exit_s": wall - inside if last else None,
                    "stdout": done.stdout.splitlines()[-3:],
                    "stderr": done.stderr.splitlines()[-5:],
                }
            )
            print(json.dumps(plain[-1]), flush=True)
        res["plain"] = plain
        done = subprocess.run(
            [sys.executable, "-X", "importtime", "-c", CHILD, *sweep], cwd=ROOT, env=env, capture_output=True, text=True
        )
        rows = []
        for ln in done.stderr.splitlines():
            if ln.startswith("import time:") and "|" in ln:
                parts = [p.strip() for p in ln.removeprefix("import time:").split("|")]
                if parts[0].isdigit():
                    rows.append((int(parts[1]), int(parts[0]), parts[2]))
        rows.sort(reverse=True)
        res["importtime_cumulative_us_top"] = [{"cumulative_us": c, "self_us": s, "module": m} for c, s, m in rows[:40]]
        prof = Path(tmp) / "p.prof"
        t = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "cProfile", "-o", str(prof), "-m", "batchveh.sweep", *sweep],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
        )
        res["cprofile_wall_s"] = time.perf_counter() - t
        st = pstats.Stats(str(prof))
        top = sorted(st.stats.items(), key=lambda kv: kv[1][3], reverse=True)[: args.top]
        res["cprofile_cumulative_top"] = [
            {"function": f"{Path(f).name}:{line}({name})", "calls": nc, "tottime_s": tt, "cumtime_s": ct}
            for (f, line, name), (_, nc, tt, ct, _) in top
        ]
        if args.pyspy:
            raw, rate = Path(tmp) / "pyspy.txt", 100
            cmd = [args.pyspy, "record", "--idle", "--threads", "--format", "raw", "-r", str(rate)]
            t = time.perf_counter()
            done = subprocess.run(
                [*cmd, "-o", str(raw), "--", sys.executable, "-m", "batchveh.sweep", *sweep],
                cwd=ROOT,
                env=env,
                capture_output=True,
                text=True,
            )
            res["pyspy_wall_s"] = time.perf_counter() - t
            if raw.exists():
                res["pyspy"] = pyspy_summary(raw, rate, args.top)
                for r in res["pyspy"]["top"]:
                    print(f"{r['seconds']:7.2f} s  {r['where'][:220]}")
            else:
                res["pyspy_error"] = done.stderr.splitlines()[-5:]
                print("py-spy:", res["pyspy_error"])
    for r in res["importtime_cumulative_us_top"][:15]:
        print(f"import {r['cumulative_us'] / 1e6:7.2f} s  {r['module']}")
    for r in res["cprofile_cumulative_top"]:
        print(f"{r['cumtime_s']:8.2f} s cum {r['tottime_s']:8.2f} s self  {r['function']}")
    Path(args.out).write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
