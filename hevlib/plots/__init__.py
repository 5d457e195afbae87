"""Figures for the reports: one module per domain (cycles, maps, traces, surrogates, fronts, pareto).

Every figure is written with :func:`save_figure` (Agg backend, fixed DPI, atomic rename) so a failed
stage leaves no half-written PNG behind.
"""

from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from hevlib.io import save_with  # noqa: E402

DPI = 120


def save_figure(fig: plt.Figure, path: str | os.PathLike) -> None:
    """Save ``fig`` as PNG to ``path`` atomically and close it; the canvas grows to hold whatever is drawn
    outside the axes (legends, long labels: ``bbox_inches="tight"``), so nothing is cropped."""
    fig.tight_layout()
    save_with(
        path,
        lambda tmp: fig.savefig(
            tmp, dpi=DPI, format="png", metadata={"Software": None}, bbox_inches="tight", pad_inches=0.1
        ),
    )
    plt.close(fig)


__all__ = ["plt", "save_figure", "DPI"]
