"""Training program for the Gaussian-texton autoencoder (``python -m train``, a Hydra app)."""

import neuraltex  # noqa: F401  (sets the allocator environment before torch is imported)
