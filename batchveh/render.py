"""Render one run to a GIF, or a still image of the model, headless.

    python -m batchveh.render straight_line --slope-deg 10 --out motion.gif
    python -m batchveh.render results/slope --variant 120 --out variant120.gif
    python -m batchveh.render straight_line --still --out model.png    # the seed's "mode 0"

Rendering uses MuJoCo's offscreen OpenGL renderer. On a machine without a screen it
needs EGL (Debian packages libegl1 and libegl-mesa0, with Mesa's software rasteriser
libgl1-mesa-dri when there is no GPU) or OSMesa (libosmesa6; set MUJOCO_GL=osmesa).
batchveh sets MUJOCO_GL=egl when it is unset and there is no DISPLAY. Exit codes: 0 ok, 2 bad input.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import mujoco  # noqa: E402  (batchveh/__init__ chose MUJOCO_GL before this import)
import numpy as np

from batchveh.cli import run_main  # noqa: E402
from batchveh.config import ConfigError, OneLineParser, check_dataclass  # noqa: E402
from batchveh.model.scenarios import Scenario, load_scenario  # noqa: E402
from batchveh.model.vehicle import Vehicle, load_vehicle  # noqa: E402
from batchveh.stepping.batch import make_batch  # noqa: E402

NO_GL = (
    "no OpenGL for offscreen rendering ({err}); install EGL (libegl1 libegl-mesa0 libgl1-mesa-dri) "
    "or OSMesa (libosmesa6, MUJOCO_GL=osmesa)"
)


def _renderer(m: mujoco.MjModel, height: int, width: int) -> mujoco.Renderer:
    """MuJoCo's offscreen renderer; any failure to get an OpenGL context is one ConfigError line."""
    try:
        return mujoco.Renderer(m, height, width)
    except ValueError as err:  # the size exceeds the model's offscreen buffer
        raise ConfigError(f"--size: {width} x {height} is not allowed ({err})") from None
    except Exception as err:  # mujoco.FatalError, or AttributeError/ImportError from a missing GL library
        import batchveh

        msg = batchveh.GL_PROBLEM or (str(err).splitlines()[0] if str(err) else type(err).__name__)
        raise ConfigError(NO_GL.format(err=msg)) from None


MAX_SIZE = 640  # pixels: the model's offscreen buffer (vehicle.mjcf's <visual><global offwidth/offheight>)


def _camera(m: mujoco.MjModel) -> mujoco.MjvCamera:
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    cam.trackbodyid = m.body("chassis").id
    cam.distance, cam.azimuth, cam.elevation = 3.2, 135.0, -20.0
    return cam


def frames(
    vehicle: Vehicle,
    scenario: Scenario,
    *,
    fps: int = 20,
    width: int = 320,
    height: int = 240,
    max_frames: int | None = None,
) -> list[np.ndarray]:
    """Simulate on MuJoCo C and return RGB frames (height, width, 3), uint8, at `fps` per simulated second."""
    from batchveh.stepping.rollout import mujoco_steps

    batch = make_batch(vehicle, scenario, {})
    m = batch.model
    params = {k: v[0] for k, v in batch.params.items()}
    every = max(1, int(round(1.0 / (fps * m.opt.timestep))))
    out = []
    renderer = _renderer(m, height, width)
    try:
        cam = _camera(m)
        steps = mujoco_steps(m, params, scenario=scenario, n_steps=scenario.n_steps)
        for i, (d, _) in enumerate(steps):  # d: the state after i steps; a frame every `every` steps
            if i == scenario.n_steps:
                break
            if i % every == 0:
                renderer.update_scene(d, camera=cam)
                out.append(renderer.render().copy())
                if max_frames and len(out) >= max_frames:
                    break
    finally:
        renderer.close()
    return out


def still(vehicle: Vehicle, *, width: int = 640, height: int = 480) -> np.ndarray:
    """One frame of the model at rest, without simulating (the seed's mode 0)."""
    m = make_batch(vehicle, Scenario(), {}).model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    renderer = _renderer(m, height, width)
    try:
        renderer.update_scene(d, camera=_camera(m))
        return renderer.render().copy()
    finally:
        renderer.close()


def save(images: list[np.ndarray], path: Path, fps: int = 20) -> Path:
    """Write frames as an animated GIF, or one frame as PNG (by the suffix)."""
    from PIL import Image

    path.parent.mkdir(parents=True, exist_ok=True)
    pics = [Image.fromarray(im) for im in images]
    if path.suffix.lower() == ".gif":
        pics[0].save(path, save_all=True, append_images=pics[1:], duration=int(1000 / fps), loop=0)
    elif path.suffix.lower() == ".png":
        pics[0].save(path)
    else:
        raise ConfigError(f"--out: {str(path)!r} is not allowed; allowed suffixes: .gif, .png")
    return path


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
        prog="python -m batchveh.render",
        description=__doc__.split("\n\n")[0],
        epilog="Headless machines need EGL or OSMesa; see the module docstring.",
    )
    parser.add_argument("source", help="a scenario name or YAML, or a sweep result directory")
    parser.add_argument("--variant", type=int, help="with a sweep result: the variant id to render")
    parser.add_argument("--vehicle", help="vehicle YAML (scenario sources only)")
    parser.add_argument("--slope-deg", type=float, help="slope in deg (scenario sources only)")
    parser.add_argument("--total-time", type=float, help="simulated time in s")
    parser.add_argument("--fps", type=int, default=20, help="frames per simulated second")
    parser.add_argument("--size", type=int, nargs=2, default=(320, 240), metavar=("W", "H"))
    parser.add_argument("--still", action="store_true", help="one image of the model at rest, no simulation")
    parser.add_argument("--out", type=Path, default=Path("motion.gif"), help=".gif (animation) or .png (still)")
    return run_main(parser, _render, argv, where=lambda args: args.out)


def _render(args: argparse.Namespace) -> int:
    """The command on its parsed arguments; `run_main` turns its input errors into one line."""
    if args.fps < 1:
        raise ConfigError(f"--fps: {args.fps} is not allowed; allowed: an integer >= 1")
    w, h = args.size
    if w < 1 or h < 1 or w > MAX_SIZE or h > MAX_SIZE:
        raise ConfigError(f"--size: {w} {h} is not allowed; allowed: width and height from 1 to {MAX_SIZE} pixels")
    if args.out.suffix.lower() not in (".gif", ".png"):
        raise ConfigError(f"--out: {str(args.out)!r} is not allowed; allowed suffixes: .gif, .png")
    src = Path(args.source)
    if src.is_dir():
        import batchveh
        from batchveh.sweeping.spec import spec_of_result

        if args.variant is None:
            raise ConfigError(f"{src}: a sweep result; give --variant N")
        df = batchveh.load(src)
        rows = df[df.variant == args.variant]
        if rows.empty:
            raise ConfigError(f"--variant: {args.variant} is not in {src}; allowed: 0 to {df.variant.max()}")
        vehicle, scenario = spec_of_result(src).variant(rows.iloc[0])
    else:
        vehicle, scenario = load_vehicle(args.vehicle), load_scenario(args.source)
    over = {k: getattr(args, k) for k in ("slope_deg", "total_time") if getattr(args, k) is not None}
    if over:
        scenario = dataclasses.replace(scenario, **over)
        check_dataclass(scenario, "command line")
        scenario.validate("command line")
    images = (
        [still(vehicle, width=w, height=h)]
        if args.still
        else frames(vehicle, scenario, fps=args.fps, width=w, height=h)
    )
    path = save(images, args.out, args.fps)
    print(f"wrote {path} ({len(images)} frame{'s' if len(images) > 1 else ''}, {w}x{h})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
