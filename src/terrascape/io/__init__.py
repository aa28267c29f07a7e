"""Reading and writing heightmap files.

:func:`read_heightmap` / :func:`write_heightmap` dispatch by extension (:data:`FORMATS`);
each format also has its own module (``image``, ``raw``, ``tiff``, ``npy``, ``terragen``),
``fill`` fills nodata holes, and ``atomic`` makes every write all-or-nothing. The names are
imported on first use (:mod:`terrascape._lazy`): ``terrascape.io.atomic`` loads no numpy.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §2.1.
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.1.
"""

from __future__ import annotations

from terrascape._lazy import lazy_exports

TYPE_CHECKING = False
if TYPE_CHECKING:
    from terrascape.io.atomic import atomic_output, check_output_path, output_unit
    from terrascape.io.fill import fill_nodata
    from terrascape.io.heightmap_file import (
        FORMATS,
        READ_EXTENSIONS,
        WRITE_EXTENSIONS,
        WRITE_FORMAT_NAMES,
        formats_help,
        read_heightmap,
        write_heightmap,
    )
    from terrascape.io.image import (
        REC601_LUMA,
        luminance,
        read_image,
        write_png16,
        write_preview,
    )
    from terrascape.io.npy import read_npy, write_npy
    from terrascape.io.raw import read_raw16, read_raw32, sidecar_path, write_raw16, write_raw32
    from terrascape.io.terragen import read_terragen, terragen_encoding, write_terragen
    from terrascape.io.tiff import geographic_spacing, read_tiff, write_tiff

__getattr__, __dir__ = lazy_exports(__name__, {
    "atomic": ("atomic_output", "check_output_path", "output_unit"),
    "fill": ("fill_nodata",),
    "heightmap_file": ("FORMATS", "READ_EXTENSIONS", "WRITE_EXTENSIONS", "WRITE_FORMAT_NAMES",
                       "formats_help", "read_heightmap", "write_heightmap"),
    "image": ("REC601_LUMA", "luminance", "read_image", "write_png16", "write_preview"),
    "npy": ("read_npy", "write_npy"),
    "raw": ("read_raw16", "read_raw32", "sidecar_path", "write_raw16", "write_raw32"),
    "terragen": ("read_terragen", "terragen_encoding", "write_terragen"),
    "tiff": ("geographic_spacing", "read_tiff", "write_tiff"),
})

__all__ = [
    "FORMATS",
    "READ_EXTENSIONS",
    "REC601_LUMA",
    "WRITE_EXTENSIONS",
    "WRITE_FORMAT_NAMES",
    "atomic_output",
    "check_output_path",
    "fill_nodata",
    "formats_help",
    "geographic_spacing",
    "luminance",
    "output_unit",
    "read_heightmap",
    "read_image",
    "read_npy",
    "read_raw16",
    "read_raw32",
    "read_terragen",
    "read_tiff",
    "sidecar_path",
    "terragen_encoding",
    "write_heightmap",
    "write_npy",
    "write_png16",
    "write_preview",
    "write_raw16",
    "write_raw32",
    "write_terragen",
    "write_tiff",
]
