"""More queries for dense textures: E_s's learned queries resampled to a finer anchor grid.

With the anchor prior (:class:`neuraltex.segmentation.AnchorPrior`) query k owns anchor k of a
rows x cols grid (rows = round(sqrt(n)), cols = ceil(n / rows), row-major), and its learned
embeddings (``query_feat``, ``query_pos``: (n, D)) describe how its mask moves off that anchor.
Resampling the embeddings bilinearly from the old grid to a finer one gives a model with more
queries (e.g. 100 -> 196 for textures of 100-180 elements) that starts from the trained one:
``trainer.init_from`` / ``init_parts`` apply it when the query counts differ, and
``neuraltex.model.load_model(..., num_queries=n)`` applies it at load time. Only these two
tensors depend on n; every other weight is shared as it is.
"""

from __future__ import annotations

import math
from dataclasses import replace

import torch
import torch.nn.functional as F

QUERY_KEYS = ("query_feat", "query_pos")
MAX_QUERIES = 1024  # resampled queries at most (E_s's memory grows with them)


def grid_shape(n: int) -> tuple[int, int]:
    """(rows, cols) of the anchor grid of n queries (as AnchorPrior lays them out)."""
    rows = max(1, round(math.sqrt(n)))
    return rows, math.ceil(n / rows)


def resample_queries(q: torch.Tensor, n: int) -> torch.Tensor:
    """Query embeddings (n_old, D) on their anchor grid -> (n, D) on the grid of n queries.

    Cells of a partly filled old grid take the mean embedding; bilinear, cell centres aligned
    (align_corners=False), as the anchors sit at cell centres.
    """
    n_old, D = q.shape
    if n == n_old:
        return q.clone()
    rows, cols = grid_shape(n_old)
    full = q.mean(0, keepdim=True).expand(rows * cols, D).clone()
    full[:n_old] = q
    grid = full.T.reshape(1, D, rows, cols)  # (1, D, rows, cols)
    new = F.interpolate(grid, size=grid_shape(n), mode="bilinear", align_corners=False)
    return new.reshape(D, -1).T[:n].contiguous()  # (n, D)


def adapt_queries(state: dict[str, torch.Tensor], n: int,
                  prefix: str = "segmenter.") -> dict[str, torch.Tensor]:
    """A state dict with E_s's query embeddings (keys ``prefix + QUERY_KEYS``) resampled to
    n queries; other entries unchanged. Raises KeyError when the state has no E_s queries."""
    out = dict(state)
    for key in QUERY_KEYS:
        out[prefix + key] = resample_queries(state[prefix + key], n)
    return out


def with_queries(model, n: int):
    """A copy of the autoencoder ``model`` whose E_s has n queries (resampled, no training);
    ``model`` itself when it has n already. Raises KeyError when its E_s has no queries."""
    from neuraltex.model import build_model

    if n == model.config.networks().segmentation.num_queries:
        return model
    cfg, state = resampled(model.config, model.state_dict(), n)
    copy = build_model(cfg, info=model.info)
    copy.load_state_dict(state)
    return copy.to(next(model.parameters()).device).eval()


def resampled(cfg, state: dict[str, torch.Tensor], n: int):
    """(model config, state dict) of a model with n queries: E_s's embeddings resampled
    (:func:`adapt_queries`); unchanged when it has n already."""
    if n == cfg.networks().segmentation.num_queries:
        return cfg, state
    return replace(cfg, num_queries=n), adapt_queries(state, n)
