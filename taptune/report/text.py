"""Numbers as text for people: the same rules in the CLI, the PDF report and the app."""

from __future__ import annotations


def signed(value: float, decimals: int) -> str:
    """``value`` with its sign and ``decimals`` places; one that rounds to zero is "0.000",
    never "-0.000" or "+0.000" (a misfit of nothing has no direction)."""
    text = f"{value:+.{decimals}f}"
    return text[1:] if float(text) == 0 else text
