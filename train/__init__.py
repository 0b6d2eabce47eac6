"""Training program for the Gaussian-texton autoencoder (``python -m train``, a Hydra app)."""
