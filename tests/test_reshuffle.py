import torch

from conftest import make_textons
from neuraltex.reshuffle import reshuffle, soft_reshuffle, swap_coefficients


def test_reshuffle_permutes_features_among_effective_textons_only():
    t = make_textons(B=2, K=12, C=3, seed=4)
    out = reshuffle(t, seed=7)
    for name in ("mu", "cov", "v", "p", "delta", "order"):
        assert torch.equal(getattr(out, name), getattr(t, name)), name
    for b in range(2):
        eff = t.delta[b] > 0.5
        assert torch.equal(out.f[b, ~eff], t.f[b, ~eff])  # ineffective keep theirs
        before = sorted(map(tuple, t.f[b, eff].tolist()))
        after = sorted(map(tuple, out.f[b, eff].tolist()))
        assert before == after  # same multiset: a permutation
    assert not torch.equal(out.f, t.f)
    assert torch.equal(reshuffle(t, seed=7).f, out.f)  # seeded
    assert not torch.equal(reshuffle(t, seed=8).f, out.f)


def test_swap_coefficients_cases_of_eq_4_18():
    p = torch.tensor([[0.9, 0.8, 0.0, 0.0]])
    perm = torch.tensor([[1, 2, 0, 3]])  # 0<-1 both effective, 1<-2 ineffective donor, 2<-0
    tau = swap_coefficients(p, perm, gamma=0.5)
    assert tau[0, 0] > 0.9      # effective <- effective: a real swap
    assert tau[0, 1] < 1e-3     # effective <- ineffective: keeps its own feature
    assert tau[0, 2] == 1.0     # ineffective <- effective: takes it (not rendered anyway)
    assert torch.equal(swap_coefficients(p, perm, gamma=0.0), torch.ones(1, 4))


def test_soft_reshuffle_gamma_zero_is_a_hard_permutation_and_is_differentiable():
    t = make_textons(B=1, K=6, C=3, seed=1)
    t.f.requires_grad_(True)
    g = torch.Generator().manual_seed(0)
    out = soft_reshuffle(t, gamma=0.0, generator=g)
    rows = {tuple(r) for r in t.f[0].tolist()}
    assert all(tuple(r) in rows for r in out.f[0].tolist())
    out.f.sum().backward()
    assert torch.allclose(t.f.grad, torch.ones_like(t.f))
