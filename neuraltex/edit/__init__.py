"""Texture editing on textons (seed 003, section 4.4), as functions on texton sets (and images
for propagation and stylization).

transfer     structure from one texture, appearance from another (4.4.2)
interpolate  Hungarian correspondence + convex blend, also spatially (4.4.4)
vary         scale appearance / shape variation around the mean (4.4.3, eqs. 4.25-4.30)
texton_edits select, move, scale, rotate, delete, duplicate; JSON edit lists (4.4.5.1)
propagate    repeat a pixel edit on similar textons (4.4.5.2)
animation    perturbed shear flow and vortex flow (4.4.6, appendix 7.7.3)
stylize      a large image from overlapping patches, in a texture's appearance (4.4.2)
Reshuffling (4.4.1) lives in :mod:`neuraltex.reshuffle`.
"""
