"""Procedural textures with ground-truth texton instance masks, and image-folder data.

Main entry points: :func:`generate` (one sample, here), the torch datasets in
:mod:`neuraltex.data.datasets` (``ProceduralTextures``, ``InfiniteProceduralTextures``,
``ImageFolderTextures``), :class:`neuraltex.data.augment.Augment`, and the fixed
validation/benchmark splits in :mod:`neuraltex.data.splits`. Importing this package
does not import torch.
"""

from neuraltex.data.families import EASY, FAMILIES, FAMILY_NAMES, HARD
from neuraltex.data.generator import Sample, generate

__all__ = ["EASY", "FAMILIES", "FAMILY_NAMES", "HARD", "Sample", "generate"]
