"""Discretisation options of the free-free model (docs/physics.md §1).

The defaults give a converged model (docs/physics.md §1): halving every
element changes f1–f3 by less than 0.05 % and ζ1 by less than 1 %. They are finer than
the mesh first chosen (0.25 mm growing ×1.3 to 1.5 mm): that one passes the
bundled and development assemblies with ≈20 % margin but failed on random assemblies
with short contact zones or slender tools at corners of the search space (worst change
0.13 %). With these defaults the worst change over 42 random assemblies × 5 hard
corners was 0.034 % (f) and 0.12 % (ζ1), at ≈1.3× the DOFs (≈380 for the reference
assembly).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

SHEAR_FORMULAS = ("hutchinson", "cowper")
MASS_VARIANTS = ("consistent", "core")


@dataclass(frozen=True)
class ModelOptions:
    """How an assembly is meshed and which element variants are used.

    Parameters
    ----------
    h_max_mm : float
        Largest element outside the graded contact-zone ends [mm].
    zone_h_min_mm : float
        Element length at both ends of the contact zone [mm]; the stiff contact layer
        loads the beams in a boundary layer a few mm long there.
    layer_h_min_ratio, layer_h_max_ratio : float
        The first and the largest zone element are also no longer than these multiples
        of the shortest contact boundary layer over the search space (slender tools
        under the stiffest admissible contact, see
        :func:`taptune.model.mesh.boundary_layer_length`).
    zone_growth : float
        Ratio between neighbouring element lengths moving away from a zone end.
    zone_h_max_mm : float
        Largest element inside the contact zone [mm].
    elements_per_wavelength : float
        Every element is also no longer than the local bending wavelength at the highest
        reachable third bending frequency divided by this (0 switches it off); it only
        bites in stubby assemblies with high third modes.
    shear : {"hutchinson", "cowper"}
        Shear-coefficient formula for hollow circular sections (docs/physics.md §1).
    mass : {"consistent", "core"}
        Element mass matrix (docs/physics.md §1).
    mesh_scale : float
        1 for the default mesh. A value s < 1 splits every element of the default
        mesh into ``ceil(1/s)`` equal parts (0.5 halves every element, which is how the
        convergence requirement is checked); s > 1 multiplies every target element
        length by s (coarser meshes for studies).
    """

    h_max_mm: float = 2.0
    zone_h_min_mm: float = 0.25
    layer_h_min_ratio: float = 0.07
    layer_h_max_ratio: float = 1.5
    zone_growth: float = 1.2
    zone_h_max_mm: float = 1.0
    elements_per_wavelength: float = 40.0
    shear: str = "hutchinson"
    mass: str = "consistent"
    mesh_scale: float = 1.0

    def __post_init__(self):
        for name in ("h_max_mm", "zone_h_min_mm", "layer_h_min_ratio", "layer_h_max_ratio", "zone_h_max_mm", "mesh_scale"):
            value = getattr(self, name)
            if not value > 0:
                raise ValueError(f"ModelOptions.{name} must be > 0, got {value!r}")
        if not self.zone_growth >= 1.0:
            raise ValueError(f"ModelOptions.zone_growth must be >= 1, got {self.zone_growth!r}")
        if not self.elements_per_wavelength >= 0:
            raise ValueError(f"ModelOptions.elements_per_wavelength must be >= 0, got {self.elements_per_wavelength!r}")
        if self.zone_h_min_mm > self.zone_h_max_mm:
            raise ValueError("ModelOptions.zone_h_min_mm must not exceed zone_h_max_mm")
        if self.shear not in SHEAR_FORMULAS:
            raise ValueError(f"ModelOptions.shear must be one of {SHEAR_FORMULAS}, got {self.shear!r}")
        if self.mass not in MASS_VARIANTS:
            raise ValueError(f"ModelOptions.mass must be one of {MASS_VARIANTS}, got {self.mass!r}")

    def to_dict(self) -> dict:
        """Plain JSON-able options, stored with every holder-library entry for provenance."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict, source: str = "model options") -> "ModelOptions":
        """Inverse of :meth:`to_dict`; unknown keys are ignored (newer versions may add some).

        The data come from files (the holder library), so a bad value is an InputError
        naming ``source``, not a traceback.
        """
        from taptune.errors import InputError

        if not isinstance(data, dict):
            raise InputError(f"{source}: must be a table of model options, got {type(data).__name__}")
        known = {k: data[k] for k in cls.__dataclass_fields__ if k in data}
        for key, value in known.items():
            want = (int, float) if isinstance(getattr(cls(), key), float) else str
            if isinstance(value, bool) or not isinstance(value, want):
                raise InputError(f"{source}: {key} must be a {'number' if want != str else 'string'}, got {value!r}")
        try:
            return cls(**known)
        except (TypeError, ValueError) as err:
            raise InputError(f"{source}: {err}") from None
