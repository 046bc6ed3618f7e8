"""Measured data: the one loader of voltage/displacement records.

The standard file is a CSV whose header row names the columns ``time_s``,
``voltage_V`` and ``displacement_um`` (any order; other columns are ignored)::

    time_s,voltage_V,displacement_um
    0,0,-1.6174316
    0.0002,0.0942,-1.7242432

A header that names the quantities in other words is read too, when every
column it needs is named once: ``Time [ms]``, ``time (s)``, ``t_s``, ``time``;
``Voltage [V]``, ``u``, ``input voltage (mV)``; ``Displacement [nm]``,
``position_um``, ``y``; in German or French, ``Zeit``, ``Spannung``, ``Weg``,
``temps``, ``tension``, ``déplacement``.  A unit in brackets, parentheses,
after ``/`` or ``_`` or after ``in`` is converted to s, V and µm; a name
without a unit is taken to be in s, V and µm; a column whose unit is of
another quantity (``displacement [V]``, a raw sensor signal) is not used.
:attr:`MeasuredData.read_as` says which column was read as what.

Other layouts are read with options: column names or 1-based column numbers,
no header row, a ``;``, whitespace or other delimiter, and a sample rate when
there is no time column.  A file separated by ``;``, tabs or spaces may write
a decimal comma (``0,5``), as a European locale exports; tabs alone separate
a header whose names hold spaces (``Time [s]<tab>Voltage [V]``).  Every
problem with a file is a :class:`pysim.identification.errors.DataError` whose
one-line message names the file, the line (1-based, as an editor shows it) and
the column (number and name) where that applies.

Parsing is fast (``numpy.loadtxt``); when that fails, a careful line-by-line
scan of the same rules finds the exact line and cell to report, so both paths
accept and reject exactly the same files.
"""
from __future__ import annotations

import csv
import difflib
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pysim.core.fileio import atomic_write_text
from pysim.identification.errors import DataError, IdentificationError

__all__ = [
    "COLUMNS", "MeasuredData", "load_measured", "load_reference", "save_measured", "require_samples",
    "estimate_sample_rate", "sampling_interval", "require_even_sampling", "resample_record", "resampling_stride",
    "common_sample_rate",
    "checked_sample_rate",
    "EVEN_SAMPLING_SPREAD", "shipped_dataset", "SHIPPED_DATASETS",
]

#: The standard column names, in the order :func:`save_measured` writes them.
COLUMNS = ("time_s", "voltage_V", "displacement_um")

#: Data sets shipped in ``data/measured/<name>/<file>`` (standard CSV).
SHIPPED_DATASETS = {
    "smart_hysteresis": "hysteresis_v_150_1hz.csv",
    "discrete_backlash": "model_vi_do.csv",
}

_WHITESPACE = None  # delimiter value meaning "runs of spaces and tabs"
_DELIMITER_WORDS = {     # a tab's words are resolved by the first line (_tab_or_whitespace)
    "comma": ",", "semicolon": ";", " ": _WHITESPACE, "space": _WHITESPACE, "whitespace": _WHITESPACE,
}
_TAB_WORDS = ("tab", "\\t", "\t")
_DELIMITER_NAMES = {",": "comma ','", ";": "semicolon ';'", "\t": "tab", " ": "spaces",
                    "|": "bar '|'", ":": "colon ':'"}
_DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+([eE][+-]?\d+)?")
# Relative spread of the sampling intervals below which a record counts as
# uniformly sampled (timestamps rounded by the logger jitter by far less).
_UNIFORM_SPREAD = 0.01


@dataclass(frozen=True, eq=False)
class MeasuredData:
    """A measured record: voltage in, displacement out, on a time grid.

    Parameters
    ----------
    time_s : array_like
        Sample times in s, strictly increasing.
    voltage_V : array_like
        Actuator voltage in V.
    displacement_um : array_like
        Measured displacement in µm.
    source : str
        Where the data came from (the file name as given to the loader).
    sample_rate_hz : float, optional
        Sample rate in Hz; estimated from ``time_s`` when not given (see
        :func:`estimate_sample_rate`).
    read_as : tuple of str
        One sentence per column that was not read as a standard name says
        which header cell became which quantity, and its unit conversion
        (e.g. ``"column 1 'Time [ms]' read as time_s (ms to s, × 0.001)"``).

    Notes
    -----
    The arrays are float64 copies and read-only, so a record cannot change
    after it has been loaded.  ``len(data)`` is the number of samples.
    """

    time_s: np.ndarray
    voltage_V: np.ndarray
    displacement_um: np.ndarray
    source: str = ""
    sample_rate_hz: float | None = None
    read_as: tuple = ()

    def __post_init__(self):
        for name in COLUMNS:
            array = np.array(getattr(self, name), dtype=np.float64)
            if array.ndim != 1:
                raise IdentificationError(f"MeasuredData.{name} must be one-dimensional, got shape {array.shape}")
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        sizes = {self.time_s.size, self.voltage_V.size, self.displacement_um.size}
        if len(sizes) != 1:
            raise IdentificationError(f"MeasuredData arrays differ in length: time {self.time_s.size}, "
                             f"voltage {self.voltage_V.size}, displacement {self.displacement_um.size}")
        object.__setattr__(self, "source", str(self.source))
        object.__setattr__(self, "read_as", tuple(str(line) for line in self.read_as))
        rate = estimate_sample_rate(self.time_s) if self.sample_rate_hz is None else float(self.sample_rate_hz)
        object.__setattr__(self, "sample_rate_hz", rate)

    def __len__(self) -> int:
        return int(self.time_s.size)


#: Largest deviation of one sampling interval from the record's (:func:`sampling_interval`), as a share
#: of it, that a record whose dynamics are fitted tolerates: logger timestamps jitter and are rounded, but
#: a missing sample (2x) or a pause is a jump in time that every lag, delay and creep would be fitted
#: across.
EVEN_SAMPLING_SPREAD = 0.5


def estimate_sample_rate(time_s) -> float:
    """Sample rate in Hz of a strictly increasing time vector in s.

    A uniformly sampled record (every interval within 1 % of
    :func:`sampling_interval`) gets ``(n - 1) / (t[-1] - t[0])``: loggers
    round timestamps, and the mean over the whole record removes that rounding
    (5000 Hz rather than 4999.75 Hz for a 5 kHz logger writing 9 significant
    digits).  One whose times are rounded to a good part of an interval
    (every interval within ``EVEN_SAMPLING_SPREAD``) gets one over the
    least-squares slope of its times against the sample number: 3000 Hz, not
    the 3333 Hz of the median interval, for a 3 kHz logger writing its times
    to 0.1 ms.  A record with gaps gets ``1 / sampling_interval``.  Fewer than
    two samples give NaN.

    Examples
    --------
    >>> t = np.round(np.arange(9000) / 3000.0, 4)          # 0.1 ms timestamps at 3 kHz
    >>> round(estimate_sample_rate(t), 3)
    3000.0
    """
    t = np.asarray(time_s, dtype=np.float64)
    if t.size < 2:
        return math.nan
    interval = sampling_interval(t)
    if not interval > 0:
        return math.nan
    deviation = np.abs(np.diff(t) - interval)
    if np.all(deviation <= _UNIFORM_SPREAD * interval):
        return float((t.size - 1) / (t[-1] - t[0]))      # a logger's jitter: the first and last times
    if np.all(deviation <= EVEN_SAMPLING_SPREAD * interval):
        # times rounded to a good part of an interval: the first and last are off by up to half the
        # rounding step, every one of them by as much, and a fit through all of them averages that out
        k = np.arange(t.size, dtype=np.float64) - 0.5 * (t.size - 1)
        return float(np.dot(k, k) / np.dot(k, t - t.mean()))
    return 1.0 / interval


def sampling_interval(time_s) -> float:
    """The sampling interval (s) of a strictly increasing time vector: the median over the record of
    the time spanned by ``L`` intervals over ``L`` (``L`` a tenth of the record, at most 100).

    A single interval's median is off when the logger rounds its timestamps to a good part of an
    interval (a 3 kHz record written to 0.1 ms steps by 0.3 and 0.4 ms, median 0.3 ms), and the mean
    over the record is off when it has gaps; over ``L`` intervals the rounding shrinks ``L``-fold and a
    gap reaches only the spans that hold it.  NaN for fewer than two samples.

    Examples
    --------
    >>> round(sampling_interval(np.round(np.arange(9000) / 7000.0, 4)) * 7000.0, 2)  # 0.1 ms steps
    1.0
    >>> round(sampling_interval(np.r_[np.arange(100), np.arange(150, 250)] * 1e-3), 9)   # a 50 ms gap
    0.001
    """
    t = np.asarray(time_s, dtype=np.float64)
    if t.size < 2:
        return math.nan
    lag = max(1, min(100, (t.size - 1) // 10))
    return float(np.median(t[lag:] - t[:-lag]) / lag)


def require_samples(data: MeasuredData, n_needed: int, what: str) -> None:
    """Raise :class:`DataError` unless ``data`` has at least ``n_needed`` samples.

    Parameters
    ----------
    data : MeasuredData
    n_needed : int
        Minimum number of samples.
    what : str
        What they are needed for, completing "need at least M for ...", e.g.
        ``"an MPI model with 10 operators (22 parameters)"``.

    Raises
    ------
    DataError
        ``"<file>: N samples, need at least M for <what>"``.
    """
    if len(data) < n_needed:
        raise DataError(f"{data.source or 'data'}: {len(data)} samples, need at least {n_needed} for {what}")


def require_even_sampling(data: MeasuredData, what: str) -> None:
    """Raise :class:`DataError` when the samples of ``data`` are not evenly spaced in time.

    Every interval must lie within ``EVEN_SAMPLING_SPREAD`` of the sampling
    interval (:func:`sampling_interval`); timestamp jitter and rounding pass,
    a missing sample or a pause does not.

    Parameters
    ----------
    data : MeasuredData
    what : str
        What needs them evenly spaced, completing "... ; <what> needs evenly
        spaced samples", e.g. ``"the diagnosis"``.

    Raises
    ------
    DataError
        ``"<file>: the samples are not evenly spaced: an interval of X s after
        t = T s against a sampling interval of M s; ..."``.

    Examples
    --------
    >>> t = np.r_[np.arange(100), np.arange(150, 250)] * 1e-3
    >>> data = MeasuredData(t, np.sin(t), np.sin(t), "rig.csv")
    >>> try:
    ...     require_even_sampling(data, "the diagnosis")
    ... except DataError as exc:
    ...     print(str(exc)[:84])
    rig.csv: the samples are not evenly spaced: an interval of 0.051 s after t = 0.099 s
    """
    t = np.asarray(data.time_s, dtype=np.float64)
    if t.size < 3:
        return
    steps = np.diff(t)
    interval = sampling_interval(t)
    deviation = np.abs(steps - interval)
    worst = int(np.argmax(deviation))
    if deviation[worst] > EVEN_SAMPLING_SPREAD * interval:
        raise DataError(f"{data.source or 'data'}: the samples are not evenly spaced: an interval of "
                        f"{steps[worst]:.6g} s after t = {t[worst]:.6g} s against a sampling interval of "
                        f"{interval:.6g} s; {what} needs evenly spaced samples (resample the record, or split "
                        "it at the gap)")


def checked_sample_rate(sample_rate_hz, what: str = "sample rate", error: type = DataError) -> float:
    """``sample_rate_hz`` as a float, or one ``error`` naming ``what`` when it is not a
    positive finite number of Hz.

    The one check of a sample rate given as a number -- the loader's option,
    the records given to the diagnosis, resampling, an excitation.  Text,
    booleans, NaN, infinities, zero and negative numbers are refused; each
    layer passes its own error type.

    Examples
    --------
    >>> checked_sample_rate(np.int64(2000))
    2000.0
    >>> try:
    ...     checked_sample_rate("2000", "run.csv: sample rate")
    ... except DataError as exc:
    ...     print(exc)
    run.csv: sample rate must be a positive finite number of Hz, got '2000'
    """
    number = isinstance(sample_rate_hz, (int, float, np.integer, np.floating)) and not isinstance(sample_rate_hz, bool)
    if not (number and math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        shown = repr(sample_rate_hz) if isinstance(sample_rate_hz, str) else sample_rate_hz
        raise error(f"{what} must be a positive finite number of Hz, got {shown}")
    return float(sample_rate_hz)


def resampling_stride(from_rate_hz: float, to_rate_hz: float) -> int:
    """Every how many samples of a record at ``from_rate_hz`` :func:`resample_record` keeps one (at
    least 1): the ratio of the rates to the nearest whole number.  Sample ``k`` used is sample
    ``k * stride`` of the record as logged.

    Examples
    --------
    >>> resampling_stride(6000.0, 2000.0), resampling_stride(2000.0, 2000.0 * (1 + 1e-6))
    (3, 1)
    """
    return max(1, round(float(from_rate_hz) / float(to_rate_hz)))


def _misplacement_samples(from_rate_hz: float, to_rate_hz: float, n_samples: int) -> float:
    """How far, in samples of ``from_rate_hz``, the last sample :func:`resample_record` keeps of a
    record of ``n_samples`` lies from where ``to_rate_hz`` puts it (every :func:`resampling_stride`-th
    sample taken as one period of ``to_rate_hz``); below half a sample the record is usable."""
    ratio = float(from_rate_hz) / float(to_rate_hz)        # input samples per output sample
    return abs(resampling_stride(from_rate_hz, to_rate_hz) / ratio - 1.0) * (n_samples - 1)


#: The most samples of the first record :func:`common_sample_rate` merges into one: a common rate
#: lower than that would throw away most of the record the models are fitted on.
MAX_COMMON_STRIDE = 10


def common_sample_rate(first_rate_hz: float, first_samples: int, second_rate_hz: float,
                       second_samples: int) -> float:
    """The rate, Hz, at which two records of one actuator are used together: the first record's
    rate when the second is as fast or a whole number of times faster, else the highest rate the
    first reaches at every m-th sample (m at most :data:`MAX_COMMON_STRIDE`) on whose grid the
    second record's samples fall too, by :func:`resample_record`'s rule (each record's last sample
    used lies less than half a sample from its place).

    Parameters
    ----------
    first_rate_hz, second_rate_hz : float
        The records' sample rates, Hz.
    first_samples, second_samples : int
        Their lengths, in samples.

    Returns
    -------
    float
        ``first_rate_hz / m`` for the smallest ``m`` that fits.

    Raises
    ------
    DataError
        When a rate is not a positive finite number, or when no common rate down to
        ``first_rate_hz / MAX_COMMON_STRIDE`` fits both records.

    Examples
    --------
    >>> common_sample_rate(10000.0, 5000, 20000.0, 8000)      # the second at every 2nd sample
    10000.0
    >>> common_sample_rate(10000.0, 5000, 5000.0, 8000)       # the first at every 2nd sample
    5000.0
    >>> common_sample_rate(5000.0, 5000, 2000.0, 8000)        # every 5th and every 2nd
    1000.0
    """
    first = checked_sample_rate(first_rate_hz, "the first record's sample rate")
    second = checked_sample_rate(second_rate_hz, "the second record's sample rate")
    for stride in range(1, MAX_COMMON_STRIDE + 1):
        # a second record slower than the rate tried is misplaced by most of its length
        if _misplacement_samples(second, first / stride, second_samples) < 0.5:
            return first / stride
    raise DataError(f"records at {first:g} Hz and {second:g} Hz have no common rate down to "
                    f"{first / MAX_COMMON_STRIDE:g} Hz on which both records' samples fall (every m-th sample "
                    "of each; interpolating would invent samples and make the noise look smaller): record them "
                    "at one rate, or at rates of which one is a whole multiple of the other")


def resample_record(voltage_V, displacement_um, from_rate_hz: float, to_rate_hz: float) -> tuple:
    """The samples of a record taken at ``from_rate_hz`` that fall on the grid of ``to_rate_hz``.

    Nothing is interpolated, so nothing is filtered, shifted in time or
    invented, and the displacement's noise stays white (interpolated samples
    would make it look smaller and correlated, and every significance test
    would then see effects in it).  Two cases are accepted:

    * *as recorded*: the rates differ by so little that the samples, used as
      they are, are misplaced by less than half a sample at the record's end
      (two loggers' rounding of one rate);
    * *every m-th sample*: the record is m times faster, by the same rule.

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record, one sample per ``1 / from_rate_hz`` s.
    from_rate_hz, to_rate_hz : float
        Its sample rate and the one wanted, Hz.

    Returns
    -------
    voltage_V, displacement_um : ndarray
    how : str
        ``"as recorded"`` or ``"every m-th sample"`` (m the number).

    Raises
    ------
    DataError
        When a rate is not a positive finite number, when ``from_rate_hz`` is
        not ``to_rate_hz`` or a whole multiple of it, or when fewer than two
        samples would be left.

    Examples
    --------
    >>> v = np.arange(10.0)
    >>> v2, y2, how = resample_record(v, 2 * v, 2000.0, 1000.0)
    >>> v2.tolist(), how
    ([0.0, 2.0, 4.0, 6.0, 8.0], 'every 2nd sample')
    >>> resample_record(v, 2 * v, 1000.0, 1000.0 * (1 + 1e-5))[2]
    'as recorded'
    >>> try:
    ...     resample_record(v, 2 * v, 1000.0, 2000.0)
    ... except DataError as exc:
    ...     print(str(exc)[:51])
    a record at 1000 Hz cannot be used at 2000 Hz: only
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    y = np.asarray(displacement_um, dtype=float).ravel()
    checked_sample_rate(from_rate_hz, "from_rate_hz")
    checked_sample_rate(to_rate_hz, "to_rate_hz")
    if v.size != y.size or v.size < 2:
        raise DataError(f"a record to resample needs at least 2 samples of voltage and displacement each "
                        f"(got {v.size} and {y.size})")
    m = resampling_stride(from_rate_hz, to_rate_hz)
    if _misplacement_samples(from_rate_hz, to_rate_hz, v.size) >= 0.5:
        raise DataError(f"a record at {float(from_rate_hz):g} Hz cannot be used at {float(to_rate_hz):g} Hz: only "
                        "the same rate or a whole multiple of it is used, every m-th sample (interpolating would "
                        "invent samples and make the noise look smaller); record at "
                        f"{float(to_rate_hz):g} Hz or a whole multiple of it, or give both records at a common rate")
    if m == 1:
        return v.copy(), y.copy(), "as recorded"
    if (v.size - 1) // m + 1 < 2:
        raise DataError(f"{v.size} samples at {float(from_rate_hz):g} Hz leave 1 at {float(to_rate_hz):g} Hz")
    ordinal = {1: "st", 2: "nd", 3: "rd"}.get(m % 10 if m % 100 not in (11, 12, 13) else 0, "th")
    return v[::m].copy(), y[::m].copy(), f"every {m}{ordinal} sample"


def save_measured(data: MeasuredData, path) -> Path:
    """Write ``data`` as a standard CSV (``time_s,voltage_V,displacement_um``).

    Values are written as the shortest decimal that reads back to the same
    float64 (Python's ``repr``), so ``load_measured(save_measured(d, p))``
    returns exactly the same numbers.  The file is written atomically: on any
    error no partial file is left behind.

    Returns
    -------
    Path
        ``path``.
    """
    columns = [getattr(data, name) for name in COLUMNS]
    for name, values in zip(COLUMNS, columns):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise DataError(f"{data.source or 'data'}: {name} sample {bad[0]} is {values[bad[0]]}; "
                            f"only finite values can be saved")
    lists = [values.tolist() for values in columns]  # Python floats: repr is the shortest round trip
    body = "".join(f"{t!r},{v!r},{d!r}\n" for t, v, d in zip(*lists))
    return atomic_write_text(path, ",".join(COLUMNS) + "\n" + body)


def shipped_dataset(name: str) -> Path:
    """Path of a data set shipped with the project, in the standard CSV format.

    Parameters
    ----------
    name : str
        ``"smart_hysteresis"`` (±150 V, 1 Hz, 5 kHz) or ``"discrete_backlash"``
        (0–3.6 V, 1 Hz, 200 Hz); see ``data/measured/<name>/SOURCE.md``.

    Notes
    -----
    The data are ``data/measured/`` in the repository, installed as the package
    data ``pysim.identification.datasets``.
    """
    if name not in SHIPPED_DATASETS:
        raise DataError(f"unknown data set {name!r}; shipped: {', '.join(sorted(SHIPPED_DATASETS))}")
    import pysim.identification.datasets as datasets

    path = Path(datasets.__file__).resolve().parent / name / SHIPPED_DATASETS[name]
    if not path.is_file():
        raise DataError(f"{path}: shipped data set {name!r} not found: the installation is incomplete")
    return path


# ----------------------------------------------------------------- loading

def load_measured(path, *, time_column=None, voltage_column=None, displacement_column=None,
                  header=True, delimiter=None, sample_rate_hz=None, skip_rows=0) -> MeasuredData:
    """Load a measured record from a delimited text file.

    Parameters
    ----------
    path : str or Path
        The data file.
    time_column, voltage_column, displacement_column : str or int, optional
        A header name, or a 1-based column number (an int, or a string of
        digits that is not a header name).  With a header the defaults are the
        standard names ``time_s``, ``voltage_V``, ``displacement_um``; without a
        header the voltage and displacement numbers must be given.  The time
        column is optional when ``sample_rate_hz`` is given.
    header : bool
        Whether the first line read (after ``skip_rows``) names the columns.
    delimiter : str, optional
        ``","``, ``";"``, whitespace (``" "``, ``"\\t"``, ``"tab"`` or
        ``"whitespace"``: runs of spaces and tabs; a tab alone when a header
        cell between tabs holds words with a space) or another single
        character.  Default: detected from the first line read (semicolon,
        then tab, then comma, else whitespace).  Except with ``","``, a cell
        with one comma and no point is read with the comma as decimal point.
    sample_rate_hz : float, optional
        Sample rate in Hz for a file without a time column: ``time_s = k / fs``.
        Giving it for a file that has a time column is an error (one source of
        time only).
    skip_rows : int
        Lines to skip before the header (or the data).  Line numbers in error
        messages still count every line of the file.

    Returns
    -------
    MeasuredData
        With ``source`` = ``str(path)`` and ``sample_rate_hz`` the given rate or
        :func:`estimate_sample_rate` of the time column.

    Raises
    ------
    DataError
        For any file that cannot be used, with a message naming the file, the
        line and the column where that applies.  Blank lines are skipped; every
        other line after the header must have as many cells as the header (or
        the first data row), each used cell a finite number; time must
        strictly increase; at least 2 samples.
    """
    specs = {"time_s": time_column, "voltage_V": voltage_column, "displacement_um": displacement_column}
    column, rate, read_as = _load_columns(path, specs, header, delimiter, sample_rate_hz, skip_rows)
    return MeasuredData(column["time_s"], column["voltage_V"], column["displacement_um"], source=str(path),
                        sample_rate_hz=rate, read_as=read_as)


def load_reference(path, *, time_column=None, displacement_column=None, header=True, delimiter=None,
                   sample_rate_hz=None, skip_rows=0) -> tuple:
    """Load a displacement reference (what the stage should follow) from a delimited text file.

    The same reader and checks as :func:`load_measured`, for a file with a time
    column (or ``sample_rate_hz``) and a displacement column, default names
    ``time_s`` and ``displacement_um``.

    Returns
    -------
    time_s, displacement_um : numpy.ndarray
        Read-only float64 arrays.
    sample_rate_hz : float
        The given rate or :func:`estimate_sample_rate` of the time column.

    Raises
    ------
    DataError
        As :func:`load_measured`: one message naming the file, line and column.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "ref.csv")
    ...     with open(path, "w") as f:
    ...         _ = f.write("time_s,displacement_um\\n0,10\\n0.001,12\\n0.002,15\\n")
    ...     t, x, fs = load_reference(path)
    >>> x.tolist(), round(fs)
    ([10.0, 12.0, 15.0], 1000)
    """
    specs = {"time_s": time_column, "displacement_um": displacement_column}
    column, rate, _ = _load_columns(path, specs, header, delimiter, sample_rate_hz, skip_rows)
    time, displacement = (np.array(column[key], dtype=np.float64) for key in ("time_s", "displacement_um"))
    for array in (time, displacement):
        array.setflags(write=False)
    return time, displacement, (estimate_sample_rate(time) if rate is None else float(rate))


def _load_columns(path, specs: dict, header, delimiter, sample_rate_hz, skip_rows) -> tuple:
    """``({role: float64 array}, rate or None, read_as)`` of the columns named by
    ``specs`` (role -> name or 1-based number, None for the role's default name),
    in s, V and µm; ``time_s`` is made from the sample rate when the file has no
    time column; ``read_as`` describes the columns found by another name."""
    name = str(path)
    path = Path(path)
    rate = None if sample_rate_hz is None else checked_sample_rate(sample_rate_hz, f"{name}: sample rate")
    if isinstance(skip_rows, bool) or not isinstance(skip_rows, (int, np.integer)) or skip_rows < 0:
        raise DataError(f"{name}: skip_rows must be a whole number >= 0, got {skip_rows!r}")
    lines = _read_lines(path, name)

    first = next((i for i in range(skip_rows, len(lines)) if not _blank(lines[i])), None)
    if first is None:
        if skip_rows and any(not _blank(line) for line in lines):
            raise DataError(f"{name}: nothing left after skipping {skip_rows} lines "
                            f"(the file has {_count_lines(lines)} lines)")
        raise DataError(f"{name}: the file is empty (only blank lines)")
    sep = _resolve_delimiter(name, delimiter, lines[first])
    cells = _split(lines[first], sep)
    if len(cells) < 2:
        raise DataError(_one_column_message(name, first + 1, lines[first], sep, detected=delimiter is None))

    scales, read_as = {}, ()
    if header:
        names = [_unquote(cell) for cell in cells]
        _reject_numeric_header(name, first + 1, names)
        try:
            columns, scales, read_as = _columns_from_header(name, first + 1, names, specs, rate)
        except DataError as exc:
            raise DataError(f"{exc}{_header_further_down(lines, first, specs, rate)}") from None
        data_start = first + 1
    else:
        names = None
        columns = _columns_from_numbers(name, len(cells), specs, rate)
        data_start = first
    reader = _Reader(name, lines, data_start, sep, len(cells), columns, names, header_line=first + 1)
    table = reader.parse()
    column = reader.columns_of(table, rate)
    for role, scale in scales.items():
        if scale != 1.0 and column.get(role) is not None:
            # divide by 1000 rather than multiply by 0.001 (not a binary fraction): correctly rounded
            column[role] = column[role] * scale if scale > 1.0 else column[role] / round(1.0 / scale)
    return column, rate, read_as


class _Reader:
    """Parse and check the data rows of one file (fast path, careful scan)."""

    def __init__(self, name, lines, data_start, sep, n_cells, columns, names, header_line):
        self.name, self.lines, self.data_start, self.sep = name, lines, data_start, sep
        self.n_cells, self.columns, self.names, self.header_line = n_cells, columns, names, header_line
        # Parse each used column once, in file order; ``columns`` maps role -> index.
        self.used = sorted(set(index for index in columns.values() if index is not None))
        self.rows = [line for line in lines[data_start:] if not _blank(line)]
        self._line_numbers = None

    # -- helpers for messages
    def line_of(self, row: int) -> int:
        """1-based file line of data row ``row`` (computed only for messages)."""
        if self._line_numbers is None:
            self._line_numbers = [self.data_start + k + 1
                                  for k, line in enumerate(self.lines[self.data_start:]) if not _blank(line)]
        return self._line_numbers[row]

    def label(self, index: int) -> str:
        role = next((r for r, i in self.columns.items() if i == index), None)
        if self.names is None:
            return f"column {index + 1} ({role})" if role else f"column {index + 1}"
        shown = self.names[index]
        if role and shown != role:
            return f"column {index + 1} ({shown}, used as {role})"
        return f"column {index + 1} ({shown})"

    def where(self, row: int, index: int) -> str:
        return f"{self.name}: line {self.line_of(row)}, {self.label(index)}"

    # -- parsing
    def parse(self) -> np.ndarray:
        """(n, len(used)) float64 table of the used columns."""
        if not self.rows:
            where = (f"after the header (line {self.header_line})" if self.names is not None
                     else "in the file")
            raise DataError(f"{self.name}: no data rows {where}; need at least 2 samples")
        table = self._fast()
        return table if table is not None else self._careful()

    def _fast(self):
        if self.sep is _WHITESPACE:
            counts = np.fromiter((len(line.split()) for line in self.rows), dtype=np.intp, count=len(self.rows))
            expected = self.n_cells
        else:
            counts = np.fromiter((line.count(self.sep) for line in self.rows), dtype=np.intp,
                                 count=len(self.rows))
            expected = self.n_cells - 1
        if np.any(counts != expected):
            return None
        rows = self.rows
        if self.sep != "," and any("," in line for line in rows):
            # decimal commas (a ';' or tab file from a European locale): a cell with one comma and no
            # point reads as with a point; any other comma leaves two points, which no number has
            rows = [line.replace(",", ".") for line in rows]
        try:
            return np.loadtxt(rows, dtype=np.float64, delimiter=self.sep, usecols=self.used,
                              comments=None, ndmin=2)
        except ValueError:
            return None  # the careful scan says where, or accepts (e.g. quoted numbers)

    def _careful(self) -> np.ndarray:
        table = np.empty((len(self.rows), len(self.used)), dtype=np.float64)
        for row, line in enumerate(self.rows):
            cells = _split(line, self.sep)
            if len(cells) != self.n_cells:
                raise DataError(self._count_message(row, line, cells))
            for j, index in enumerate(self.used):
                table[row, j] = self._number(row, index, cells[index])
        return table

    def _number(self, row: int, index: int, cell: str) -> float:
        text = _unquote(cell)
        if not text:
            raise DataError(f"{self.where(row, index)}: empty cell, expected a number")
        try:
            if "_" in text:  # Python accepts 1_000; a data file should not
                raise ValueError
            if self.sep != "," and text.count(",") == 1 and "." not in text:
                return float(text.replace(",", "."))     # a decimal comma (as the fast path reads it)
            return float(text)
        except ValueError:
            hint = ""
            if _DECIMAL_COMMA.fullmatch(text):
                hint = " (decimal comma? write numbers with a '.' as decimal separator)"
            raise DataError(f"{self.where(row, index)}: {text!r} is not a number{hint}") from None

    def _count_message(self, row, line, cells) -> str:
        ref = (f"the header (line {self.header_line})" if self.names is not None
               else f"the first data row (line {self.header_line})")
        head = f"{self.name}: line {self.line_of(row)}: {len(cells)} cells, but {ref} has {self.n_cells}"
        if len(cells) < self.n_cells:
            missing = [i for i in self.used if i >= len(cells)]
            what = f"; {self.label(missing[0])} is missing" if missing else ""
            seen = _other_delimiters(line, self.sep)
            hint = (f" (the line contains {_DELIMITER_NAMES.get(seen[0], repr(seen[0]))}, "
                    f"the file is read with {_delimiter_name(self.sep)})") if seen else ""
            return head + what + hint
        return head + " (too many cells: a stray delimiter or a decimal comma?)"

    # -- checks on the numbers
    def columns_of(self, table: np.ndarray, rate) -> dict:
        """``{role: column}`` after the checks on the numbers (finite, enough
        rows, time strictly increasing); ``time_s`` from ``rate`` if absent."""
        bad = ~np.isfinite(table)
        if bad.any():
            row = int(np.flatnonzero(bad.any(axis=1))[0])
            index = self.used[int(np.flatnonzero(bad[row])[0])]
            cell = _unquote(_split(self.rows[row], self.sep)[index])
            raise DataError(f"{self.where(row, index)}: {cell!r} is not a finite number")
        n = table.shape[0]
        if n < 2:
            raise DataError(f"{self.name}: line {self.line_of(0)}: only one data row; need at least 2 samples")
        column = {role: (None if index is None else table[:, self.used.index(index)])
                  for role, index in self.columns.items()}
        time = column["time_s"]
        if time is None:
            time = np.arange(n, dtype=np.float64) / rate
        else:
            steps = np.diff(time)
            wrong = np.flatnonzero(~(steps > 0))
            if wrong.size:
                k = int(wrong[0])
                index = self.columns["time_s"]
                previous = self.line_of(k)
                if steps[k] == 0:
                    raise DataError(f"{self.where(k + 1, index)}: duplicate timestamp {float(time[k + 1])!r} s "
                                    f"(same as line {previous}); time must strictly increase")
                raise DataError(f"{self.where(k + 1, index)}: time {float(time[k + 1])!r} s is not after "
                                f"{float(time[k])!r} s on line {previous}; time must strictly increase")
        column["time_s"] = time
        return column


# ------------------------------------------------------------- file level

def _read_lines(path: Path, name: str) -> list:
    """The file's lines (newline-free, any line-ending convention)."""
    if path.is_dir():
        raise DataError(f"{name}: is a directory, not a data file")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{name}: no such file") from None
    except PermissionError:
        raise DataError(f"{name}: permission denied") from None
    except OSError as exc:
        raise DataError(f"{name}: cannot be read ({exc.strerror or exc})") from None
    if not raw:
        raise DataError(f"{name}: the file is empty (0 bytes)")
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):  # spreadsheet "Unicode text" exports
        text = raw.decode("utf-16")
    else:
        nul = raw.find(b"\x00")
        if nul >= 0:
            line_no = raw.count(b"\n", 0, nul) + 1
            raise DataError(f"{name}: line {line_no}: contains a NUL byte; "
                            f"this is a binary file, not a text data file")
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError:
            text = raw.decode("latin-1")  # e.g. a 'µm' in a header from an 8-bit Windows tool
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def _count_lines(lines) -> int:
    return len(lines) - 1 if lines and lines[-1] == "" else len(lines)


def _blank(line: str) -> bool:
    return not line or line.isspace()


# ------------------------------------------------------------- delimiters

def _tab_or_whitespace(first_line):
    """A tab alone when a cell between tabs holds words with a space (a header ``Time [s]<tab>Voltage
    [V]``), else runs of spaces and tabs (numbers aligned with both)."""
    def words(cell):
        tokens = cell.split()
        return len(tokens) > 1 and not all(_is_number(token) for token in tokens)

    return "\t" if any(words(cell) for cell in first_line.split("\t")) else _WHITESPACE


def _resolve_delimiter(name, delimiter, first_line):
    if delimiter is None:
        for sep in (";", "\t", ","):
            if sep in first_line:
                return _tab_or_whitespace(first_line) if sep == "\t" else sep
        return _WHITESPACE
    if not isinstance(delimiter, str):
        raise DataError(f"{name}: delimiter must be a string, got {delimiter!r}")
    if delimiter.lower() in _TAB_WORDS:
        return _tab_or_whitespace(first_line)
    if delimiter.lower() in _DELIMITER_WORDS:
        return _DELIMITER_WORDS[delimiter.lower()]
    if len(delimiter) != 1 or delimiter in "\"'\n\r" or delimiter.isalnum() or delimiter in ".+-":
        raise DataError(f"{name}: unusable delimiter {delimiter!r}; use ',', ';', 'tab', 'whitespace' "
                        f"or another single punctuation character")
    return delimiter


def _delimiter_name(sep) -> str:
    return "whitespace" if sep is _WHITESPACE else _DELIMITER_NAMES.get(sep, repr(sep))


def _other_delimiters(line: str, sep) -> list:
    """Delimiter characters in ``line`` other than ``sep``, likeliest first."""
    seen = [d for d in (";", ",", "\t", "|", ":") if d in line]
    if " " in line.strip():
        seen.append(" ")
    own = (" ", "\t") if sep is _WHITESPACE else (sep,)
    return [d for d in seen if d not in own]


def _one_column_message(name, line_no, line, sep, detected) -> str:
    how = "detected" if detected else "given"
    head = f"{name}: line {line_no}: only one column found (delimiter {_delimiter_name(sep)}, {how})"
    seen = _other_delimiters(line, sep)
    if seen:
        other = seen[0]
        pass_as = "whitespace" if other in " \t" else other
        return (f"{head}; the line contains {_DELIMITER_NAMES.get(other, repr(other))}: "
                f"is the file {pass_as!r}-separated? (give delimiter {pass_as!r})")
    return f"{head}; expected at least a voltage and a displacement column"


def _split(line: str, sep) -> list:
    if sep is _WHITESPACE:
        return line.split()
    if '"' not in line:
        return line.split(sep)
    return next(csv.reader([line], delimiter=sep, skipinitialspace=True), [])


def _unquote(cell: str) -> str:
    text = cell.strip()
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        text = text[1:-1].strip()
    return text


# ---------------------------------------------------------------- columns

def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _reject_numeric_header(name, line_no, names) -> None:
    filled = [cell for cell in names if cell]
    if filled and all(_is_number(cell) for cell in filled):
        raise DataError(f"{name}: line {line_no} looks like data, not a header naming the columns "
                        f"{', '.join(COLUMNS)}; for a file without header give header=False "
                        f"(pysim: --no-header) and the column numbers")


def _as_number(spec):
    """1-based column number of a column spec, or None if it is a name."""
    if isinstance(spec, bool):
        return None
    if isinstance(spec, (int, np.integer)):
        return int(spec)
    if isinstance(spec, str) and spec.strip().isdigit():
        return int(spec.strip())
    return None


def _check_number(name, role, number, n_cells, where) -> int:
    if not 1 <= number <= n_cells:
        raise DataError(f"{name}: {role} column number {number} is out of range: {where} has "
                        f"{n_cells} columns (numbered from 1)")
    return number - 1


def _columns_from_header(name, line_no, names, specs, rate) -> tuple:
    """``(columns, scales, read_as)`` from header names: role -> 0-based column
    index (time may be None), role -> factor to the role's unit, and a sentence
    for every column found by another name than its standard one."""
    columns, missing, scales, read_as = {}, [], {}, []
    where = f"the header (line {line_no})"
    for role, spec in specs.items():
        if spec is None:
            wanted = role
        elif isinstance(spec, str) and spec in names:
            wanted = spec
        elif _as_number(spec) is not None:
            columns[role] = _check_number(name, role, _as_number(spec), len(names), where)
            continue
        elif isinstance(spec, str):
            wanted = spec
        else:
            raise DataError(f"{name}: {role} column must be a name or a 1-based number, got {spec!r}")
        hits = [i for i, cell in enumerate(names) if cell == wanted]
        if len(hits) > 1:
            raise DataError(f"{name}: line {line_no}: the header names {wanted!r} more than once "
                            f"(columns {', '.join(str(i + 1) for i in hits)})")
        if spec is None and not hits and not (role == "time_s" and rate is not None):
            hits = _recognised(name, line_no, names, role)
        if role == "time_s" and spec is None and rate is not None:
            if hits:
                raise DataError(f"{name}: line {line_no}: the file has a time column ({names[hits[0]]}, column "
                                f"{hits[0] + 1}) and a sample rate was given too; give only one")
            columns[role] = None
            continue
        if hits:
            columns[role] = hits[0]
            if names[hits[0]] != role:
                scale, unit = _unit_of(names[hits[0]], role)
                scales[role] = scale
                converted = "" if scale == 1.0 else f", × {scale:g}"
                read_as.append(f"column {hits[0] + 1} {names[hits[0]]!r} read as {role} ({unit}{converted})")
        else:
            missing.append((role, wanted))
    if missing:
        raise DataError(_missing_message(name, line_no, names, missing, rate))
    if columns.get("time_s") is not None and rate is not None:
        raise DataError(f"{name}: a time column and a sample rate were both given; give only one")
    _reject_shared(name, columns)
    return columns, scales, tuple(read_as)


# Words that name each quantity in a header (lower case, words separated by one space), and the
# units of each with the factor to the standard unit.  Only whole-cell matches count: a cell such
# as "voltage setpoint" or "position error" is not the quantity.
_QUANTITY_WORDS = {
    # English, then the German and French of a European locale's export (it writes decimal commas too)
    "time_s": ("time", "t", "timestamp", "elapsed time", "zeit", "temps"),
    "voltage_V": ("voltage", "volt", "volts", "v", "u", "input", "input voltage", "piezo voltage",
                  "actuator voltage", "drive voltage", "applied voltage", "voltage in", "vin", "u in",
                  "spannung", "tension"),
    "displacement_um": ("displacement", "position", "y", "x", "output", "output displacement",
                        "measured displacement", "stage position", "disp", "pos", "extension", "stroke",
                        "weg", "auslenkung", "verschiebung", "déplacement", "deplacement"),
}
_UNITS = {
    "time_s": {"s": 1.0, "sec": 1.0, "seconds": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6},
    "voltage_V": {"v": 1.0, "volt": 1.0, "volts": 1.0, "mv": 1e-3, "kv": 1e3},
    "displacement_um": {"um": 1.0, "µm": 1.0, "μm": 1.0, "micron": 1.0, "microns": 1.0, "nm": 1e-3,
                        "mm": 1e3, "m": 1e6},
}
_ALL_UNITS = {unit for units in _UNITS.values() for unit in units}
_STANDARD_UNIT = {"time_s": "s", "voltage_V": "V", "displacement_um": "µm"}
_UNIT_PATTERNS = tuple(re.compile(pattern, re.IGNORECASE) for pattern in (
    r"^(?P<word>.+?)\s*[\[(]\s*(?P<unit>[^\])]*?)\s*[\])]$",   # Time [ms], time (s)
    r"^(?P<word>.+?)\s*/\s*(?P<unit>[^\s/]+)$",                 # t/s
    r"^(?P<word>.+?)\s+in\s+(?P<unit>\S+)$",                     # time in ms
    r"^(?P<word>.+?)[_ ](?P<unit>[^_ ]+)$",                     # t_s, position um
))


def _word_and_unit(cell: str) -> tuple:
    """``(words in lower case, unit in lower case or None, unit as written)`` of a header cell."""
    text = " ".join(cell.strip().replace("-", " ").split())
    for pattern in _UNIT_PATTERNS:
        match = pattern.match(text)
        if match and match["unit"].lower() in _ALL_UNITS:
            return " ".join(match["word"].lower().replace("_", " ").split()), match["unit"].lower(), match["unit"]
    return " ".join(text.lower().replace("_", " ").split()), None, None


def _unit_of(cell: str, role: str) -> tuple:
    """``(factor to the role's unit, how the unit was read)`` of a header cell (factor 1 when
    the cell names no unit or one of another quantity: a column named by the user)."""
    _, unit, written = _word_and_unit(cell)
    standard = _STANDARD_UNIT[role]
    if unit is None:
        return 1.0, f"no unit given: taken as {standard}"
    if unit not in _UNITS[role]:
        return 1.0, f"{written} is not a unit of {role}: taken as {standard}"
    return _UNITS[role][unit], f"{written} to {standard}" if _UNITS[role][unit] != 1.0 else written


def _recognised(name, line_no, names, role) -> list:
    """The header cell that names ``role``'s quantity in other words, with a unit of that
    quantity or none (``[]`` when no cell does; an error when several do)."""
    hits = []
    for i, cell in enumerate(names):
        words, unit, _ = _word_and_unit(cell)
        if words in _QUANTITY_WORDS[role] and (unit is None or unit in _UNITS[role]):
            hits.append(i)
    if len(hits) > 1:
        cells = ", ".join(f"{names[i]!r} (column {i + 1})" for i in hits)
        raise DataError(f"{name}: line {line_no}: more than one column could be {role}: {cells}; "
                        f"give the {role.split('_')[0]} column by name or number")
    return hits


def _missing_message(name, line_no, names, missing, rate) -> str:
    parts = []
    for role, wanted in missing:
        text = f"{wanted!r}"
        guess = _close_match(wanted, names)
        if guess is not None:
            text += f" (did you mean {names[guess]!r}, column {guess + 1}?)"
        parts.append(text)
    noun = "column" if len(parts) == 1 else "columns"
    found = ", ".join(f"{cell!r} ({i + 1})" for i, cell in enumerate(names))
    message = f"{name}: line {line_no}: the header has no {noun} {', '.join(parts)}; columns found: {found}"
    if any(role == "time_s" for role, _ in missing) and rate is None:
        message += "; without a time column give the sample rate"
    return message


def _header_further_down(lines, first, specs, rate) -> str:
    """A hint when a preamble sits above the real header: where the header is."""
    wanted = [spec if isinstance(spec, str) else role for role, spec in specs.items()
              if _as_number(spec) is None and not (role == "time_s" and spec is None and rate is not None)]
    for i in range(first + 1, min(len(lines), first + 100)):
        if all(word in lines[i] for word in wanted):
            return f"; the header seems to be line {i + 1}: skip {i} lines (skip_rows={i})"
    return ""


def _close_match(wanted: str, names) -> int | None:
    """Index of the header name closest to ``wanted`` (case first, then spelling)."""
    for i, cell in enumerate(names):
        if cell.lower() == wanted.lower():
            return i
    guess = difflib.get_close_matches(wanted, names, n=1, cutoff=0.6)
    if not guess:
        lowered = [cell.lower() for cell in names]
        guess = difflib.get_close_matches(wanted.lower(), lowered, n=1, cutoff=0.6)
        return lowered.index(guess[0]) if guess else None
    return names.index(guess[0])


def _columns_from_numbers(name, n_cells, specs, rate) -> dict:
    """Map role -> 0-based column index for a file without header."""
    columns = {}
    where = "the first data row"
    for role, spec in specs.items():
        if spec is None:
            if role == "time_s":
                if rate is None:
                    raise DataError(f"{name}: no time column and no sample rate; for a file without header "
                                    f"give the time column number or the sample rate in Hz")
                columns[role] = None
                continue
            raise DataError(f"{name}: the file has no header, so give the {role} column by number "
                            f"(1-based; {where} has {n_cells} columns)")
        number = _as_number(spec)
        if number is None:
            raise DataError(f"{name}: without a header, columns are given by number (1-based), "
                            f"got {spec!r} for {role}")
        columns[role] = _check_number(name, role, number, n_cells, where)
    if columns["time_s"] is not None and rate is not None:
        raise DataError(f"{name}: a time column and a sample rate were both given; give only one")
    _reject_shared(name, columns)
    return columns


def _reject_shared(name, columns) -> None:
    seen = {}
    for role, index in columns.items():
        if index is None:
            continue
        if index in seen:
            raise DataError(f"{name}: column {index + 1} is given for both {seen[index]} and {role}")
        seen[index] = role
