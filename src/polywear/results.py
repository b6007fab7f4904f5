"""The base class of every result object: one interface for summaries, data, plots and files.

Every public result (a bifurcation diagram, a simulation, a stability map, a wear map, a
friction fit, ...) derives from :class:`Result` and offers the same methods:

- ``summary()``: a JSON-serialisable dict (what the command's ``--json`` prints);
- ``to_xarray()``: an ``xarray.Dataset`` whose attributes carry the parameters
  (``params_toml``, ``model``), ``polywear_version``, ``settings`` and ``summary_json``;
- ``to_dataframe()``: a ``pandas.DataFrame`` of the main rows (the table ``--csv`` writes);
- ``plot(ax=None)``: draws onto ``ax`` (new axes if None) and returns the artists; never shows;
- ``figure()``: a new matplotlib Figure with the default plot(s);
- ``save(path)``: the suffix decides: ``.nc`` netCDF of ``to_xarray()``, ``.json`` the summary
  with ``polywear_version``, ``params`` and ``settings`` added, ``.csv`` the dataframe;
  written atomically (:mod:`polywear.io`); returns the path written.

A subclass implements ``summary``, ``_dataset`` (the data without the common attributes)
and ``plot``; it overrides ``to_dataframe`` when the dataset has more than one table.
"""

from __future__ import annotations

import dataclasses
import json
from abc import ABC, abstractmethod
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import __version__

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr
    from matplotlib.figure import Figure

    from .params import Params

__all__ = ["Result", "SAVE_SUFFIXES", "jsonable", "with_deprecated_keys"]

SAVE_SUFFIXES = (".nc", ".json", ".csv")
"""File suffixes :meth:`Result.save` writes."""


def with_deprecated_keys(summary: dict, renamed: dict[str, str | tuple[str, float]]) -> dict:
    """``summary`` with, beside each renamed key, its old name (readable for one release; CHANGELOG.md).

    ``renamed`` maps a new key to its old name, or to ``(old name, factor)`` where the unit
    changed: the old key then holds the new value times ``factor`` (``None`` stays ``None``;
    lists and lists of pairs are scaled element by element). Keys absent from ``summary``
    are skipped; the old key follows the new one. Returns a new dict.
    """
    out: dict = {}
    for key, value in summary.items():
        out[key] = value
        entry = renamed.get(key)
        if isinstance(entry, tuple):
            old, factor = entry
            out[old] = _scaled(value, factor)
        elif entry is not None:
            out[entry] = value
    return out


def _scaled(value: Any, factor: float) -> Any:
    """``value`` times ``factor``, through lists and tuples; ``None`` stays ``None``."""
    if value is None:
        return None
    if isinstance(value, (list, tuple)):
        return [_scaled(v, factor) for v in value]
    return value * factor


def jsonable(obj: Any) -> Any:
    """``json.dumps`` default: numpy arrays and scalars, paths, tuples of settings, enums."""
    if hasattr(obj, "tolist"):  # numpy arrays and scalars
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return dataclasses.asdict(obj)
    if hasattr(obj, "model_dump"):  # pydantic models
        return obj.model_dump(mode="json")
    if hasattr(obj, "value") and hasattr(obj, "name"):  # enums
        return obj.value
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


class Result(ABC):
    """Base of every result object (see the module docstring for the common interface).

    ``params`` is the parameter set the result was computed for (None where the result
    does not come from a parameter set, e.g. a measured run) and ``settings`` its
    numerical settings (None where there are none). Subclasses declare them as fields
    where they have them (annotations only here: a value in the base would become a
    dataclass default of every subclass).
    """

    params: Params | None
    settings: Any

    def __getattr__(self, name: str) -> Any:
        """``params`` and ``settings`` are None on a result that has no such field."""
        if name in ("params", "settings"):
            return None
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def polywear_version(self) -> str:
        """Version of polywear that computed the result."""
        return __version__

    @abstractmethod
    def summary(self) -> dict:
        """The result as a JSON-serialisable dict (what ``--json`` prints)."""

    @abstractmethod
    def _dataset(self) -> xr.Dataset:
        """The result's data; :meth:`to_xarray` adds the common attributes."""

    @abstractmethod
    def plot(self, ax: Any = None) -> Any:
        """Draw the result onto ``ax`` (new axes if None); returns the artists."""

    def to_xarray(self) -> xr.Dataset:
        """The result as an xarray Dataset; attrs: ``model`` and ``params_toml`` (where there
        are parameters), ``polywear_version``, ``settings`` (repr, where there are any) and
        ``summary_json``."""
        ds = self._dataset()
        params, settings = self.params, self.settings
        if params is not None:
            from .params import to_toml

            ds.attrs.setdefault("model", params.model)
            ds.attrs.setdefault("params_toml", to_toml(params))
        ds.attrs.setdefault("polywear_version", self.polywear_version)
        if settings is not None:
            ds.attrs.setdefault("settings", repr(settings))
        ds.attrs.setdefault("summary_json", json.dumps(self.summary(), default=jsonable))
        return ds

    def to_dataset(self) -> xr.Dataset:
        """Same as :meth:`to_xarray` (the older name)."""
        return self.to_xarray()

    def to_dataframe(self) -> pd.DataFrame:
        """The main table of the result. By default the variables of :meth:`to_xarray` that
        lie on the same dimensions as its first variable, one row per coordinate combination
        (the coordinates as columns); results with a table of their own return that."""
        ds = self.to_xarray()
        dims = next(iter(ds.data_vars.values())).dims
        names = [name for name, var in ds.data_vars.items() if var.dims == dims]
        return ds[names].to_dataframe().reset_index()

    def _table_dataset(self) -> xr.Dataset:
        """:meth:`to_dataframe` as a Dataset along ``row`` (for results that are a table;
        text and mixed columns as strings)."""
        import xarray as xr

        df = self.to_dataframe().reset_index(drop=True).rename_axis("row")
        for name in df.columns:
            if df[name].dtype == object:
                df[name] = df[name].map(lambda v: v if isinstance(v, str) else json.dumps(v, default=jsonable))
        return xr.Dataset.from_dataframe(df)

    def figure(self) -> Figure:
        """A new matplotlib Figure with the default plot."""
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 4.5))
        self.plot(ax=ax)
        fig.tight_layout()
        return fig

    def provenance(self) -> dict:
        """``polywear_version``, and ``params`` and ``settings`` where there are any (JSON-ready)."""
        out: dict[str, Any] = {"polywear_version": self.polywear_version}
        params, settings = self.params, self.settings
        if settings is not None:
            out["settings"] = json.loads(json.dumps(settings, default=jsonable))
        if params is not None:
            out["params"] = params.model_dump(mode="json")
        return out

    def save(self, path: str | Path) -> Path:
        """Write the result; the suffix decides: ``.nc`` netCDF (h5netcdf) of :meth:`to_xarray`,
        ``.json`` :meth:`summary` with :meth:`provenance` added, ``.csv`` :meth:`to_dataframe`
        (no index column). Written atomically; returns the path.

        Raises
        ------
        ValueError
            For any other suffix.
        """
        from .io import atomic_path

        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in SAVE_SUFFIXES:
            raise ValueError(f"{type(self).__name__}.save: cannot write {path.name!r}; "
                             f"use one of {', '.join(SAVE_SUFFIXES)}")
        with atomic_path(path) as tmp:
            if suffix == ".nc":
                self.to_xarray().to_netcdf(tmp, engine="h5netcdf")
            elif suffix == ".csv":
                self.to_dataframe().to_csv(tmp, index=False)
            else:
                payload = {**self.summary(), **self.provenance()}
                tmp.write_text(json.dumps(payload, indent=2, ensure_ascii=False, allow_nan=False, default=jsonable),
                               encoding="utf-8")
        return path
