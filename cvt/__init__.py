"""cvt: Clustered Vector Textures (seed 000) -- SVG exemplar in, larger SVG pattern out.

All sample state (positions, cluster ids, existence, z, shape-context features) lives in
torch tensors; see seed 000 sections 4-6.
"""

from neuraltex import __version__

__all__ = ["__version__"]
