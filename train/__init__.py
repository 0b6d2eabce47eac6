"""Training program for the Gaussian-texton autoencoder (``python -m train``, a Hydra app).

Seed 003, 4.3.5 and appendix 7.7.2: the patch GAN (eq. 4.20), the equivariance consistency
(eqs. 4.21-4.23, :mod:`train.consistency`) and the total objective (eq. 4.24,
:mod:`train.objective`); docs/equations.md has the full equation index.
"""

import neuraltex  # noqa: F401  (sets the allocator environment before torch is imported)
