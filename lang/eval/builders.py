"""The registry of block builders: which function turns each block's grouped items into
its value. Each builder module lists its own blocks; this joins them."""

from __future__ import annotations

from lang.eval import media, scene, surfaces, textures
from lang.eval.context import Builder

BUILDERS: dict[str, Builder] = {
    **surfaces.BUILDERS,
    **scene.BUILDERS,
    **textures.BUILDERS,
    **media.BUILDERS,
}
