"""Numbers as text for people: the same rules in the CLI, the PDF report and the app."""

from __future__ import annotations


def number(value: float, spec: str) -> str:
    """``format(value, spec)`` with the sign dropped where the printed number is zero:
    a difference that rounds to nothing prints ``0.00``, never ``-0.00`` or ``+0.00``
    (which read as a real, if tiny, error with a direction).

    ``spec`` is a format spec (``"+.2f"``) or a template with one field (``"{:.3g}"``).

    >>> number(-0.0004, "+.2f"), number(0.0, "+.2f"), number(-0.013, "+.2f")
    ('0.00', '0.00', '-0.01')
    """
    text = spec.format(value) if spec.startswith("{") else format(value, spec)
    mantissa = text.lstrip("+-").split("e")[0].split("E")[0]
    if text[:1] in "+-" and not any(c in "123456789" for c in mantissa):
        return text[1:]
    return text


def signed(value: float, decimals: int) -> str:
    """``value`` with its sign and ``decimals`` places; one that rounds to zero is "0.000",
    never "-0.000" or "+0.000" (a misfit of nothing has no direction)."""
    return number(value, f"+.{decimals}f")
