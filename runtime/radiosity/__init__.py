"""The radiosity method (NOTES.md §6): patches, form factors, solvers, Gouraud display.

Imported only when a scene has `radiosity {}` (the package pulls in numpy-heavy code).
Modules: `formfactor` (analytic point-to-polygon kernel, polygon quadrature, visibility),
`solve` (Gauss–Seidel, progressive refinement, direct), `patches` (meshing, adaptive
subdivision), `gouraud` (vertex radiosity and lookup at hit points).
"""
