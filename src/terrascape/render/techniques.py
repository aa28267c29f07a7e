"""Registry of terrain shading techniques: name → program file, textures, default parameters.

A :class:`Technique` says which ``.glsl`` program draws the terrain, which textures it samples
(each a :class:`TextureSlot` whose builder makes the default texture from the heightmap) and
which parameters it accepts with their defaults. :class:`~terrascape.render.terrain.
TerrainRenderer` does the rest, so adding a technique (e.g. parallax/relief mapping in
``render/shaders/relief/``) is one :func:`register_technique` call — in a module named
``render/tech_<name>.py``, which :func:`get_technique` imports automatically.

Shader interface every technique program can rely on (see ``shaders/common/``):

* vertex stage: ``#include "common/terrain_vertex.glsl"`` — attributes ``in_position``,
  ``in_normal``, ``in_tangent`` (xyz + handedness w, B = w·N×T); outputs ``v_world``,
  ``v_normal``, ``v_tangent``, ``v_uv`` (planar mapping ``grid·u_uv_scale``) and ``v_grid``
  (``x/extent_x, z/extent_z`` ∈ [0, 1]);
* fragment stage: ``#include "common/terrain_fragment.glsl"`` — the inputs above,
  ``out vec4 f_color``, ``grid_texcoord(sampler)`` (texel-centre lookup of textures aligned
  with the vertices), ``shade(albedo, N)`` (the ``lighting`` parameter: none / Phong with the
  given normal / × lightmap / daylight — linear radiance with the per-pixel soft terrain
  shadows and sky light of :mod:`terrascape.lighting.daylight`), ``phong(...)`` (daylight
  too when it is on) and ``finish(color)`` (daylight: aerial perspective, exposure, ACES
  tone map, sRGB; otherwise fog; alpha 1);
* uniforms set by the renderer every frame: ``u_view_proj``, ``u_camera_pos``, ``u_extent``,
  ``u_spacing``, ``u_grid_size``, ``u_exaggeration``, ``u_height_range`` (world, exaggerated),
  ``u_sun_dir``, and every parameter ``name`` as ``u_name`` (skipped if the program lacks it)
  except those read on the CPU (:data:`CPU_PARAMS` and the technique's ``cpu_params``).

What is particular to a technique lives on its entry, not in the renderer: its textures
(``textures``), the uniforms it derives from its parameters (the ``uniforms`` hook, e.g. the
region table of ``regions``), the parameters that are not uniforms (``cpu_params``), whether
it is shaded deferred (``deferred``) and what draws when this GL cannot run it
(``fallback``; :func:`choose_drawable` decides it once per context and says so once).
"""

from __future__ import annotations

import importlib
import math
import pkgutil
import warnings
import weakref
from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from terrascape._validate import check_positive
from terrascape.errors import GLUnavailableError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture.hextile import HEX_CONTRAST, HEX_ROTATION, HEX_SHARPNESS

LIGHTING_MODES = {"none": 0, "vertex": 1, "lightmap": 2, "daylight": 3}

#: The height-field tracers of the relief programs (``relief/common/heightfield.glsl``),
#: selected with ``#define TECHNIQUE <id>``. The shader loader defines ``TECH_<NAME>`` for
#: each in every program (:func:`terrascape.render.shaders.load_source`), so the GLSL
#: compares ``TECHNIQUE == TECH_RELIEF`` and no ``.glsl`` file keeps a copy of the numbers.
#: The names are the relief quad's (``terrascape relief``); the terrain techniques map to
#: them in :mod:`terrascape.render.relief_techniques`.
RELIEF_TRACERS: dict[str, int] = {
    "plain": 0,
    "parallax": 1,
    "offset_limiting": 2,
    "steep": 3,
    "pom": 4,
    "relief": 5,
    "interval": 6,
    "cone": 7,
    "minmax": 8,
    "by_distance": 10,
}


def tracer_id_defines() -> dict[str, int]:
    """``TECH_<NAME>`` → id of every relief tracer: the ``#define`` block every program gets."""
    return {f"TECH_{name.upper()}": tid for name, tid in RELIEF_TRACERS.items()}


@dataclass(frozen=True)
class TextureData:
    """CPU-side texture: ``data`` plus how to sample it.

    Parameters
    ----------
    data
        ``uint8``/``uint16``/``float32``; ``(H, W)`` or ``(H, W, C)`` for ``kind="2d"``,
        ``(L, H, W)`` or ``(L, H, W, C)`` for ``"3d"`` and ``"array"``; ``C`` in 1..4.
    kind
        ``"2d"``, ``"3d"`` (``sampler3D``) or ``"array"`` (``sampler2DArray``).
    repeat
        Wrap (tiled material textures) or clamp to edge (maps aligned with the grid). A 3D
        texture always clamps along depth, so the top layer never blends into the bottom one.
    mipmaps
        Build mipmaps and sample trilinearly (off for 3D textures: their mip levels would
        average the layers together).
    nearest
        Sample without filtering or mipmaps (lookup tables such as cone maps, whose
        interpolated values would be wrong).
    levels
        An explicit mip chain for a 2D texture: levels 1, 2, … (level 0 is ``data``), each
        half the size of the previous one, sampled NEAREST (e.g. min/max depth pyramids,
        which averaging would break). The renderer also sets the integer uniform
        ``<sampler>_levels`` to the number of levels including level 0.
    mip_blend
        With ``mipmaps``: blend the two nearest mip levels (trilinear). ``False`` reads only
        the nearest level (half the texel reads; for textures a shader samples many times
        per pixel, where a software rasteriser pays for every read).
    """

    data: np.ndarray
    kind: str = "2d"
    repeat: bool = True
    mipmaps: bool = True
    nearest: bool = False
    levels: tuple[np.ndarray, ...] = ()
    mip_blend: bool = True


TextureBuilder = Callable[[Heightmap, Mapping[str, Any]], TextureData]
#: ``uniforms(renderer, params) -> {uniform: value}``: what a technique derives from its
#: parameters each frame (the renderer gives ``heightmap``, ``regions(params)`` and
#: ``tile_size(params)``).
UniformsHook = Callable[[Any, Mapping[str, Any]], dict[str, Any]]


@dataclass(frozen=True)
class TextureSlot:
    """A sampler uniform of a technique and how to build its default texture.

    ``depends`` names parameters whose change rebuilds the texture (e.g. the lightmap depends
    on ``sun``); ``when`` makes the slot conditional on the parameters.
    """

    uniform: str
    builder: TextureBuilder
    depends: tuple[str, ...] = ()
    when: Callable[[Mapping[str, Any]], bool] | None = None
    description: str = ""


@dataclass(frozen=True)
class Technique:
    """A shading technique: ``program`` under ``render/shaders`` plus textures and params."""

    name: str
    program: str
    textures: tuple[TextureSlot, ...] = ()
    defaults: Mapping[str, Any] = field(default_factory=dict)
    defines: Mapping[str, Any] = field(default_factory=dict)
    description: str = ""
    # Per-pixel shading heavy enough (several texture layers, a ray march) that a frame of
    # sub-pixel triangles on a software rasteriser is cheaper shaded once per pixel in a
    # deferred pass (TerrainRenderer's deferred_shading) than triangle by triangle.
    deferred: bool = False
    # the technique's own uniforms from its parameters (UniformsHook), beyond u_<name>
    uniforms: UniformsHook | None = None
    # its parameters read on the CPU (texture builders, the uniforms hook): never u_<name>
    cpu_params: frozenset[str] = frozenset()
    # what draws instead when this GL cannot run the program (None: nothing, it raises)
    fallback: str | None = "plain"

    def parameters(self) -> dict[str, Any]:
        """All accepted parameters with defaults (common ones, then the technique's)."""
        return {**COMMON_PARAMS, **self.defaults}

    def resolve(self, params: Mapping[str, Any] | None) -> dict[str, Any]:
        """Defaults overlaid with ``params``; unknown names raise with the valid list."""
        merged = self.parameters()
        for key, value in (params or {}).items():
            if key not in merged and key != "textures":
                raise InvalidParameterError(
                    f"unknown parameter {key!r} for technique {self.name!r}; valid: "
                    + ", ".join(sorted(merged))
                )
            merged[key] = value
        lighting = merged["lighting"]
        if lighting not in LIGHTING_MODES:
            raise InvalidParameterError(
                f"lighting must be one of {', '.join(LIGHTING_MODES)}, got {lighting!r}"
            )
        return merged

    def active_slots(self, params: Mapping[str, Any]) -> list[TextureSlot]:
        return [s for s in self.textures if s.when is None or s.when(params)]

    def parameter_uniforms(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """``u_<name>`` for every set parameter that is not read on the CPU (booleans as
        integers); the program skips the ones it does not declare."""
        return parameter_uniforms(params, CPU_PARAMS | self.cpu_params)


def parameter_uniforms(params: Mapping[str, Any],
                       cpu_params: frozenset[str] | None = None) -> dict[str, Any]:
    """``u_<name>`` for every set parameter not in ``cpu_params`` (default
    :data:`CPU_PARAMS`), booleans as integers."""
    cpu = CPU_PARAMS if cpu_params is None else cpu_params
    out = {}
    for key, value in params.items():
        if key in cpu or key == "textures" or value is None:
            continue
        if isinstance(value, (bool, np.bool_)):
            value = int(value)
        out[f"u_{key}"] = value
    return out


# ----------------------------------------------------------------------------------------
# Default texture builders (CPU algorithms from terrascape.texture / terrascape.lighting)
# ----------------------------------------------------------------------------------------
def _regions(hm: Heightmap, params: Mapping[str, Any]):
    from terrascape.texture import default_regions

    regions = params.get("regions")
    return default_regions(hm) if regions is None else list(regions)


def _material(name: str, params: Mapping[str, Any]) -> np.ndarray:
    from terrascape.texture import BUILTIN_MATERIALS, builtin_material

    key = name.lower() if name.lower() in BUILTIN_MATERIALS else "rock"
    return builtin_material(key, int(params["material_size"]), seed=int(params["seed"]))


def _region_materials(hm: Heightmap, params: Mapping[str, Any]) -> np.ndarray:
    """``(L, S, S, 3)`` material textures, one per region (user textures when given)."""
    from terrascape.texture.materials import load_texture

    size = int(params["material_size"])
    layers = [
        load_texture(
            r.texture, default_name=_builtin_name(r.name), size=size, seed=int(params["seed"])
        )
        for r in _regions(hm, params)
    ]
    return np.stack(layers)


def _builtin_name(name: str) -> str:
    from terrascape.texture import BUILTIN_MATERIALS

    return name.lower() if name.lower() in BUILTIN_MATERIALS else "rock"


def build_region_texture(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Filipović 2008 §3.1.1 procedural colour texture, one texel per vertex (clamped)."""
    from terrascape.texture import region_texture

    tex = region_texture(hm, params.get("regions"), seed=int(params["seed"]))
    return TextureData(tex, repeat=False)


def build_lightmap(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Filipović 2008 §3.2.2 lightmap (slope shading × cast shadows) for the current sun."""
    from terrascape.lighting.shadows import lightmap

    az, el = params["sun"]
    lm = lightmap(
        hm, az, el, ambient=float(params["lightmap_ambient"]), shadows=bool(params["shadows"])
    )
    return TextureData(np.ascontiguousarray(lm, dtype=np.float32), repeat=False)


def build_detail(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Grey detail texture (Filipović 2008 §3.1.1: a second texture unit with tiled noise), centred
    on 0.5 so that ``2·detail`` modulates the colour around 1."""
    rgb = _material("sand", params).astype(np.float32)
    lum = rgb @ np.array([0.299, 0.587, 0.114], dtype=np.float32)
    lum = 0.5 + (lum - lum.mean()) / max(float(lum.std()), 1e-6) * 0.12
    return TextureData(np.clip(lum, 0.0, 1.0).astype(np.float32), repeat=True)


def build_material_array(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    return TextureData(_region_materials(hm, params), kind="array", repeat=True)


def build_layer_volume(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Filipović 2008 §3.1.2: layer textures stacked along r (``layer_stack``) as a 3D texture."""
    from terrascape.texture import layer_stack

    stack = layer_stack(list(_region_materials(hm, params)))
    return TextureData(stack, kind="3d", repeat=True, mipmaps=False)


def build_layer_coordinate(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Per-vertex 3D-texture depth coordinate r (``layer_coordinate``), float, clamped."""
    from terrascape.texture import layer_coordinate

    r = layer_coordinate(hm, params.get("regions"))
    return TextureData(np.ascontiguousarray(r, dtype=np.float32), repeat=False, mipmaps=False)


def _splat_maps(hm: Heightmap, params: Mapping[str, Any]) -> list[np.ndarray]:
    from terrascape.texture import material_ids_from_rules, pack_splat_maps, splat_weights

    regions = _regions(hm, params)
    if len(regions) > 8:
        raise InvalidParameterError(f"splat supports at most 8 layers, got {len(regions)}")
    ids = material_ids_from_rules(hm, regions)
    return pack_splat_maps(splat_weights(ids, n_materials=len(regions)))


def build_splat0(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Filipović 2008 §3.1.3: RGBA alpha map of layers 0–3 (vertex resolution)."""
    return TextureData(_splat_maps(hm, params)[0], repeat=False)


def build_splat1(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Alpha map of layers 4–7 (zeros when there are at most four layers)."""
    maps = _splat_maps(hm, params)
    data = maps[1] if len(maps) > 1 else np.zeros_like(maps[0])
    return TextureData(data, repeat=False)


def build_normal_height(hm: Heightmap, params: Mapping[str, Any]) -> TextureData:
    """Tiled RGBA normal+height texture (Janković 2010 §2.3.1) of a rock photo's relief.

    The detail height is the photo's luminance (``height_from_image`` idea of Janković 2010:
    bright = high; :func:`terrascape.texture.photo_materials.detail_normal_height`), its
    normals in RGB and the height in A. ``bump_height`` scales the relief. bump.glsl
    hex-tiles it, so the tiling leaves no grid of seams.
    """
    from terrascape.texture.photo_materials import detail_normal_height

    size = int(params["material_size"])
    size = 1 << max(4, min(11, size.bit_length() - 1))  # photo layers: powers of two
    data = detail_normal_height("rock", size, seed=int(params["seed"]),
                                strength=float(params["bump_height"]))
    return TextureData(data, repeat=True)


# ----------------------------------------------------------------------------------------
# Parameters shared by every technique
# ----------------------------------------------------------------------------------------
COMMON_PARAMS: dict[str, Any] = {
    "sun": (135.0, 45.0),  # (azimuth°, elevation°); terrascape.lighting.sun convention
    # none | vertex (Phong with the vertex normal) | lightmap | daylight (sun + sky + bounce
    # with per-pixel soft terrain shadows, Preetham sky, aerial perspective, ACES tone map)
    "lighting": "daylight",
    "ka": 0.35,
    "kd": 0.75,
    "ks": 0.0,
    "shininess": 32.0,
    "ambient_color": (1.0, 1.0, 1.0),
    "diffuse_color": (1.0, 1.0, 1.0),
    "specular_color": (1.0, 1.0, 1.0),
    "sky": True,
    "horizon_color": (0.74, 0.82, 0.92),
    "zenith_color": (0.26, 0.46, 0.80),
    "sun_color": (1.0, 0.95, 0.85),
    "fog_density": None,  # per world unit; None = automatic from the terrain size, 0 = off
    "fog_color": None,  # None = horizon colour
    "wireframe": False,
    "wireframe_color": (0.05, 0.05, 0.05, 1.0),
    "uv_scale": 16.0,  # planar mapping repeats over the terrain (v_uv)
    "tile_size": None,  # world units per material repeat; None = 32 × max spacing
    "seed": 0,  # seeds the built-in materials
    "regions": None,  # list[terrascape.texture.Region]; None = default_regions(heightmap)
    "material_size": 256,
    "lightmap_ambient": 0.2,
    "shadows": True,
    # daylight look (terrascape.lighting.daylight, terrascape.render.atmosphere)
    "turbidity": 3.0,  # haze of the sky model, 1.7 (very clear) … 10 (hazy)
    "exposure": 0.0,  # stops on top of the automatic exposure
    "haze": None,  # aerial-perspective extinction per world unit; None = automatic, 0 = off
    "sun_radius": 0.5,  # degrees: the sun's disc (and aureole) that softens the shadows
    "shadow_samples": 6,  # shadow sweeps over the sun's disc (penumbra levels)
    "sea_level": None,  # water surface height (heightmap units, before exaggeration)
    "water_depth": None,  # float32 (rows, cols) water depth on the terrain (lakes), or None
    "surround": None,  # beyond the terrain: sea | plane | fade; None = sea with a sea level,
    # else fade
    "time": 0.0,  # seconds, animates the water ripples
    # sun, moon and stars of a date and place (terrascape.lighting.solar_position.SkyState);
    # None: the sun of "sun", no moon
    "sky_state": None,
    # objects on the terrain (TerrainRenderer.set_objects; terrascape.render.objects)
    "object_shadows": None,  # cascades | volumes | none; None = cascades with objects
    "impostor_pixels": 48.0,  # objects shorter than this on screen are drawn as impostors
    "cascade_resolution": None,  # texels per side of each sun cascade; None = automatic
    "cascade_terrain": False,  # draw the terrain into the cascades too (else: ray-cast)
}

#: Common parameters the renderer turns into uniforms itself (sun, lighting, fog, tile
#: size, the daylight look) or reads on the CPU (textures, shadows, water, the sky, objects'
#: own settings are read by their renderers): none is sent as ``u_<name>``.
CPU_PARAMS = frozenset({
    "sun", "lighting", "fog_density", "fog_color", "tile_size", "regions", "seed",
    "material_size", "sky", "wireframe", "shadows", "lightmap_ambient", "turbidity",
    "exposure", "haze", "sun_radius", "shadow_samples", "sea_level", "water_depth",
    "surround", "sky_state",
})  # fmt: skip

_REGISTRY: dict[str, Technique] = {}
_DISCOVERED = False


def register_technique(technique: Technique, *, replace: bool = False) -> Technique:
    """Add a technique; a second one with the same name needs ``replace=True``."""
    if not isinstance(technique, Technique):
        raise InvalidParameterError(f"expected a Technique, got {type(technique).__name__}")
    if technique.name in _REGISTRY and not replace:
        raise InvalidParameterError(
            f"technique {technique.name!r} is already registered (pass replace=True)"
        )
    _REGISTRY[technique.name] = technique
    return technique


def _discover() -> None:
    """Import the relief family and the ``terrascape.render.tech_*`` modules once (they
    register their techniques)."""
    global _DISCOVERED
    if _DISCOVERED:
        return
    _DISCOVERED = True
    import terrascape.render as pkg

    # the relief mapping family is built in: registered by its own module, which imports
    # this one (so it is imported here, not at the top)
    importlib.import_module("terrascape.render.relief_techniques")
    for mod in pkgutil.iter_modules(pkg.__path__):
        if mod.name.startswith("tech_"):
            importlib.import_module(f"terrascape.render.{mod.name}")


#: Old or other spellings of registered technique names (the relief quad's, the viewer's,
#: hyphens for underscores): accepted everywhere a technique name is, with a one-line
#: deprecation note naming the registered name.
TECHNIQUE_ALIASES: dict[str, str] = {
    "offset_limiting": "parallax_limited",
    "offset-limiting": "parallax_limited",
    "offset-limited": "parallax_limited",
    "offset_limited": "parallax_limited",
    "parallax-limited": "parallax_limited",
    "steep": "steep_parallax",
    "steep-parallax": "steep_parallax",
    "by_distance": "relief_by_distance",
    "by-distance": "relief_by_distance",
    "relief-by-distance": "relief_by_distance",
    "texture-3d": "texture3d",
    "texture_3d": "texture3d",
}


def canonical_technique_name(name: str, *, warn: bool = True) -> str:
    """The registered name for ``name``: itself, or the name an alias stands for (with a
    ``FutureWarning`` saying so when ``warn``). Unknown names are returned unchanged."""
    if name in TECHNIQUE_ALIASES:
        canonical = TECHNIQUE_ALIASES[name]
        if warn:
            warnings.warn(f"technique {name!r} is now called {canonical!r}; the old name "
                          "will stop working in a later version", FutureWarning, stacklevel=3)
        return canonical
    return name


def technique_names() -> list[str]:
    """Registered technique names, sorted (aliases not included)."""
    _discover()
    return sorted(_REGISTRY)


def get_technique(name: str) -> Technique:
    """The technique called ``name`` (or an alias of it, see :data:`TECHNIQUE_ALIASES`);
    unknown names raise listing the available ones."""
    _discover()
    if isinstance(name, Technique):
        return name
    try:
        return _REGISTRY[canonical_technique_name(name) if isinstance(name, str) else name]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"unknown technique {name!r}; available: {', '.join(sorted(_REGISTRY))}"
        ) from None


# ----------------------------------------------------------------------------------------
# Which technique draws: the fallback, decided once per context
# ----------------------------------------------------------------------------------------
class TechniqueFallbackWarning(UserWarning):
    """A technique could not run on this GL; its fallback (plain texturing) drew instead."""


@dataclass(frozen=True)
class DrawnTechnique:
    """What drew a frame: the ``requested`` technique, or its fallback ``name`` because this
    GL could not run it (``reason``: the first line of the driver's error)."""

    requested: str
    name: str
    reason: str | None = None

    @property
    def fell_back(self) -> bool:
        return self.name != self.requested


_Built = TypeVar("_Built")
# context -> {key of a program this GL could not build: the reason}
_UNAVAILABLE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def choose_drawable(
    ctx,
    requested: str,
    build: Callable[[str], _Built],
    *,
    fallback: str | None,
    key: Hashable = None,
    what: str = "technique",
    category: type[Warning] = TechniqueFallbackWarning,
    warn: Callable[[str], None] | None = None,
) -> tuple[_Built, DrawnTechnique]:
    """Build ``requested`` on ``ctx``, or ``fallback`` when this GL cannot (Janković 2010
    §2.6.4.3: a technique the hardware cannot run degrades to plain texturing instead of
    stopping the program).

    The decision is made once per context and ``key`` (default: ``requested``): the first
    failure says so once — through ``warn(message)``, or as a ``category`` warning — and
    later calls build the fallback without trying again. Callers read the returned
    :class:`DrawnTechnique`, not the warning.

    Raises
    ------
    GLUnavailableError
        When ``requested`` has no fallback (or is its own), or the fallback fails too.
    """
    known = _UNAVAILABLE.setdefault(ctx, {})
    key = requested if key is None else key
    reason = known.get(key)
    if reason is None:
        try:
            return build(requested), DrawnTechnique(requested, requested)
        except GLUnavailableError as exc:
            if fallback is None or fallback == requested:
                raise
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            known[key] = reason
            message = (f"{what} {requested!r} is not available on this GL ({reason}); "
                       f"rendering {fallback} texturing instead")
            if warn is not None:
                warn(message)
            else:
                warnings.warn(message, category, stacklevel=3)
    return build(fallback), DrawnTechnique(requested, fallback, reason)


# ----------------------------------------------------------------------------------------
# Uniform hooks of the built-in techniques
# ----------------------------------------------------------------------------------------
def layer_count_uniforms(renderer: Any, params: Mapping[str, Any]) -> dict[str, Any]:
    """``u_n_layers``: how many region layers the technique's textures hold."""
    return {"u_n_layers": len(renderer.regions(params))}


def region_uniforms(renderer: Any, params: Mapping[str, Any]) -> dict[str, Any]:
    """The height-region table of ``regions`` (Filipović 2008 T1: each region's maximum and
    range, the water and rock layers, the slope band where rock takes over) and the detail
    texture's repeat (``detail_size``; ``None``: a fifth of the material tile)."""
    from terrascape.texture import SlopeRule

    regions = renderer.regions(params)
    if not 1 <= len(regions) <= 8:
        raise InvalidParameterError(f"regions: 1 to 8 regions supported, got {len(regions)}")
    maxs = np.zeros(8)
    ranges = np.ones(8)
    maxs[: len(regions)] = [r.max for r in regions]
    ranges[: len(regions)] = [r.range for r in regions]
    names = [r.name.lower() for r in regions]
    rule = params["slope_rule"]
    rock, s0, s1 = -1, 0.0, 0.0
    if rule is True:
        rule = SlopeRule() if "rock" in names else None
    if rule:
        if not isinstance(rule, SlopeRule):
            raise InvalidParameterError(f"slope_rule must be bool or SlopeRule, got {rule!r}")
        if rule.region.lower() not in names:
            raise InvalidParameterError(
                f"slope rule region {rule.region!r} is not among the regions {names}"
            )
        rock = names.index(rule.region.lower())
        s0, s1 = math.radians(rule.start_deg), math.radians(rule.end_deg)
    detail = params["detail_size"]
    return {
        "u_detail_size": (renderer.tile_size(params) / 5.0 if detail is None
                          else check_positive(detail, "detail_size")),
        "u_n_regions": len(regions),
        "u_region_max": maxs,
        "u_region_range": ranges,
        "u_water_index": names.index("water") if "water" in names else -1,
        "u_rock_index": rock,
        "u_slope_start": s0,
        "u_slope_end": s1,
        "u_n_layers": len(regions),
    }


def _wants_lightmap(params: Mapping[str, Any]) -> bool:
    return params["lighting"] == "lightmap"


LIGHTMAP_SLOT = TextureSlot(
    "u_lightmap",
    build_lightmap,
    depends=("sun", "lightmap_ambient", "shadows"),
    when=_wants_lightmap,
    description="lightmap (terrascape.lighting.lightmap)",
)
_REGION_DEPS = ("seed", "regions", "material_size")

register_technique(
    Technique(
        "plain",
        "terrain/plain",
        textures=(
            TextureSlot(
                "u_color_tex",
                build_region_texture,
                depends=("seed", "regions"),
                description="colour texture, one texel per vertex (region_texture)",
            ),
            LIGHTMAP_SLOT,
        ),
        description="one colour texture (default: procedural region texture), optional lightmap",
        fallback=None,  # the last resort: a GL that cannot draw it cannot draw terrain
    )
)
register_technique(
    Technique(
        "regions",
        "terrain/regions",
        deferred=True,
        textures=(
            TextureSlot(
                "u_materials",
                build_material_array,
                depends=_REGION_DEPS,
                description="one tiled material per region (2D texture array)",
            ),
            TextureSlot(
                "u_detail",
                build_detail,
                depends=("seed", "material_size"),
                description="tiled grey detail texture (second texture unit)",
            ),
            LIGHTMAP_SLOT,
        ),
        defaults={"detail_size": None, "detail_strength": 0.6, "slope_rule": True},
        uniforms=region_uniforms,
        cpu_params=frozenset({"detail_size", "slope_rule"}),
        description="Filipović 2008 T1 region blending on the GPU: (range − |h − max|)/range",
    )
)
# Layers sampled through hex-tiling (Mikkelsen 2022) so their tile period does not show;
# hex_tiling=False wraps them as the seed does.
_HEX_TILING_DEFAULTS: dict[str, Any] = {
    "hex_tiling": True,
    "hex_rotation": HEX_ROTATION,
    "hex_contrast": HEX_CONTRAST,
    "hex_sharpness": HEX_SHARPNESS,
    "hex_seed": 0,
}
register_technique(
    Technique(
        "texture3d",
        "terrain/texture3d",
        textures=(
            TextureSlot(
                "u_layers",
                build_layer_volume,
                depends=_REGION_DEPS,
                description="layer stack as a 3D texture (layer_stack)",
            ),
            TextureSlot(
                "u_layer_coord",
                build_layer_coordinate,
                depends=("regions",),
                description="per-vertex depth coordinate r (layer_coordinate)",
            ),
            LIGHTMAP_SLOT,
        ),
        defaults=_HEX_TILING_DEFAULTS,
        description="Filipović 2008 T2: 3D texture addressed by height, hex-tiled",
    )
)
register_technique(
    Technique(
        "splat",
        "terrain/splat",
        deferred=True,
        textures=(
            TextureSlot(
                "u_splat0",
                build_splat0,
                depends=("regions",),
                description="RGBA alpha map, layers 0-3 (pack_splat_maps)",
            ),
            TextureSlot(
                "u_splat1",
                build_splat1,
                depends=("regions",),
                description="RGBA alpha map, layers 4-7",
            ),
            TextureSlot(
                "u_materials",
                build_material_array,
                depends=_REGION_DEPS,
                description="tiled layer textures (2D texture array)",
            ),
            LIGHTMAP_SLOT,
        ),
        defaults=_HEX_TILING_DEFAULTS,
        uniforms=layer_count_uniforms,
        description="Filipović 2008 T3: texture splatting, all layers in one pass, hex-tiled",
    )
)
register_technique(
    Technique(
        "bump",
        "terrain/bump",
        textures=(
            TextureSlot(
                "u_color_tex",
                build_region_texture,
                depends=("seed", "regions"),
                description="colour texture, one texel per vertex (region_texture)",
            ),
            TextureSlot(
                "u_normal_height",
                build_normal_height,
                depends=("seed", "material_size", "bump_height"),
                description="tiled RGBA normal + height (pack_normal_height)",
            ),
        ),
        defaults={"ks": 0.2, "bump_height": 1.0, "bump_strength": 1.0},
        cpu_params=frozenset({"bump_height"}),  # baked into u_normal_height
        description="Janković 2010: normal mapping in tangent space with Phong lighting",
    )
)

__all__ = [
    "COMMON_PARAMS",
    "CPU_PARAMS",
    "LIGHTING_MODES",
    "RELIEF_TRACERS",
    "TECHNIQUE_ALIASES",
    "DrawnTechnique",
    "Technique",
    "TechniqueFallbackWarning",
    "TextureData",
    "TextureSlot",
    "canonical_technique_name",
    "choose_drawable",
    "get_technique",
    "layer_count_uniforms",
    "parameter_uniforms",
    "region_uniforms",
    "register_technique",
    "technique_names",
    "tracer_id_defines",
]
