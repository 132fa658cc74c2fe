"""Writing figures: the one place a matplotlib figure becomes a file (plotting functions never save)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["save_figure"]


def save_figure(fig, path: str | Path, *, dpi: int = 110) -> Path:
    """Write ``fig`` to ``path`` (format from the suffix), close it and print the path."""
    import matplotlib.pyplot as plt

    path = Path(path)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    print(f"  wrote {path}")
    return path
