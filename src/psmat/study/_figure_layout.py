"""Place the panels of a study figure with margins measured from its own texts (inches).

What matplotlib's constrained layout does for these figures (every tick label, axis label and
title outside the others' panels, the figure title on top, the key below), without its cost:
constrained layout draws every axis once more, without rendering, each time a figure is saved
(about half of a figure's time). Here only the texts are measured: the tick labels that the
axes' locators and formatters will draw, the axis labels, the titles and the key.
"""

from __future__ import annotations

from typing import Any

__all__ = ["PAD_IN", "MIN_PANEL_IN", "arrange"]

#: Space between a text and its neighbour, and at the figure's edges (inches).
PAD_IN = 0.05
#: The smallest panel; a figure too small for its texts grows to give each panel this (inches).
MIN_PANEL_IN = 0.5


class _Measure:
    """Extents of texts as the figure's renderer draws them (inches), each distinct one measured once
    (the tick labels of many panels repeat)."""

    def __init__(self, fig: Any) -> None:
        from matplotlib.text import Text

        self.renderer = fig.canvas.get_renderer()
        self.dpi = float(fig.dpi)
        self._probe = Text(0.0, 0.0, "")
        self._probe.set_figure(fig)
        self._seen: dict[tuple[Any, ...], tuple[float, float, float, float]] = {}

    def extent(self, text: Any, content: str | None = None) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1) of ``content`` (default: the text's own) drawn as ``text`` is (font,
        rotation, alignment) with its anchor at (0, 0): its size and where it lies around its
        anchor (inches)."""
        from matplotlib.transforms import IdentityTransform

        content = text.get_text() if content is None else content
        key = (content, text.get_fontproperties(), text.get_rotation(), text.get_rotation_mode(),
               text.get_horizontalalignment(), text.get_verticalalignment(), text.get_linespacing(),
               text.get_usetex(), text.get_parse_math())
        if key not in self._seen:
            probe = self._probe
            probe.update_from(text)  # font, rotation, alignment; and the transform, reset:
            probe.set_transform(IdentityTransform())
            probe.set_text(content)
            box = probe.get_window_extent(self.renderer)
            self._seen[key] = (box.x0 / self.dpi, box.x1 / self.dpi, box.y0 / self.dpi, box.y1 / self.dpi)
        return self._seen[key]

    def height(self, text: Any) -> float:
        """Height of a text artist as drawn (inches); 0 if it is empty or hidden."""
        if text is None or not text.get_visible() or not text.get_text():
            return 0.0
        x0, x1, y0, y1 = self.extent(text)
        return y1 - y0


def _ticks(axis: Any, measure: _Measure) -> tuple[list[tuple[float, tuple[float, float, float, float]]], float, float]:
    """The tick labels ``axis`` will draw: [(position along the axis as a fraction of the panel,
    extent around the label's anchor)], the distance from the panel's edge to the labels'
    anchors and the height of the offset text (inches)."""
    axes = axis.axes
    tick = axis.majorTicks[0]  # the label prototype (font, rotation, alignment)
    if not tick.label1.get_visible():
        return [], 0.0, 0.0
    gap = (tick.get_pad() + tick.get_tick_padding()) / 72.0
    locs = axis.get_majorticklocs()
    formatter = axis.get_major_formatter()
    labels = formatter.format_ticks(locs)
    lo, hi = sorted(axis.get_view_interval())
    tol = 1e-9 * max(abs(hi - lo), 1e-300)
    along = 0 if axis.axis_name == "x" else 1
    to_axes = axes.transScale + axes.transLimits
    out = []
    for loc, label in zip(locs, labels):
        if label and lo - tol <= loc <= hi + tol:
            frac = float(to_axes.transform((loc, loc))[along])
            out.append((frac, measure.extent(tick.label1, label)))
    offset = formatter.get_offset()
    off_h = 0.0
    if offset:
        x0, x1, y0, y1 = measure.extent(axis.offsetText, offset)
        off_h = y1 - y0 + axis.OFFSETTEXTPAD / 72.0
    return out, gap, off_h


def _decorations(ax: Any, measure: _Measure) -> tuple[Any, float, float]:
    """(a function (panel width, panel height) -> (left, right, bottom, top): how far the texts
    of ``ax`` reach outside its panel on each side, the height of its y offset text (the
    "1e-5" above a panel), the height of its title with its pad) (inches). The title rises
    above the offset texts of its row: ``top`` leaves them out."""
    from matplotlib import rcParams

    if not ax.axison:
        return (lambda w, h: (0.0, 0.0, 0.0, 0.0)), 0.0, 0.0
    pt = 1.0 / 72.0
    xt, xgap, xoff = _ticks(ax.xaxis, measure)
    yt, ygap, yoff = _ticks(ax.yaxis, measure)
    xlab = measure.height(ax.xaxis.label)
    ylab = 0.0
    if ax.yaxis.label.get_visible() and ax.yaxis.label.get_text():
        x0, x1, _, _ = measure.extent(ax.yaxis.label)  # drawn turned by 90°: its width
        ylab = x1 - x0
    title = measure.height(ax.title)
    xtick_h = max((-e[2] for _, e in xt), default=0.0)  # tick labels hang below their anchors
    ytick_w = max((-e[0] for _, e in yt), default=0.0)  # and left of them
    bottom = (xgap + xtick_h if xt else 0.0) + max(xlab + ax.xaxis.labelpad * pt if xlab else 0.0, xoff)
    left = (ygap + ytick_w if yt else 0.0) + (ylab + ax.yaxis.labelpad * pt if ylab else 0.0)
    top = title + rcParams["axes.titlepad"] * pt if title else 0.0

    def reach(w: float, h: float) -> tuple[float, float, float, float]:
        # tick labels near a panel's edge may reach past it (rotated or wide ones)
        return (max([left] + [-(f * w + e[0]) for f, e in xt]),
                max([0.0] + [f * w + e[1] - w for f, e in xt]),
                max([bottom] + [-(f * h + e[2]) for f, e in yt]),
                max([top] + [f * h + e[3] - h for f, e in yt]))

    return reach, yoff, top


def arrange(fig: Any, axes: Any, title: Any = None, key: Any = None) -> None:
    """Place the grid ``axes`` (of ``fig.subplots``) inside ``fig``: ``title`` (a
    ``fig.suptitle``) on top, ``key`` (a ``fig.legend`` at ``"lower center"``) at the bottom,
    the panels between them as large as their texts allow, every text clear of the others.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        With a canvas (its renderer measures the texts) and no layout engine.
    axes : (nrows, ncols) array of matplotlib.axes.Axes
        Every panel's texts set (titles, labels, ticks) and its data drawn: the tick labels
        measured are those of its limits now. A title set with ``y=1.0`` stays where this
        function puts it (saves matplotlib placing it again at each draw).
    title, key : matplotlib artists, optional
        Placed by this function (their positions are overwritten).

    Notes
    -----
    The figure keeps its size unless it is narrower than its title or key, or its panels would
    be smaller than ``MIN_PANEL_IN``; then it grows by what they lack.
    """
    measure = _Measure(fig)
    nrows, ncols = len(axes), len(axes[0])
    found = [[_decorations(ax, measure) for ax in row] for row in axes]
    reach = [[f[0] for f in row] for row in found]
    lift = [max(f[1] for f in row) for row in found]  # a row's titles in line, above any offset text
    width, height = fig.get_size_inches()
    title_h = 0.0
    if title is not None and title.get_text():
        x0, x1, y0, y1 = measure.extent(title)
        title_h = y1 - y0 + PAD_IN
        width = max(width, x1 - x0 + 2 * PAD_IN)  # a figure narrower than its title or key grows
    key_h = 0.0
    if key is not None:
        box = key.get_window_extent(measure.renderer)
        key_h = box.height / measure.dpi + PAD_IN
        width = max(width, box.width / measure.dpi + 2 * PAD_IN)
    w, h = width / ncols, height / nrows
    for _ in range(3):  # the reach of edge labels depends on the panel size: settle it
        r = [[reach[i][j](w, h) for j in range(ncols)] for i in range(nrows)]
        left = [max(r[i][j][0] for i in range(nrows)) for j in range(ncols)]
        right = [max(r[i][j][1] for i in range(nrows)) for j in range(ncols)]
        bottom = [max(r[i][j][2] for j in range(ncols)) for i in range(nrows)]
        top = [max(max(r[i][j][3], found[i][j][2] + lift[i]) for j in range(ncols)) for i in range(nrows)]
        m_left, m_right = PAD_IN + left[0], PAD_IN + right[-1]
        m_top, m_bottom = PAD_IN + title_h + top[0], PAD_IN + key_h + bottom[-1]
        wgap = max((right[j] + PAD_IN + left[j + 1] for j in range(ncols - 1)), default=0.0)
        hgap = max((bottom[i] + PAD_IN + top[i + 1] for i in range(nrows - 1)), default=0.0)
        w = max((width - m_left - m_right - (ncols - 1) * wgap) / ncols, MIN_PANEL_IN)
        h = max((height - m_top - m_bottom - (nrows - 1) * hgap) / nrows, MIN_PANEL_IN)
    width = max(width, m_left + m_right + ncols * w + (ncols - 1) * wgap)
    height = max(height, m_top + m_bottom + nrows * h + (nrows - 1) * hgap)
    fig.set_size_inches(width, height)
    fig.subplots_adjust(left=m_left / width, right=1.0 - m_right / width, bottom=m_bottom / height,
                        top=1.0 - m_top / height, wspace=wgap / w, hspace=hgap / h)
    for row, up in zip(axes, lift):
        for ax in row:
            ax.title.set_y(1.0 + up / h)
    if title is not None:
        title.set_y(1.0 - PAD_IN / height)
        title.set_verticalalignment("top")
    if key is not None:
        key.set_bbox_to_anchor((0.5, PAD_IN / height), transform=fig.transFigure)

