"""What the engines share: device checks, the 'auto' rules, chunk sizes and padding."""

from __future__ import annotations

import sys

import jax
import numpy as np

from batchveh.stepping.batch import VariantBatch

# warp engine on one H200, elliptic contact: 4.88e6 / 4.98e6 / 4.98e6 variant-steps/s at 65k / 131k / 262k
# variants (benchmarks/results/archive.json: h200-warp-elliptic10.json): 131k is as fast as any larger chunk
GPU_CHUNK_MAX = 131072
GPU_BYTES_PER_VARIANT = 35e3  # measured peak device memory per variant (warp: 4.54 GB at 131072, pyramidal)
# mujoco: per-chunk costs (Batch setup and reset, the last block's fold, finalize, a Parquet part) are
# paid once per chunk: 4096 ran 0.81x raw mujoco.batch on 16 cores where 1024 ran 0.73x (median of 4
# alternated pairs, benchmarks/results/archive.json: h200-cpu16-overhead.json); on 2 cores 2048 and 1024 tied (0.91x)
CPU_CHUNK = {"mujoco": 4096, "mjx": 256, "warp": 256}


def has_gpu() -> bool:
    """Whether JAX sees an accelerator."""
    try:
        return any(d.platform != "cpu" for d in jax.devices())
    except RuntimeError:
        return False


def warp_installed() -> bool:
    """Whether the warp engine can run: MuJoCo Warp (mujoco-warp) and warp-lang importable."""
    try:
        import mujoco_warp  # noqa: F401
        import warp  # noqa: F401
    except (ImportError, RuntimeError):
        return False
    return True


def resolve_backend(name: str) -> str:
    """'auto' is warp when JAX sees a CUDA GPU and warp-lang is installed, mjx on another JAX
    accelerator (or without warp-lang), otherwise mujoco (MuJoCo C on the CPU threads)."""
    if name == "auto":
        if not has_gpu():
            return "mujoco"
        gpu = any(d.platform == "gpu" for d in jax.devices())
        return "warp" if gpu and warp_installed() else "mjx"
    return name


def auto_chunk(name: str, n_variants: int | None) -> int:
    """Variants per chunk: as many as fit (GPU) in equal chunks, with little padding."""
    if name == "mujoco" or not has_gpu():
        # a small sweep is one chunk of its own size: nothing is padded
        return min(CPU_CHUNK[name], n_variants) if n_variants else CPU_CHUNK[name]
    limit = GPU_CHUNK_MAX
    mem = jax.devices()[0].memory_stats() or {}
    if "bytes_limit" in mem:
        limit = min(limit, int(0.5 * mem["bytes_limit"] / GPU_BYTES_PER_VARIANT))
    if name == "mjx":  # MJX shards a chunk over every local device; the warp engine runs on one
        limit *= len(jax.devices())
    if not n_variants:
        return limit
    n_chunks = -(-n_variants // limit)
    per = -(-n_variants // n_chunks)
    return -(-per // 256) * 256


def pad(batch: VariantBatch, size: int) -> VariantBatch:
    """Repeat the last variant so the chunk has `size` variants (same compiled shape)."""
    extra = size - batch.n
    if extra <= 0:
        return batch

    def rep(a):
        return np.concatenate([a, np.repeat(a[-1:], extra, axis=0)], axis=0)

    return VariantBatch(
        batch.model, {k: rep(v) for k, v in batch.fields.items()}, {k: rep(v) for k, v in batch.params.items()}, size
    )


def spawn_safe() -> bool:
    """Whether worker processes may be started: a spawned process imports the parent's main script again, which
    is safe for batchveh's own command lines (python -m batchveh.sweep) and where there is no script (a
    notebook, a REPL), but would run an unguarded user script a second time."""
    main = sys.modules.get("__main__")
    spec = getattr(main, "__spec__", None)
    return getattr(main, "__file__", None) is None or (spec is not None and spec.name.startswith("batchveh."))
