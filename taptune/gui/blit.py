"""A plot canvas that follows a slider: the axes' frames, ticks, labels and legends are drawn
once and kept as a picture; each update draws only the data over that picture.

With matplotlib 3.11 the text (tick labels, axis labels, legends) is most of a render:
in the Machine view ~85 of ~100 ms, the curves themselves ~15 ms. :class:`BlitCanvas`
caches the figure without its data (its "background") and, while the axes' limits, the
legends and the widget's size stay the same, an update restores that picture, draws the
data artists in their z-order and pastes the legends back on top (legends are drawn
opaque). Anything else draws the whole figure once more and caches a new background.

What counts as background in each axes: its patch, its x and y axis (ticks, tick labels,
axis labels) and its legend. Everything else (lines, fills, annotations, titles, spines,
the grid of :func:`add_grid`) is data and is drawn at every update. The axes' own grid
belongs to the axis, so it would lie under the data (a stable area's fill would hide it):
:func:`add_grid` draws the same lines as a data artist instead.

A full draw by Qt (a resize, ``draw_idle``) still draws everything in the usual way, so
the picture is the same whichever path made it.
"""

from __future__ import annotations

from PySide6.QtCore import QTimer

from taptune.gui.plotting import STYLE, PlotCanvas


#: Round tops of a y axis (times a power of ten): steps of at most 25 %.
ROUND_TOPS = (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)
#: A kept top stays while the curve's highest point needs at least this share of it.
KEEP_DOWN_TO = 0.5
#: When the top must grow, it grows to hold this much more than needed (fewer jumps in a drag).
GROW_ROOM = 1.25


def round_top(value: float) -> float:
    """The smallest round number (:data:`ROUND_TOPS` × 10^k) ≥ ``value`` (> 0)."""
    import math

    decade = 10.0 ** math.floor(math.log10(value))
    for step in ROUND_TOPS:
        if step * decade >= value * (1 - 1e-12):
            return step * decade
    return 10 * decade


def steady_top(need: float, current: float | None) -> float:
    """Top of a y axis that must show up to ``need``: ``current`` while ``need`` fits in
    [KEEP_DOWN_TO, 1] of it, else a round number (with room to grow when it rises).

    A slider's curve then changes its axis only now and then, and the axis keeps round
    numbers; ``current`` None (a new picture) gives the tightest round top.
    """
    if not (need > 0 and need < float("inf")):
        return current if current is not None else 1.0
    if current is None:
        return round_top(need)
    if KEEP_DOWN_TO * current <= need <= current:
        return current
    return round_top(need * GROW_ROOM if need > current else need)


def add_grid(ax):
    """The major grid of ``ax`` as one data artist (the axes' own grid is switched off).

    Its lines follow the major ticks; :class:`BlitCanvas` moves them whenever it draws a
    new background.
    """
    import matplotlib
    from matplotlib.collections import LineCollection

    ax.grid(False)
    rc = matplotlib.rcParams
    grid = LineCollection([], colors=rc["grid.color"], linewidths=rc["grid.linewidth"],
                          linestyles=rc["grid.linestyle"], alpha=STYLE.get("grid.alpha", rc["grid.alpha"]),
                          zorder=1.5, transform=ax.transAxes)
    grid.set_snap(True)
    grid.set_gid("grid")
    ax.add_collection(grid, autolim=False)
    return grid


def _grid_segments(ax) -> list:
    """Segments of the major grid of ``ax`` in axes coordinates (the ticks inside the limits)."""
    import numpy as np

    out = []
    for axis, lim, to_axes in ((ax.xaxis, ax.get_xlim(), lambda v: (ax.transData + ax.transAxes.inverted())
                                .transform(np.column_stack([v, np.zeros_like(v)]))[:, 0]),
                               (ax.yaxis, ax.get_ylim(), lambda v: (ax.transData + ax.transAxes.inverted())
                                .transform(np.column_stack([np.zeros_like(v), v]))[:, 1])):
        locs = np.asarray(axis.get_majorticklocs(), dtype=float)
        lo, hi = min(lim), max(lim)
        span = hi - lo
        locs = locs[(locs >= lo - 1e-9 * span) & (locs <= hi + 1e-9 * span)]
        for p in to_axes(locs):
            out.append([(p, 0.0), (p, 1.0)] if axis is ax.xaxis else [(0.0, p), (1.0, p)])
    return out


class BlitCanvas(PlotCanvas):
    """A :class:`~taptune.gui.plotting.PlotCanvas` whose :meth:`render` redraws only the data.

    Call :meth:`render` (instead of ``draw_idle``) after giving the artists new data: the
    draw runs once from the event loop, however many calls came before it. When only a y
    limit changed, only that y axis (its ticks, labels and title strip left of the axes)
    is drawn again into the kept picture.
    """

    def __init__(self, parent=None, height_in: float = 3.0, layout: str | None = None):
        super().__init__(parent, height_in, layout)
        # (key, y limits per axes, the figure without its data, the empty figure)
        self._background = None
        self._pending = False
        self.renders = {"full": 0, "y axis": 0, "data": 0}  # how each render went (benchmark, tests)

    def render(self) -> None:
        """Queue an update of the picture (coalesced; runs from the event loop)."""
        if not self._pending:
            self._pending = True
            QTimer.singleShot(0, self._render)

    def draw_idle(self) -> None:
        """Every queued redraw (a resize, another view's ``draw_idle``) goes through :meth:`render`."""
        self.render()

    def render_now(self) -> None:
        """Update the picture now (from the kept background when it is still valid)."""
        self._pending = False
        if self.width() <= 0 or self.height() <= 0 or not self.figure.axes:
            self.draw()
            return
        key, ylims = self._background_key()
        renderer = self.get_renderer()
        if self._background is None or self._background[0] != key:
            self._draw_background(key, ylims)
            self.renders["full"] += 1
        else:
            _, kept_ylims, region, blank = self._background
            renderer.restore_region(region)
            changed = [ax for ax, old, new in zip(self.figure.axes, kept_ylims, ylims) if old != new]
            for ax in changed:
                self._redraw_y_axis(ax, renderer, blank)
            if changed:
                self._background = (key, ylims, self.copy_from_bbox(self.figure.bbox), blank)
                self._move_grids()
            self.renders["y axis" if changed else "data"] += 1
        for ax in self.figure.axes:
            for artist in self._data(ax):
                artist.draw(renderer)
        height = renderer.height
        for legend in self._legends():
            # The legend as the background has it, over the data. Agg's regions count y
            # downwards, and ``xy`` is where the region's corner goes (this one's is the figure's).
            x0, y0, x1, y1 = legend.get_window_extent(renderer).padded(0.5).extents
            renderer.restore_region(self._background[2], bbox=(int(x0), int(height - y1), int(x1) + 1,
                                                               int(height - y0) + 1), xy=(0, 0))
        self.update()  # Qt paints the buffer (no further matplotlib draw)

    def _render(self) -> None:
        if self._pending:
            self.render_now()

    def invalidate(self) -> None:
        """Forget the kept background (the next render draws everything)."""
        self._background = None

    # ------------------------------------------------------------------ internals

    def _legends(self) -> list:
        return [ax.get_legend() for ax in self.figure.axes if ax.get_legend() is not None
                and ax.get_legend().get_visible()]

    @staticmethod
    def _data(ax) -> list:
        """The artists of ``ax`` drawn at every update, in the order ``Axes.draw`` uses."""
        from operator import attrgetter

        skip = {id(ax.patch), id(ax.xaxis), id(ax.yaxis), id(ax.get_legend())}
        out = [a for a in ax.get_children() if id(a) not in skip and a.get_visible()]
        return sorted(out, key=attrgetter("zorder"))

    def _background_key(self) -> tuple:
        """What the background depends on, and apart from that each axes' y limits."""
        parts = [self.get_width_height(physical=True), self.figure.dpi]
        for ax in self.figure.axes:
            legend = ax.get_legend()
            parts.append((id(ax), ax.get_position().bounds, ax.get_xlim(), ax.get_xlabel(), ax.get_ylabel(),
                          ax.xaxis.get_visible(), ax.yaxis.get_visible(),
                          None if legend is None else (legend.get_visible(),
                                                       tuple(t.get_text() for t in legend.get_texts()))))
        return tuple(parts), tuple(ax.get_ylim() for ax in self.figure.axes)

    def _draw_background(self, key, ylims) -> None:
        """Draw the figure without its data and keep that picture (and the empty figure)."""
        renderer = self.get_renderer()
        renderer.clear()
        self.figure.patch.draw(renderer)
        blank = self.copy_from_bbox(self.figure.bbox)
        # The titles are data too, but Axes.draw places them from their own extent, which an
        # invisible text has not (it would put them off the figure): they are drawn clear.
        titles = {id(t) for ax in self.figure.axes for t in (ax.title, ax._left_title, ax._right_title)}
        data = [a for ax in self.figure.axes for a in self._data(ax)]
        hidden = [a for a in data if id(a) not in titles]
        clear = [(a, a.get_alpha()) for a in data if id(a) in titles]
        for a in hidden:
            a.set_visible(False)
        for a, _ in clear:
            a.set_alpha(0.0)
        try:
            super().draw()  # FigureCanvasQTAgg.draw: the Agg render, then a Qt update
        finally:
            for a in hidden:
                a.set_visible(True)
            for a, alpha in clear:
                a.set_alpha(alpha)
        self._background = (key, ylims, self.copy_from_bbox(self.figure.bbox), blank)
        self._move_grids()

    def _redraw_y_axis(self, ax, renderer, blank) -> None:
        """Clear the strip left of ``ax`` (its y ticks, tick labels and label) and draw its y axis there."""
        box = ax.bbox
        # From the right edge of the axes on the left (what lies above its bottom there is
        # data, drawn again anyway; its x tick labels lie lower) or the figure's edge to
        # this axes' left edge; from just under its lowest y tick label (its x tick labels
        # lie lower) to the top of the figure.
        left = max([0.0] + [other.bbox.x1 for other in self.figure.axes if other is not ax and other.bbox.x1 <= box.x0])
        bottom = box.y0 - 0.5 * ax.yaxis.get_ticklabels()[0].get_fontsize() * self.figure.dpi / 72 - 2
        height = renderer.height
        renderer.restore_region(blank, bbox=(int(left) + 3, 0, int(box.x0), int(height - bottom)), xy=(0, 0))
        ax.yaxis.draw(renderer)

    def _move_grids(self) -> None:
        for ax in self.figure.axes:
            for artist in ax.collections:
                if artist.get_gid() == "grid":
                    artist.set_segments(_grid_segments(ax))
