"""What every matplotlib figure of firenav shares: the headless backend, saving a figure
and the 2-sigma position ellipse. matplotlib is imported when a function is called, never
with this module (it takes longer to import than a short run takes)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["pyplot", "save_figure", "add_position_ellipse"]


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the headless Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig: Any, path: Path, *, dpi: int = 110, tight: bool = True) -> Path:
    """Write ``fig`` to ``path`` at ``dpi`` (``tight``: cropped to what is drawn) and close
    it; the path."""
    if tight:
        fig.savefig(path, dpi=dpi, bbox_inches="tight")
    else:
        fig.savefig(path, dpi=dpi)
    pyplot().close(fig)
    return path


def add_position_ellipse(ax: Any, xy: np.ndarray, cov: np.ndarray, color: str, *,
                         lw: float) -> bool:
    """Draw the 2-sigma ellipse of the horizontal position covariance ``cov[:2, :2]``
    [m^2] about ``xy`` (ENU [m]) on ``ax``; False (nothing drawn) when either is not
    finite."""
    from matplotlib.patches import Ellipse
    c = cov[:2, :2]
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(xy))):
        return False
    w, v = np.linalg.eigh(c)
    axes_len = 2 * 2.0 * np.sqrt(np.maximum(w, 0.0))  # full axes of the 2-sigma ellipse
    ang = np.degrees(np.arctan2(v[1, 1], v[0, 1]))
    ax.add_patch(Ellipse(xy, axes_len[1], axes_len[0], angle=ang, fill=False, color=color,
                         lw=lw, alpha=0.7))
    return True
