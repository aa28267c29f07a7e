"""OpenGL rendering (moderngl): headless context, GLSL program loading, terrain renderer,
technique registry and off-screen rendering. The only package (with ``viewer``) that imports
OpenGL; everything it draws comes from the pure-numpy core.
"""

from terrascape.render.context import (
    create_headless_context,
    current,
    describe_context,
    headless_context,
)
from terrascape.render.offscreen import (
    OffscreenRenderer,
    default_camera,
    render_frames,
    render_to_array,
    turntable,
    turntable_cameras,
)
from terrascape.render.shaders import (
    ShaderCompileError,
    ShaderSourceError,
    available_programs,
    load_program,
    load_source,
    set_uniforms,
)
from terrascape.render.techniques import (
    DrawnTechnique,
    Technique,
    TechniqueFallbackWarning,
    TextureData,
    TextureSlot,
    get_technique,
    register_technique,
    technique_names,
)
from terrascape.render.terrain import TerrainRenderer, upload_texture

__all__ = [
    "DrawnTechnique",
    "OffscreenRenderer",
    "ShaderCompileError",
    "ShaderSourceError",
    "Technique",
    "TechniqueFallbackWarning",
    "TerrainRenderer",
    "TextureData",
    "TextureSlot",
    "available_programs",
    "create_headless_context",
    "current",
    "default_camera",
    "describe_context",
    "get_technique",
    "headless_context",
    "load_program",
    "load_source",
    "register_technique",
    "render_frames",
    "render_to_array",
    "set_uniforms",
    "technique_names",
    "turntable",
    "turntable_cameras",
    "upload_texture",
]
