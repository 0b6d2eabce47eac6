"""cvt.shape_context.chi2_table: the deduplicated, chunked table gives chi2's floats."""

import pytest
import torch

from cvt.shape_context import chi2, chi2_table, shape_contexts


def _reference(a, b):
    """One broadcast chi2 over all pairs (the table before deduplication)."""
    return chi2(a[:, None, :], b[None, :, :])


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_chi2_table_equals_pairwise_chi2(dtype):
    g = torch.Generator().manual_seed(0)
    pos = torch.rand(300, 2, generator=g, dtype=dtype)
    cluster = torch.randint(0, 70, (300,), generator=g)  # some clusters of one sample
    a = shape_contexts(pos, cluster)
    a = torch.cat([a, a[:40], torch.rand(7, 60, generator=g, dtype=dtype)])  # repeated rows
    b = shape_contexts(pos[:120] * 3, cluster[:120] % 9)
    assert torch.unique(a, dim=0).shape[0] < a.shape[0]  # the test has duplicates
    ref = _reference(a, b)
    assert torch.equal(chi2_table(a, b), ref)  # same floats, not just close
    assert torch.equal(chi2_table(a, b, chunk=3), ref)
    assert chi2_table(a[:0], b).shape == (0, 120) and chi2_table(a, b[:0]).shape == (a.shape[0], 0)
