"""The Python API: the subcommands' jobs on arrays, for notebooks and scripts.

Each function takes a heightfield in one of three forms and returns its result in the same form:

- a NumPy array ``float[ny, nx]`` of elevations (m, row 0 = north, NaN = nodata) with
  ``cell_size`` (m; one number, or ``(dx, dy)``) and optionally ``crs`` (e.g. ``"EPSG:32632"``);
- an ``xarray.DataArray`` with ``y``/``x`` coordinates and a CRS (``rioxarray``: the
  ``unerode-cli[xarray]`` extra), whose coordinates, CRS and attributes the result keeps;
- a :class:`~unerode_cli.io.terrain.Terrain` (what :func:`read` returns).

The keyword arguments are the subcommand's options, declared once for the command line, the
pipelines and this API (``dt=500`` for ``--dt 500``, ``K=2e-5`` for ``--K 2e-5``; a process
parameter may also be an array on the heightfield's grid), checked by the same declarations:
a bad value raises :class:`~unerode_cli.errors.InputError` with the command line's sentence.

Every function runs the subcommand's own job (plan, run, write), so its numbers are the
command line's, bit for bit: the heightfield and array parameters are handed to the job as
lossless float64 GeoTIFFs in a temporary folder, and the job's float64 outputs are read back.
``cancel``, a function of no argument, stops a time-stepping job at the end of a step when it
returns True (the result is then that of the steps done).
"""

from __future__ import annotations

import contextlib
import dataclasses
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.gdal_io import WriteOptions
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_terrain, write_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.pipeline.commands import JOBS, run_job
from unerode_cli.run.declare import build, options_of
from unerode_cli.run.job import Progress

__all__ = ["read", "write", "flow", "erode", "unerode", "climate_run", "glaciate", "particle_erode",
           "sandstone", "Terrain", "InputError"]

CellSize = float | tuple[float, float] | None


def read(path: str | Path, band: int | None = None, channel: str | None = None) -> Terrain:
    """Read a heightfield (GeoTIFF, any GDAL raster, or OpenEXR).

    Parameters
    ----------
    path : str or Path
        The raster file.
    band : int, optional
        Band of a multi-band raster (1-based).
    channel : str, optional
        Channel of an EXR file (default ``Y``).

    Returns
    -------
    Terrain
        ``elevation`` float64[ny, nx] in metres (NaN = nodata), ``dx``/``dy`` cell sizes in
        metres, ``crs_wkt``, ``transform`` and ``tags``.

    Examples
    --------
    >>> import unerode_cli
    >>> dem = unerode_cli.read("sample_dems/valley_utm32n_30m.tif")
    >>> dem.shape, dem.dx
    ((256, 256), 30.0)
    """
    return read_terrain(Path(path), band=band, channel=channel)


def write(heightfield: Any, path: str | Path, cell_size: CellSize = None, crs: str | None = None,
          dtype: str = "float32", overwrite: bool = False) -> Path:
    """Write a heightfield; the format follows the extension (``.tif``, ``.exr``, ...).

    Parameters
    ----------
    heightfield : ndarray, xarray.DataArray or Terrain
        Elevations (m).
    path : str or Path
        Output file; an existing one is replaced only with ``overwrite``.
    cell_size, crs :
        For an array: cell size (m) and CRS.
    dtype : {"float32", "float64"}
        Sample type of GDAL outputs.

    Returns
    -------
    Path
        The written file.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib, unerode_cli
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> unerode_cli.write(np.ones((4, 5)), folder / "flat.tif", cell_size=10.0).name
    'flat.tif'
    >>> unerode_cli.read(folder / "flat.tif").shape
    (4, 5)
    """
    terrain, _ = _as_terrain(heightfield, cell_size, crs)
    target = Path(path)
    plan = OutputPlan()
    with plan.active():
        plan.check_output(target, overwrite)
        write_terrain(terrain, target, WriteOptions(dtype, False, {}))
    return target


def flow(heightfield: Any, cell_size: CellSize = None, crs: str | None = None, **options: Any) -> Any:
    """Discharge (m³/y), drainage area (m²) or D8 receivers of a heightfield (``flow``).

    Parameters
    ----------
    heightfield, cell_size, crs :
        See the module docstring.
    **options :
        Options of ``unerode-cli flow``: ``what`` (``discharge``, ``area`` or ``receivers``),
        ``method`` (``mfd`` or ``d8``), ``precipitation`` (m/y; a number or an array),
        ``outlets``, ``sea_level``.

    Returns
    -------
    ndarray, xarray.DataArray or Terrain
        The field, NaN outside the domain.

    Examples
    --------
    >>> import numpy as np, unerode_cli
    >>> ramp = np.add.outer(np.arange(8.0), np.zeros(6)) * 10.0   # drains north
    >>> area = unerode_cli.flow(ramp, cell_size=30.0, what="area", method="d8", outlets="N")
    >>> float(area[0, 0])   # eight cells of 900 m² drain through each cell of the north row
    7200.0
    """
    return _run("flow", heightfield, cell_size, crs, options)["output"]


def erode(heightfield: Any, cell_size: CellSize = None, crs: str | None = None,
          cancel: Callable[[], bool] | None = None, **options: Any) -> Any:
    """Run surface processes forward in time (``erode``; 000 §3–4, 001 §6.2–6.4).

    Parameters
    ----------
    heightfield, cell_size, crs :
        See the module docstring.
    cancel : callable, optional
        Returns True to stop at the end of the current step.
    **options :
        Options of ``unerode-cli erode``: ``process`` (e.g. ``"fluvial,thermal"``), ``dt``
        (years), ``duration`` (years) or ``steps``, ``outlets``, ``sea_level``, and the process
        parameters by name or symbol (``K``, ``K_d``, ``m``, ``n``, ``k_th`` …), each a number
        or an array on the grid.

    Returns
    -------
    ndarray, xarray.DataArray or Terrain
        The eroded elevations (m).

    Examples
    --------
    >>> import numpy as np, unerode_cli
    >>> dem = unerode_cli.read("sample_dems/valley_utm32n_30m.tif")
    >>> eroded = unerode_cli.erode(dem.elevation, cell_size=30.0, dt=1000, steps=3, K=2e-5)
    >>> eroded.shape, bool(np.nanmean(eroded) < np.nanmean(dem.elevation))   # rivers incise
    ((256, 256), True)
    """
    return _run("erode", heightfield, cell_size, crs, options, cancel)["output"]


def unerode(heightfield: Any, cell_size: CellSize = None, crs: str | None = None,
            cancel: Callable[[], bool] | None = None, **options: Any) -> Any:
    """Run surface processes backward in time (``unerode``; 000 §3.2, slope limiter).

    Takes the options of :func:`erode` (``dt`` stays positive: the job reverses it).

    Returns
    -------
    ndarray, xarray.DataArray or Terrain
        The uneroded (past) elevations (m).

    Examples
    --------
    >>> import numpy as np, unerode_cli
    >>> dem = unerode_cli.read("sample_dems/valley_utm32n_30m.tif")
    >>> past = unerode_cli.unerode(dem, dt=500, steps=2, K=2e-5)
    >>> float(np.nanmean(past.elevation - dem.elevation)) > 0.0     # valleys filled back
    True
    """
    return _run("unerode", heightfield, cell_size, crs, options, cancel)["output"]


def climate_run(heightfield: Any, cell_size: CellSize = None, crs: str | None = None,
                cancel: Callable[[], bool] | None = None, **options: Any) -> Any:
    """(Un)erode along a paleo-climate chronology (``climate-run``; 000 §5).

    Parameters
    ----------
    **options :
        Options of ``unerode-cli climate-run``: ``chronology`` (a δ18O or sea-level table),
        ``sea_level`` (table), ``from_ka``/``to_ka`` (ka), ``dt`` (years), ``process`` …

    Returns
    -------
    ndarray, xarray.DataArray or Terrain
        The elevations (m) at the end age.
    """
    return _run("climate-run", heightfield, cell_size, crs, options, cancel)["output"]


def glaciate(heightfield: Any, cell_size: CellSize = None, crs: str | None = None,
             cancel: Callable[[], bool] | None = None, **options: Any) -> tuple[Any, Any]:
    """Grow glaciers and erode their bed (``glaciate``; 001 §3–6).

    Parameters
    ----------
    **options :
        Options of ``unerode-cli glaciate``: ``ela`` (m: a number or an array), ``duration``
        and ``dt`` (years), ``iceflow`` (``blatter``, ``sia`` or ``cnn``, with ``seed``), ``layers`` …

    Returns
    -------
    (bed, ice) : two of ndarray, xarray.DataArray or Terrain
        The eroded bed (m) and the final ice thickness (m).

    Examples
    --------
    >>> import numpy as np, unerode_cli
    >>> y, x = np.mgrid[0:24, 0:24] * 100.0
    >>> mountain = 3000.0 - 0.05 * np.hypot(x - 1150.0, y - 1150.0)
    >>> bed, ice = unerode_cli.glaciate(mountain, cell_size=100.0, ela=2900.0, duration=40,
    ...                                 dt=10, iceflow="sia")
    >>> bool(ice.max() > 0.0), bed.shape
    (True, (24, 24))
    """
    files = _run("glaciate", heightfield, cell_size, crs, options, cancel, extra={"ice": "ice.tif"})
    return files["output"], files["ice"]


def particle_erode(heightfield: Any, cell_size: CellSize = None, crs: str | None = None,
                   **options: Any) -> Any:
    """Erode a heightfield with particles (``particle-erode``; 003).

    Parameters
    ----------
    **options :
        Options of ``unerode-cli particle-erode`` (``particles``, ``seed``, ``kinds`` …).

    Returns
    -------
    ndarray, xarray.DataArray or Terrain
        The eroded heightfield (m).
    """
    return _run("particle-erode", heightfield, cell_size, crs, options)["output"]


def sandstone(heightfield: Any = None, cell_size: CellSize = None, crs: str | None = None,
              cancel: Callable[[], bool] | None = None, **options: Any) -> Any:
    """Erode sandstone in 3D (``sandstone``; 002): from a heightfield extruded into a block, or
    with ``heightfield=None`` from a ``preset`` or ``scene``.

    Returns
    -------
    ndarray, xarray.DataArray or Terrain
        The top heightfield (m) of the eroded rock.
    """
    files = _run("sandstone", heightfield, cell_size, crs, options, cancel,
                 extra={"heightfield": "top.tif"})
    return files["heightfield"]


# ---------------------------------------------------------------------------------------------


def _as_terrain(heightfield: Any, cell_size: CellSize, crs: str | None) -> tuple[Terrain, Any]:
    """A Terrain from any accepted form, and what converts a Terrain back to that form."""
    if isinstance(heightfield, Terrain):
        return heightfield, lambda terrain: terrain
    if type(heightfield).__name__ == "DataArray":
        return _from_xarray(heightfield)
    array = np.asarray(heightfield, dtype=np.float64)
    if array.ndim != 2:
        raise InputError(f"a heightfield is a 2-D array of elevations, got {array.ndim} dimension(s).")
    if cell_size is None:
        raise InputError("give cell_size (m) with an array heightfield.")
    dx, dy = (cell_size, cell_size) if np.isscalar(cell_size) else tuple(cell_size)  # type: ignore[misc]
    if not (dx > 0 and dy > 0):
        raise InputError(f"cell_size must be > 0 m, got {cell_size}.")
    from affine import Affine

    crs_wkt = ""
    if crs:
        from pyproj import CRS

        crs_wkt = CRS.from_user_input(crs).to_wkt()
    terrain = Terrain(array.copy(), float(dx), float(dy), crs_wkt,
                      Affine(float(dx), 0.0, 0.0, 0.0, -float(dy), array.shape[0] * float(dy)))
    return terrain, lambda result: result.elevation


def _from_xarray(data: Any) -> tuple[Terrain, Any]:
    try:
        import rioxarray  # noqa: F401  (registers the .rio accessor)
    except ImportError:
        raise InputError("xarray heightfields need rioxarray: pip install 'unerode-cli[xarray]'.") from None
    transform = data.rio.transform()
    crs = data.rio.crs
    values = np.asarray(data.values, dtype=np.float64)
    terrain = Terrain(values.copy(), abs(transform.a), abs(transform.e), crs.to_wkt() if crs else "",
                      transform)

    def back(result: Terrain) -> Any:
        return data.copy(data=result.elevation)

    return terrain, back


@contextlib.contextmanager
def _workspace() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="unerode-api-") as folder:
        yield Path(folder)


def _run(command: str, heightfield: Any, cell_size: CellSize, crs: str | None, options: dict[str, Any],
         cancel: Callable[[], bool] | None = None, extra: dict[str, str] | None = None) -> dict[str, Any]:
    """Run ``command``'s job on ``heightfield`` with ``options``; its outputs by option name."""
    entry = JOBS[command]
    job_class = entry.job_class()
    declared = options_of(job_class)
    with _workspace() as folder:
        values: dict[str, Any] = {}
        back: Any = None
        terrain: Terrain | None = None
        if heightfield is not None:
            terrain, back = _as_terrain(heightfield, cell_size, crs)
            values[_source_option(job_class)] = _staged(terrain, folder / "input.tif")
        for name, value in options.items():
            key = _option_name(declared, name, command)
            if isinstance(value, np.ndarray) or type(value).__name__ == "DataArray":
                if terrain is None:
                    raise InputError(f"{name}: an array parameter needs a heightfield to lie on.")
                array = np.asarray(getattr(value, "values", value), dtype=np.float64)
                if array.shape != terrain.shape:
                    raise InputError(f"{name}: an array of shape {array.shape} is not on the "
                                     f"heightfield's grid {terrain.shape}.")
                layer = dataclasses.replace(terrain, elevation=array, tags={})
                value = str(_staged(layer, folder / f"{key}.tif"))
            values[key] = value
        outputs = {"output": folder / "output.tif", **{k: folder / v for k, v in (extra or {}).items()}}
        for key, path in outputs.items():
            if key in declared:
                values[key] = path
        if "dtype" in declared:
            values["dtype"] = "float64"
        try:
            job = build(job_class, values)
        except ValueError as exc:
            raise InputError(f"{command}: {str(exc).rstrip('.')}.") from None
        run_job(job, Progress(cancel))
        results = {}
        for key, path in outputs.items():
            if path.exists():
                result = read_terrain(path)
                results[key] = back(result) if back is not None else result
        return results


def _source_option(job_class: Any) -> str:
    """The job's input heightfield: its first positional path argument read by the job."""
    for opt in job_class.OPTIONS:
        if opt.argument and opt.role == "input":
            return opt.name
    raise InputError(f"{job_class.COMMAND} takes no input heightfield.")


def _option_name(declared: dict[str, Any], name: str, command: str) -> str:
    """The field of a keyword argument: the option's name, or a flag's name (``K`` for ``--K``)."""
    if name in declared:
        return name
    flag = "--" + name.replace("_", "-")
    for opt in declared.values():
        if flag in opt.all_flags:
            return opt.name
    raise InputError(f"{command} has no option {name} (see unerode-cli {command} --help).")


def _staged(terrain: Terrain, path: Path) -> Path:
    """Write ``terrain`` losslessly (float64 GeoTIFF) for a job to read."""
    plan = OutputPlan()
    with plan.active():
        plan.check_output(path, overwrite=False)
        write_terrain(terrain, path, WriteOptions("float64", False, {}))
    return path
