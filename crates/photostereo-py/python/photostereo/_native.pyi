"""Type stub of photostereo._native, the compiled half of the package.

The public functions are those of ``photostereo`` (``__init__.py``), which accept a
Dataset, a path or an array and call these with arrays. Conventions: x right, y up,
z toward the camera (orthographic); normals (H, W, 3) float32; depth (H, W) float32 in
pixels, larger = closer, NaN outside the mask; lights (K, 3) unit directions
(surface -> light). Errors: FileNotFoundError (missing path), OSError (other file
problems), ValueError (bad data or arguments), with the library's message.
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
F32 = npt.NDArray[np.float32]
Bool = npt.NDArray[np.bool_]

class Dataset:
    """K images under K lights (``photostereo.load_dataset`` or ``Dataset(images, ...)``)."""

    def __init__(
        self,
        images: F32,
        lights: Optional[F32] = None,
        mask: Optional[Bool] = None,
        names: Optional[Sequence[str]] = None,
    ) -> None:
        """A dataset from arrays: images (K, H, W) float32, lights (K, 3), mask (H, W) bool."""
    @property
    def images(self) -> F32:
        """(K, H, W) float32 linear luminance, light intensities divided out (a view, no copy)."""
    @property
    def lights(self) -> Optional[F32]:
        """(K, 3) float32 unit light directions, or None."""
    @property
    def mask(self) -> Optional[Bool]:
        """(H, W) bool object mask, or None."""
    @property
    def names(self) -> list[str]:
        """Image file names in light order."""
    @property
    def path(self) -> Optional[str]:
        """The dataset directory (None for a dataset made from arrays)."""
    def __len__(self) -> int:
        """Number of images K."""

class Result:
    """Normals and the maps that come with them."""

    @property
    def normals(self) -> F32:
        """(H, W, 3) float32 unit normals, [0, 0, 0] outside the mask."""
    @property
    def albedo(self) -> Optional[F32]:
        """(H, W) albedo: Lambertian (absolute) or lookup with normalize=True (relative to the sphere)."""
    @property
    def confidence(self) -> Optional[F32]:
        """(H, W) lookup confidence in [0, 1] (None for Lambertian)."""
    @property
    def residual(self) -> F32:
        """(H, W) RMS residual per light used (intensity units)."""
    @property
    def weights(self) -> Optional[list[F32]]:
        """Two (H, W) mixture weights (a, b) with two tables, else None."""
    @property
    def normals_sigma(self) -> Optional[F32]:
        """(H, W) angular standard error (degrees) of each normal from its own data (None with two tables)."""
    @property
    def own_share(self) -> Optional[F32]:
        """(H, W) share in [0, 1] of each pixel's own data in its normal (spatial stage)."""
    @property
    def warnings(self) -> list[tuple[str, str]]:
        """[(code, message)]: what limits the result, e.g. ("spatial_stage_skipped", ...) with two tables."""

class Table:
    """A lookup table intensity tuple -> normal, from a calibration sphere."""

    @property
    def circle(self) -> tuple[float, float, float]:
        """The sphere's circle (cx, cy, r) in pixels (cx along columns, cy along rows)."""
    @property
    def k(self) -> int:
        """Number of lights K."""
    @property
    def names(self) -> list[str]:
        """Image names the table was built from."""
    @property
    def material(self) -> str:
        """Free-text material name."""
    @property
    def rim_blur(self) -> Optional[float]:
        """The optical blur (px, Gaussian sigma) measured on the sphere's rim; None if not measured.
        Above 0.35 px the spatial stage weights the target's outline down."""
    @property
    def fit_rms(self) -> Optional[float]:
        """RMS distance of the sphere's edge points to the circle (px); None for a loaded table."""
    def __len__(self) -> int:
        """Number of table entries (sphere pixels used)."""
    def lookup(
        self,
        target: Union[Dataset, PathLike, F32],
        *,
        mask: Optional[Bool] = None,
        normalize: bool = False,
        spatial: bool = True,
    ) -> Result:
        """Normals of target (a Dataset, directory or (K, H, W) array) by this table, as
        ``photostereo normals --lut``; spatial=False leaves out the spatial stage. The
        search index is built at the first lookup and reused."""
    def save(self, path: PathLike) -> None:
        """Write the .lut file (as ``photostereo calibrate``), atomically."""
    @staticmethod
    def load(path: PathLike) -> Table:
        """Read a .lut file written by save or ``photostereo calibrate``."""

def load_dataset(path: PathLike, response: Optional[str] = None) -> Dataset:
    """Read a dataset directory (DiLiGenT layout; PNG/TIFF/JPEG images; lights from
    light_directions.txt, an RTI .lp or an AliceVision lights.json). response:
    "linear", "srgb", "gamma=G", or None (sRGB for JPEG files, linear otherwise)."""

def calibrate(
    images: F32,
    names: Sequence[str],
    mask: Optional[Bool] = None,
    circle: Optional[tuple[float, float, float]] = None,
    sphere_region: Optional[tuple[int, int, int, int]] = None,
    rim: float = 2.0,
    material: str = "",
    smooth: Optional[float] = None,
) -> Table:
    """Detect the sphere in (K, H, W) images and build its lookup table."""

def lookup(
    images: F32,
    names: Sequence[str],
    tables: Sequence[Table],
    mask: Optional[Bool] = None,
    normalize: bool = False,
    spatial: Optional[bool] = None,
) -> Result:
    """Normals of (K, H, W) images by one table, or two for a mixture; the spatial
    stage follows with one table unless spatial=False (True with two is an error)."""

def lambertian(
    images: F32,
    lights: F32,
    mask: Optional[Bool] = None,
    robust: bool = True,
    spatial: bool = True,
    black_level: Union[str, float, None] = "auto",
) -> Result:
    """Lambertian photometric stereo with known (K, 3) lights, then the spatial stage
    unless spatial=False; black_level: "auto" (measured, taken off when clearly above
    0), None (nothing) or a level in [0, 0.25) of full scale, as ``--black-level``."""

def lights_from_sphere(
    images: F32,
    mask: Optional[Bool] = None,
    kind: str = "chrome",
    circle: Optional[tuple[float, float, float]] = None,
) -> F32:
    """(K, 3) light directions from a chrome or matte sphere."""

def integrate(
    normals: F32,
    mask: Optional[Bool] = None,
    method: Optional[str] = None,
    weights: Optional[F32] = None,
    camera: Optional[Tuple[str, str]] = None,
    focal: Optional[float] = None,
    min_nz: float = 0.05,
    bini_k: float = 2.0,
) -> F32:
    """(H, W) depth from (H, W, 3) normals; camera = (3x3 matrix as text, its name)
    or focal (pixels) for perspective integration."""

def interreflect(
    images: F32,
    lights: F32,
    mask: Optional[Bool] = None,
    max_iter: int = 10,
    tol: float = 0.01,
    method: Optional[str] = None,
    block: Optional[int] = None,
    black_level: float = 0.0,
    full_scale: float = 1.0,
) -> tuple[F32, F32, F32, str, str, list[tuple[int, float, float, float]], int]:
    """Nayar-Ikeuchi-Kanade iteration: (normals, albedo, depth, summary, csv, rows, best)."""

def run(
    target: str,
    out: str,
    sphere: Optional[str] = None,
    table: Optional[Table] = None,
    lambertian: bool = False,
    lights: Optional[str] = None,
    chrome: Optional[str] = None,
    mask: Optional[str] = None,
    image_scale: Optional[float] = None,
    interreflections: bool = False,
    method: Optional[str] = None,
    spatial: bool = True,
    block: Optional[int] = None,
    response: Optional[str] = None,
    memory: Optional[str] = None,
    black_level: Union[str, float, None] = "auto",
) -> dict:
    """The whole ``photostereo run``; returns what run.json holds (a dict)."""
