"""neuraltex: textures taken apart into editable Gaussian textons and put back together.

The core modules follow seed 003, chapter 4 (Compositional Neural Textures):

- :mod:`neuraltex.coords`      the resolution-independent coordinate convention
- :mod:`neuraltex.textons`     the texton container (a batch of 2D Gaussian sets)
- :mod:`neuraltex.estimation`  masks + feature maps -> textons (eqs. 4.3-4.7)
- :mod:`neuraltex.splatting`   textons -> feature grid and max-opacity map (eqs. 4.11-4.14)
- :mod:`neuraltex.model`       E and G wired together (eq. 4.1), :mod:`neuraltex.losses` (eqs.
  4.8-4.10, 4.15-4.16), :mod:`neuraltex.reshuffle` (eqs. 4.17-4.19), :mod:`neuraltex.edit`
  (eqs. 4.25-4.31, 7.1-7.2); training-only losses live in :mod:`train` (eqs. 4.20-4.24)

docs/equations.md maps every seed equation (CNT eqs. 4.x/7.x of seed 003, CVT eqs. 1-18 of
seed 000) to the file and function that implements it.
"""

import os as _os

# Large CPU tensors (feature grids of 256 px x 384 channels are 100 MB) on transparent huge
# pages: first-touch page faults otherwise cost as much as the matmuls that fill them
# (measured 2-3x on splatting, scripts/bench_splat.py --no-thp). Read by PyTorch's CPU
# allocator once, so this only takes effect when neuraltex is imported before torch, as the
# CLIs and the training program do.
_os.environ.setdefault("THP_MEM_ALLOC_ENABLE", "1")

__version__ = "0.1.0"
