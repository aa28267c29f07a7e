"""The interactive viewer (Janković 2010 §2.6.4, Filipović 2008 §5.2): a free-flying
camera over the terrain with run-time technique, LOD and lighting switches, a sky and a HUD.

Only this package and :mod:`terrascape.render` import OpenGL. The window itself
(:mod:`terrascape.viewer.app`) needs moderngl-window + pyglet and a display; everything it
draws is done by :class:`~terrascape.viewer.session.ViewerSession`, which renders into any
framebuffer (so it also runs headless).
"""

from terrascape.viewer.controls import (
    HELP,
    LOD_MODES,
    TECHNIQUES,
    Action,
    ViewerState,
    fly,
    look,
)
from terrascape.viewer.font import BitmapFont, build_font, layout_text, text_block_size
from terrascape.viewer.session import (
    KeyRepeat,
    LodManager,
    Smoothed,
    ViewerSession,
    ground_height,
    ordered_techniques,
    sky_colors,
    start_camera,
    technique_params,
)

__all__ = [
    "HELP",
    "LOD_MODES",
    "TECHNIQUES",
    "Action",
    "BitmapFont",
    "KeyRepeat",
    "LodManager",
    "Smoothed",
    "ViewerSession",
    "ViewerState",
    "build_font",
    "fly",
    "ground_height",
    "layout_text",
    "look",
    "ordered_techniques",
    "sky_colors",
    "start_camera",
    "technique_params",
    "text_block_size",
]
