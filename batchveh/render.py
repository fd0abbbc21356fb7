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

from batchveh.config import ConfigError  # noqa: E402
from batchveh.scenarios import Scenario, control_schedule, load_scenario  # noqa: E402
from batchveh.variants import make_batch  # noqa: E402
from batchveh.vehicle import Vehicle, load_vehicle  # noqa: E402


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
    import jax.numpy as jnp

    batch = make_batch(vehicle, scenario, {})
    m = batch.model
    d = mujoco.MjData(m)
    params = {k: jnp.asarray(v[0]) for k, v in batch.params.items()}
    dt = m.opt.timestep
    ctrls = np.asarray(control_schedule(scenario)(params, jnp.asarray(np.arange(scenario.n_steps) * dt)), np.float64)
    every = max(1, int(round(1.0 / (fps * dt))))
    out = []
    renderer = mujoco.Renderer(m, height, width)
    try:
        cam = _camera(m)
        mujoco.mj_forward(m, d)
        for i in range(scenario.n_steps):
            if i % every == 0:
                renderer.update_scene(d, camera=cam)
                out.append(renderer.render().copy())
                if max_frames and len(out) >= max_frames:
                    break
            d.ctrl[:] = ctrls[i]
            mujoco.mj_step(m, d)
    finally:
        renderer.close()
    return out


def still(vehicle: Vehicle, *, width: int = 640, height: int = 480) -> np.ndarray:
    """One frame of the model at rest, without simulating (the seed's mode 0)."""
    m = make_batch(vehicle, Scenario(), {}).model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    renderer = mujoco.Renderer(m, height, width)
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
    parser = argparse.ArgumentParser(
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
    args = parser.parse_args(argv)
    try:
        src = Path(args.source)
        if src.is_dir():
            import batchveh
            from batchveh.spec import spec_of_result, variant_setup

            if args.variant is None:
                raise ConfigError(f"{src}: a sweep result; give --variant N")
            df = batchveh.load(src)
            rows = df[df.variant == args.variant]
            if rows.empty:
                raise ConfigError(f"--variant: {args.variant} is not in {src}; allowed: 0 to {df.variant.max()}")
            vehicle, scenario = variant_setup(spec_of_result(src), rows.iloc[0])
        else:
            vehicle, scenario = load_vehicle(args.vehicle), load_scenario(args.source)
            if args.slope_deg is not None:
                scenario = dataclasses.replace(scenario, slope_deg=args.slope_deg)
        if args.total_time is not None:
            scenario = dataclasses.replace(scenario, total_time=args.total_time)
        w, h = args.size
        images = (
            [still(vehicle, width=w, height=h)]
            if args.still
            else frames(vehicle, scenario, fps=args.fps, width=w, height=h)
        )
        path = save(images, args.out, args.fps)
    except ConfigError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except mujoco.FatalError as err:
        print(
            f"error: no OpenGL for offscreen rendering ({err}); install EGL (libegl1 libegl-mesa0 "
            "libgl1-mesa-dri) or OSMesa (libosmesa6, MUJOCO_GL=osmesa)",
            file=sys.stderr,
        )
        return 2
    print(f"wrote {path} ({len(images)} frame{'s' if len(images) > 1 else ''}, {args.size[0]}x{args.size[1]})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
