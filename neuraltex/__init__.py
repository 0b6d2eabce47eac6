"""neuraltex: textures taken apart into editable Gaussian textons and put back together.

The core modules follow seed 003, chapter 4 (Compositional Neural Textures):

- :mod:`neuraltex.coords`      the resolution-independent coordinate convention
- :mod:`neuraltex.textons`     the texton container (a batch of 2D Gaussian sets)
- :mod:`neuraltex.estimation`  masks + feature maps -> textons (eqs. 4.3-4.7)
- :mod:`neuraltex.splatting`   textons -> feature grid and max-opacity map (eqs. 4.11-4.14)
"""

__version__ = "0.1.0"
