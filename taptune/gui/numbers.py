"""Numbers and dates as the views print them: no negative zero, no ± wider than the value it qualifies, one date form.

A difference that rounds to zero prints ``0.00 %``, not ``-0.00 %`` (which reads as a
real, if tiny, error). A parameter whose spread over the near-optimal fits is larger than
its value is not determined by the tap: a ± there would suggest a measurement that was
not made, so the views say so in words and keep the numbers in a tooltip.
"""

from __future__ import annotations

import math

from taptune.report.text import number  # noqa: F401  (the views' one formatter, shared with the CLI and the PDF)

#: Shown instead of "value ± spread" when the spread exceeds the value (a table cell;
#: the surrounding text says "by this tap").
NOT_DETERMINED = "not determined"


def determined(value: float, spread: float) -> bool:
    """Whether the tap fixes ``value``: its spread over the near-optimal fits is no larger than it."""
    return math.isfinite(value) and math.isfinite(spread) and abs(spread) <= abs(value)


def date_text(iso: str | None) -> str:
    """A stored UTC time (``2026-11-27T08:21:49Z``) as every view and ``library list`` show it: ``2026-11-27 08:21``."""
    from taptune.library.schema import date_label

    return date_label(iso)
