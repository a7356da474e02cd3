"""What a reviewer checks on a figure, by matplotlib's own measure of its drawn text: every text inside the
canvas and no two texts on top of each other. `captured` keeps the figures a module's `save` is handed."""
from __future__ import annotations

import itertools
import sys


def text_problems(fig) -> list[str]:
    """The texts of a drawn figure that are cut by the canvas's edge or overlap another text (by more than a
    pixel each way), e.g. ["'shaft 1' overlaps 'D2'", "'τ⊥ [N·m]' is cut by the canvas"]."""
    from matplotlib.text import Text

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    canvas = fig.bbox
    ticks, drawn = set(), []
    for ax in fig.axes:
        for axis in [getattr(ax, f"{k}axis") for k in "xyz" if hasattr(ax, f"{k}axis")]:
            lo, hi = sorted(axis.get_view_interval())
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                ticks |= {id(tick.label1), id(tick.label2)}
                if lo - 1e-9 * (hi - lo) <= tick.get_loc() <= hi + 1e-9 * (hi - lo):
                    drawn += [t for t in (tick.label1, tick.label2) if t.get_visible()]
    texts = [t for t in fig.findobj(Text) if id(t) not in ticks and t.get_visible()] + drawn
    texts = [t for t in texts if t.get_text().strip() and (t.axes is None or t.axes.get_visible())]
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in texts]
    problems = [f"{text!r} is cut by the canvas" for text, b in boxes
                if b.x0 < canvas.x0 - 0.5 or b.y0 < canvas.y0 - 0.5 or b.x1 > canvas.x1 + 0.5 or b.y1 > canvas.y1 + 0.5]
    for (ta, a), (tb, b) in itertools.combinations(boxes, 2):
        if min(a.x1, b.x1) - max(a.x0, b.x0) > 1 and min(a.y1, b.y1) - max(a.y0, b.y0) > 1:
            problems.append(f"{ta!r} overlaps {tb!r}")
    return problems


def captured(monkeypatch, module) -> list:
    """The figures `module.save` is handed from now on (each is still written); for a package (io.plots), in
    each of its modules that draws."""
    figures, save = [], module.save

    def keep(fig, path, *args, **kw):
        figures.append(fig)
        return save(fig, path, *args, **kw)

    for name, m in list(sys.modules.items()):
        if (name == module.__name__ or name.startswith(module.__name__ + ".")) and getattr(m, "save", None) is save:
            monkeypatch.setattr(m, "save", keep)
    return figures
