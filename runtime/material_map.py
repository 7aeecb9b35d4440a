"""`texture { material_map { png "file" … texture {…} texture {…} … } }`: an image whose
value at each point picks one whole texture, as POV-Ray's material_map (imageutil.cpp).

lang gives a patterned texture whose pattern is "material_map" (the image settings in its
params, as an image_map's, and "count", the number of textures) and whose map lists the
textures at keys 0, 1, 2 …; the texture resolver (runtime.context) picks the entry whose
key is the index `material_index` returns, as for any list pattern.

The pattern-space point maps to image pixels as a bump_map's does (runtime.bump_map:
map_type, `once`, `interpolate`). A palette image gives its palette index (blended and
truncated when interpolated); any other image the red value times 255, truncated (a grey
image: its grey level, as POV-Ray stores it: runtime.bump_map). Interpolated, an image
without a palette takes the first texture wherever the blend's weights sum to less than 1
(POV-Ray blends "no index" markers too; see material_index). The file's values are read
with no gamma unless the block gives one, as POV-Ray reads them. Points off the image
(`once`) take the first texture; an index past the count wraps round it (modulo), but an
index equal to the count takes the last texture, as POV-Ray's walk down its list stops
there.
"""

from __future__ import annotations

import numpy as np

from runtime import bump_map


def material_index(p: np.ndarray, params: dict) -> np.ndarray:
    """(N,) int64 texture numbers at pattern-space points (0 where the image is missing)."""
    n = len(p)
    heights = bump_map.image_heights({**params, "use_index": True})
    count = max(int(params.get("count", 1)), 1)
    if heights is None:
        return np.zeros(n, dtype=np.int64)
    h, w = heights.red.shape
    once = bool(params.get("once"))
    interp = int(params.get("interpolate", 0))
    x, y, ok = bump_map.map_pos(p, int(params.get("map_type", 0)), w, h, once)
    number = np.zeros(n, dtype=np.int64)
    rows = np.nonzero(ok)[0]
    if not len(rows):
        return number
    x, y = x[rows], y[rows]
    # POV-Ray blends colours in double and keeps them in single precision
    red = bump_map.sample(heights.red, x, y, interp, once).astype(np.float32)
    value = np.trunc(red.astype(np.float64) * 255.0).astype(np.int64)
    # POV-Ray blends the pixels' indices as it blends their colours, an image without a
    # palette giving -1 for each; the truncated blend is the index unless it is -1. So
    # where the blend's weights sum to a shade under 1, such an image gives index 0.
    table = heights.indices if heights.indices is not None else np.full((h, w), -1.0)
    index = np.trunc(bump_map.sample(table, x, y, interp, once)).astype(np.int64)
    value = np.where(index == -1, value, index)
    value = np.where(value > count, value % count, value)
    number[rows] = np.clip(value, 0, count - 1)
    return number
