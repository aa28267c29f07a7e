"""The viewer's state machine: keys → parameter changes → uniforms. No window, no GL.

Key bindings follow Janković 2010 §2.6.4 (the parameter keys of the original program: parallax
scale in ±0.001 steps from 0.01, linear search steps ±1 from 11), moved off W/A/S/D because
those fly the camera here (Filipović 2008 §5.2's free camera). Keys are plain names ("W", "TAB",
"F1", "PAGE_UP", "EQUAL", …) so this module does not depend on the window library; the app
translates its key codes to these names.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from terrascape.camera import Camera
from terrascape.lod.schemes import SCHEMES

# The Tab cycle before a session fills in the registry's techniques (the same names as
# render/techniques.py, in the session's PREFERRED_ORDER).
TECHNIQUES: tuple[str, ...] = (
    "material",
    "plain",
    "regions",
    "texture3d",
    "splat",
    "bump",
    "parallax",
    "parallax_limited",
    "steep_parallax",
    "pom",
    "relief",
    "interval",
    "cone",
    "minmax",
    "relief_by_distance",
)
LOD_MODES: tuple[str, ...] = ("none", *SCHEMES)  # L cycles these (lod/schemes.py)

PARALLAX_SCALE_STEP = 0.001  # Janković 2010 §2.6.4.3: parametar ± 0.001
SUN_AZIMUTH_STEP = 10.0
SUN_ELEVATION_STEP = 5.0
#: Speeds of the sky clock (simulated seconds per second), C / V step through them.
TIME_RATES: tuple[float, ...] = (60.0, 300.0, 900.0, 1800.0, 3600.0, 7200.0, 14400.0)
DEFAULT_TIME_RATE = 1800.0  # half an hour a second: a day in 48 s
TIME_STEP_HOURS = 0.25  # Y / U: a quarter of an hour back / forward


class Action(Enum):
    """Side effects a key asks of the window (the state machine itself has none)."""

    NONE = "none"
    QUIT = "quit"
    RELEASE_MOUSE = "release_mouse"
    SCREENSHOT = "screenshot"


# (key, needs shift) → description, shown in the help panel in this order.
# G cycles the objects' shadows (terrascape.render.objects.OBJECT_SHADOW_MODES)
OBJECT_SHADOW_CYCLE = ("cascades", "volumes", "none")

HELP: tuple[tuple[str, str], ...] = (
    ("W A S D / arrows", "fly (Shift: faster; scroll: change speed)"),
    ("Q / E", "down / up"),
    ("mouse (click to capture)", "look around; Esc releases, Esc again quits"),
    ("Tab / Shift+Tab", "next / previous texturing technique"),
    ("= / -", "parallax scale ± 0.001"),
    ("] / [", "linear search steps ± 1"),
    (". / ,", "binary search steps ± 1"),
    ("X", "self-shadowing on/off"),
    ("Z", "wireframe on/off"),
    ("L", "LOD algorithm: " + " / ".join(LOD_MODES)),
    ("J", "which LOD setting PgUp / PgDn change (ROAM: triangle target, tolerance)"),
    ("PgUp / PgDn", "finer / coarser: triangle target or pixel tolerance"),
    ("K", "lightmap with shadows on/off"),
    ("O / P", "sun azimuth ∓ 10° (stops the clock)"),
    ("N / M", "sun elevation ∓ 5° (below 0: night; stops the clock)"),
    ("Space", "run / pause the time of day (sun, moon, stars)"),
    ("R", "run the time forward / backward"),
    ("C / V", "time slower / faster"),
    ("Y / U", "time ∓ 15 minutes"),
    ("F", "fog on/off"),
    ("T", "terrain following on/off"),
    ("B", "objects on the terrain on/off (with --objects)"),
    ("G", "object shadows: " + " / ".join(OBJECT_SHADOW_CYCLE)),
    ("F1 / H", "this help"),
    ("F12", "screenshot to PNG"),
)


@dataclass
class ViewerState:
    """Everything the keys can change; :meth:`uniforms` is what the renderer receives."""

    technique: str = "plain"
    parallax_scale: float = 0.01
    linear_steps: int = 11
    binary_steps: int = 8
    self_shadow: bool = False
    wireframe: bool = False
    lod: str = "none"
    # per scheme: its key-adjustable update() settings (lod/schemes.py defaults)
    lod_settings: dict[str, dict[str, float]] = field(default_factory=lambda: {
        name: {p.name: p.default for p in s.adjustable} for name, s in SCHEMES.items()})
    lod_focus: int = 0  # index into the scheme's adjustable settings (J)
    lightmap: bool = True
    sun_azimuth: float = 135.0
    sun_elevation: float = 35.0
    fog: bool = True
    terrain_following: bool = False
    show_help: bool = False
    mouse_captured: bool = False
    has_objects: bool = False  # the session draws objects (--objects)
    objects: bool = True  # B: shown
    object_shadows: str = "cascades"  # G: OBJECT_SHADOW_CYCLE
    speed: float = 1.0  # world units per second; set from the terrain size at start
    available: tuple[str, ...] = field(default=TECHNIQUES)
    # The sky clock: an instant (UTC) at a place; None = the sun keys' fixed sun.
    clock: _dt.datetime | None = None
    latitude: float = 45.0
    longitude: float = 0.0
    time_running: bool = False
    time_rate: float = DEFAULT_TIME_RATE  # simulated seconds per second
    time_direction: int = 1  # +1 forward, -1 backward

    def __post_init__(self) -> None:
        if self.technique not in self.available:
            self.technique = self.available[0]

    # --- keys ---------------------------------------------------------------------------
    def handle_key(self, key: str, *, shift: bool = False) -> Action:
        """Apply one key press; return what the window must do."""
        key = key.upper()
        if key == "ESCAPE":
            if self.mouse_captured:
                self.mouse_captured = False
                return Action.RELEASE_MOUSE
            return Action.QUIT
        if key == "F12":
            return Action.SCREENSHOT
        if key in ("F1", "H"):
            self.show_help = not self.show_help
        elif key == "TAB":
            self.cycle_technique(-1 if shift else 1)
        elif key == "EQUAL":
            self.parallax_scale = round(self.parallax_scale + PARALLAX_SCALE_STEP, 6)
        elif key == "MINUS":
            # seed: "if (parametar > 0) parametar -= 0.001" — never negative
            self.parallax_scale = max(0.0, round(self.parallax_scale - PARALLAX_SCALE_STEP, 6))
        elif key == "RIGHT_BRACKET":
            self.linear_steps = min(256, self.linear_steps + 1)
        elif key == "LEFT_BRACKET":
            self.linear_steps = max(1, self.linear_steps - 1)
        elif key == "PERIOD":
            self.binary_steps = min(32, self.binary_steps + 1)
        elif key == "COMMA":
            self.binary_steps = max(0, self.binary_steps - 1)
        elif key == "X":
            self.self_shadow = not self.self_shadow
        elif key == "Z":
            self.wireframe = not self.wireframe
        elif key == "L":
            self.lod = LOD_MODES[(LOD_MODES.index(self.lod) + 1) % len(LOD_MODES)]
            self.lod_focus = 0
        elif key == "J":
            n = len(SCHEMES[self.lod].adjustable) if self.lod in SCHEMES else 0
            self.lod_focus = (self.lod_focus + 1) % n if n else 0
        elif key in ("PAGE_UP", "PAGE_DOWN"):
            self._change_detail(up=key == "PAGE_UP")
        elif key == "K":
            self.lightmap = not self.lightmap
        elif key in ("O", "P"):
            step = SUN_AZIMUTH_STEP if key == "P" else -SUN_AZIMUTH_STEP
            self.clock = None  # the sun is placed by hand now
            self.sun_azimuth = (self.sun_azimuth + step) % 360.0
        elif key in ("N", "M"):
            step = SUN_ELEVATION_STEP if key == "M" else -SUN_ELEVATION_STEP
            self.clock = None
            self.sun_elevation = max(-30.0, min(90.0, self.sun_elevation + step))
        elif key == "SPACE":
            self._start_clock()
            self.time_running = not self.time_running
        elif key == "R":
            self._start_clock()
            self.time_direction = -self.time_direction
        elif key in ("C", "V"):
            self._start_clock()
            i = min(range(len(TIME_RATES)), key=lambda k: abs(TIME_RATES[k] - self.time_rate))
            i = max(0, min(len(TIME_RATES) - 1, i + (1 if key == "V" else -1)))
            self.time_rate = TIME_RATES[i]
        elif key in ("Y", "U"):
            self._start_clock()
            sign = 1.0 if key == "U" else -1.0
            self.clock += _dt.timedelta(hours=sign * TIME_STEP_HOURS)
            self._sync_sun()
        elif key == "F":
            self.fog = not self.fog
        elif key == "T":
            self.terrain_following = not self.terrain_following
        elif key == "B":
            self.objects = not self.objects
        elif key == "G":
            i = OBJECT_SHADOW_CYCLE.index(self.object_shadows)
            self.object_shadows = OBJECT_SHADOW_CYCLE[(i + 1) % len(OBJECT_SHADOW_CYCLE)]
        return Action.NONE

    # --- the sky clock --------------------------------------------------------------------
    def _start_clock(self) -> None:
        """Time keys without a clock: start one at the moment (June solstice, local solar
        time) whose sun is nearest the hand-placed one's elevation, in the morning or
        afternoon the azimuth says."""
        if self.clock is not None:
            return
        from terrascape.lighting.solar_position import sky_state, solar_time_to_utc

        date = _dt.date(2026, 6, 21)
        afternoon = 0.0 < self.sun_azimuth % 360.0 < 180.0
        best = None
        for quarter in range(0, 96):
            hours = quarter / 4.0
            if (hours >= 12.0) == afternoon and hours != 12.0:
                continue
            when = solar_time_to_utc(date, hours, self.longitude)
            el = sky_state(when, self.latitude, self.longitude).sun_elevation
            if best is None or abs(el - self.sun_elevation) < best[0]:
                best = (abs(el - self.sun_elevation), when)
        self.clock = best[1]
        self._sync_sun()

    def set_clock(self, when: _dt.datetime, latitude: float, longitude: float, *,
                  running: bool = False) -> None:
        """Run the sky from ``when`` (aware or naive UTC) at a place."""
        if when.tzinfo is None:
            when = when.replace(tzinfo=_dt.UTC)
        self.clock = when.astimezone(_dt.UTC)
        self.latitude, self.longitude = float(latitude), float(longitude)
        self.time_running = running
        self._sync_sun()

    def advance_time(self, dt: float) -> None:
        """Move the clock by ``dt`` real seconds at the current rate (if it runs)."""
        if self.clock is None or not self.time_running or not dt > 0:
            return
        dt = min(float(dt), 0.25)  # a stalled frame does not jump the day
        self.clock += _dt.timedelta(seconds=self.time_direction * self.time_rate * dt)
        self._sync_sun()

    def sky_state(self):
        """The clock's :class:`~terrascape.lighting.solar_position.SkyState`, or None."""
        if self.clock is None:
            return None
        from terrascape.lighting.solar_position import sky_state

        return sky_state(self.clock, self.latitude, self.longitude)

    def _sync_sun(self) -> None:
        state = self.sky_state()
        if state is not None:
            self.sun_azimuth, self.sun_elevation = state.sun

    def time_line(self) -> str | None:
        """The clock for the HUD: local solar time, date, rate and direction."""
        if self.clock is None:
            return None
        state = self.sky_state()
        hh, mm = divmod(round(state.solar_time * 60.0) % 1440, 60)
        local = self.clock + _dt.timedelta(hours=self.longitude / 15.0)
        rate = self.time_rate / 60.0
        run = ("▶" if self.time_direction > 0 else "◀") + f" {rate:g} min/s" \
            if self.time_running else "paused"
        return (f"{local:%Y-%m-%d} {hh:02d}:{mm:02d} solar ({self.clock:%H:%M} UTC)  "
                f"lat {self.latitude:.1f}°  {run}  moon {state.moon_illumination:.0%}")

    def cycle_technique(self, step: int) -> None:
        i = self.available.index(self.technique)
        self.technique = self.available[(i + step) % len(self.available)]

    def _focused(self):
        """(scheme name, the setting PgUp/PgDn change); ROAM's when LOD is off."""
        name = self.lod if self.lod in SCHEMES else next(iter(SCHEMES))
        adjustable = SCHEMES[name].adjustable
        return name, adjustable[self.lod_focus % len(adjustable)]

    def _change_detail(self, *, up: bool) -> None:
        """PgUp: a finer mesh (more triangles / a smaller tolerance), PgDn: coarser."""
        name, param = self._focused()
        values = self.lod_settings[name]
        values[param.name] = param.stepped(values[param.name], finer=up)

    def lod_update_settings(self) -> dict[str, float | int | None]:
        """The current scheme's ``update`` keywords ("off" values left out)."""
        if self.lod not in SCHEMES:
            return {}
        out = {}
        for p in SCHEMES[self.lod].adjustable:
            v = self.lod_settings[self.lod][p.name]
            if v is not None and not (p.off is not None and v == p.off):
                out[p.name] = v
        return out

    @property
    def triangle_target(self) -> int:
        """The triangle budget of the current scheme (ROAM's when it has none)."""
        name = self.lod if "max_triangles" in self.lod_settings.get(self.lod, {}) else "roam"
        return int(self.lod_settings[name]["max_triangles"])

    @triangle_target.setter
    def triangle_target(self, value: int) -> None:
        """Set the triangle budget of every scheme that has one."""
        for values in self.lod_settings.values():
            if "max_triangles" in values:
                values["max_triangles"] = int(value)

    def scroll(self, amount: float) -> None:
        """Mouse wheel: each notch changes the flying speed by 20 %."""
        self.speed = float(min(1e6, max(1e-3, self.speed * 1.2**amount)))

    # --- output -------------------------------------------------------------------------
    @property
    def daylight(self) -> float:
        """0 at night (sun 6° or more below the horizon) … 1 in daylight (sun above 6°)."""
        return float(np.clip((self.sun_elevation + 6.0) / 12.0, 0.0, 1.0))

    def uniforms(self) -> dict[str, float | int | bool]:
        """Renderer parameters (the thesis's "shader constant callback" values)."""
        return {
            "parallax_scale": self.parallax_scale,
            "linear_steps": self.linear_steps,
            "binary_steps": self.binary_steps,
            "self_shadow": self.self_shadow,
            "fog": self.fog,
            "daylight": self.daylight,
        }

    def status_lines(self) -> list[str]:
        """Technique and its parameters, for the HUD."""
        lines = [f"technique: {self.technique}"]
        if self.technique not in ("plain", "regions", "texture3d", "splat", "bump"):
            lines.append(
                f"scale {self.parallax_scale:.3f}  linear {self.linear_steps}  "
                f"binary {self.binary_steps}  self-shadow {'on' if self.self_shadow else 'off'}"
            )
        detail = ""
        if self.lod in SCHEMES:
            _, focus = self._focused()
            detail = "  " + "  ".join(
                ("→ " if p is focus and len(SCHEMES[self.lod].adjustable) > 1 else "")
                + p.label(self.lod_settings[self.lod][p.name])
                for p in SCHEMES[self.lod].adjustable)
        lines.append(f"LOD: {self.lod}{detail}")
        lines.append(
            f"sun az {self.sun_azimuth:.0f}° el {self.sun_elevation:.0f}°  "
            f"lightmap {'on' if self.lightmap else 'off'}  fog {'on' if self.fog else 'off'}"
        )
        clock = self.time_line()
        if clock is not None:
            lines.append(clock)
        if self.has_objects:
            lines.append(f"objects {'on' if self.objects else 'off'}  "
                         f"shadows {self.object_shadows}")
        return lines


# --- camera flight -----------------------------------------------------------------------
MOVE_KEYS = {
    "W": (0, 0, 1), "UP": (0, 0, 1),
    "S": (0, 0, -1), "DOWN": (0, 0, -1),
    "D": (1, 0, 0), "RIGHT": (1, 0, 0),
    "A": (-1, 0, 0), "LEFT": (-1, 0, 0),
    "E": (0, 1, 0), "Q": (0, -1, 0),
}  # fmt: skip


def fly(
    camera: Camera,
    keys_down: set[str],
    dt: float,
    speed: float,
    *,
    fast: bool = False,
    ground=None,
    clearance: float = 2.0,
    follow: bool = False,
) -> Camera:
    """Move the camera for ``dt`` seconds with the held keys.

    Forward/back follow the view direction (a free-flying camera), strafing stays horizontal,
    Q/E move along world Y. ``ground(x, z) -> height`` keeps the eye ``clearance`` above the
    terrain when ``follow`` (terrain following) is on, and otherwise only stops it from
    sinking below that height.
    """
    move = np.zeros(3)
    for key in keys_down:
        if key.upper() in MOVE_KEYS:
            move += MOVE_KEYS[key.upper()]
    step = speed * dt * (4.0 if fast else 1.0)
    offset = (
        camera.right * move[0] + np.array([0.0, 1.0, 0.0]) * move[1] + camera.forward * move[2]
    )
    norm = np.linalg.norm(offset)
    cam = camera.moved(offset / norm * step) if norm > 0 and step > 0 else camera
    if ground is not None:
        x, y, z = cam.eye
        floor = float(ground(x, z)) + clearance
        if y < floor or follow:
            cam = replace(cam, position=(x, floor, z))
    return cam


def look(camera: Camera, dx: float, dy: float, sensitivity: float = 0.15) -> Camera:
    """Mouse look: ``dx``/``dy`` pixels → yaw/pitch degrees (pitch stays within ±89.9°)."""
    if not (math.isfinite(dx) and math.isfinite(dy)):
        return camera
    return camera.turned(dx * sensitivity, -dy * sensitivity)
