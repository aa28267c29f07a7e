"""Dynamic resolution: the share of the window's pixels a moving view is drawn at, chosen
from the measured frame times so the viewer holds its target frame rate.

On a software rasteriser most of a frame's time is spent per pixel, and the heaviest looks
(photo materials, relief marches) cost several times the plain one. While the camera moves,
the viewer draws into a smaller target (:class:`~terrascape.render.scaled_target.
ScaledTarget`) at :attr:`ResolutionControl.scale` of the window's width and height and
enlarges it; when the camera stops, frames are drawn at full size again, so what a user
looks at (and every screenshot) has the full look.

The control: frame time ≈ fixed + per-pixel · scale². The time of each moving frame (from its
start to the next frame's: drawing, buffer swap, events) is measured, and the median of the
last :data:`MEASURE_FRAMES` decides. When that is above :data:`SHRINK_ABOVE` of the target's
frame time, the scale whose frames would take :data:`HEADROOM` of it is taken: from the fixed and
per-pixel parts fitted through the medians at this scale and the previous one, or, at the
first step, counting all of the time as per pixel (which under-corrects when part is fixed,
so the scale approaches its value from above). It moves at most :data:`MAX_STEP` a frame,
rounded to :data:`QUANTUM` (each new size reallocates the targets), and grows again only
when frames are faster than :data:`GROW_BELOW` of the target's frame time; a new scale is
measured for a few frames before it changes again. A shrink that left most of the frame's
time in place (:data:`FUTILE_SHARE`: the time is not in the pixels) is taken back.

References
----------
- D. Binks, "Dynamic resolution rendering", Intel / GDC 2011 (frame-time driven render
  scale, enlarged for display).
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field

from terrascape._validate import check_range

#: Frames slower than this share of the target frame rate's frame time shrink the scale
#: (a median right at the target leaves half the frames below the rate).
SHRINK_ABOVE = 0.97
#: The frame time aimed at after a change, as a share of the target frame rate's frame time
#: (room for the frame-to-frame noise).
HEADROOM = 0.9
#: Frames faster than this share of the target's frame time may grow the scale again.
GROW_BELOW = 0.8
#: Largest change of the scale from one frame to the next.
MAX_STEP = 0.25
#: Frames at a new scale that are not measured (the first one reallocates the targets).
SKIP_AFTER_CHANGE = 1
#: Frames measured at a scale before it may change; it follows the median of the last
#: this many (one slow frame — a collection, a shader compile — moves nothing).
MEASURE_FRAMES = 3
#: Least difference of the squared scales of two measurements to fit the fixed part of the
#: frame time through them (closer ones amplify the frames' noise).
MIN_FIT_SPREAD = 0.2
#: A shrink after which the fitted fixed part of the frame is above this share of the
#: bigger frames' time saved too little (the LOD update, the vertices, the enlargement
#: dominate): the scale goes back and does not shrink again for :data:`HOLD_FRAMES` frames.
FUTILE_SHARE = 0.85
HOLD_FRAMES = 150
#: Scales are multiples of this.
QUANTUM = 0.05
#: Default target frame rate of the viewer while moving.
DEFAULT_TARGET_FPS = 15.0
#: Default lowest scale (a quarter of the pixels).
DEFAULT_MIN_SCALE = 0.5


@dataclass
class ResolutionControl:
    """The render scale of moving frames (1.0: full size), fed with their frame times.

    ``target_fps`` 0 switches the control off (every frame at full size).
    """

    target_fps: float = DEFAULT_TARGET_FPS
    min_scale: float = DEFAULT_MIN_SCALE
    scale: float = 1.0
    frame_ms: float | None = None  # median of the recent frames at this scale
    _seen: int = 0
    _recent: list = field(default_factory=list)
    _before: tuple | None = None  # (scale, median ms) measured at the previous scale
    _anchor: tuple | None = None  # the same where the current run of shrinks started
    _hold: int = 0  # frames left before the scale may shrink again

    def __post_init__(self) -> None:
        self.target_fps = check_range(self.target_fps, "target frame rate", 0.0, 1000.0)
        self.min_scale = check_range(self.min_scale, "lowest render scale", 0.1, 1.0)

    @property
    def active(self) -> bool:
        return self.target_fps > 0.0

    def restart(self) -> None:
        """Back to full size, measured afresh (what a frame costs changed: another look)."""
        self.scale = 1.0
        self.reset()
        self._before = self._anchor = None
        self._hold = 0

    def _fit(self) -> tuple[float, float, tuple] | None:
        """``(per-pixel ms at full size, fixed ms, the other measurement)`` through this
        scale's median and the previous scale's, or where the current run of shrinks
        started; None when neither is far enough from this scale to tell."""
        if self.frame_ms is None:
            return None
        for other in (self._before, self._anchor):
            if other is None:
                continue
            s0, t0 = other
            spread = self.scale * self.scale - s0 * s0
            if abs(spread) >= MIN_FIT_SPREAD:
                per_pixel = (self.frame_ms - t0) / spread
                return per_pixel, self.frame_ms - per_pixel * self.scale * self.scale, other
        return None

    def _scale_for(self, ms: float, fit: tuple | None) -> float:
        """The scale whose frames would take ``ms``: from the fixed and per-pixel parts
        of ``fit`` (:meth:`_fit`), or, with none (one scale measured, or two too close for
        the frames' noise) or one that makes no sense, counting all of the time as per
        pixel."""
        if fit is not None:
            per_pixel, fixed, _ = fit
            if per_pixel > 0.0 and 0.0 <= fixed < ms:
                return math.sqrt((ms - fixed) / per_pixel)
        return self.scale * math.sqrt(ms / self.frame_ms)

    def reset(self) -> None:
        """Forget the frame times measured at this scale (it changed)."""
        self.frame_ms = None
        self._seen = 0
        self._recent = []

    def update(self, frame_ms: float) -> float:
        """Take the time of a frame drawn at :attr:`scale` and return the next scale.

        The scale shrinks when the median frame time is near or past the target's, and
        grows when it is well within it; it holds in between, and for the first frames at a
        new scale (the first reallocates the targets, then :data:`MEASURE_FRAMES` are
        measured).
        """
        if not self.active or not math.isfinite(frame_ms) or frame_ms <= 0.0:
            return self.scale
        self._hold = max(0, self._hold - 1)
        self._seen += 1
        if self._seen <= SKIP_AFTER_CHANGE:
            return self.scale
        self._recent = [*self._recent[-(MEASURE_FRAMES - 1):], frame_ms]
        self.frame_ms = statistics.median(self._recent)
        if len(self._recent) < MEASURE_FRAMES:
            return self.scale
        budget = 1000.0 / self.target_fps
        aim = budget * HEADROOM
        fit = self._fit()
        if fit is not None and fit[2][0] > self.scale and (
                fit[0] <= 0.0 or fit[1] >= FUTILE_SHARE * fit[2][1]):
            # shrinking bought too little: back to the bigger frames, and hold there
            self.scale = fit[2][0]
            self._before = self._anchor = None
            self._hold = HOLD_FRAMES
            self.reset()
            return self.scale
        if self.frame_ms > budget * SHRINK_ABOVE and self._hold == 0:
            want = max(self._scale_for(aim, fit), self.scale - MAX_STEP)
            new = min(round(want / QUANTUM) * QUANTUM, self.scale - QUANTUM)
        elif self.frame_ms < budget * GROW_BELOW and self.scale < 1.0:
            want = min(self._scale_for(aim, fit), self.scale + MAX_STEP)
            new = max(math.floor(want / QUANTUM + 1e-9) * QUANTUM, self.scale)
        else:
            return self.scale
        new = round(min(1.0, max(self.min_scale, new)), 6)
        if new != self.scale:
            self._before = (self.scale, self.frame_ms)
            if new > self.scale:
                self._anchor = None
            elif self._anchor is None:
                self._anchor = self._before
            self.scale = new
            self.reset()  # the times were measured at the old scale
        return self.scale


__all__ = ["DEFAULT_MIN_SCALE", "DEFAULT_TARGET_FPS", "ResolutionControl"]
