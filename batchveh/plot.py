"""Figures: the seed's four torque figures, with a time axis and units.

Smoothing is the seed's: every 10th sample, then a Gaussian filter with sigma = 5
(decimated) samples (scipy.ndimage.gaussian_filter1d).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy.ndimage import gaussian_filter1d  # noqa: E402

from batchveh.vehicle import CORNERS  # noqa: E402

CORNER_TITLES = {"lf": "Left-Front", "rf": "Right-Front", "lr": "Left-Rear", "rr": "Right-Rear"}
SEED_DECIMATE, SEED_SIGMA = 10, 5.0


def smooth(time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The seed's smoothing: every 10th sample, Gaussian filter sigma 5 samples."""
    t, v = np.asarray(time_s)[::SEED_DECIMATE], np.asarray(values)[::SEED_DECIMATE]
    return t, gaussian_filter1d(v, SEED_SIGMA) if len(v) > 1 else v


def torque_figure(series: pd.DataFrame, kind: str, smoothed: bool, title: str) -> plt.Figure:
    """2x2 figure of the drive or steering torques per corner (N m over s)."""
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True, constrained_layout=True)
    for ax, corner in zip(axes.ravel(), CORNERS):
        t, y = series["time"].to_numpy(), series[f"{kind}_{corner}"].to_numpy()
        if smoothed:
            t, y = smooth(t, y)
        ax.plot(t, y, lw=1.0)
        ax.set_title(CORNER_TITLES[corner])
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"{'driving' if kind == 'drive' else 'steering'} torque [N m]")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{title}: {'driving' if kind == 'drive' else 'steering'} motor torques"
                 f"{' (smoothed)' if smoothed else ''}")
    return fig


def seed_figures(series: pd.DataFrame, out_dir: str | Path, title: str) -> list[Path]:
    """Write the seed's four figures (driving/steering, raw/smoothed) as PNG; return their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for kind in ("drive", "steer"):
        for smoothed in (False, True):
            fig = torque_figure(series, kind, smoothed, title)
            path = out_dir / f"{kind}_torques{'_smoothed' if smoothed else ''}.png"
            fig.savefig(path, dpi=100)
            plt.close(fig)
            paths.append(path)
    return paths
