"""Writing figures: one place that turns an unwritable picture into a one-line error."""

from __future__ import annotations

from pathlib import Path

from taptune.errors import InputError


def save_png(fig, path, dpi: float | None = None) -> None:
    """Write the matplotlib figure ``fig`` as a PNG (its folder created); InputError naming the file."""
    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(str(path), format="png", dpi=dpi or fig.dpi)
    except OSError as err:
        raise InputError(f"{path}: cannot write the picture ({err.strerror})") from None
