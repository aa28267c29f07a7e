"""The objects' cascaded sun shadows in every lighting mode, on pixels: with no lighting,
Phong and the lightmap the cascades darken the terrain and the objects where the CPU ray
cast says an object blocks the sun, and only there, as dark as the stencil volumes'."""

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.lighting.sun import sun_direction
from terrascape.objects import Instances
from terrascape.objects.shadow_reference import agreement, boundary_band, shadow_reference

pytestmark = pytest.mark.gl

SIZE = (200, 150)
SUN = (45.0, 35.0)  # the shadows fall toward the camera
DARKER = 0.85


@pytest.fixture(scope="module")
def scene(gl_ctx, box_mesh):
    from terrascape.render.offscreen import OffscreenRenderer

    hm = Heightmap(np.zeros((97, 97), np.float32), spacing=(1.0, 1.0))
    r = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    # a tall box, a short one standing in its shadow (objects receive too), and a third
    # out in the sun
    grey = (0.7, 0.7, 0.7)
    boxes = Instances((box_mesh((10.0, 18.0, 8.0), grey, "test-box"),
                       box_mesh((6.0, 6.0, 6.0), grey, "test-box")), [0, 1, 0],
                      [[48, 0, 48], [38, 0, 58], [22, 0, 70]], [1.0, 1.0, 0.7],
                      [0.0, 0.3, 0.6])
    r.terrain.set_objects(boxes)
    cam = Camera.look_at((45, 70, 100), (42, 0, 55), aspect=SIZE[0] / SIZE[1], near=1.0,
                         far=1000.0)
    yield r, boxes, cam
    r.release()


def _sun_facing(points, eye):
    """bool: pixels whose surface (normal from neighbouring pixels' points, turned toward
    the camera) faces the sun."""
    n = np.cross(np.gradient(points, axis=0), np.gradient(points, axis=1))
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
    toward = np.einsum("...i,...i->...", n, eye - points)
    n *= np.where(np.nan_to_num(toward) < 0, -1.0, 1.0)[..., None]
    return np.nan_to_num(n @ np.asarray(sun_direction(*SUN))) > 0.2


def _luma(img):
    return img[..., :3].astype(np.float64).mean(axis=-1)


@pytest.mark.parametrize("technique", ["plain", "bump"])  # shade(); phong() and unlit()
@pytest.mark.parametrize("lighting", ["none", "vertex", "lightmap"])
def test_cascades_shadow_where_the_ray_cast_does_in_every_lighting_mode(scene, technique,
                                                                        lighting):
    r, boxes, cam = scene
    # every object its mesh: the ray cast needs the surface under each pixel
    params = {"sun": SUN, "fog_density": 0.0, "lighting": lighting, "impostor_pixels": 0}
    lit = r.render(cam, technique, {**params, "object_shadows": "none"})
    shaded = r.render(cam, technique, {**params, "object_shadows": "cascades"})
    assert r.terrain.drawn_technique == technique
    ref = shadow_reference(cam, r.last_depth(), SUN, instances=boxes)
    volumes = r.render(cam, technique, {**params, "object_shadows": "volumes"})
    dark = _luma(shaded) < DARKER * _luma(lit)
    facing = _sun_facing(ref.points, np.asarray(cam.eye))
    keep = ref.surface & ~boundary_band(ref.object_shadow, 2) & facing
    assert (keep & ref.object_shadow).sum() > 400  # a real shadow in view ...
    on_objects = keep & ref.object_shadow & (np.abs(np.nan_to_num(ref.points[..., 1])) > 0.1)
    assert on_objects.sum() > 30  # ... falling on the short box's top as well
    assert agreement(dark, ref.object_shadow, keep) >= 0.98
    assert dark[on_objects].mean() >= 0.9  # (the misses: pixels on the edge of two faces)
    # outside the shadows the frame is the one without object shadows
    out = keep & ~ref.object_shadow
    assert (np.abs(_luma(shaded) - _luma(lit))[out] <= 1.0).mean() >= 0.99
    # inside, as dark as the stencil volumes make it (the same shadowed colour)
    core = keep & ref.object_shadow
    assert np.median(np.abs(_luma(shaded) - _luma(volumes))[core]) <= 1.0
