"""Pictures of posed rigs: a z-buffered, smoothly shaded numpy rasteriser with each active shape coloured.

It draws the session pictures of ``harness pack`` (`session`) and the contact sheets of the report
(`reports`): the template posed in an expression (Carrigan et al. 2020, sec. 3), seen through a camera such
as `rigs.frontal_camera`, each triangle in the colour of the shape its corners are active in (eq. 2). Seams
(twin vertices at one position) shade smoothly (`coincident`), and a face cut out of a larger mesh fades out
towards the cut (`edge_fade`).
"""

from render._fade import edge_fade
from render._raster import (
    Backdrop,
    Frame,
    Motion,
    Raster,
    active_vertices,
    coincident,
    rasterise,
    render_mesh,
    shape_colours,
    triangle_colours,
    vertex_normals,
)

__all__ = [
    "Backdrop",
    "Frame",
    "Motion",
    "Raster",
    "active_vertices",
    "coincident",
    "edge_fade",
    "rasterise",
    "render_mesh",
    "shape_colours",
    "triangle_colours",
    "vertex_normals",
]
