"""Procedural textures with ground-truth texton instance masks, and image-folder data.

Main entry points: :func:`generate` (one sample), :class:`ProceduralTextures`,
:class:`InfiniteProceduralTextures`, :class:`ImageFolderTextures`, and the fixed
validation/benchmark splits in :mod:`neuraltex.data.splits`.
"""

from neuraltex.data.families import EASY, FAMILIES, FAMILY_NAMES, HARD
from neuraltex.data.generator import Sample, generate

__all__ = ["EASY", "FAMILIES", "FAMILY_NAMES", "HARD", "Sample", "generate"]
