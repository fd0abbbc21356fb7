"""The GPU peer: MuJoCo Warp driven directly, with no batchveh code in the stepping loop.

This is what a GPU user would write without batchveh: one MjModel (batchveh's MJCF of the
seed vehicle, the same as every row of the benchmark), `put_model` and `make_data` with one
world per variant, the varying fields given per world (gravity for the slope, the ground's
friction), a small kernel that sets each world's drive controls from its time (speed
servo: omega; position servo: omega t) and `step`, captured as one CUDA graph per
`graph_steps` steps. No statistics are kept. MuJoCo Warp is the copy vendored in
mujoco-mjx (the same code as the mujoco-warp package of that release).
"""

from __future__ import annotations

import time

import numpy as np


def bench_mjwarp_direct(model, gravity, friction, omega, n_steps: int, graph_steps: int = 50, contacts: int = 24):
    """variant-steps/s of MuJoCo Warp stepping len(omega) worlds for n_steps.

    model: the MjModel; gravity (n, 3), friction (n,) of the ground geom, omega (n,) rad/s."""
    import warp as wp
    from mujoco.mjx.third_party import mujoco_warp as mjw

    from batchveh.engines.warp import constraint_rows
    from batchveh.model.vehicle import layout

    n = len(omega)
    lay = layout(model)
    cuda = wp.get_cuda_device_count() > 0
    device = "cuda:0" if cuda else "cpu"
    with wp.ScopedDevice(device):
        mw = mjw.put_model(model)
        mw.opt.warn_overflow = 0
        mw.opt.gravity = wp.array(np.asarray(gravity, np.float32), dtype=wp.vec3)
        fr = np.broadcast_to(model.geom_friction, (n, *model.geom_friction.shape)).astype(np.float32)
        fr[:, lay.ground_geom, 0] = friction
        mw.geom_friction = wp.array(fr, dtype=wp.vec3)
        d = mjw.make_data(model, nworld=n, naconmax=n * contacts, njmax=constraint_rows(model, contacts))
        w = wp.array(np.asarray(omega, np.float32))
        vel_ids = wp.array(np.asarray(lay.drive_vel_act, np.int32))
        pos_ids = wp.array(np.asarray(lay.drive_pos_act, np.int32))

        @wp.kernel
        def set_ctrl(
            t: wp.array(dtype=float),
            om: wp.array(dtype=float),
            vel: wp.array(dtype=int),
            pos: wp.array(dtype=int),
            ctrl: wp.array2d(dtype=float),
        ):
            world, k = wp.tid()
            ctrl[world, vel[k]] = om[world]
            ctrl[world, pos[k]] = om[world] * t[world]

        def steps(count):
            for _ in range(count):
                wp.launch(set_ctrl, dim=(n, 4), inputs=[d.time, w, vel_ids, pos_ids, d.ctrl])
                mjw.step(mw, d)

        steps(1)  # compile and load the kernels
        wp.synchronize()
        if cuda:
            with wp.ScopedCapture() as capture:
                steps(graph_steps)
            graph = capture.graph
            run = lambda: wp.capture_launch(graph)  # noqa: E731
        else:
            run = lambda: steps(graph_steps)  # noqa: E731
        run()
        wp.synchronize()
        calls = max(1, n_steps // graph_steps)
        t0 = time.perf_counter()
        for _ in range(calls):
            run()
        wp.synchronize()
        wall = time.perf_counter() - t0
        qvel = d.qvel.numpy()
    finite = float(np.isfinite(qvel).all(axis=1).mean())
    return n * calls * graph_steps / wall, {"graph_steps": graph_steps, "device": device, "finite_share": finite}
