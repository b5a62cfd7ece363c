"""mbs from Python: the DEM numerical movable bed (Gotoh, Harada & Sakai 2000).

The same library as the ``mbs`` command, not a second implementation:

- :class:`Config`: the embedded default or a file; :meth:`Config.set` is
  checked exactly as ``--set`` (a bad value raises :class:`ConfigError`, a
  ``ValueError``, naming the key, the value and the allowed range).
- :func:`run`: the main job with the command line's guarantees (cell store,
  resume, lock, log); KeyboardInterrupt checkpoints like Ctrl-C. Returns
  :class:`Results`: transport, timeseries and profiles as pandas DataFrames
  (numpy structured arrays without pandas) and the summary as a dict.
- :class:`Sim`: one bed for interactive work: ``settle()``, ``step(n)``,
  grain arrays as numpy, contacts, ``q_star()``, ``digest()``,
  ``checkpoint()`` and :meth:`Sim.restore`. A cell stepped here gives the
  same bits as the same cell of ``mbs run``.
"""

from __future__ import annotations

import copy as _copy
import csv as _csv
import json as _json
import math as _math
import os as _os
from pathlib import Path as _Path
from typing import Any, Dict, Optional, Union

import numpy as _np

from . import _mbs
from ._mbs import ConfigError, SimulationError

__all__ = ["Config", "ConfigError", "SimulationError", "Results", "Sim", "run", "__version__"]
__version__ = _mbs.__version__

PathLike = Union[str, "_os.PathLike[str]"]


def _toml_value(value: Any) -> str:
    """A Python value as the TOML text of a ``--set`` value."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, _np.integer)):
        return str(int(value))
    if isinstance(value, (float, _np.floating)):
        x = float(value)
        if _math.isnan(x):
            return "nan"
        if _math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    if isinstance(value, str):
        return _json.dumps(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple, _np.ndarray)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise ConfigError(f"{value!r}: a number, a string, a bool, a list or a dict of them")


class Config:
    """A configuration: the embedded default (``Config()``) or a TOML file
    (``Config("case.toml")``), with overrides checked as ``--set``.

    >>> c = Config()
    >>> c.set("flow.tau_star", [0.1, 0.2]).tau_stars
    [0.1, 0.2]
    """

    def __init__(self, path: Optional[PathLike] = None) -> None:
        self._native = _mbs.NativeConfig(None if path is None else _os.fspath(path))

    def set(self, key: Union[str, Dict[str, Any]], value: Any = None) -> "Config":
        """Overrides ``key`` (``"section.key"``) with ``value``, checked exactly
        as ``--set key=value``; or, given a dict, every key of it, checked
        together as one command line's ``--set`` options (for values that
        depend on each other, such as ``time.window`` and ``time.block``).
        Raises :class:`ConfigError` and changes nothing if a value is
        refused. Returns the configuration, for chaining."""
        pairs = key.items() if isinstance(key, dict) else [(key, value)]
        self._native.set([(k, _toml_value(v)) for k, v in pairs])
        return self

    def to_toml(self) -> str:
        """The configuration as a run saves it in ``DIR/config.toml``: every
        key, except those that leave the paper's model unchanged at their
        defaults (docs/guarantees.md)."""
        return self._native.to_toml()

    def copy(self) -> "Config":
        """An independent copy."""
        return _copy.copy(self)

    def __copy__(self) -> "Config":
        c = Config.__new__(Config)
        c._native = _copy.copy(self._native)
        return c

    @property
    def tau_stars(self) -> list:
        """The Shields numbers of the sweep."""
        return list(self._native.tau_stars)

    @property
    def seeds(self) -> list:
        """The seeds of the sweep."""
        return list(self._native.seeds)

    @property
    def output(self) -> _Path:
        """``run.output``: where :func:`run` writes without ``out``."""
        return _Path(self._native.output)

    @property
    def sets(self) -> list:
        """The overrides applied, as ``--set`` arguments."""
        return list(self._native.sets)

    def __repr__(self) -> str:
        return f"Config(tau_stars={self.tau_stars}, seeds={self.seeds}, sets={self.sets})"


def _read_csv(path: _Path):
    """A CSV as a pandas DataFrame, or a numpy structured array without pandas."""
    try:
        import pandas as pd
    except ImportError:
        pd = None
    if pd is not None:
        return pd.read_csv(path)
    with open(path, newline="") as f:
        rows = list(_csv.reader(f))
    header, body = rows[0], rows[1:]

    def column(k: int):
        values = [r[k] for r in body]
        try:
            return _np.array([float(v) if v != "" else _np.nan for v in values])
        except ValueError:
            return _np.array(values)

    columns = [column(k) for k in range(len(header))]
    dtype = [(name, c.dtype) for name, c in zip(header, columns)]
    out = _np.empty(len(body), dtype=dtype)
    for name, c in zip(header, columns):
        out[name] = c
    return out


class Results:
    """What :func:`run` wrote into ``dir``, read back."""

    def __init__(self, dir: PathLike) -> None:
        self.dir = _Path(dir)
        #: one row per τ* (``transport.csv``)
        self.transport = _read_csv(self.dir / "transport.csv")
        #: each cell's block means (``timeseries.csv``)
        self.timeseries = _read_csv(self.dir / "timeseries.csv")
        #: the mean profiles per τ* (``profiles.csv``)
        self.profiles = _read_csv(self.dir / "profiles.csv")
        #: ``summary.json`` as a dict
        self.summary: Dict[str, Any] = _json.loads((self.dir / "summary.json").read_text())

    def __repr__(self) -> str:
        return f"Results({str(self.dir)!r}, {len(self.transport)} τ*)"


def run(
    config: Optional[Config] = None,
    out: Optional[PathLike] = None,
    threads: int = 0,
    resume: Optional[PathLike] = None,
    progress: bool = False,
) -> Results:
    """The main job (``mbs run``) of ``config`` (the embedded default when
    None) into ``out`` (else ``run.output``), on ``threads`` workers (0: one
    per core; results do not depend on it), or the interrupted run in
    ``resume`` continued. Finished cells are stored and reused, the
    directory is locked, ``mbs.log`` appended, as on the command line; the
    GIL is released while cells run. KeyboardInterrupt (Ctrl-C) makes the
    running cells checkpoint before it is raised; ``run(resume=DIR)`` then
    finishes the same table, byte for byte. ``progress``: a tqdm bar of the
    integration steps where tqdm is installed, else the command line's bar
    on standard error."""
    native = None if config is None else config._native
    bar, on_progress, quiet = None, None, True
    if progress:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            quiet = False
        else:
            bar = tqdm(total=0, unit="step", unit_scale=True, desc="mbs run")

            def on_progress(done: int, total: int) -> None:
                if bar.total != total:
                    bar.total = total
                bar.update(done - bar.n)

    try:
        dir = _mbs.run(
            native,
            None if out is None else _os.fspath(out),
            threads,
            None if resume is None else _os.fspath(resume),
            quiet,
            on_progress,
        )
    finally:
        if bar is not None:
            bar.close()
    return Results(dir)


class Sim:
    """One (τ*, seed) bed of a configuration, held between calls.

    >>> sim = Sim(Config().set("bed.columns", 5), tau_star=0.2, seed=1)
    >>> sim.settle()   # exactly as ``mbs run`` settles the seed's bed
    'AtRest'
    >>> sim.step(100)
    >>> len(sim.grains()["x"])
    55
    """

    def __init__(
        self,
        config: Optional[Config] = None,
        tau_star: float = 0.2,
        seed: int = 1,
        precision: Optional[str] = None,
    ) -> None:
        config = Config() if config is None else config.copy()
        if precision is not None:
            config.set("run.precision", precision)
        self.config = config
        self._native = _mbs.NativeSim(config._native, float(tau_star), int(seed))

    def settle(self) -> str:
        """Settles as ``mbs run`` settles the seed's bed (until at rest, at most
        ``time.settle``) and starts the flow; returns ``"AtRest"`` or
        ``"NotAtRest"``."""
        return self._native.settle()

    def step(self, n: int = 1) -> None:
        """Runs ``n`` integration steps (the GIL released)."""
        self._native.step(int(n))

    def run_cell(self) -> Dict[str, Any]:
        """The whole cell ``mbs run`` computes for this τ* and seed (settling
        first if needed), as a dict: ``q_star``, ``q_star_class``,
        ``window_s``, ``discarded_blocks``, ``steady``, ``block_q_star``, …;
        the held bed is not stepped."""
        return self._native.run_cell()

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self._native.time

    @property
    def step_count(self) -> int:
        """Integration steps since the bed was built."""
        return self._native.step_count

    @property
    def tau_star(self) -> float:
        return self._native.tau_star

    @property
    def seed(self) -> int:
        return self._native.seed

    def grains(self) -> Dict[str, _np.ndarray]:
        """Every grain as numpy arrays (copies, safe after the Sim is gone):
        ``x``, ``y`` (m), ``u``, ``v`` (m/s), ``spin`` (rad/s), ``radius`` (m),
        ``fixed`` (bool), ``class`` (uint8)."""
        raw = self._native.grains()
        out = {k: _np.frombuffer(raw[k], dtype="<f8").copy() for k in ("x", "y", "u", "v", "spin", "radius")}
        out["fixed"] = _np.frombuffer(raw["fixed"], dtype=_np.uint8).astype(bool)
        out["class"] = _np.frombuffer(raw["class"], dtype=_np.uint8).copy()
        return out

    def contacts(self) -> Dict[str, _np.ndarray]:
        """Every contact as numpy arrays: grains ``i``, ``j`` and the force
        ``fx``, ``fy`` (N) on i from j, as the next step applies it."""
        raw = self._native.contacts()
        out = {k: _np.frombuffer(raw[k], dtype="<u8").astype(_np.int64) for k in ("i", "j")}
        out.update({k: _np.frombuffer(raw[k], dtype="<f8").copy() for k in ("fx", "fy")})
        return out

    def q_star(self) -> float:
        """q* now, as a window samples it (all classes, on the largest
        diameter)."""
        return self._native.q_star()

    def profile(self) -> Dict[str, _np.ndarray]:
        """The profiles now, as a window samples them: per cell of the column,
        bottom up, ``y_over_d`` (the cell's centre over the largest diameter;
        0: the fixed grains' mean centre), ``solid_fraction``,
        ``grain_velocity_m_s``, ``fluid_velocity_m_s`` and the shear stresses
        ``contact_stress_pa``, ``kinetic_stress_pa``, ``viscous_stress_pa``,
        ``reynolds_stress_pa`` (numpy copies; ``profiles.csv`` holds their
        means over a cell's window)."""
        raw = self._native.profile()
        return {k: _np.frombuffer(v, dtype="<f8").copy() for k, v in raw.items()}

    def digest(self) -> int:
        """The 64-bit state digest (docs/determinism.md)."""
        return self._native.digest()

    def checkpoint(self) -> bytes:
        """Every bit of the state, as the kernel checkpoints it."""
        return bytes(self._native.checkpoint())

    @classmethod
    def restore(
        cls,
        data: bytes,
        config: Optional[Config] = None,
        tau_star: float = 0.2,
        seed: int = 1,
    ) -> "Sim":
        """A Sim continued from ``data`` (a :meth:`checkpoint`), bit for bit;
        :class:`SimulationError` if it is damaged or of another capacity."""
        sim = cls(config, tau_star, seed)
        sim._native.restore(bytes(data))
        return sim

    def __repr__(self) -> str:
        return f"Sim(tau_star={self.tau_star}, seed={self.seed}, time={self.time:.6g} s)"
