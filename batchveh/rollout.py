"""Rollouts: pure functions that step one vehicle model through a scenario.

- `mjx_stats(model, params, ...)`: MJX, `lax.scan` over steps, statistics reduced
  in the carry; the sweep driver `jit(vmap(...))`s it over a batched model.
- `mjx_series(...)`: MJX, the per-step samples (single runs and tests).
- `mujoco_series(...)`: MuJoCo C, one MjData, the same samples (the reference).

A step: ctrl = controls(p, t); mj_step; sample. The sample after step i is at
t = (i + 1) dt; its torques are the ones applied during that step.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from batchveh import stats
from batchveh.scenarios import Scenario, control_schedule, controls_fn
from batchveh.variants import VariantBatch
from batchveh.vehicle import Layout, layout


def put_batch(batch: VariantBatch) -> tuple[mjx.Model, mjx.Model]:
    """The MJX model with batched fields, and its `in_axes` tree (0 where a field varies)."""
    m = mjx.put_model(batch.model)
    axes = jax.tree_util.tree_map(lambda _: None, m)
    opt, opt_axes = {}, {}
    top, top_axes = {}, {}
    for name, values in batch.fields.items():
        if name.startswith("opt."):
            opt[name[4:]], opt_axes[name[4:]] = jnp.asarray(values), 0
            continue
        if isinstance(getattr(m, name, None), np.ndarray):
            raise ValueError(f"model field {name} is static in MJX and cannot vary inside one program")
        if not hasattr(m, name):
            continue  # a field MJX does not use (e.g. dof_length)
        top[name], top_axes[name] = jnp.asarray(values), 0
    m = m.replace(opt=m.opt.replace(**opt), **top)
    axes = axes.replace(opt=axes.opt.replace(**opt_axes), **top_axes)
    return m, axes


def _scan(model: mjx.Model, params: Mapping[str, Any], scenario: Scenario, n_steps: int, lay: Layout, body_out):
    ctrl_fn = controls_fn(scenario)
    dt = model.opt.timestep

    def body(carry, i):
        d, acc = carry
        ctrl = ctrl_fn(params, i * dt).astype(d.ctrl.dtype)
        d = mjx.step(model, d.replace(ctrl=ctrl))
        s = stats.sample(d.qpos, d.qvel, d.qfrc_actuator, ctrl, lay)
        return body_out(d, acc, s, i)

    return body


def mjx_stats(
    model: mjx.Model, params: Mapping[str, Any], *, scenario: Scenario, cfg: stats.StatsConfig, lay: Layout
) -> dict[str, jax.Array]:
    """Statistics columns of one variant (pure; vmap it over a batched model)."""
    dtype = model.opt.timestep.dtype

    def out(d, acc, s, i):
        block = {k: v[None] for k, v in s.items()}  # a block of one step: time axis -2
        return (d, stats.update(acc, block, i[None], cfg, xp=jnp)), None

    body = _scan(model, params, scenario, cfg.n_steps, lay, out)
    init = (mjx.make_data(model), stats.init(cfg, (), xp=jnp, dtype=dtype))
    (_, acc), _ = jax.lax.scan(body, init, jnp.arange(cfg.n_steps))
    return stats.finalize(acc, cfg, xp=jnp)


def mjx_series(
    model: mjx.Model, params: Mapping[str, Any], *, scenario: Scenario, n_steps: int, lay: Layout
) -> dict[str, jax.Array]:
    """Per-step samples of one variant, each (n_steps, ...)."""

    def out(d, acc, s, i):
        return (d, acc), s

    body = _scan(model, params, scenario, n_steps, lay, out)
    _, series = jax.lax.scan(body, (mjx.make_data(model), ()), jnp.arange(n_steps))
    return series


def mujoco_series(
    m: mujoco.MjModel, params: Mapping[str, Any], *, scenario: Scenario, n_steps: int
) -> dict[str, np.ndarray]:
    """Per-step samples from MuJoCo C (float64), the reference for MJX."""
    lay = layout(m)
    d = mujoco.MjData(m)
    p = {k: jnp.asarray(v) for k, v in params.items()}
    times = jnp.asarray(np.arange(n_steps) * m.opt.timestep)
    ctrls = np.asarray(jax.jit(control_schedule(scenario))(p, times), dtype=np.float64)
    rows = []
    for i in range(n_steps):
        d.ctrl[:] = ctrls[i]
        mujoco.mj_step(m, d)
        rows.append(stats.sample(d.qpos.copy(), d.qvel.copy(), d.qfrc_actuator.copy(), ctrls[i], lay))
    return {k: np.stack([r[k] for r in rows]) for k in rows[0]}


def series_stats(series: Mapping[str, np.ndarray], cfg: stats.StatsConfig) -> dict[str, Any]:
    """Statistics of a recorded series, by the same reduction the sweeps use."""
    acc = stats.init(cfg, ())
    block = {k: np.asarray(v[: cfg.n_steps], np.float64) for k, v in series.items()}
    acc = stats.update(acc, block, np.arange(cfg.n_steps), cfg)
    return stats.finalize(acc, cfg)
