"""Readers of flight-test records: one text file per channel, CSV, MATLAB .mat, Parquet.

Every reader returns the requested channels as :class:`RawChannel` (time stamps [s] and raw
values in the source unit, NaN samples removed, nothing resampled or repaired: that is
:mod:`~simplexspline.aero.data.time_base`'s job, which reports what it does).

* ``channels``: a directory with one text file per channel, named by a pattern such as
  ``{source}.txt``; each file holds two columns (time, value) or one (values at a stated
  rate); whitespace, comma or semicolon separated; lines starting with ``#`` and the
  header lines before the first line of numbers are skipped; ``NA``, ``-``, blank fields
  and the like are missing samples; clock times ``hh:mm:ss.s`` become seconds of the day.
  An empty file is a channel without data (a missing sensor).
* ``csv`` / ``parquet``: one table, one column per channel, a time column.
* ``mat``: MATLAB files; v4-v7.2 through :func:`scipy.io.loadmat`, v7.3 (HDF5) through h5py.
  Channels are variables; ``struct.field`` (or ``group/dataset`` in v7.3) reaches inside.
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simplexspline.errors import FlightDataError

__all__ = ["RawChannel", "read_channels"]


@dataclass(frozen=True)
class RawChannel:
    """One channel as recorded.

    Attributes
    ----------
    source : str
        Its name in the record.
    t : ndarray, shape (n,)
        Time stamps [s], as recorded (not sorted, duplicates kept).
    values : ndarray, shape (n,)
        Values in the source unit; NaN samples removed (with their time stamps).
    dropped_nan : int
        NaN samples removed.
    timed : bool
        False for values stored without time stamps: ``t`` then counts from 0 at the stated
        rate and the import aligns it with the record's first time stamp.
    """

    source: str
    t: np.ndarray
    values: np.ndarray
    dropped_nan: int = 0
    timed: bool = True


def _finite(source: str, t, v, timed: bool = True) -> RawChannel:
    t = np.asarray(t, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    if t.shape != v.shape:
        raise FlightDataError(f"channel {source!r}: {v.size} values but {t.size} time stamps")
    if np.isinf(v).any():
        k = int(np.flatnonzero(np.isinf(v))[0])
        raise FlightDataError(f"channel {source!r}: infinite value at sample {k} "
                              f"(t = {t[k]:.6g}); fix or blank it in the record")
    keep = np.isfinite(v) & np.isfinite(t)
    return RawChannel(source, t[keep], v[keep], int((~keep).sum()), timed)


#: Words that stand for a missing sample in a channel file (read as NaN, then dropped).
MISSING_WORDS = ("NA", "N/A", "n/a", "NULL", "null", "None", "none", "-", "--")

_CLOCK = re.compile(r"(?<![\w.:])(\d{1,2}):([0-5]\d):([0-5]\d(?:\.\d*)?)(?![\w.:])")
_MISSING = re.compile(r"(?<![\w.+-])(?:" + "|".join(re.escape(w) for w in sorted(
    MISSING_WORDS, key=len, reverse=True)) + r")(?![\w.])")
_EMPTY_FIELD = re.compile(r"(?<=[,;])[ \t]*(?=[,;])")


def _clock_seconds(match: re.Match) -> float:
    """Seconds of the day of a matched ``hh:mm:ss.s``."""
    h, m, sec = match.groups()
    return int(h) * 3600 + int(m) * 60 + float(sec)


def _through_midnight(t: np.ndarray) -> np.ndarray:
    """Clock seconds counted on past midnight (a step back of over 12 h adds a day)."""
    t = np.asarray(t, dtype=float)
    return t + 86400.0 * np.concatenate(([0.0], np.cumsum(np.diff(t) < -43200.0)))


def _is_data_line(line: str) -> bool:
    token = line.replace(",", " ").replace(";", " ").split()[0]
    if _CLOCK.fullmatch(token):
        return True
    try:
        float(token)
    except ValueError:
        return token in MISSING_WORDS
    return True


def _numeric_lines(path: Path) -> np.ndarray:
    """The numbers of a channel file: (n, 1) values or (n, 2) time stamps and values.

    Skipped: blank lines, ``#`` comments and the header lines before the first line of
    numbers (a name, a unit, a description: as many as there are). Read as missing (NaN):
    the words of :data:`MISSING_WORDS` and empty fields between separators (``1.0,,``).
    Time stamps written as a clock time ``hh:mm:ss.s`` become seconds of the day (past
    midnight: counted on, not restarted).
    """
    text = path.read_text(encoding="utf-8", errors="replace")
    lines = text.splitlines()
    first, skipped = None, 0
    for i, ln in enumerate(lines):
        if ln.strip() and not ln.lstrip().startswith("#"):
            if _is_data_line(ln):
                first = i
                break
            skipped += 1
    if first is None:
        if not skipped:
            return np.empty((0, 1))
        header = next(ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#"))
        raise FlightDataError(
            f"{path}: no line of numbers in {skipped} line(s) (first: "
            f"{header.strip()[:60]!r}); a channel file holds one column (values) or "
            "two (time, value), after any header lines")
    body = "\n".join(lines[first:])
    clock = _CLOCK.match(lines[first].replace(",", " ").replace(";", " ").split()[0])
    if clock:
        body = _CLOCK.sub(lambda match: repr(_clock_seconds(match)), body)
    try:   # plain numbers: the fast path
        a = np.loadtxt(io.StringIO(body.replace(",", " ").replace(";", " ")),
                       comments="#", ndmin=2)
    except ValueError:
        a = None
    if a is None:
        if "," in body or ";" in body:
            body = _EMPTY_FIELD.sub("nan", body)
        body = _MISSING.sub("nan", body).replace(",", " ").replace(";", " ")
        try:
            a = np.loadtxt(io.StringIO(body), comments="#", ndmin=2)
        except ValueError as exc:
            raise FlightDataError(f"{path}: not a table of numbers after its header ({exc}); "
                                  "a channel file holds one column (values) or two (time, "
                                  "value); missing samples may be blank fields, NaN or one "
                                  f"of {', '.join(MISSING_WORDS)}") from None
    if a.shape[1] not in (1, 2):
        raise FlightDataError(f"{path}: {a.shape[1]} columns; a channel file holds one "
                              "column (values at the stated rate) or two (time, value)")
    if clock and a.shape[1] == 2:   # a flight through midnight: the clock starts again
        a[:, 0] = _through_midnight(a[:, 0])
    return a


def _from_files(directory: Path, pattern: str, wanted: dict, time_scale: float) -> dict:
    if not directory.is_dir():
        raise FlightDataError(f"record directory {str(directory)!r} does not exist")
    out = {}
    for source, (rate, where) in wanted.items():
        f = directory / pattern.format(source=source)
        if not f.is_file():
            raise FlightDataError(f"channel {source!r} ({where}): file {str(f)!r} does not "
                                  "exist; fix 'source' or remove the channel from the mapping")
        a = _numeric_lines(f)
        if a.shape[1] == 2:
            out[source] = _finite(source, a[:, 0] * time_scale, a[:, 1])
        else:
            if a.shape[0] and rate is None:
                raise FlightDataError(f"channel {source!r} ({where}): {f.name} holds values "
                                      "without time stamps; give rate_hz in [record] or in the "
                                      "channel's entry")
            out[source] = _finite(source, np.arange(a.shape[0]) / (rate or 1.0), a[:, 0],
                                  timed=False)
    return out


def _from_table(columns, path: Path, wanted: dict, time: str | None, time_scale: float,
                getter) -> dict:
    out = {}
    for source, (rate, where, own_time) in wanted.items():
        if source not in columns:
            raise FlightDataError(f"channel {source!r} ({where}) is not in {path.name}; it "
                                  f"has {sorted(columns)[:40]}")
        tname = own_time or time
        v = getter(source)
        if tname is None:
            if rate is None:
                raise FlightDataError(f"channel {source!r} ({where}): no time channel; set "
                                      "[record] time or rate_hz")
            t = np.arange(len(v)) / rate
            out[source] = _finite(source, t, v, timed=False)
            continue
        else:
            if tname not in columns:
                raise FlightDataError(f"time channel {tname!r} (for {source!r}, {where}) is "
                                      f"not in {path.name}")
            t = getter(tname) * time_scale
        out[source] = _finite(source, t, v)
    return out


def _read_csv(path: Path):
    """A CSV record as a DataFrame: the separator (comma, semicolon or tab) from the header
    line, :data:`MISSING_WORDS` as missing, and the unit rows under the header (rows in
    which no field is a number, at most 3) dropped."""
    import pandas as pd  # optional dependency (the 'aero' extra)

    with open(path, encoding="utf-8", errors="replace") as fh:
        head = next((ln for ln in fh if ln.strip()), "")
    sep = ";" if head.count(";") > head.count(",") else \
        "\t" if head.count("\t") > head.count(",") else ","
    df = pd.read_csv(path, sep=sep, na_values=list(MISSING_WORDS), skipinitialspace=True)
    df.columns = [str(c).strip() for c in df.columns]
    units = 0
    while units < min(3, len(df)):
        row = df.iloc[units]
        if row.notna().any() and pd.to_numeric(row, errors="coerce").isna().all() \
                and not row.astype(str).str.fullmatch(_CLOCK.pattern).any():
            units += 1
        else:
            break
    return df.iloc[units:].reset_index(drop=True)


def _mat_getter(path: Path):
    import h5py  # optional dependency (the 'aero' extra): MATLAB v7.3 files
    import scipy.io

    if h5py.is_hdf5(path):  # MATLAB v7.3 (HDF5 with a 512-byte MATLAB header)
        return _h5_getter(path)
    try:
        data = scipy.io.loadmat(path, simplify_cells=True)
    except (RuntimeError, ValueError, TypeError, OSError) as exc:   # v7.3 is caught above
        raise FlightDataError(f"cannot read MATLAB file {str(path)!r}: {exc}") from None
    names = set()

    def walk(prefix, d):
        for k, v in d.items():
            if k.startswith("__"):
                continue
            name = f"{prefix}{k}"
            if isinstance(v, dict):
                walk(name + ".", v)
            else:
                names.add(name)

    walk("", data)

    def get(name):
        v = data
        for part in name.split("."):
            v = v[part]
        a = np.asarray(v, dtype=float)
        if a.ndim > 1 and min(a.shape) > 1:
            raise FlightDataError(f"{path.name}: variable {name!r} has shape {a.shape}; a "
                                  "channel is a vector")
        return a.ravel()

    return names, get


def _h5_getter(path: Path):
    import h5py  # optional dependency (the 'aero' extra), as in _mat_getter

    try:
        fh = h5py.File(path, "r")
    except OSError as exc:
        raise FlightDataError(f"cannot read MATLAB v7.3 file {str(path)!r}: {exc}") from None
    names = set()
    fh.visititems(lambda n, obj: names.add(n) if isinstance(obj, h5py.Dataset) else None)
    names |= {n.replace("/", ".") for n in names}

    def get(name):
        a = np.asarray(fh[name.replace(".", "/")][()], dtype=float)
        if a.ndim > 1 and min(a.shape) > 1:
            raise FlightDataError(f"{path.name}: dataset {name!r} has shape {a.shape}; a "
                                  "channel is a vector")
        return a.ravel()

    return names, get


def read_channels(fmt: str, path: Path, wanted: dict, *, pattern: str = "{source}.txt",
                  time: str | None = None, time_scale: float = 1.0) -> dict:
    """Read the wanted channels of a record.

    Parameters
    ----------
    fmt : {'channels', 'csv', 'mat', 'parquet'}
    path : Path
        Directory (``channels``) or file.
    wanted : dict
        Source name -> (rate_hz or None, where, own time channel or None); ``where`` names
        the mapping line for messages.
    pattern : str
        File name pattern of ``channels`` records.
    time : str or None
        Time column of table records.
    time_scale : float
        Seconds per unit of the time stamps.

    Returns
    -------
    dict of str to RawChannel

    Raises
    ------
    FlightDataError
        A missing file or channel, or one that is not numbers, naming it.
    """
    if fmt == "channels":
        return _from_files(path, pattern, {s: w[:2] for s, w in wanted.items()}, time_scale)
    if not path.is_file():
        raise FlightDataError(f"record file {str(path)!r} does not exist")
    if fmt in ("csv", "parquet"):
        import pandas as pd  # optional dependency (the 'aero' extra)

        try:
            df = _read_csv(path) if fmt == "csv" else pd.read_parquet(path)
        except Exception as exc:  # pandas/pyarrow raise many types for malformed files
            raise FlightDataError(f"cannot read {str(path)!r}: {exc}") from None

        def get(name):
            col = df[name]
            if not pd.api.types.is_numeric_dtype(col) and \
                    col.astype(str).str.fullmatch(_CLOCK.pattern).all():
                return _through_midnight([_clock_seconds(_CLOCK.fullmatch(x)) for x in col])
            try:
                return pd.to_numeric(col, errors="raise").to_numpy(dtype=float)
            except (ValueError, TypeError):
                bad = col[pd.to_numeric(col, errors="coerce").isna() & col.notna()]
                raise FlightDataError(
                    f"{path.name}: column {name!r} is not numeric (row {bad.index[0]}: "
                    f"{bad.iloc[0]!r}); missing samples may be blank, NaN or one of "
                    f"{', '.join(MISSING_WORDS)}") from None

        return _from_table(set(df.columns), path, wanted, time, time_scale, get)
    if fmt == "mat":
        names, get = _mat_getter(path)
        return _from_table(names, path, wanted, time, time_scale, get)
    raise FlightDataError(f"unknown record format {fmt!r}")
