"""Continuous Curve Textures (seed 001): connected strokes as sample graphs, synthesized with
cvt's neighborhoods, PatchMatch search and least-squares assignment, reconstructed as Bézier
paths. Modules: strokes (SVG in), graph (the representation), sampling (strokes -> graph),
similarity (eqs. 3-5 as a feature table), edges (eqs. 16-22), synthesis (the loop),
reconstruction (graph -> paths -> SVG), autocomplete, stats and baselines (evaluation)."""
