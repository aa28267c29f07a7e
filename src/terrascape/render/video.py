"""MP4 video (H.264, yuv420p) of rendered frames, through ffmpeg (imageio-ffmpeg).

References
----------
.. [1] imageio-ffmpeg: ``write_frames``, a generator that feeds raw frames to an ffmpeg
   process's standard input (https://github.com/imageio/imageio-ffmpeg).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from terrascape._interrupts import interrupts_deferred
from terrascape.errors import FileFormatError, InvalidParameterError


def check_mp4_size(size: tuple[int, int]) -> None:
    """Refuse a frame size H.264 with 4:2:0 chroma cannot encode (odd width or height)."""
    w, h = size
    if w % 2 or h % 2:
        raise InvalidParameterError(f"MP4 (H.264, yuv420p) needs an even size, got {w}×{h}")


def write_mp4(path: str | Path, frames: Iterable[np.ndarray], size: tuple[int, int],
              fps: float, *, total: int = 0,
              progress: Callable[[int, int], None] | None = None) -> None:
    """Encode ``frames`` (uint8 RGB or RGBA, ``size`` = (width, height)) into ``path`` at
    ``fps`` frames a second; ``progress(k, total)`` after each frame.

    ffmpeg starts with signals held back (:func:`terrascape._interrupts.interrupts_deferred`):
    interrupted while starting, it ran on unknown and wrote its file after the caller had
    removed it. Afterwards an interruption closes its input and waits for it (a second one
    kills it), so it has ended before the caller removes the unfinished file."""
    try:
        import imageio_ffmpeg
    except ImportError as exc:  # pragma: no cover - install extra
        raise FileFormatError(f"MP4 output needs imageio + imageio-ffmpeg: {exc}") from None
    check_mp4_size(size)
    w, h = size
    writer = imageio_ffmpeg.write_frames(
        str(path), (w, h), pix_fmt_in="rgb24", pix_fmt_out="yuv420p", fps=fps, quality=None,
        codec="libx264", macro_block_size=1, ffmpeg_log_level=None,
        output_params=["-loglevel", "error"])
    try:
        with interrupts_deferred():
            writer.send(None)  # ffmpeg starts here
        for k, img in enumerate(frames):
            if img.shape[:2] != (h, w):
                raise InvalidParameterError(f"frame {k} is {img.shape[1]}×{img.shape[0]}, "
                                            f"the video {w}×{h}")
            writer.send(np.ascontiguousarray(img[..., :3], dtype=np.uint8))
            if progress:
                progress(k + 1, total)
    finally:
        writer.close()


__all__ = ["check_mp4_size", "write_mp4"]
