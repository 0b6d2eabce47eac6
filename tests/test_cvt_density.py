"""Density per kind with the border's fragments counted by their share (cvt/density.py)."""


from cvt.density import fragment_owners
from cvt.judge import judge
from cvt.kinds import cut_mask, element_kinds
from cvt.pattern import pattern_svg, synthesize_pattern
from cvt.svg import parse_svg
from cvt.synthesis import SynthesisConfig

NS = 'xmlns="http://www.w3.org/2000/svg"'
FRAME = "M{x0},{y0} H{x1} V{y1} H{x0} Z M{a0},{b0} V{b1} H{a1} V{b0} Z"


def _frame_piece(cx: float, cy: float, side: float) -> str:
    """A square frame (outer 10, stroke 2) centred at (cx, cy), cut to the [0, side] canvas."""
    def clip(v):
        return min(max(v, 0.0), side)

    x0, y0, x1, y1 = (clip(cx - 5), clip(cy - 5), clip(cx + 5), clip(cy + 5))
    a0, b0, a1, b1 = (clip(cx - 3), clip(cy - 3), clip(cx + 3), clip(cy + 3))
    d = FRAME.format(x0=x0, y0=y0, x1=x1, y1=y1, a0=a0, b0=b0, a1=a1, b1=b1)
    return f'<path fill-rule="evenodd" fill="#123" d="{d}"/>'


def _lattice_with_border_pieces() -> bytes:
    """Frames every 20 units over a 100 x 100 canvas with a background: 16 whole frames, and
    halves and quarters where the border cuts the frames centred on it."""
    side = 100
    body = [f'<rect width="{side}" height="{side}" fill="#eee"/>']
    body += [_frame_piece(i * 20, j * 20, side) for i in range(6) for j in range(6)]
    return f'<svg {NS} viewBox="0 0 {side} {side}">{"".join(body)}</svg>'.encode()


def test_border_pieces_count_their_share_of_the_frame():
    ex = parse_svg(_lattice_with_border_pieces())
    cut = cut_mask(ex.elements, ex.viewbox)
    kinds = element_kinds(ex.elements, cut)
    owner, weight = fragment_owners(ex.elements, kinds, cut, ex.viewbox)
    assert (~cut).sum() == 16 and cut.sum() == 20
    whole_kind = int(kinds[~cut][0])
    assert (owner[cut] == whole_kind).all()
    # 16 whole + 16 halves + 4 quarters over 100 x 100: 25 frames, one per 20 x 20 cell
    assert abs(weight[owner == whole_kind].sum() - 25.0) < 0.1


def test_lattice_output_keeps_the_frame_density():
    ex = parse_svg(_lattice_with_border_pieces())
    size = (200.0, 200.0)
    pattern = synthesize_pattern(ex, size, SynthesisConfig(levels=1, iterations=1))
    assert pattern.lattice is not None
    r = judge(ex, pattern_svg(ex, pattern), size)
    assert r["density"] < 0.05 and r["integrity"] == 1.0
    # the lattice tiles whole frames only: no pieces stacked onto them
    assert r["d"]["out"]["degree"] == 0


def test_thin_stroke_cut_across_by_the_border_is_a_fragment():
    """The corner of a frame drawn as one L-shaped ring: its cut edges are only as long as the
    stroke is wide. A circle tangent to the border stays whole."""
    corner = '<path d="M0,26 H26 V0 H30 V30 H0 Z" fill="#123"/>'
    dot = '<circle cx="50" cy="4" r="4" fill="#123"/>'
    ex = parse_svg(f'<svg {NS} viewBox="0 0 100 100">{corner}{dot}</svg>'.encode())
    assert cut_mask(ex.elements, ex.viewbox).tolist() == [True, False]
