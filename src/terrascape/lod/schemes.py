"""The view-dependent LOD schemes behind one interface, and the table that lists them.

Every scheme (ROAM, Turner's ROAM, geomipmapping) is a class built from a
:class:`~terrascape.Heightmap` that follows :class:`LodScheme`: ``update(camera, viewport,
*, tolerance_px, max_triangles, time_budget_ms)`` adapts the mesh to a view and returns
:class:`LodStats`, ``triangles(visible_only=...)`` gives the mesh. A scheme takes only some
of the three settings; :data:`SCHEMES` says which (with their defaults and key steps), and a
setting a scheme does not take raises :class:`~terrascape.errors.InvalidParameterError`.

The viewer (``L`` cycles ``none`` + the table, ``J`` picks the setting ``PgUp``/``PgDn``
change, ``--lod`` choices), ``terrascape mesh --lod``, ``bench lod_flight`` and
``docs/architecture.md`` all read :data:`SCHEMES`. This module imports no numba code: the
classes are imported when a scheme is built (the CLI's ``--help`` stays fast).

Adding a scheme: its module in ``lod/``, one :class:`Scheme` entry below, one test.
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from terrascape.errors import InvalidParameterError

if TYPE_CHECKING:
    import numpy as np

    from terrascape.camera import Camera
    from terrascape.heightmap import Heightmap


@runtime_checkable
class LodStats(Protocol):
    """What every scheme's ``update`` reports (schemes add their own fields)."""

    triangles: int  # triangles in the mesh after the update
    update_ms: float  # wall time of the update, milliseconds

    @property
    def settled(self) -> bool:
        """False when another update with the same view would still change the mesh (ROAM
        stopped by its time budget, Turner's threshold feedback still off its target)."""

    @property
    def summary(self) -> str:
        """One line for a HUD, e.g. ``max error 0.83 px (triangles)``."""


@runtime_checkable
class LodScheme(Protocol):
    """A view-dependent level-of-detail mesh over one heightmap."""

    heightmap: Heightmap

    def update(
        self,
        camera: Camera,
        viewport: tuple[int, int],
        *,
        tolerance_px: float | None = None,
        max_triangles: int | None = None,
        time_budget_ms: float | None = None,
    ) -> LodStats:
        """Adapt the mesh to ``camera`` and a ``(width, height)`` viewport in pixels."""

    def triangles(self, *, visible_only: bool = False) -> np.ndarray:
        """The mesh of the last update: uint32 ``(M, 3)`` grid vertex indices
        ``row·cols + col``, counter-clockwise seen from above (+Y). ``visible_only`` leaves
        out what the scheme's frustum test rejected."""


def unsupported(scheme: str, **given: Any) -> None:
    """Raise for the first setting in ``given`` that is not ``None`` (a scheme's ``update``
    calls this with the settings it does not take)."""
    for name, value in given.items():
        if value is not None:
            raise InvalidParameterError(f"{scheme} does not take {name} (got {value!r})")


@dataclass(frozen=True)
class LodParameter:
    """One ``update`` keyword a scheme takes.

    ``default`` is what the viewer starts with (``None``: not passed). ``step`` is the
    factor one ``PgUp``/``PgDn`` press multiplies or divides by (``None``: no key changes
    it); ``finer`` is +1 when a larger value gives a finer mesh (a triangle budget), -1 when
    a smaller one does (a pixel tolerance). ``off`` is a value meaning "no limit" that the
    keys reach below ``minimum`` (ROAM's tolerance 0: refine to the triangle budget).
    """

    name: str
    default: float | int | None
    help: str
    minimum: float = 0.0
    maximum: float = math.inf
    step: float | None = None
    finer: int = 1
    integer: bool = False
    off: float | None = None

    def stepped(self, value: float, *, finer: bool) -> float | int:
        """``value`` after one key press towards a finer (``finer``) or coarser mesh."""
        if self.step is None:
            return value
        grow = finer == (self.finer > 0)
        if self.off is not None and value == self.off:
            # "off" sits below the minimum: coarser leaves it for the minimum, finer stays
            new = self.minimum if grow else self.off
        else:
            new = value * self.step if grow else value / self.step
            if self.off is not None and new < self.minimum:
                new = self.off
            else:
                new = min(self.maximum, max(self.minimum, new))
        return int(new) if self.integer else float(new)

    def label(self, value: float | None) -> str:
        """``value`` as the HUD shows it."""
        short, unit = _LABELS.get(self.name, (self.name, ""))
        if value is None or (self.off is not None and value == self.off):
            return f"{short} off"
        if self.integer:
            return f"{short} {int(value):,}{unit}"
        return f"{short} {value:.2f}{unit}"


_LABELS = {"max_triangles": ("target", " tris"), "tolerance_px": ("tolerance", " px"),
           "time_budget_ms": ("time budget", " ms")}


TRIANGLE_BUDGET = LodParameter(
    "max_triangles", 80_000, "triangle budget per frame", minimum=1_000, maximum=2_000_000,
    step=1.25, finer=1, integer=True)
TIME_BUDGET = LodParameter("time_budget_ms", None, "update time budget (milliseconds)")


@dataclass(frozen=True)
class Scheme:
    """One row of :data:`SCHEMES`.

    ``target`` is ``"module:Class"`` (imported by :meth:`load`), ``options`` the
    constructor keywords for a map of ``n`` samples a side (patch sizes), ``draw_visible_only``
    what a renderer draws (``triangles(visible_only=...)``), ``label`` the name in tables.
    """

    name: str
    target: str
    label: str
    help: str
    parameters: tuple[LodParameter, ...]
    options: dict[str, int] = field(default_factory=dict)
    draw_visible_only: bool = False

    def load(self) -> type:
        module, _, cls = self.target.partition(":")
        return getattr(importlib.import_module(module), cls)

    def constructor_options(self, n: int) -> dict[str, int]:
        """Constructor keywords for an ``n``-sample map (patch sizes capped at ``n``)."""
        return {k: min(v, n) if k == "patch_size" else v for k, v in self.options.items()}

    def build(self, heightmap: Heightmap, **options: Any) -> LodScheme:
        """A new scheme over ``heightmap`` (``options`` override :meth:`constructor_options`)."""
        kwargs = self.constructor_options(heightmap.rows)
        kwargs.update(options)
        return self.load()(heightmap, **kwargs)

    def parameter(self, name: str) -> LodParameter | None:
        return next((p for p in self.parameters if p.name == name), None)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def adjustable(self) -> tuple[LodParameter, ...]:
        """The parameters the viewer's keys change, in ``J`` order."""
        return tuple(p for p in self.parameters if p.step is not None)

    def defaults(self) -> dict[str, float | int | None]:
        return {p.name: p.default for p in self.parameters}


SCHEMES: dict[str, Scheme] = {
    s.name: s
    for s in (
        Scheme(
            "roam", "terrascape.lod.roam:Roam", "ROAM",
            "ROAM: split/merge queues kept across frames (Duchaineau et al. 1997)",
            (TRIANGLE_BUDGET,
             LodParameter("tolerance_px", 0.0, "screen-space error tolerance (pixels; "
                          "off: refine to the budget)", minimum=0.25, maximum=64.0,
                          step=1.25, finer=-1, off=0.0),
             TIME_BUDGET),
        ),
        Scheme(
            "turner", "terrascape.lod.turner_roam:TurnerRoam", "Turner",
            "Turner's split-only ROAM over patches, rebuilt each frame to a triangle target",
            (TRIANGLE_BUDGET,),
            {"patch_size": 65}, draw_visible_only=True,
        ),
        Scheme(
            "geomipmap", "terrascape.lod.geomipmap:Geomipmap", "geomipmap",
            "geomipmapping: a level per patch from its screen-space error (de Boer 2000)",
            (LodParameter("tolerance_px", 2.0, "screen-space error tolerance (pixels)",
                          minimum=0.25, maximum=64.0, step=1.25, finer=-1),),
            {"patch_size": 17}, draw_visible_only=True,
        ),
    )
}


def scheme(name: str) -> Scheme:
    """The :data:`SCHEMES` entry ``name``; a one-line error naming the choices otherwise."""
    try:
        return SCHEMES[name]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"LOD scheme must be one of {', '.join(SCHEMES)}, got {name!r}") from None


__all__ = [
    "SCHEMES",
    "LodParameter",
    "LodScheme",
    "LodStats",
    "Scheme",
    "scheme",
    "unsupported",
]
