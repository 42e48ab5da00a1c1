"""Meshing of holder and tool with grading toward the contact-zone ends (docs/physics.md §1).

Breakpoints are every segment end of both bodies and the contact-zone ends, so holder
and tool have nodes at exactly the same z inside the contact zone. On top of them, grading points are placed
around both ends of the contact zone (short elements growing geometrically away from
each end): the stiff contact layer loads both beams in a boundary layer a few mm long
there, and uniform meshes would need ≈1 mm elements everywhere to converge. The
first element follows the shortest boundary layer of the search space (slender tools
need it shorter), and every element resolves the bending wavelength at the highest
reachable third bending frequency (stubby sections). Sizes: see ``ModelOptions``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from taptune.io.assembly import Assembly, Segment
from taptune.model.elements import BeamElements, section_properties, shear_coefficient
from taptune.model.options import ModelOptions
from taptune.model.params import P_UPPER

MM = 1e-3
# Breakpoints closer than this (1e-6 mm) are one [m].
MERGE_TOL = 1e-9


@dataclass(frozen=True)
class Mesh:
    """Holder and tool elements plus the contact bookkeeping.

    Attributes
    ----------
    holder, tool : BeamElements
        The two bodies, nodes in increasing z [m].
    contact_elements : ndarray, shape (n_c, 2), int
        (holder element, tool element) index pairs spanning the same interval of the
        contact zone, in increasing z.
    contact_nodes : ndarray, shape (n_c + 1, 2), int
        (holder node, tool node) index pairs with the same z in the contact zone.
    z_zone : tuple of float
        (z_c0, L_h): the contact zone [m].
    """

    holder: BeamElements
    tool: BeamElements
    contact_elements: np.ndarray
    contact_nodes: np.ndarray
    z_zone: tuple[float, float]


def merge_points(points, anchors=()) -> np.ndarray:
    """Sorted unique points, merging those closer than ``MERGE_TOL``; anchors win a merge [m]."""
    anchors = np.asarray(sorted(anchors), dtype=float)
    pts = np.asarray(points, dtype=float)
    if anchors.size:
        near = np.min(np.abs(pts[:, None] - anchors[None, :]), axis=1) < MERGE_TOL
        pts = np.concatenate([pts[~near], anchors])
    pts = np.sort(pts)
    keep = np.concatenate([[True], np.diff(pts) >= MERGE_TOL])
    return pts[keep]


def segment_bounds(start: float, segments: tuple[Segment, ...]) -> np.ndarray:
    """z of the boundaries of consecutive segments starting at ``start`` [m], shape (n + 1,)."""
    return start + np.concatenate([[0.0], np.cumsum([s.length for s in segments])])


def grading_points(z_end, direction, limit, h_min, growth, h_cap, drop_near=()):
    """Points spaced h_min, h_min·g, h_min·g², … away from ``z_end`` [m].

    Parameters
    ----------
    z_end : float
        Start of the grading (a contact-zone end) [m].
    direction : {+1, -1}
        Towards larger or smaller z.
    limit : float
        No point is placed at or beyond this z [m].
    h_min, growth, h_cap : float
        First spacing [m], growth ratio, largest spacing [m]; the grading stops once the
        next spacing would reach ``h_cap`` (the uniform subdivision takes over there).
    drop_near : sequence of float
        Fixed breakpoints [m]: a grading point closer than half the local spacing to
        one is dropped, so that no sliver element is created.
    """
    fixed = np.asarray(drop_near, dtype=float)
    out = []
    h, z = h_min, z_end
    while h < h_cap:
        z = z + direction * h
        if direction * (limit - z) <= 0.5 * h:
            break
        if fixed.size == 0 or np.min(np.abs(fixed - z)) >= 0.5 * h:
            out.append(z)
        h *= growth
    return out


def subdivide(breakpoints, cap_of) -> np.ndarray:
    """Nodes: every interval split into equal elements no longer than its cap [m].

    Parameters
    ----------
    breakpoints : array_like, shape (m,)
        Sorted breakpoints [m].
    cap_of : callable
        (a, b) arrays of interval ends → largest element length per interval [m].
    """
    bp = np.asarray(breakpoints, dtype=float)
    a, b = bp[:-1], bp[1:]
    cap = cap_of(a, b)
    n = np.maximum(1, np.ceil((b - a) / cap - 1e-9)).astype(int)
    nodes = [a[i] + (b[i] - a[i]) * np.arange(n[i]) / n[i] for i in range(len(a))]
    nodes.append(bp[-1:])
    return np.concatenate(nodes)


def split_elements(z, parts: int) -> np.ndarray:
    """Nodes with every element of ``z`` split into ``parts`` equal elements [m]."""
    if parts == 1:
        return z
    t = np.arange(parts) / parts
    inner = (z[:-1, None] + np.diff(z)[:, None] * t[None, :]).ravel()
    return np.concatenate([inner, z[-1:]])


def boundary_layer_length(assembly: Assembly, shear: str = "hutchinson") -> float:
    """Shortest decay length of the contact boundary layer over the search space [m].

    A layer of line stiffness c loads a beam over a length of about sqrt(κGA/c) (shear,
    translational layer) or sqrt(EI/c) (bending, rotational layer). With the stiffest
    layer of the search space (docs/physics.md §2) this is a few mm for a Ø16 tool but well
    under 1 mm for slender tools, so the first zone elements must follow it.
    """
    c_t = 10.0 ** P_UPPER[0] * 1e3  # N/m per m of contact
    c_r = 10.0 ** P_UPPER[1] * 1e3  # N·m/rad per m of contact
    zc0, L_h = assembly.z_contact_start, assembly.holder.length
    lengths = []
    for start, body in ((0.0, assembly.holder), (assembly.z_tool_start, assembly.tool)):
        bounds = segment_bounds(start, body.segments)
        for seg, a, b in zip(body.segments, bounds[:-1], bounds[1:]):
            if min(b, L_h) - max(a, zc0) <= MERGE_TOL:
                continue
            area, inertia = section_properties([seg.od], [seg.id])
            m = body.material
            kappa = shear_coefficient([seg.od], [seg.id], m.poisson, shear)
            g = m.youngs_modulus / (2 * (1 + m.poisson))
            lengths += [np.sqrt(kappa * g * area / c_t)[0], np.sqrt(m.youngs_modulus * inertia / c_r)[0]]
    return float(min(lengths))


def bending_wavelength(segments, material, freq_hz: float, shear: str = "hutchinson") -> np.ndarray:
    """Wavelength of free bending waves at ``freq_hz`` in each segment (Timoshenko) [m], (n,).

    From the dispersion relation EI k⁴ − ω²ρI (1 + E/κG) k² − ω²ρA + ω⁴ρ²I/κG = 0
    (the propagating root): shear and rotary inertia shorten the wave, which matters for
    the stubby holder sections at the third bending frequency.
    """
    od = np.array([s.od for s in segments])
    id_ = np.array([s.id for s in segments])
    area, inertia = section_properties(od, id_)
    kappa = shear_coefficient(od, id_, material.poisson, shear)
    E, rho = material.youngs_modulus, material.density
    kg = kappa * E / (2 * (1 + material.poisson))
    w2 = (2 * np.pi * freq_hz) ** 2
    a = E * inertia
    b = -w2 * rho * inertia * (1 + E / kg)
    c = w2 * w2 * rho * rho * inertia / kg - w2 * rho * area
    k2 = (-b + np.sqrt(b * b - 4 * a * c)) / (2 * a)
    return 2 * np.pi / np.sqrt(k2)


def _segment_caps(start, segments, material, freq_hz, per_wavelength, shear):
    """(bounds, caps): element-length caps [m] per segment from the bending wavelength."""
    bounds = segment_bounds(start, segments)
    if not freq_hz or per_wavelength <= 0:
        return bounds, np.full(len(segments), np.inf)
    return bounds, bending_wavelength(segments, material, freq_hz, shear) / per_wavelength


def _cap_at(z, bounds, caps) -> np.ndarray:
    """Cap of the segment containing each z (inf outside the body) [m]."""
    idx = np.searchsorted(bounds, z) - 1
    inside = (idx >= 0) & (idx < len(caps))
    return np.where(inside, caps[np.clip(idx, 0, len(caps) - 1)], np.inf)


def _body(z, start, segments, material, shear) -> BeamElements:
    """Elements on nodes z, properties from the segment containing each mid-point."""
    bounds = segment_bounds(start, segments)
    mid = 0.5 * (z[:-1] + z[1:])
    idx = np.clip(np.searchsorted(bounds, mid) - 1, 0, len(segments) - 1)
    od = np.array([segments[i].od for i in idx])
    id_ = np.array([segments[i].id for i in idx])
    return BeamElements(
        z=z,
        od=od,
        id=id_,
        density=material.density,
        youngs_modulus=material.youngs_modulus,
        poisson=material.poisson,
        loss_factor=material.loss_factor,
        shear=shear,
    )


def build_mesh(assembly: Assembly, options: ModelOptions = ModelOptions(), f_max_hz: float | None = None) -> Mesh:
    """Mesh holder and tool of an assembly (docs/physics.md §1 plus contact-end grading).

    Parameters
    ----------
    assembly : Assembly
        Validated geometry (SI).
    options : ModelOptions
        Element sizes and grading; see :class:`ModelOptions` for ``mesh_scale``.
    f_max_hz : float, optional
        Highest frequency the mesh must resolve [Hz]: every element is also no longer
        than the local bending wavelength at f_max_hz over
        ``options.elements_per_wavelength`` (stubby sections, high third modes).

    Returns
    -------
    Mesh
    """
    holder, tool = assembly.holder, assembly.tool
    L_h, z_c0 = holder.length, assembly.z_contact_start
    z_back, z_tip = assembly.z_tool_start, assembly.z_tip
    zone = (z_c0, L_h)
    coarsen = max(1.0, options.mesh_scale)
    layer = boundary_layer_length(assembly, options.shear)
    h_out = options.h_max_mm * MM * coarsen
    h_zone = min(options.zone_h_max_mm * MM, options.layer_h_max_ratio * layer)
    h_min = min(options.zone_h_min_mm * MM, options.layer_h_min_ratio * layer, h_zone)
    h_zone, h_min = h_zone * coarsen, h_min * coarsen

    holder_geo = merge_points(np.concatenate([segment_bounds(0.0, holder.segments), [z_c0]]), (z_c0, L_h))
    tool_geo = merge_points(
        np.concatenate([segment_bounds(z_back, tool.segments), [z_c0, L_h]]), (z_c0, L_h, z_back, z_tip)
    )

    def strictly_in_zone(p):
        return p[(p > z_c0 + MERGE_TOL) & (p < L_h - MERGE_TOL)]

    fixed = np.concatenate([holder_geo, tool_geo])
    mid_zone = 0.5 * (z_c0 + L_h)
    grading = []
    # Towards the middle of the zone (both bodies) and away from it (one or both bodies).
    for z_end, inward, outward_limit in ((z_c0, +1, 0.0), (L_h, -1, z_tip)):
        grading += grading_points(z_end, inward, mid_zone, h_min, options.zone_growth, h_zone, fixed)
        grading += grading_points(z_end, -inward, outward_limit, h_min, options.zone_growth, h_out, fixed)
    grading = np.asarray(grading)

    def within(p, lo, hi):
        return p[(p > lo + MERGE_TOL) & (p < hi - MERGE_TOL)]

    holder_bp = merge_points(
        np.concatenate([holder_geo, strictly_in_zone(tool_geo), within(grading, 0.0, L_h)]), (z_c0, L_h)
    )
    tool_bp = merge_points(
        np.concatenate([tool_geo, strictly_in_zone(holder_geo), within(grading, z_back, z_tip)]),
        (z_c0, L_h, z_back, z_tip),
    )
    wave = (f_max_hz, options.elements_per_wavelength, options.shear)
    hb, hc = _segment_caps(0.0, holder.segments, holder.material, *wave)
    tb, tc = _segment_caps(z_back, tool.segments, tool.material, *wave)
    hc, tc = hc * coarsen, tc * coarsen

    def caps(own, other):
        def cap_of(a, b):
            mid = 0.5 * (a + b)
            inside = (a >= z_c0 - MERGE_TOL) & (b <= L_h + MERGE_TOL)
            # In the zone both bodies take the same caps, so their nodes stay coincident.
            cap = np.minimum(np.where(inside, h_zone, h_out), _cap_at(mid, *own))
            return np.where(inside, np.minimum(cap, _cap_at(mid, *other)), cap)

        return cap_of

    z_h = subdivide(holder_bp, caps((hb, hc), (tb, tc)))
    z_t = subdivide(tool_bp, caps((tb, tc), (hb, hc)))
    if options.mesh_scale < 1.0:
        parts = math.ceil(1.0 / options.mesh_scale - 1e-9)
        z_h, z_t = split_elements(z_h, parts), split_elements(z_t, parts)

    h_body = _body(z_h, 0.0, holder.segments, holder.material, options.shear)
    t_body = _body(z_t, z_back, tool.segments, tool.material, options.shear)
    contact_nodes, contact_elements = _contact_pairs(z_h, z_t, zone)
    return Mesh(h_body, t_body, contact_elements, contact_nodes, zone)


def _contact_pairs(z_h, z_t, zone):
    """Coincident node and element pairs of holder and tool inside the contact zone."""
    in_h = np.flatnonzero((z_h >= zone[0] - MERGE_TOL) & (z_h <= zone[1] + MERGE_TOL))
    in_t = np.flatnonzero((z_t >= zone[0] - MERGE_TOL) & (z_t <= zone[1] + MERGE_TOL))
    if len(in_h) != len(in_t) or np.max(np.abs(z_h[in_h] - z_t[in_t])) > MERGE_TOL:
        # The breakpoint rules guarantee coincidence; anything else is a bug, not bad input.
        raise RuntimeError("holder and tool nodes do not coincide in the contact zone")
    nodes = np.stack([in_h, in_t], axis=1)
    elements = nodes[:-1]  # element e spans nodes e and e + 1
    return nodes, elements
