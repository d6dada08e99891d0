"""photostereo: photometric stereo for real, shiny objects (numpy in and out).

Calibration-based photometric stereo (a lookup table from a sphere of the same
material under the same lights; Woodham 1994, Hertzmann & Seitz 2005), Lambertian
photometric stereo, light calibration from a chrome or matte sphere, integration of
normals into depth, and interreflection removal (Nayar, Ikeuchi & Kanade 1991). The
computations run in the Rust library `photostereo` with the GIL released.

Conventions (as the command-line tool): x right, y up, z toward the camera,
orthographic; normals (H, W, 3) float32 unit vectors; p = -nx/nz, q = -ny/nz;
depth (H, W) float32 in pixels, larger = closer, NaN outside the mask; lights are
unit directions from the surface toward the light.

Errors: FileNotFoundError for a missing path, OSError for other file problems,
ValueError for bad data or arguments; the message names the file and the fix.

Example::

    import photostereo as ps
    table = ps.calibrate("data/sphere")             # find the sphere, build the table
    res = table.lookup("data/vase")                 # as `photostereo normals --lut`
    depth = ps.integrate(res.normals, ps.load_dataset("data/vase").mask)
"""

from __future__ import annotations

import os
from typing import Any, Optional, Sequence, Union

import numpy as np

from . import _native
from ._native import Dataset, Result, Table

__all__ = [
    "Dataset",
    "Result",
    "Table",
    "load_dataset",
    "calibrate",
    "lookup",
    "lambertian",
    "lights_from_sphere",
    "integrate",
    "interreflect",
    "run",
]

__version__ = _native.__version__

PathLike = Union[str, "os.PathLike[str]"]
Images = Union[Dataset, PathLike, np.ndarray]


def load_dataset(path: PathLike) -> Dataset:
    """Read a dataset directory (DiLiGenT layout).

    The directory holds one image per light (8/16-bit PNG or TIFF, grayscale or RGB),
    sorted by name or listed in ``filenames.txt``; ``light_directions.txt`` (K lines
    ``x y z``), optional ``light_intensities.txt`` and optional ``mask.png``.

    Returns a :class:`Dataset` with ``.images`` (K, H, W) float32 linear luminance
    (light intensities divided out), ``.lights`` (K, 3) or None, ``.mask`` (H, W) bool
    or None, ``.names``.

    Raises FileNotFoundError (no such directory), OSError, ValueError (bad file).
    """
    return _native.load_dataset(os.fspath(path))


def _dataset(x: Images) -> Dataset:
    """A Dataset from a Dataset, a directory path or a (K, H, W) array."""
    if isinstance(x, Dataset):
        return x
    if isinstance(x, (str, os.PathLike)):
        return load_dataset(x)
    arr = np.asarray(x)
    if arr.ndim != 3:
        raise ValueError(
            f"images of shape {arr.shape}: give a Dataset, a dataset directory or a (K, H, W) array"
        )
    return Dataset(np.asarray(arr, dtype=np.float32))


def _array(x: Any, what: str, shape: str, ndim: int, last: Optional[int] = None) -> np.ndarray:
    """x as a float32 array of `ndim` dimensions (the last of size `last`), else ValueError."""
    a = np.asarray(x, dtype=np.float32)
    if a.ndim != ndim or (last is not None and a.shape[-1] != last):
        raise ValueError(f"{what} of shape {a.shape}: give a {shape} array")
    return a


def _existing(path: Optional[PathLike], what: str, fix: str) -> Optional[str]:
    """A path that must exist (FileNotFoundError naming it and the fix otherwise), or None."""
    if path is None:
        return None
    p = os.fspath(path)
    if not os.path.exists(p):
        raise FileNotFoundError(f"{what} {p}: no such file: {fix}")
    return p


def _mask(mask: Any, default: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
    if mask is None:
        return default
    if isinstance(mask, (str, os.PathLike)):
        raise ValueError("mask: give an (H, W) bool array (load a mask file with load_dataset)")
    m = np.asarray(mask)
    if m.ndim != 2:
        raise ValueError(f"mask of shape {m.shape}: give an (H, W) bool array")
    return np.ascontiguousarray(m != 0)


def calibrate(
    sphere: Union[Dataset, PathLike],
    *,
    circle: Optional[Sequence[float]] = None,
    sphere_region: Optional[Sequence[int]] = None,
    mask: Optional[np.ndarray] = None,
    rim: float = 2.0,
    material: str = "",
    smooth: Optional[float] = None,
    denoise: Optional[str] = None,
) -> Table:
    """Find the calibration sphere and build its lookup table (``photostereo calibrate``).

    sphere: a Dataset or a directory with the K images of a sphere of the target's
        material under the target's lights.
    circle: (cx, cy, r) in pixels to use instead of detecting the sphere; cx along
        columns, cy along rows, pixel (r, c) centred at (c + 0.5, r + 0.5).
    sphere_region: (x, y, w, h) window to search the sphere in (left column, top row,
        width, height), when the sphere shares the images with the target.
    mask: (H, W) bool; search the sphere only inside it. Default: the dataset's own
        mask.png when it has one (as ``photostereo run --sphere`` does).
    rim: leave out this many pixels inside the rim (grazing normals, mixed pixels).
    material: free-text name stored in the table.
    smooth: Gaussian blur of the sphere images against noise (pixels); default: chosen
        from the noise measured on the sphere (none on clean images).
    denoise: how a noisy sphere is denoised: "normal" (a local quadratic fit over the
        normal sphere, width by cross-validation), "image" (the blur above); default
        None (or "auto"): the fit when the blur would be at least 1 px
        (``calibrate --denoise``).

    Returns a :class:`Table` (``.circle`` = (cx, cy, r), ``.save(path)``,
    ``Table.load(path)``, ``.lookup(target)``).

    Raises ValueError when no sphere is found (check the circle, give ``circle=``).
    """
    ds = _dataset(sphere)
    return _native.calibrate(
        ds.images,
        ds.names,
        mask=_mask(mask, ds.mask),
        circle=None if circle is None else tuple(float(v) for v in circle),
        sphere_region=None if sphere_region is None else tuple(int(v) for v in sphere_region),
        rim=float(rim),
        material=material,
        smooth=smooth,
        denoise=denoise,
    )


def lookup(
    target: Images,
    tables: Sequence[Table],
    *,
    mask: Optional[np.ndarray] = None,
    normalize: bool = False,
    spatial: Optional[bool] = None,
) -> Result:
    """Normals of a target by table lookup, as ``photostereo normals --lut``.

    target: a Dataset, a dataset directory or a (K, H, W) float32 array, under the
        same K lights (same order) as the tables' sphere.
    tables: one Table, or two for a mixture of two materials (Hertzmann & Seitz:
        t = a I_A(n) + b I_B(n), a, b >= 0; the weights come back in ``.weights``).
    mask: (H, W) bool pixels to solve (default: the dataset's mask, else all).
    normalize: for albedo changes (``normals --normalize``): an albedo relative to the
        sphere comes back (``.albedo``); brightness-normalised matching, or on a
        specular table (more than 2% of its light not Lambertian) the diffuse +
        specular fit.
    spatial: the spatial stage after the lookup, as ``photostereo normals``: pixels
        whose data say little take their normal from their neighbours; ``.own_share``
        comes back and the confidence is multiplied by it. Default (None): on with one
        table, off with two (it models one material; True with two tables is an
        error). False: every pixel keeps its own match (``normals --no-spatial``).
        ``.normals_sigma`` (degrees) comes back with one table either way.

    The table's search index is built at its first lookup and reused by the next ones
    (``Table.lookup`` is the same with one table).

    Returns a :class:`Result`: ``.normals`` (H, W, 3) float32, ``.confidence`` (H, W),
    ``.albedo`` (normalize only), ``.residual``, ``.weights`` (two tables),
    ``.normals_sigma`` and ``.own_share`` (spatial stage).
    """
    if isinstance(tables, Table):
        tables = [tables]
    ds = _dataset(target)
    return _native.lookup(
        ds.images,
        ds.names,
        list(tables),
        mask=_mask(mask, ds.mask),
        normalize=normalize,
        spatial=spatial,
    )


def lambertian(
    images: Images,
    lights: Optional[np.ndarray] = None,
    mask: Optional[np.ndarray] = None,
    *,
    robust: bool = True,
    spatial: bool = True,
    black_level: Union[str, float, None] = "auto",
) -> Result:
    """Lambertian photometric stereo with known lights (``photostereo normals --lambertian``).

    images: a Dataset, a dataset directory or a (K, H, W) array.
    lights: (K, 3) unit directions (surface -> light); default: the dataset's.
    mask: (H, W) bool (default: the dataset's, else all pixels).
    robust: drop shadowed and highlight samples per pixel (False: plain least squares).
    spatial: the spatial stage after the solve, as the CLI (False: ``--no-spatial``).
    black_level: the camera's black level taken off every sample, as ``--black-level``:
        "auto" (measured from the images and taken off when clearly above 0), None
        (nothing taken off) or a level in [0, 0.25) as a fraction of full scale (the
        images' unit: 1 for images in [0, 1]). A dark offset reads as light that no
        normal explains (3% on 8-bit images: about 2 degrees of error). Anything else
        raises ValueError.

    Returns a :class:`Result` with ``.normals`` (H, W, 3), ``.albedo`` (H, W),
    ``.residual``, ``.normals_sigma`` and (spatial stage) ``.own_share``.
    """
    ds = _dataset(images)
    if lights is None:
        lights = ds.lights
    if lights is None:
        raise ValueError("no light directions: pass lights=(K, 3) or a dataset with light_directions.txt")
    lights = _array(lights, "lights", "(K, 3)", 2, 3)
    return _native.lambertian(
        ds.images,
        lights,
        mask=_mask(mask, ds.mask),
        robust=robust,
        spatial=spatial,
        black_level=black_level,
    )


def lights_from_sphere(
    dataset: Images,
    kind: str = "chrome",
    *,
    mask: Optional[np.ndarray] = None,
    circle: Optional[Sequence[float]] = None,
) -> np.ndarray:
    """Light directions from a sphere imaged under the lights (``photostereo lights``).

    dataset: a Dataset, a dataset directory or a (K, H, W) array of the sphere.
    kind: "chrome" (mirror sphere: one highlight per light) or "matte" (Lambertian fit).
    mask: (H, W) bool; for a chrome sphere, its silhouette (the better outline on a
        dark background). Default: the dataset's mask.
    circle: (cx, cy, r) in pixels instead of detecting the sphere.

    Returns (K, 3) float32 unit directions (surface -> light, camera frame).
    """
    ds = _dataset(dataset)
    return _native.lights_from_sphere(
        ds.images,
        mask=_mask(mask, ds.mask),
        kind=kind,
        circle=None if circle is None else tuple(float(v) for v in circle),
    )


def integrate(
    normals: np.ndarray,
    mask: Optional[np.ndarray] = None,
    *,
    method: str = "auto",
    camera: Any = None,
    weights: Optional[np.ndarray] = None,
    min_nz: float = 0.05,
    bini_k: float = 2.0,
    parts: str = "contour",
) -> np.ndarray:
    """Depth from a normal map (``photostereo integrate``).

    normals: (H, W, 3) unit normals (x right, y up, z toward the camera).
    mask: (H, W) bool pixels to integrate (default: all).
    method: "auto" (DCT Poisson on a full rectangle, masked least squares with a
        mask; lsq with a camera), "path", "fc", "fc-reflect", "dct", "lsq" or "bini"
        (bilateral normal integration: keeps depth discontinuities).
    camera: None (orthographic); a pinhole camera for perspective integration (lsq or
        bini) as a 3x3 intrinsics matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (pixels,
        pixel centres at integers, as DiLiGenT's K.txt; ``--camera K.txt``), the path of
        such a text file, or a number: the focal length in pixels with the principal
        point at the image centre (``--focal F``).
    weights: (H, W) per-pixel confidence (>= 0) for "lsq" and "bini".
    min_nz: smallest accepted n_z; normals below it (or NaN) are clamped.
    bini_k: "bini": sharpness of its sigmoid weights (larger breaks more easily).
    parts: how separate parts of the mask are placed relative to each other (``--parts``):
        "contour" (their occluding contours at one depth: a body of revolution such as a
        goblet's cup and foot), "gap" (equal depth across the narrowest gap between parts),
        "median" (equal median depth) or "separate" (each part centred on its own).

    Returns (H, W) float32 depth, NaN outside the mask: orthographic, in pixels, larger =
    closer; with a camera, the distance along the optical axis (positive, larger =
    farther, up to scale: its geometric mean over the mask is the focal length). Separate
    parts of the mask are placed as ``parts`` says.

    Raises ValueError (bad shapes, method, camera), FileNotFoundError (camera file).
    """
    cam, focal = None, None
    if camera is None:
        pass
    elif isinstance(camera, (str, os.PathLike)):
        with open(camera, encoding="utf-8") as f:
            cam = (f.read(), os.fspath(camera))
    elif np.ndim(camera) == 0:
        focal = float(camera)
    else:
        k = np.asarray(camera, dtype=np.float64)
        if k.shape != (3, 3):
            raise ValueError(
                f"camera of shape {k.shape}: give a 3x3 intrinsics matrix "
                "[[fx, 0, cx], [0, fy, cy], [0, 0, 1]], a K.txt path or a focal length"
            )
        cam = ("\n".join(" ".join(repr(float(v)) for v in row) for row in k), "camera matrix")
    n = _array(normals, "normals", "(H, W, 3)", 3, 3)
    w = None if weights is None else _array(weights, "weights", "(H, W)", 2)
    return _native.integrate(
        n,
        mask=_mask(mask),
        method=method,
        weights=w,
        camera=cam,
        focal=focal,
        min_nz=float(min_nz),
        bini_k=float(bini_k),
        parts=str(parts),
    )


def interreflect(
    dataset: Images,
    *,
    lights: Optional[np.ndarray] = None,
    mask: Optional[np.ndarray] = None,
    max_iter: int = 10,
    tol: float = 0.01,
    image_scale: float = 1.0,
    method: str = "auto",
    block: Optional[int] = None,
    black_level: float = 0.0,
) -> dict:
    """Remove interreflections (Nayar-Ikeuchi-Kanade iteration, ``photostereo interreflect``).

    dataset: a Lambertian Dataset, directory or (K, H, W) array, in radiance units
        (multiply by image_scale to get there: bounced light depends on absolute albedo).
    lights: (K, 3) directions (default: the dataset's); mask: (H, W) bool.
    max_iter: most compensation steps; tol: stop when the change of the shape falls
        below this fraction of the depth range.
    block: facet size in pixels (default: the smallest >= 2 giving at most 4096 facets).
    black_level: the camera's black level as a fraction of full scale (images as read:
        1; ``interreflect --black-level``), taken off before the iteration. It is not
        measured here: bounced light reads as an offset.

    Returns a dict: "normals" (H, W, 3), "albedo" (H, W), "depth" (H, W) of the kept
    iterate, "summary", "csv", "iterations" (list of dicts: depth_range, mean_albedo,
    relative_change), "best" (index of the kept iterate).
    """
    ds = _dataset(dataset)
    if lights is None:
        lights = ds.lights
    if lights is None:
        raise ValueError("no light directions: pass lights=(K, 3) or a dataset with light_directions.txt")
    images = ds.images
    if image_scale != 1.0:
        images = images * np.float32(image_scale)
    normals, albedo, depth, summary, csv, rows, best = _native.interreflect(
        images,
        _array(lights, "lights", "(K, 3)", 2, 3),
        mask=_mask(mask, ds.mask),
        max_iter=int(max_iter),
        tol=float(tol),
        method=method,
        block=None if block is None else int(block),
        black_level=float(black_level),
        full_scale=float(image_scale),
    )
    return {
        "normals": normals,
        "albedo": albedo,
        "depth": depth,
        "summary": summary,
        "csv": csv,
        "best": best,
        "iterations": [
            {"iteration": t, "depth_range": d, "mean_albedo": a, "relative_change": c}
            for (t, d, a, c) in rows
        ],
    }


def run(
    target: PathLike,
    out: PathLike,
    *,
    sphere: Union[PathLike, Table, None] = None,
    lambertian: bool = False,
    lights: Optional[PathLike] = None,
    chrome: Optional[PathLike] = None,
    interreflections: bool = False,
    image_scale: Optional[float] = None,
    method: Optional[str] = None,
    mask: Optional[PathLike] = None,
    spatial: bool = True,
    block: Optional[int] = None,
    memory: Union[int, str, None] = None,
    black_level: Union[str, float, None] = "auto",
) -> dict:
    """The whole job on a dataset directory, as ``photostereo run`` (same outputs).

    target: dataset directory; out: output directory (created).
    sphere: calibration sphere directory, or a Table built beforehand (calibration-based).
    lambertian: Lambertian photometric stereo with known lights (the dataset's
        light_directions.txt, or ``lights`` file, or ``chrome`` sphere directory; a
        ``chrome`` sphere implies it, as ``run --chrome``).
    interreflections: remove interreflections (Lambertian only).
    image_scale: factor to bring the images to radiance units (Lambertian).
    method: integrator ("path", "fc", "fc-reflect", "dct", "lsq"; default from the mask).
    mask: mask file instead of the dataset's mask.png.
    spatial: the spatial stage after the normals (default on, as the CLI): pixels whose
        data say little take their normal from their neighbours (``--no-spatial``: False).
    block: facet size in pixels for interreflections (default: chosen from the size).
    memory: the run's memory budget, bytes or a size such as "2G" (``run --memory``):
        the images are read by row bands sized to it; a capture that cannot fit stops
        before any pixel is read. Default: half of the machine's memory.
    black_level: the camera's black level taken off every sample before Lambertian
        photometric stereo, as ``run --black-level``: "auto" (default; measured, taken
        off when clearly above 0), None (nothing) or a level in [0, 0.25) of full scale.
        With interreflections=True "auto" measures nothing (bounced light reads as an
        offset): give the level, which is taken off before the iteration.

    Writes normals.npy/png, albedo, confidence, depth.npy/png, mesh.ply, run.json,
    report.html into ``out``; returns what run.json holds (a dict).
    """
    table = sphere if isinstance(sphere, Table) else None
    sphere_path = None if sphere is None or table is not None else os.fspath(sphere)
    return _native.run(
        os.fspath(target),
        os.fspath(out),
        sphere=sphere_path,
        table=table,
        # as the CLI: lights from a chrome sphere mean Lambertian photometric stereo
        lambertian=lambertian or chrome is not None,
        lights=_existing(
            lights,
            "lights",
            "give a text file of K lines `x y z` (one light direction per image, in image "
            "order), or leave lights out to use the dataset's light_directions.txt",
        ),
        chrome=None if chrome is None else os.fspath(chrome),
        mask=None if mask is None else os.fspath(mask),
        image_scale=image_scale,
        interreflections=interreflections,
        method=method,
        spatial=spatial,
        block=block,
        memory=None if memory is None else str(memory),
        black_level=black_level,
    )
