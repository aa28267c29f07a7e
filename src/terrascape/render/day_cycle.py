"""A day (or any span of time) over the terrain as an MP4: one frame per sky state, the sun,
sky, moon and stars moving with the time, the camera fixed.

The video is written atomically (a temporary file next to the output, renamed at the end;
an interruption leaves nothing). Frames are streamed to the encoder, one renderer for all.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from terrascape._validate import check_positive
from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io.atomic import atomic_output
from terrascape.lighting.solar_position import SkyState


def day_cycle_frames(
    heightmap: Heightmap,
    states: Sequence[SkyState],
    *,
    ctx,
    camera: Camera | None = None,
    technique: str = "material",
    size: tuple[int, int] = (1280, 720),
    exaggeration: float = 1.0,
    params: Mapping[str, Any] | None = None,
    quality: str = "default",
) -> Iterator[np.ndarray]:
    """Yield one ``uint8 (h, w, 4)`` frame per sky state."""
    from terrascape.render.offscreen import OffscreenRenderer

    r = OffscreenRenderer(ctx, heightmap, size=size, exaggeration=exaggeration,
                          quality=quality)
    try:
        for state in states:
            if not isinstance(state, SkyState):
                raise InvalidParameterError(
                    f"day cycle states must be SkyState, got {type(state).__name__}")
            yield r.render(camera, technique, {**dict(params or {}), "sun": state.sun,
                                               "sky_state": state})
    finally:
        r.release()


def write_day_cycle(
    heightmap: Heightmap,
    states: Sequence[SkyState],
    output: str | os.PathLike,
    *,
    ctx,
    camera: Camera | None = None,
    technique: str = "material",
    size: tuple[int, int] = (1280, 720),
    exaggeration: float = 1.0,
    fps: float = 24.0,
    params: Mapping[str, Any] | None = None,
    force: bool = False,
    quality: str = "default",
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Render ``states`` to an MP4 (H.264, yuv420p) at ``output``; returns its path."""
    from terrascape.render.video import check_mp4_size, write_mp4

    fps = check_positive(fps, "fps")
    out = Path(output)
    if out.suffix.lower() != ".mp4":
        raise InvalidParameterError(f"a day cycle is written as .mp4, got {out.name!r}")
    check_mp4_size(size)
    with atomic_output(out, force=force) as tmp:
        frames = day_cycle_frames(heightmap, states, ctx=ctx, camera=camera,
                                  technique=technique, size=size, exaggeration=exaggeration,
                                  params=params, quality=quality)
        write_mp4(tmp, frames, size, fps, total=len(states), progress=progress)
    return out


__all__ = ["day_cycle_frames", "write_day_cycle"]
