"""The built-in low-poly meshes: trees, a bush, rocks and buildings, built in code.

Every mesh is built deterministically from a few parameters (no binary assets ship with the
package) in real-world metres, its foot at the origin and Y up:

* ``conifer`` — a spruce-like tree 15 m tall: a bark-brown trunk and three stacked cones of
  dark needles;
* ``broadleaf`` — a deciduous tree 11 m tall: a trunk and a crown of three overlapping faceted
  blobs (about 8 m across);
* ``bush`` — a shrub 1.3 m tall and 2.6 m across;
* ``rock`` and ``boulder`` — irregular stones (convex hulls of seeded random points on a
  squashed ellipsoid), about 1.6 m and 3.5 m across, partly buried;
* ``house`` — 10 × 8 m plastered walls 4 m high with a gabled tile roof to 7 m;
* ``hall`` — a larger building, 22 × 14 m, 9 m walls and a hipped roof to 14 m.

The meshes are flat shaded (every triangle has its own three vertices and the triangle's
normal), coloured in linear RGB (bark, needles, leaves, stone, plaster, roof tiles; a small
seeded per-face variation keeps large faces from looking flat), wound counter-clockwise seen
from outside. Each mesh is a union of closed parts (every edge of a part, with the vertices
welded, is shared by exactly two triangles in opposite directions), which shadow volumes need.
Whatever stands on slopes reaches below its foot so that it meets sloping ground without a
gap: trunks 0.6 m, stones down to 0.55 m and 1.2 m (a 35° slope drops 0.6 m and 1.3 m under
their downhill edges), buildings on a foundation 1.5 m deep.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from terrascape.objects.model import ObjectMesh

__all__ = ["BUILTIN_NAMES", "builtin_mesh", "builtin_meshes"]

# Linear-RGB base colours (a sRGB photo of the material, converted to linear).
BARK = (0.090, 0.052, 0.030)
NEEDLES = (0.018, 0.060, 0.024)
LEAVES = (0.055, 0.140, 0.030)
SHRUB = (0.070, 0.125, 0.035)
STONE = (0.230, 0.215, 0.190)
PLASTER = (0.640, 0.580, 0.470)
ROOF_TILES = (0.330, 0.075, 0.035)
FOUNDATION = (0.200, 0.190, 0.175)

#: How far the buildings' foundations reach below their foot (metres).
FOUNDATION_DEPTH = 1.5
#: How far tree trunks reach below their foot (metres).
TRUNK_DEPTH = 0.6


class _Builder:
    """Collects flat-shaded triangles of closed parts, each oriented outward."""

    def __init__(self, seed: int) -> None:
        self.tris: list[np.ndarray] = []
        self.colours: list[np.ndarray] = []
        self.rng = np.random.default_rng(seed)

    def add(self, triangles: np.ndarray, colour, centre, *, jitter: float = 0.08) -> None:
        """Add ``(T, 3, 3)`` triangles of one convex (or star-shaped) closed part whose
        interior contains ``centre``; each is flipped if needed so its normal points away."""
        tri = np.asarray(triangles, np.float64).reshape(-1, 3, 3)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        outward = np.einsum("ij,ij->i", n, tri.mean(axis=1) - np.asarray(centre, np.float64))
        flip = outward < 0
        tri[flip] = tri[flip][:, [0, 2, 1]]
        self.tris.append(tri)
        # brightness varies per face (±jitter), hue kept: low-poly facets read as foliage/stone
        k = 1.0 + jitter * (2.0 * self.rng.random(len(tri)) - 1.0)
        self.colours.append(np.asarray(colour, np.float64)[None, :] * k[:, None])

    def mesh(self, name: str) -> ObjectMesh:
        tri = np.concatenate(self.tris)
        col = np.concatenate(self.colours)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        positions = tri.reshape(-1, 3)
        normals = np.repeat(n, 3, axis=0)
        colours = np.repeat(np.clip(col, 0.0, 1.0), 3, axis=0)
        indices = np.arange(len(positions), dtype=np.uint32).reshape(-1, 3)
        return ObjectMesh(name, positions.astype(np.float32), normals.astype(np.float32),
                          colours.astype(np.float32), indices)


def _ring(sides: int, radius: float, y: float, phase: float = 0.0) -> np.ndarray:
    a = phase + 2.0 * np.pi * np.arange(sides) / sides
    return np.stack([radius * np.cos(a), np.full(sides, y), radius * np.sin(a)], axis=1)


def _frustum(sides: int, r0: float, y0: float, r1: float, y1: float,
             phase: float = 0.0) -> np.ndarray:
    """Triangles of a closed truncated cone (``r1 = 0``: a cone) between heights y0 < y1."""
    lo = _ring(sides, r0, y0, phase)
    tris = []
    c0 = np.array([0.0, y0, 0.0])
    c1 = np.array([0.0, y1, 0.0])
    if r1 > 0:
        hi = _ring(sides, r1, y1, phase)
    for i in range(sides):
        j = (i + 1) % sides
        tris.append([c0, lo[j], lo[i]])  # bottom cap
        if r1 > 0:
            tris.append([lo[i], lo[j], hi[j]])
            tris.append([lo[i], hi[j], hi[i]])
            tris.append([c1, hi[i], hi[j]])  # top cap
        else:
            tris.append([lo[i], lo[j], c1])
    return np.asarray(tris)


def _hull(points: np.ndarray) -> np.ndarray:
    """Triangles of the convex hull of ``points`` (closed, convex)."""
    hull = ConvexHull(points)
    return points[hull.simplices]


def _blob(rng: np.random.Generator, centre, radii, *, points: int = 40,
          roughness: float = 0.18) -> np.ndarray:
    """A faceted blob: the convex hull of seeded points near an ellipsoid's surface."""
    v = rng.normal(size=(points, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v *= 1.0 + roughness * (2.0 * rng.random((points, 1)) - 1.0)
    return _hull(np.asarray(centre, np.float64) + v * np.asarray(radii, np.float64))


def _box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> np.ndarray:
    c = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.asarray([t for a, b, cc, d in quads for t in ([c[a], c[b], c[cc]],
                                                             [c[a], c[cc], c[d]])])


def conifer() -> ObjectMesh:
    """A spruce-like conifer, 15 m tall."""
    b = _Builder(seed=11)
    b.add(_frustum(6, 0.30, -TRUNK_DEPTH, 0.22, 3.2), BARK, (0, 1.6, 0), jitter=0.05)
    # three tiers of needles, each cone overlapping the one below like a spruce's whorls
    for r, y0, y1, phase in ((3.0, 2.2, 8.6, 0.0), (2.3, 6.0, 11.8, 0.4), (1.5, 9.4, 15.0, 0.8)):
        b.add(_frustum(8, r, y0, 0.0, y1, phase), NEEDLES, (0, y0 + (y1 - y0) / 4, 0))
    return b.mesh("conifer")


def broadleaf() -> ObjectMesh:
    """A deciduous tree, 11 m tall with a crown about 8 m across."""
    b = _Builder(seed=12)
    b.add(_frustum(6, 0.38, -TRUNK_DEPTH, 0.26, 5.0), BARK, (0, 2.5, 0), jitter=0.05)
    rng = np.random.default_rng(120)
    for centre, radii in (((0.0, 7.2, 0.0), (3.4, 2.9, 3.4)),
                          ((1.3, 8.6, 0.7), (2.4, 2.4, 2.3)),
                          ((-1.2, 8.2, -0.9), (2.3, 2.2, 2.4))):
        b.add(_blob(rng, centre, radii, points=36), LEAVES, centre, jitter=0.12)
    return b.mesh("broadleaf")


def bush() -> ObjectMesh:
    """A shrub 1.3 m tall above its foot and about 2.6 m across."""
    b = _Builder(seed=13)
    rng = np.random.default_rng(130)
    # sunk by half its height: on a slope its downhill side still meets the ground
    b.add(_blob(rng, (0.0, 0.3, 0.0), (1.3, 0.95, 1.2), points=28), SHRUB, (0, 0.3, 0),
          jitter=0.12)
    b.add(_blob(rng, (0.55, 0.15, 0.35), (0.8, 0.65, 0.75), points=18), SHRUB,
          (0.55, 0.15, 0.35), jitter=0.12)
    return b.mesh("bush")


def _rock(name: str, seed: int, radii, sink: float) -> ObjectMesh:
    b = _Builder(seed=seed)
    rng = np.random.default_rng(seed * 10)
    centre = (0.0, radii[1] - sink, 0.0)
    b.add(_blob(rng, centre, radii, points=40, roughness=0.22), STONE, centre, jitter=0.15)
    return b.mesh(name)


def rock() -> ObjectMesh:
    """A stone about 1.6 m across, half buried (0.55 m below its foot)."""
    return _rock("rock", 21, (0.85, 0.5, 0.7), 0.55)


def boulder() -> ObjectMesh:
    """A boulder about 3.5 m across, 1.6 m above its foot and 1.2 m below."""
    return _rock("boulder", 22, (1.8, 1.4, 1.5), 1.2)


def _gable_roof(x0, x1, z0, z1, y0, y1) -> np.ndarray:
    """A closed triangular prism along X: eaves at y0 along z0 and z1, ridge at y1."""
    zm = (z0 + z1) / 2
    a = [np.array(p, float) for p in ((x0, y0, z0), (x0, y0, z1), (x0, y1, zm))]
    c = [np.array(p, float) for p in ((x1, y0, z0), (x1, y0, z1), (x1, y1, zm))]
    tris = [[a[0], a[1], a[2]], [c[0], c[2], c[1]]]
    for i, j in ((0, 1), (1, 2), (2, 0)):
        tris += [[a[i], c[i], c[j]], [a[i], c[j], a[j]]]
    return np.asarray(tris)


def _hip_roof(x0, x1, z0, z1, y0, y1, inset) -> np.ndarray:
    """A closed hipped roof: the eave rectangle at y0, a ridge along X at y1 ``inset`` from
    the two short ends."""
    zm = (z0 + z1) / 2
    e = [np.array(p, float) for p in ((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1))]
    r0 = np.array((x0 + inset, y1, zm))
    r1 = np.array((x1 - inset, y1, zm))
    return np.asarray([
        [e[0], e[1], e[2]], [e[0], e[2], e[3]],  # the ceiling (closes the part)
        [e[0], r0, r1], [e[0], r1, e[1]],        # long side at z0
        [e[2], r1, r0], [e[2], r0, e[3]],        # long side at z1
        [e[1], r1, e[2]], [e[3], r0, e[0]],      # the hips
    ])


def house() -> ObjectMesh:
    """A house: 10 × 8 m plastered walls 4 m high, a gabled tile roof to 7 m."""
    b = _Builder(seed=31)
    b.add(_box(-5.0, 5.0, -FOUNDATION_DEPTH, 0.3, -4.0, 4.0), FOUNDATION, (0, -0.6, 0),
          jitter=0.03)
    b.add(_box(-4.9, 4.9, 0.3, 4.0, -3.9, 3.9), PLASTER, (0, 2.0, 0), jitter=0.04)
    b.add(_gable_roof(-5.4, 5.4, -4.6, 4.6, 3.8, 7.0), ROOF_TILES, (0, 4.8, 0), jitter=0.06)
    b.add(_box(2.2, 2.9, 5.0, 7.6, -2.1, -1.4), PLASTER, (2.55, 6.3, -1.75), jitter=0.04)
    return b.mesh("house")


def hall() -> ObjectMesh:
    """A larger building: 22 × 14 m, 9 m plastered walls, a hipped tile roof to 14 m."""
    b = _Builder(seed=32)
    b.add(_box(-11.0, 11.0, -FOUNDATION_DEPTH, 0.4, -7.0, 7.0), FOUNDATION, (0, -0.5, 0),
          jitter=0.03)
    b.add(_box(-10.9, 10.9, 0.4, 9.0, -6.9, 6.9), PLASTER, (0, 4.5, 0), jitter=0.04)
    b.add(_hip_roof(-11.6, 11.6, -7.6, 7.6, 8.8, 14.0, 6.0), ROOF_TILES, (0, 10.0, 0),
          jitter=0.06)
    return b.mesh("hall")


_BUILDERS = {
    "conifer": conifer,
    "broadleaf": broadleaf,
    "bush": bush,
    "rock": rock,
    "boulder": boulder,
    "house": house,
    "hall": hall,
}
#: The names of the built-in meshes.
BUILTIN_NAMES: tuple[str, ...] = tuple(_BUILDERS)
_CACHE: dict[str, ObjectMesh] = {}


def builtin_mesh(name: str) -> ObjectMesh:
    """One built-in mesh by name (see :data:`BUILTIN_NAMES`)."""
    from terrascape.errors import InvalidParameterError

    if name not in _BUILDERS:
        raise InvalidParameterError(
            f"unknown built-in mesh {name!r}; available: {', '.join(BUILTIN_NAMES)}")
    if name not in _CACHE:  # immutable (read-only arrays), so one copy serves every caller
        _CACHE[name] = _BUILDERS[name]()
    return _CACHE[name]


def builtin_meshes() -> dict[str, ObjectMesh]:
    """Every built-in mesh, ``{name: ObjectMesh}`` in :data:`BUILTIN_NAMES` order."""
    return {name: builtin_mesh(name) for name in BUILTIN_NAMES}
