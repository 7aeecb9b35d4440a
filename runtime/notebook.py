"""`api.render(..., display=True)` in a notebook: the image grows in the cell's output.

One IPython display handle per render, updated with the image so far as tiles come in
(the render's own tiles, in the file's 8-bit values: `color.to_display8`), at most every
INTERVAL seconds and always with the last tile. A PNG of the whole image goes to the
front end each time: 23 ms at 1280x960, so a frequent update would cost the render time.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from lang import ir
from runtime import color, png

INTERVAL = 0.25  # seconds between two updates of the cell at most


def inline_view(width: int, height: int, settings: ir.Settings) -> InlineView | None:
    """A view in the running notebook's cell, or None outside one (no IPython, or a front
    end that shows no images, as the terminal's)."""
    try:
        from IPython import get_ipython
    except ImportError:
        return None
    shell = get_ipython()
    if shell is None or "image/png" not in shell.display_formatter.active_types:
        return None
    return InlineView(width, height, settings)


class InlineView:
    """The image so far, in a display handle of the current cell."""

    def __init__(
        self,
        width: int,
        height: int,
        settings: ir.Settings,
        clock: Callable[[], float] = time.monotonic,
    ):
        from IPython.display import display

        self.settings = settings
        self.clock = clock
        self.shown = np.zeros((height, width, 3), dtype=np.uint8)
        self.updates = 0
        self._last = clock()
        self._pending = False
        self.handle = display(self._image(), display_id=True)

    def tile(self, rect: tuple[int, int, int, int], working: np.ndarray) -> None:
        """A finished tile (the render's on_tile)."""
        x0, y0, x1, y1 = rect
        self.shown[y0:y1, x0:x1] = color.to_display8(working, self.settings)
        self._pending = True
        if self.clock() - self._last >= INTERVAL:
            self.update()

    def finish(self) -> None:
        """The render is done: the cell shows all of it."""
        if self._pending:
            self.update()

    def update(self) -> None:
        self.handle.update(self._image())
        self.updates += 1
        self._pending = False
        self._last = self.clock()

    def _image(self):
        from IPython.display import Image

        return Image(data=png.encode(self.shown), format="png")
