"""Checks of rendered matplotlib figures: every text inside the figure, none over another."""
from matplotlib.text import Text


def _undrawn_tick_labels(fig):
    """Labels of ticks outside their axis' view interval: matplotlib keeps but does not draw
    them."""
    out = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            lo, hi = lo - 1e-9 * abs(lo), hi + 1e-9 * abs(hi)
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if not lo <= tick.get_loc() <= hi:
                    out |= {id(tick.label1), id(tick.label2)}
    return out


def text_boxes(fig):
    """(text, window extent) of every drawn, non-empty text of the figure."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    skip = _undrawn_tick_labels(fig)
    out = []
    for t in fig.findobj(lambda a: hasattr(a, "get_text") and hasattr(a, "get_window_extent")):
        if t.get_visible() and t.get_text().strip() and id(t) not in skip:
            # the text alone: an annotation's own extent includes its arrow
            box = Text.get_window_extent(t, r) if isinstance(t, Text) else t.get_window_extent(r)
            out.append((t.get_text(), box))
    return out


def assert_texts_readable(fig, overlap_px=1.0):
    """No text is cut off by the figure's edge, and no two texts overlap by more than
    ``overlap_px`` pixels in both directions (tick labels included)."""
    boxes = text_boxes(fig)
    W, H = fig.bbox.width, fig.bbox.height
    cut = [t for t, b in boxes if b.x0 < -0.5 or b.y0 < -0.5 or b.x1 > W + 0.5 or b.y1 > H + 0.5]
    assert not cut, f"texts cut off by the figure's edge: {cut[:5]}"
    bad = []
    for i, (ta, a) in enumerate(boxes):
        for tb, b in boxes[i + 1:]:
            dx = min(a.x1, b.x1) - max(a.x0, b.x0)
            dy = min(a.y1, b.y1) - max(a.y0, b.y0)
            if dx > overlap_px and dy > overlap_px:
                bad.append((ta, tb))
    assert not bad, f"{len(bad)} overlapping text pairs, e.g. {bad[:4]}"
