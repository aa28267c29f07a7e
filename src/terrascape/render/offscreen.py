"""Off-screen rendering to numpy arrays, camera paths, and turntable PNG/MP4 output.

Images are ``uint8 (height, width, 4)`` RGBA with row 0 at the top (GL reads bottom-up; the
rows are flipped after ``fbo.read``). Framebuffers are single-sampled (``samples=0``) so the
same inputs give the same bytes.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from terrascape._validate import check_int, check_positive, check_range
from terrascape.camera import Camera, frame_landscape, frame_terrain
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io.atomic import atomic_output, atomic_outputs, check_output_path
from terrascape.render.context import with_current_context

QUALITIES = ("default", "high")
SUPERSAMPLE = 2
HIGH_SHADOW_SAMPLES = 16


def downsample_srgb(image: np.ndarray, factor: int) -> np.ndarray:
    """Box-filter a ``uint8 (H, W, C)`` sRGB image by ``factor`` in linear light."""
    from terrascape.lighting.daylight import linear_to_srgb, srgb_to_linear

    h, w, c = image.shape
    lin = srgb_to_linear(image.astype(np.float64) / 255.0)
    lin = lin.reshape(h // factor, factor, w // factor, factor, c).mean(axis=(1, 3))
    out = linear_to_srgb(lin)
    if c == 4:  # alpha is not a colour: averaged as is
        out[..., 3] = image[..., 3].reshape(h // factor, factor, w // factor, factor).mean(
            axis=(1, 3)) / 255.0
    return np.rint(out * 255.0).astype(np.uint8)


def default_camera(
    heightmap: Heightmap,
    size: tuple[int, int],
    *,
    exaggeration: float = 1.0,
    azimuth: float | None = None,
    elevation: float | None = None,
) -> Camera:
    """The camera that frames the whole terrain for an output size.

    Default: a landscape view (:func:`~terrascape.camera.frame_landscape`: the horizon a
    quarter below the top, the terrain in front). With an ``elevation`` (degrees), an orbit
    overview at that elevation that fits the terrain's box (``frame_terrain``).
    ``azimuth`` (degrees, the side seen from): default 180 (from the south, along the grid,
    so the terrain spans the image) for the landscape view, 210 for the overview.
    """
    lo, hi = heightmap.min * exaggeration, heightmap.max * exaggeration
    if elevation is None:
        az = 180.0 if azimuth is None else azimuth
        return frame_landscape(heightmap.extent, (lo, hi), azimuth=az,
                               aspect=size[0] / size[1],
                               edge_height=_near_edge_height(heightmap, az) * exaggeration)
    azimuth = 210.0 if azimuth is None else azimuth
    return frame_terrain(
        heightmap.extent, (lo, hi), azimuth=azimuth, elevation=elevation, aspect=size[0] / size[1]
    )


def _near_edge_height(heightmap: Heightmap, azimuth: float) -> float:
    """Highest border sample on the side of the terrain a camera at ``azimuth`` faces
    (within a tenth of the terrain's depth along the view from the nearest corner)."""
    import math

    h = heightmap.heights
    rows, cols = h.shape
    dx, dz = heightmap.spacing
    r = np.r_[np.zeros(cols, int), np.full(cols, rows - 1), np.arange(rows), np.arange(rows)]
    c = np.r_[np.arange(cols), np.arange(cols), np.zeros(rows, int), np.full(rows, cols - 1)]
    a = math.radians(azimuth)
    # toward the camera: (sin a, -cos a) in (x, z); the near side has the largest projection
    toward = c * dx * math.sin(a) - r * dz * math.cos(a)
    near = toward >= toward.max() - 0.1 * (toward.max() - toward.min())
    return float(h[r[near], c[near]].max())


def _check_camera(camera: Any) -> Camera:
    if not isinstance(camera, Camera):
        raise InvalidParameterError(f"camera must be a terrascape Camera, got {camera!r}")
    # Camera validates itself on construction; re-check in case an instance was mutated.
    if not (np.isfinite(camera.eye).all() and np.isfinite([camera.yaw, camera.pitch]).all()):
        raise InvalidParameterError(f"camera must be finite, got {camera!r}")
    return camera


@contextlib.contextmanager
def _context(ctx):
    if ctx is not None:
        yield ctx
        return
    from terrascape.render.context import headless_context

    with headless_context() as own:
        yield own


class OffscreenRenderer:
    """A :class:`~terrascape.render.terrain.TerrainRenderer` plus a framebuffer of fixed size;
    reuse it for many frames (camera paths, benchmarks)."""

    @with_current_context
    def __init__(
        self,
        ctx,
        heightmap: Heightmap,
        *,
        size=(1280, 720),
        exaggeration=1.0,
        chunk_size: int | None = None,
        small_triangle_cull: bool | None = None,
        deferred_shading: bool | None = None,
        quality: str = "default",
    ) -> None:
        from terrascape.render.terrain import TerrainRenderer, check_output_size

        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(
                f"expected a terrascape Heightmap, got {type(heightmap).__name__}"
            )
        if quality not in QUALITIES:
            raise InvalidParameterError(
                f"quality must be one of {', '.join(QUALITIES)}, got {quality!r}")
        self.ctx = ctx
        self.size = check_output_size(ctx, size)
        self.quality = quality
        # "high": supersampled — drawn at SUPERSAMPLE× the size and averaged down in linear
        # light (every pixel the mean of SUPERSAMPLE² samples), with more shadow sweeps.
        self.samples = SUPERSAMPLE if quality == "high" else 1
        w0, h0 = self.size
        self._draw_size = check_output_size(ctx, (w0 * self.samples, h0 * self.samples))
        kwargs = {} if chunk_size is None else {"chunk_size": chunk_size}
        self.terrain = TerrainRenderer(ctx, heightmap, exaggeration=exaggeration,
                                       small_triangle_cull=small_triangle_cull,
                                       deferred_shading=deferred_shading, **kwargs)
        w, h = self._draw_size
        self._color = ctx.renderbuffer((w, h), 4, samples=0)
        self._depth = ctx.depth_renderbuffer((w, h), samples=0)
        self.fbo = ctx.framebuffer(color_attachments=[self._color], depth_attachment=self._depth)
        self._stencil: Any = None  # depth + stencil target of object_shadows="volumes"
        self._last_fbo = self.fbo

    def default_camera(self, **kwargs) -> Camera:
        return default_camera(
            self.terrain.heightmap, self.size, exaggeration=self.terrain.exaggeration, **kwargs
        )

    @with_current_context
    def render(
        self,
        camera: Camera | None = None,
        technique: str = "material",
        params: Mapping[str, Any] | None = None,
    ) -> np.ndarray:
        """One frame as ``uint8 (h, w, 4)``, row 0 at the top."""
        camera = self.default_camera() if camera is None else _check_camera(camera)
        w, h = self._draw_size
        camera = replace(camera, aspect=w / h)
        p = dict(params or {})
        if self.samples > 1 and "shadow_samples" not in p:
            p["shadow_samples"] = HIGH_SHADOW_SAMPLES
        fbo = self.fbo
        if p.get("object_shadows") == "volumes":
            from terrascape.render.shadow_volumes import ShadowVolumes

            fbo = self._stencil_fbo()
            ShadowVolumes.of(self.terrain).keep_count = True  # for last_shadow_count()
        self.terrain.render(fbo, camera, technique, p)
        self._last_fbo = fbo
        raw = fbo.read(components=4, alignment=1)
        img = np.frombuffer(raw, dtype=np.uint8).reshape(h, w, 4)[::-1]
        if self.samples == 1:
            return img.copy()
        return downsample_srgb(img, self.samples)

    @with_current_context
    def last_shadow_count(self) -> np.ndarray | None:
        """uint8 ``(h, w)`` (draw size, row 0 at the top): the shadow volume count of the
        last ``object_shadows="volumes"`` frame, non-zero where objects shade the sun;
        ``None`` before one."""
        from terrascape.render.shadow_volumes import ShadowVolumes

        return ShadowVolumes.of(self.terrain).last_count if self._stencil else None

    @with_current_context
    def last_depth(self) -> np.ndarray:
        """float32 ``(h, w)`` window depth of the last frame (row 0 at the top, 1 = sky):
        with the camera given to :meth:`render` it gives each pixel's surface point
        (:func:`terrascape.objects.shadow_reference.surface_points`). A shadow-volume frame
        is drawn with an infinite far plane; its depth is mapped back to that camera's."""
        if self._stencil and self._last_fbo is self._stencil.fbo:
            depth = self._stencil.read_depth()
        else:
            w, h = self._draw_size
            raw = self.fbo.read(attachment=-1, components=1, dtype="f4")
            depth = np.frombuffer(raw, np.float32).reshape(h, w)[::-1].copy()
        drawn = self.terrain.last_camera
        if drawn is not None and drawn.infinite_far:
            finite = replace(drawn, infinite_far=False)
            depth = finite.window_depth(drawn.eye_distance(depth)).astype(np.float32)
        return depth

    def _stencil_fbo(self):
        """The framebuffer with a stencil buffer that shadow volumes count in (made on first
        use); the plain one when this GL cannot make it (the renderer then falls back)."""
        if self._stencil is None:
            from terrascape.errors import GLUnavailableError
            from terrascape.render.stencil import StencilFramebuffer

            try:
                self._stencil = StencilFramebuffer(self.ctx, self._draw_size)
            except GLUnavailableError:
                self._stencil = False
        return self._stencil.fbo if self._stencil else self.fbo

    @with_current_context
    def release(self) -> None:
        if self._stencil:
            self._stencil.release()
        self._stencil = None
        self.terrain.release()
        self.fbo.release()
        self._color.release()
        self._depth.release()


def _sun_params(params: Mapping[str, Any] | None, sun) -> dict[str, Any]:
    p = dict(params or {})
    if sun is not None:
        if len(tuple(sun)) != 2:
            raise InvalidParameterError(f"sun must be (azimuth, elevation), got {sun!r}")
        az, el = sun
        check_range(el, "sun elevation", -90.0, 90.0)
        p["sun"] = (float(az), float(el))
    return p


def render_to_array(
    heightmap: Heightmap,
    *,
    technique: str = "material",
    camera: Camera | None = None,
    size: tuple[int, int] = (1280, 720),
    sun: tuple[float, float] | None = (135.0, 45.0),
    exaggeration: float = 1.0,
    ctx=None,
    params: Mapping[str, Any] | None = None,
    quality: str = "default",
    objects=None,
) -> np.ndarray:
    """Render one image of the terrain.

    Parameters
    ----------
    heightmap
        Terrain (any size and spacing).
    technique
        Registered technique (``material`` — the default —, ``plain``, ``regions``, ``bump``, …).
    camera
        Default: :func:`default_camera` (a landscape view across the terrain,
        :func:`~terrascape.camera.frame_landscape`). Its aspect is replaced by
        ``width/height``.
    size
        ``(width, height)`` pixels.
    sun
        ``(azimuth°, elevation°)`` (overrides ``params["sun"]``).
    exaggeration
        Vertical scale.
    ctx
        moderngl context to reuse; by default a headless one is created and released.
    params
        Technique parameters.
    quality
        ``"default"`` or ``"high"`` (2×2 supersampling, 16 shadow sweeps; seconds a frame).
    objects
        :class:`~terrascape.objects.model.Instances` to draw on the terrain (trees, rocks,
        buildings; :func:`terrascape.objects.scatter`), shadowed per
        ``params["object_shadows"]``.

    Returns
    -------
    numpy.ndarray
        ``uint8 (height, width, 4)`` RGBA, row 0 = top.
    """
    p = _sun_params(params, sun)
    with _context(ctx) as c:
        r = OffscreenRenderer(c, heightmap, size=size, exaggeration=exaggeration,
                              quality=quality)
        try:
            r.terrain.set_objects(objects)
            return r.render(camera, technique, p)
        finally:
            r.release()


def render_frames(
    heightmap: Heightmap,
    cameras: Iterable[Camera],
    *,
    technique: str = "material",
    size: tuple[int, int] = (1280, 720),
    sun: tuple[float, float] | None = (135.0, 45.0),
    exaggeration: float = 1.0,
    ctx=None,
    params: Mapping[str, Any] | None = None,
    quality: str = "default",
    objects=None,
) -> Iterator[np.ndarray]:
    """Yield one ``uint8 (h, w, 4)`` frame per camera of a path (one renderer for all);
    ``objects`` as in :func:`render_to_array`."""
    p = _sun_params(params, sun)
    cams = [_check_camera(c) for c in cameras]
    with _context(ctx) as c:
        r = OffscreenRenderer(c, heightmap, size=size, exaggeration=exaggeration,
                              quality=quality)
        try:
            r.terrain.set_objects(objects)
            for cam in cams:
                yield r.render(cam, technique, p)
        finally:
            r.release()


def turntable_cameras(
    heightmap: Heightmap,
    n_frames: int,
    *,
    size=(1280, 720),
    exaggeration: float = 1.0,
    elevation: float = 35.0,
    start_azimuth: float = 210.0,
) -> list[Camera]:
    """``n_frames`` cameras orbiting the terrain once (frame_terrain distance), evenly
    spaced in azimuth, the last one step short of the first (seamless loop)."""
    n = check_int(n_frames, "turntable frames", minimum=1, maximum=100_000)
    return [
        default_camera(
            heightmap,
            size,
            exaggeration=exaggeration,
            azimuth=start_azimuth + 360.0 * k / n,
            elevation=elevation,
        )
        for k in range(n)
    ]


def _write_png(path: Path, image: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(image).save(path, format="PNG")


def turntable(
    heightmap: Heightmap,
    n_frames: int,
    output: str | os.PathLike,
    *,
    fmt: str = "png",
    technique: str = "material",
    size=(1280, 720),
    sun=(135.0, 45.0),
    exaggeration=1.0,
    elevation: float = 35.0,
    fps: float = 30.0,
    ctx=None,
    params: Mapping[str, Any] | None = None,
    force: bool = False,
    progress=None,
    quality: str = "default",
    objects=None,
) -> list[Path]:
    """Render an orbit around the terrain to a PNG sequence or an MP4.

    Parameters
    ----------
    output
        ``fmt="png"``: a path pattern; frames are written as ``<stem>_0000.png``… next to it
        (a ``{i}``/``{i:04d}`` in the name is used as the frame-number field instead).
        ``fmt="mp4"``: the video file (imageio + imageio-ffmpeg, H.264).
    force
        Overwrite existing files; otherwise any existing target aborts before rendering.
    progress
        Optional callable ``progress(done, total)``.
    objects
        Objects on the terrain, as in :func:`render_to_array`.

    Returns
    -------
    list of pathlib.Path
        The files written. Each file is written atomically (no partial files).
    """
    if fmt not in ("png", "mp4"):
        raise InvalidParameterError(f"format must be 'png' or 'mp4', got {fmt!r}")
    fps = check_positive(fps, "fps")
    cams = turntable_cameras(
        heightmap, n_frames, size=size, exaggeration=exaggeration, elevation=elevation
    )
    out = Path(output)
    if fmt == "png":
        if "{i" in out.name:
            targets = [out.with_name(out.name.format(i=k)) for k in range(len(cams))]
        else:
            targets = [out.with_name(f"{out.stem}_{k:04d}.png") for k in range(len(cams))]
        if len(set(targets)) != len(targets):
            raise InvalidParameterError(f"frame name pattern {out.name!r} repeats file names")
        for t in targets:
            check_output_path(t, force=force)
        frames = render_frames(
            heightmap,
            cams,
            technique=technique,
            size=size,
            sun=sun,
            exaggeration=exaggeration,
            ctx=ctx,
            params=params,
            quality=quality,
            objects=objects,
        )
        # The sequence is one output: its frames wait as temporaries and are committed
        # together, so an interrupted run (a fault, SIGTERM) leaves no partial sequence.
        with atomic_outputs(targets, force=force) as tmps:
            for k, (tmp, img) in enumerate(zip(tmps, frames, strict=True)):
                _write_png(tmp, img[..., :3])
                if progress:
                    progress(k + 1, len(targets))
        return targets
    from terrascape.render.video import check_mp4_size, write_mp4

    check_mp4_size(size)
    with atomic_output(out, force=force) as tmp:
        frames = render_frames(
            heightmap,
            cams,
            technique=technique,
            size=size,
            sun=sun,
            exaggeration=exaggeration,
            ctx=ctx,
            params=params,
            quality=quality,
            objects=objects,
        )
        write_mp4(tmp, frames, size, fps, total=len(cams), progress=progress)
    return [out]


__all__ = [
    "QUALITIES",
    "OffscreenRenderer",
    "default_camera",
    "downsample_srgb",
    "render_frames",
    "render_to_array",
    "turntable",
    "turntable_cameras",
]
