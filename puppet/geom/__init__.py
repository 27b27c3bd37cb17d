"""Geometry, numpy and scipy only (arrays in, arrays out; no GL, images or scene objects):
mask contours and Douglas-Peucker, planar straight-line graphs and constrained Delaunay
triangulation, meshes merged along link segments, the cotangent Laplacian, geodesic
distances, curvature, mean value coordinates, outline matching."""
