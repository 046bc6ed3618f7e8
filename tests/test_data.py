"""Tests of pysim.identification.data: the measured-data loader, its error messages and the
shipped data sets.

Truths used: numbers written to a file by hand (or as exact decimals) must come
back bit for bit; error messages must name the place a person finds by opening
the file in an editor; the shipped CSVs must equal the published originals.
"""
from __future__ import annotations

import dataclasses
import importlib.util
import math
import re
from pathlib import Path

import numpy as np
import pytest

from pysim.identification.data import (
    COLUMNS,
    SHIPPED_DATASETS,
    MeasuredData,
    checked_sample_rate,
    estimate_sample_rate,
    load_measured,
    require_even_sampling,
    require_samples,
    common_sample_rate,
    resample_record,
    save_measured,
    shipped_dataset,
)
from pysim.identification.errors import DataError

REPO = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).resolve().parent / "fixtures"
BAD = FIXTURES / "bad"
GOOD = FIXTURES / "good"
ORIGINALS = REPO.parent / "shared" / "data"  # the published files, beside the repository

# The five samples every file in fixtures/good holds.
FIVE_T = np.array([0.000, 0.001, 0.002, 0.003, 0.004])
FIVE_V = np.array([0.0, 1.5, 3.0, 4.5, 6.0])
FIVE_D = np.array([0.00, 0.42, 1.10, 1.95, 2.90])


def assert_same(data: MeasuredData, t, v, d):
    assert np.array_equal(data.time_s, t)
    assert np.array_equal(data.voltage_V, v)
    assert np.array_equal(data.displacement_um, d)


def load_error(path, **options) -> str:
    with pytest.raises(DataError) as info:
        load_measured(path, **options)
    message = str(info.value)
    assert "\n" not in message  # one line on stderr
    return message


def write(path: Path, text: str, encoding="utf-8") -> Path:
    path.write_bytes(text.encode(encoding))
    return path


# ------------------------------------------------------------ round trips

def awkward_record(n=2000, seed=3):
    """Values whose decimal form is long or unusual: must survive a round trip."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(1e-6, 1e-3, n)) - 0.5
    v = rng.normal(0, 150, n)
    v[:6] = [1 / 3, -0.0, 5e-324, 1e300, -2.2250738585072014e-308, 0.1 + 0.2]
    d = rng.normal(-120, 20, n) * np.pi
    return t, v, d


def test_save_then_load_returns_every_bit(tmp_path):
    t, v, d = awkward_record()
    path = save_measured(MeasuredData(t, v, d, source="memory"), tmp_path / "rec.csv")
    data = load_measured(path)
    assert_same(data, t, v, d)
    assert np.signbit(data.voltage_V[1])  # -0.0 stays -0.0
    assert data.source == str(path)
    assert path.read_text().splitlines()[0] == "time_s,voltage_V,displacement_um"


def test_save_refuses_non_finite_and_writes_nothing(tmp_path):
    t, v, d = awkward_record(10)
    v[4] = math.nan
    with pytest.raises(DataError, match="sample 4"):
        save_measured(MeasuredData(t, v, d, source="memory"), tmp_path / "rec.csv")
    assert list(tmp_path.iterdir()) == []


def test_good_fixtures_in_every_layout_give_the_same_samples():
    assert_same(load_measured(GOOD / "standard.csv"), FIVE_T, FIVE_V, FIVE_D)
    assert_same(load_measured(GOOD / "semicolon.csv"), FIVE_T, FIVE_V, FIVE_D)
    assert_same(load_measured(GOOD / "decimal_comma.csv"), FIVE_T, FIVE_V, FIVE_D)
    assert_same(load_measured(GOOD / "reordered_extra_columns.csv"), FIVE_T, FIVE_V, FIVE_D)
    data = load_measured(GOOD / "no_header_whitespace.txt", header=False, voltage_column=1,
                         displacement_column=2, sample_rate_hz=1000.0)
    assert_same(data, np.arange(5) / 1000.0, FIVE_V, FIVE_D)
    assert data.sample_rate_hz == 1000.0


def layouts(t, v, d):
    """The same record written by hand in several layouts: (file text, options, encoding)."""
    r = [(repr(a), repr(b), repr(c)) for a, b, c in zip(t.tolist(), v.tolist(), d.tolist())]
    std = "".join(f"{a},{b},{c}\n" for a, b, c in r)
    return {
        "crlf": ("time_s,voltage_V,displacement_um\r\n" + std.replace("\n", "\r\n"), {}, "utf-8"),
        "bom": ("\ufefftime_s,voltage_V,displacement_um\n" + std, {}, "utf-8"),
        "utf16": ("\ufefftime_s\tvoltage_V\tdisplacement_um\n" + std.replace(",", "\t"), {}, "utf-16-le"),
        "latin1_extra_column": ("Weg µm,time_s,voltage_V,displacement_um\n"
                                + "".join(f"x,{a},{b},{c}\n" for a, b, c in r), {}, "latin-1"),
        "quoted": ('"time_s","voltage_V","displacement_um"\n'
                   + "".join(f'"{a}","{b}","{c}"\n' for a, b, c in r), {}, "utf-8"),
        "spaces_and_blank_lines": ("time_s voltage_V  displacement_um\n\n"
                                   + "".join(f"  {a}   {b}\t{c}\n\n" for a, b, c in r), {}, "utf-8"),
        "preamble_skipped": ("logger v2\nrate 5 kHz\n\ntime_s;voltage_V;displacement_um\n"
                             + std.replace(",", ";"), {"skip_rows": 2}, "utf-8"),
        "custom_names": ("t,U_piezo,x_sensor\n" + std,
                         {"time_column": "t", "voltage_column": "U_piezo", "displacement_column": "x_sensor"},
                         "utf-8"),
        "numbers_with_header": ("a,b,c,d\n" + "".join(f"0,{c},{a},{b}\n" for a, b, c in r),
                                {"time_column": 3, "voltage_column": "4", "displacement_column": 2}, "utf-8"),
        # a European locale's export: ';' between cells, a comma before the decimals
        "decimal_comma": ("time_s;voltage_V;displacement_um\n"
                          + "".join(f"{a};{b};{c}\n".replace(".", ",") for a, b, c in r), {}, "utf-8"),
        "decimal_comma_quoted": ("time_s;voltage_V;displacement_um\n"
                                 + "".join(f'"{a}";"{b}";"{c}"\n'.replace(".", ",") for a, b, c in r), {},
                                 "utf-8"),
        "german_header_decimal_comma": ("Zeit [s];Spannung [V];Weg [µm]\n"
                                        + "".join(f"{a};{b};{c}\n".replace(".", ",") for a, b, c in r), {},
                                        "utf-8"),
        # tabs between header cells that hold spaces: the tab alone separates
        "tab_header_with_units": ("Time [s]\tVoltage [V]\tDisplacement [um]\n" + std.replace(",", "\t"), {},
                                  "utf-8"),
        "tab_header_decimal_comma": ("Time [s]\tVoltage [V]\tPosition [um]\n"
                                     + std.replace(".", "#").replace(",", "\t").replace("#", ","),
                                     {"delimiter": "tab"}, "utf-8"),
        "no_header_numbers": ("".join(f"{c}|{b}|{a}\n" for a, b, c in r),
                              {"header": False, "delimiter": "|", "time_column": 3, "voltage_column": 2,
                               "displacement_column": 1}, "utf-8"),
    }


@pytest.mark.parametrize("layout", sorted(layouts(*awkward_record(10))))
def test_every_layout_reads_the_numbers_exactly(tmp_path, layout):
    t, v, d = awkward_record(300)
    text, options, encoding = layouts(t, v, d)[layout]
    data = load_measured(write(tmp_path / "rec.txt", text, encoding), **options)
    assert_same(data, t, v, d)


def test_sample_rate_gives_the_time_grid(tmp_path):
    t, v, d = awkward_record(400)
    path = write(tmp_path / "rec.txt", "".join(f"{b!r} {c!r}\n" for b, c in zip(v.tolist(), d.tolist())))
    data = load_measured(path, header=False, voltage_column=1, displacement_column=2, sample_rate_hz=250)
    assert_same(data, np.arange(400) / 250.0, v, d)
    assert data.sample_rate_hz == 250.0
    assert len(data) == 400


def test_large_file_reports_the_exact_line(tmp_path):
    """The fast path's row numbers must map back to file lines (blank lines included)."""
    n = 120_000
    lines = ["junk line", "time_s,voltage_V,displacement_um"]
    for k in range(n):
        lines.append(f"{k / 1000!r},{k % 150},{-k / 7!r}")
        if k % 1000 == 999:
            lines.append("")
    row = 98_765
    line_no = 2 + row + row // 1000 + 1  # preamble, rows before it, blank lines before it
    assert lines[line_no - 1].startswith(f"{row / 1000!r},")
    path = tmp_path / "big.csv"
    write(path, "\n".join(lines) + "\n")
    data = load_measured(path, skip_rows=1)
    assert len(data) == n and data.time_s[row] == row / 1000

    nan_lines = list(lines)
    nan_lines[line_no - 1] = f"{row / 1000!r},nan,0"
    write(path, "\n".join(nan_lines))
    assert f"line {line_no}, column 2 (voltage_V): 'nan'" in load_error(path, skip_rows=1)

    text_lines = list(lines)
    text_lines[line_no - 1] = f"{row / 1000!r},12,oops"
    write(path, "\n".join(text_lines))
    assert f"line {line_no}, column 3 (displacement_um): 'oops'" in load_error(path, skip_rows=1)

    back_lines = list(lines)
    back_lines[line_no - 1] = "0.5,1,1"
    write(path, "\n".join(back_lines))
    assert (f"line {line_no}, column 1 (time_s): time 0.5 s is not after {(row - 1) / 1000!r} s "
            f"on line {line_no - 1}") in load_error(path, skip_rows=1)


# ------------------------------------------------------------ bad files

# Every file of fixtures/bad with the fragments its message must contain.
BAD_FILES = {
    "empty.csv": ["empty"],
    "blank_lines.csv": ["empty"],
    "header_only.csv": ["line 1", "no data rows"],
    "single_row.csv": ["line 2", "only one data row", "at least 2"],
    "missing_column.csv": ["line 1", "no column 'displacement_um'", "'time_s' (1), 'voltage_V' (2)"],
    "misspelled_column.csv": ["line 1", "no column 'voltage_V'", "did you mean 'voltge_V', column 2"],
    "non_numeric.csv": ["line 4, column 2 (voltage_V)", "'3.0V' is not a number"],
    "nan.csv": ["line 5, column 3 (displacement_um)", "'NaN' is not a finite number"],
    "inf.csv": ["line 3, column 2 (voltage_V)", "'inf' is not a finite number"],
    "empty_cell.csv": ["line 4, column 2 (voltage_V)", "empty cell"],
    "too_few_cells.csv": ["line 5", "2 cells", "column 3 (displacement_um) is missing"],
    "too_many_cells.csv": ["line 3", "4 cells", "header (line 1) has 3"],
    "time_not_increasing.csv": ["line 5, column 1 (time_s)", "0.0015 s is not after 0.002 s on line 4"],
    "duplicate_time.csv": ["line 5, column 1 (time_s)", "duplicate timestamp 0.002 s", "line 4"],
    "wrong_delimiter.csv": ["line 1", "only one column found", "bar '|'"],
    "no_header.csv": ["line 1", "looks like data", "header=False"],
    "no_time_column.csv": ["line 1", "no column 'time_s'", "sample rate"],
    "binary.csv": ["line 3", "binary"],
    "directory.csv": ["is a directory"],
}


def test_every_bad_fixture_is_checked():
    assert sorted(p.name for p in BAD.iterdir()) == sorted(BAD_FILES)


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_bad_fixture_names_file_line_and_column(name):
    path = str(BAD / name)
    message = load_error(path)
    assert message.startswith(f"{path}: ")
    for fragment in BAD_FILES[name]:
        assert fragment in message, (fragment, message)


def test_missing_file(tmp_path):
    path = str(tmp_path / "nope.csv")
    assert load_error(path) == f"{path}: no such file"


@pytest.mark.parametrize("options, fragments", [
    ({"delimiter": ","}, ["line 1", "only one column found", "comma ','", "semicolon ';'", "delimiter ';'"]),
    ({"delimiter": "tab"}, ["line 1", "only one column found", "semicolon ';'"]),
    ({"delimiter": "ab"}, ["unusable delimiter 'ab'"]),
    ({"sample_rate_hz": 100.0}, ["line 1", "time column (time_s, column 1)", "sample rate"]),
    ({"sample_rate_hz": 0}, ["sample rate", "positive"]),
    ({"sample_rate_hz": -5.0}, ["sample rate", "positive"]),
    ({"sample_rate_hz": math.nan}, ["sample rate", "positive"]),
    ({"voltage_column": 4}, ["voltage_V column number 4", "header (line 1) has 3 columns"]),
    ({"voltage_column": "U_piezo"}, ["no column 'U_piezo'"]),
    ({"voltage_column": 3}, ["column 3 is given for both voltage_V and displacement_um"]),
    ({"skip_rows": 9}, ["nothing left after skipping 9 lines", "6 lines"]),
    ({"skip_rows": -1}, ["skip_rows"]),
])
def test_bad_options_on_a_good_file(options, fragments):
    path = GOOD / ("semicolon.csv" if "delimiter" in options else "standard.csv")
    message = load_error(path, **options)
    assert message.startswith(f"{path}: ")
    for fragment in fragments:
        assert fragment in message, (fragment, message)


@pytest.mark.parametrize("options, fragments", [
    ({"voltage_column": 1, "displacement_column": 2}, ["no time column and no sample rate"]),
    ({"voltage_column": 1, "sample_rate_hz": 1.0}, ["give the displacement_um column by number", "3 columns"]),
    ({"voltage_column": "voltage_V", "displacement_column": 2, "sample_rate_hz": 1.0}, ["by number"]),
    ({"time_column": 3, "voltage_column": 1, "displacement_column": 2, "sample_rate_hz": 1.0},
     ["time column and a sample rate"]),
])
def test_bad_options_without_header(options, fragments):
    path = GOOD / "no_header_whitespace.txt"
    message = load_error(path, header=False, **options)
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_messages_name_custom_columns_and_count_skipped_lines(tmp_path):
    text = "export 1\nexport 2\nt;U_piezo;x\n0;1;2\n\n0,5;1;2\n0,7;1,2.5;2\n"
    message = load_error(write(tmp_path / "x.csv", text), skip_rows=2, time_column="t",
                         voltage_column="U_piezo", displacement_column="x")
    # a decimal comma is read; a comma beside a point is no number in any locale
    assert message.endswith("line 7, column 2 (U_piezo, used as voltage_V): '1,2.5' is not a number"), message


def test_a_quoted_decimal_comma_in_a_comma_file_is_refused_with_a_hint(tmp_path):
    message = load_error(write(tmp_path / "x.csv", 'time_s,voltage_V,displacement_um\n0,1,2\n"0,5",1,2\n'))
    assert "line 3, column 1 (time_s): '0,5' is not a number (decimal comma?" in message


def test_unrecognised_header_names_are_suggested(tmp_path):
    path = write(tmp_path / "x.csv", "Tim_S,voltage_out,displacement_um\n0,1,2\n1,2,3\n")
    message = load_error(path)
    assert "no columns 'time_s' (did you mean 'Tim_S', column 1?), 'voltage_V' (did you mean 'voltage_out', " \
           "column 2?)" in message


@pytest.mark.parametrize("sep, cells", [
    # (header cell, quantity, how many of the file's unit make one standard unit)
    (",", [("Time [ms]", "t", 1000), ("Voltage [mV]", "v", 1000), ("Displacement [nm]", "d", 1000)]),
    (";", [("time (s)", "t", 1), ("input voltage (V)", "v", 1), ("position (µm)", "d", 1)]),
    ("\t", [("t/ms", "t", 1000), ("u/kV", "v", 0.001), ("y/mm", "d", 0.001)]),
    (",", [("Time_S", "t", 1), ("volt_V", "v", 1), ("displacement_um", "d", 1)]),
    (",", [("t", "t", 1), ("u", "v", 1), ("x", "d", 1)]),
    (",", [("position in nm", "d", 1000), ("time in us", "t", 1e6), ("voltage", "v", 1)]),
])
def test_a_header_in_other_words_is_read_in_standard_units(tmp_path, sep, cells):
    truth = {"t": FIVE_T, "v": FIVE_V, "d": FIVE_D}
    columns = [[f"{round(x * scale, 9):.12g}" for x in truth[q]] for _, q, scale in cells]
    text = sep.join(c for c, _, _ in cells) + "\n" + "".join(sep.join(row) + "\n" for row in zip(*columns))
    data = load_measured(write(tmp_path / "x.csv", text))
    for got, want in ((data.time_s, FIVE_T), (data.voltage_V, FIVE_V), (data.displacement_um, FIVE_D)):
        np.testing.assert_array_max_ulp(got, want, maxulp=1)   # × 1000 of a decimal: within one ulp
    assert len(data.read_as) == sum(c not in COLUMNS for c, _, _ in cells)
    if all(scale >= 1 for _, _, scale in cells):
        assert_same(data, FIVE_T, FIVE_V, FIVE_D)   # a division by 1000 is correctly rounded: exact


def test_a_header_in_other_words_must_name_each_quantity_once_in_its_units(tmp_path):
    ambiguous = write(tmp_path / "a.csv", "t,x,y\n0,1,2\n1,2,3\n")
    assert "more than one column could be displacement_um: 'x' (column 2), 'y' (column 3)" in load_error(ambiguous)
    # a displacement in volts is a raw sensor signal, not a displacement: not used, suggested only
    sensor = write(tmp_path / "s.csv", "time_s,voltage_V,displacement [V]\n0,1,2\n1,2,3\n")
    assert "no column 'displacement_um' (did you mean 'displacement [V]', column 3?)" in load_error(sensor)
    # named by the user: used as given, and said so
    data = load_measured(sensor, displacement_column="displacement [V]")
    assert data.read_as == ("column 3 'displacement [V]' read as displacement_um "
                            "(V is not a unit of displacement_um: taken as µm)",)
    # a sample rate is the one source of time: a time column found by another name is then not used
    timed = write(tmp_path / "t.csv", "Time [s],Voltage [V],Displacement [um]\n0,1,2\n1,2,3\n")
    data = load_measured(timed, sample_rate_hz=10.0)
    assert data.time_s.tolist() == [0.0, 0.1] and data.voltage_V.tolist() == [1.0, 2.0]


def test_a_preamble_above_the_header_is_pointed_out(tmp_path):
    path = write(tmp_path / "x.csv", "exported by scope 7\nrate: 5 kHz\ntime_s,voltage_V,displacement_um\n0,1,2\n1,2,3\n")
    message = load_error(path)
    assert "line 1: the header has no columns" in message
    assert "the header seems to be line 3: skip 2 lines (skip_rows=2)" in message
    assert_same(load_measured(path, skip_rows=2), [0, 1], [1, 2], [2, 3])


def test_a_duplicated_header_name_is_ambiguous(tmp_path):
    path = write(tmp_path / "x.csv", "time_s,voltage_V,voltage_V,displacement_um\n0,1,1,2\n1,2,2,3\n")
    assert "names 'voltage_V' more than once (columns 2, 3)" in load_error(path)


def test_quoted_numbers_take_the_careful_path_with_the_same_result(tmp_path):
    plain = write(tmp_path / "plain.csv", (GOOD / "standard.csv").read_text())
    quoted = write(tmp_path / "quoted.csv", "time_s,voltage_V,displacement_um\n" + "".join(
        f'"{a}", "{b}" ,{c}\n' for a, b, c in zip(FIVE_T, FIVE_V, FIVE_D)))
    assert_same(load_measured(quoted), *(getattr(load_measured(plain), c) for c in COLUMNS))


@pytest.mark.parametrize("cell, value", [("0,5", 0.5), (",5", 0.5), ("5,", 5.0), ("-1,25e-3", -1.25e-3),
                                         ("2.5", 2.5), ("1,2,3", None), ("1,2.5", None)])
def test_decimal_commas_read_alike_on_the_fast_path_and_the_careful_one(tmp_path, cell, value):
    """A ';' file's cell with one comma and no point is a number with a decimal comma, whichever
    path reads it (quotes send a file to the careful scan); any other comma is no number."""
    outcomes = []
    for quote in ("", '"'):
        text = "time_s;voltage_V;displacement_um\n0;1;2\n" + f"1;{quote}{cell}{quote};3\n"
        path = write(tmp_path / f"x{len(quote)}.csv", text)
        if value is None:
            outcomes.append(load_error(path))
        else:
            outcomes.append(float(load_measured(path).voltage_V[1]))
    if value is None:
        assert all(f"line 3, column 2 (voltage_V): '{cell}' is not a number" in m for m in outcomes), outcomes
    else:
        assert outcomes == [value, value]


def test_python_only_number_syntax_is_refused(tmp_path):
    path = write(tmp_path / "x.csv", "time_s,voltage_V,displacement_um\n0,1,2\n1,1_000,3\n")
    assert "line 3, column 2 (voltage_V): '1_000' is not a number" in load_error(path)


# ------------------------------------------------------------ small API pieces

def test_estimate_sample_rate():
    # A 5 kHz record whose timestamps jitter by up to 20 ns (as the smart_hysteresis
    # original does): the mean over 10 s is within 4e-8 s / 10 s of the true rate.
    rng = np.random.default_rng(7)
    t = np.arange(50_001) / 5000 + rng.uniform(-2e-8, 2e-8, 50_001)
    assert estimate_sample_rate(t) == pytest.approx(5000.0, rel=5e-9)
    # A record with a gap: the median interval, not the mean.
    gap = np.concatenate([np.arange(100) * 0.01, 5.0 + np.arange(100) * 0.01])
    assert estimate_sample_rate(gap) == pytest.approx(100.0, rel=1e-12)
    assert math.isnan(estimate_sample_rate([1.0]))


@pytest.mark.parametrize("rate_hz, decimals", [(3000, 4), (6000, 4), (7000, 4), (3000, 5), (1300, 4)])
def test_timestamps_rounded_to_a_good_part_of_an_interval_keep_the_true_rate(tmp_path, rate_hz, decimals):
    """A logger that writes its times with too few digits (a 3 kHz record to 0.1 ms: intervals of 0.3
    and 0.4 ms, median 0.3 ms) gave the median's rate, 3333 Hz for 3000 Hz, and every lag, delay and
    creep time would have been fitted 11 % off.  Read from a CSV, the rate is the logger's to 10⁻⁵, the
    record counts as evenly sampled, and one sample missing is still refused."""
    n = 9000
    t = np.arange(n) / rate_hz
    v = 50.0 + 40.0 * np.sin(2 * np.pi * 3.0 * t)
    path = tmp_path / "rounded.csv"
    path.write_text("time_s,voltage_V,displacement_um\n" + "".join(
        f"{a:.{decimals}f},{b:.4f},{0.2 * b:.4f}\n" for a, b in zip(t, v)), encoding="utf-8")
    data = load_measured(path)
    assert data.sample_rate_hz == pytest.approx(rate_hz, rel=1e-5)
    require_even_sampling(data, "the diagnosis")
    missing = np.delete(data.time_s, n // 2)
    with pytest.raises(DataError, match="not evenly spaced"):
        require_even_sampling(MeasuredData(missing, v[:-1], v[:-1], source="rounded.csv"), "the diagnosis")


def test_require_even_sampling_passes_jitter_and_refuses_a_missing_sample_or_a_pause():
    rng = np.random.default_rng(3)
    n = 2000
    even = np.arange(n) * 1e-3
    jittered = even + rng.uniform(-2e-4, 2e-4, n)          # ±20 % of an interval, still increasing
    signal = np.sin(2 * np.pi * even)
    require_even_sampling(MeasuredData(jittered, signal, signal, source="rig.csv"), "the diagnosis")
    for times, interval, after in ((np.delete(even, 700), 2e-3, 0.699),            # one sample missing
                                   (np.r_[even[:500], even[500:] + 1.0], 1.001, 0.499)):  # a 1 s pause
        with pytest.raises(DataError) as raised:
            require_even_sampling(MeasuredData(times, signal[:times.size], signal[:times.size], source="rig.csv"),
                                  "the diagnosis")
        message = str(raised.value)
        assert message.startswith("rig.csv: the samples are not evenly spaced")
        assert f"an interval of {interval:.6g} s after t = {after:.6g} s" in message, message
        assert "the diagnosis needs evenly spaced samples" in message


def test_resample_record_keeps_the_samples_on_the_grid_and_invents_none():
    n = 1001
    ramp = 0.5 * np.arange(n)
    noisy = np.random.default_rng(2).normal(size=n)
    # every m-th sample when the record is m times faster: the samples themselves, noise and all
    v, y, how = resample_record(ramp, noisy, 5000.0, 1000.0)
    assert how == "every 5th sample" and np.array_equal(v, ramp[::5]) and np.array_equal(y, noisy[::5])
    assert resample_record(ramp, noisy, 12000.0, 1000.0)[2] == "every 12th sample"
    # two loggers' rounding of one rate: misplaced by less than half a sample at the end, used as recorded
    for rate in (2000.0 * (1 + 0.4 / n), 2000.0 * (1 - 0.4 / n)):
        v, y, how = resample_record(ramp, noisy, 2000.0, rate)
        assert how == "as recorded" and np.array_equal(v, ramp) and np.array_equal(y, noisy)
    # ... the same for a multiple; and refused when the end would be a sample off or the ratio is not whole
    assert resample_record(ramp, noisy, 4000.0 * (1 + 0.4 / n), 2000.0)[2] == "every 2nd sample"
    for from_hz, to_hz in ((2000.0, 2000.0 * (1 + 1.2 / n)), (3000.0, 2000.0), (1000.0, 2000.0)):
        with pytest.raises(DataError) as refused:
            resample_record(ramp, noisy, from_hz, to_hz)
        assert str(refused.value).startswith(f"a record at {from_hz:g} Hz cannot be used at {to_hz:g} Hz")


def test_common_sample_rate_is_the_highest_grid_both_records_fall_on():
    """Checked against the definition by brute force: the rate returned is the first record's over a
    whole m, the second record's samples fall on it by the resampling rule, and no smaller m would do."""
    def fits(second_hz, n2, rate_hz):
        try:
            resample_record(np.zeros(n2), np.zeros(n2), second_hz, rate_hz)
        except DataError:
            return False
        return True

    cases = [(10000.0, 20000.0), (10000.0, 10000.0), (10000.0, 5000.0), (10000.0, 4000.0), (5000.0, 2000.0),
             (2000.0, 3000.0), (2000.0, 2000.0 * (1 + 0.3 / 5000)), (1000.0, 125.0)]
    for first_hz, second_hz in cases:
        rate = common_sample_rate(first_hz, 4000, second_hz, 5000)
        m = first_hz / rate
        assert m == round(m) and fits(second_hz, 5000, rate), (first_hz, second_hz, rate)
        assert not any(fits(second_hz, 5000, first_hz / k) for k in range(1, round(m))), (first_hz, second_hz)
        # exact rates of whole numbers: the grid is their greatest common divisor when that is reachable
        if second_hz == round(second_hz):
            gcd = float(np.gcd(int(first_hz), int(second_hz)))
            if first_hz / gcd <= 10:
                assert rate == gcd, (first_hz, second_hz, rate)
    # 48 kHz and 44.1 kHz share 300 Hz, a 160th of the first: too much of the first record thrown away
    with pytest.raises(DataError) as refused:
        common_sample_rate(48000.0, 4000, 44100.0, 5000)
    assert str(refused.value).startswith("records at 48000 Hz and 44100 Hz have no common rate down to 4800 Hz")


def test_one_sample_rate_check_serves_the_loader_the_diagnosis_and_the_excitation(tmp_path):
    """A sample rate given as a number is checked by one rule everywhere: text, booleans, NaN,
    infinities, zero and negative numbers are refused with one line naming where, in the error type
    of the layer that was called; every kind of real number is taken as a float."""
    from pysim.diagnosis.diagnose import diagnose
    from pysim.diagnosis.errors import DiagnosisError
    from pysim.diagnosis.excitation import separating_excitation

    for good in (2000, 2000.0, np.int32(2000), np.float32(2000.0)):
        assert checked_sample_rate(good) == 2000.0 and type(checked_sample_rate(good)) is float
    path = write(tmp_path / "r.csv", "voltage_V,displacement_um\n0,0\n1,2\n2,3\n")
    v = np.r_[np.linspace(0.0, 10.0, 250), np.linspace(10.0, 0.0, 250)]
    for bad, shown in (("2000", "'2000'"), (True, "True"), (math.nan, "nan"), (math.inf, "inf"), (0.0, "0.0"),
                       (-5, "-5"), (None, "None")):
        fragment = f"must be a positive finite number of Hz, got {shown}"
        with pytest.raises(DataError, match=re.escape(f"rate of x must be a positive finite number of Hz, got {shown}")):
            checked_sample_rate(bad, "rate of x")
        if bad is not None:            # None is the loader's "from the time column"
            assert load_error(path, sample_rate_hz=bad) == f"{path}: sample rate {fragment}"
        for call in (lambda: diagnose(v, 2.0 * v, bad), lambda: separating_excitation(["delay"], (0.0, 10.0), bad)):
            with pytest.raises(DiagnosisError) as refused:
                call()
            assert str(refused.value) == f"sample rate {fragment}"


def test_resample_record_refuses_bad_rates_and_too_few_samples():
    for rates, fragment in (((0.0, 1000.0), "from_rate_hz must be a positive finite number of Hz, got 0.0"),
                            ((1000.0, math.nan), "to_rate_hz must be a positive finite number of Hz, got nan")):
        with pytest.raises(DataError, match=re.escape(fragment)):
            resample_record(np.arange(10.0), np.arange(10.0), *rates)
    with pytest.raises(DataError, match="3 samples at 3000 Hz leave 1 at 1000 Hz"):
        resample_record(np.arange(3.0), np.arange(3.0), 3000.0, 1000.0)
    with pytest.raises(DataError, match="at least 2 samples"):
        resample_record(np.arange(3.0), np.arange(4.0), 1000.0, 500.0)


def test_require_samples():
    data = MeasuredData(FIVE_T, FIVE_V, FIVE_D, source="rig.csv")
    require_samples(data, 5, "anything")
    with pytest.raises(DataError) as info:
        require_samples(data, 23, "an MPI model with 10 operators (22 parameters)")
    assert str(info.value) == "rig.csv: 5 samples, need at least 23 for an MPI model with 10 operators (22 parameters)"


def test_measured_data_is_an_immutable_copy():
    t = FIVE_T.copy()
    data = MeasuredData(t, FIVE_V, FIVE_D)
    t[0] = 99.0
    assert data.time_s[0] == 0.0
    with pytest.raises(ValueError):
        data.voltage_V[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        data.source = "x"
    assert data.time_s.dtype == np.float64 and len(data) == 5
    assert data.sample_rate_hz == pytest.approx(1000.0, rel=1e-12)
    with pytest.raises(ValueError, match="differ in length"):
        MeasuredData(FIVE_T, FIVE_V[:4], FIVE_D)


# ------------------------------------------------------------ shipped data sets

# The published layouts, as their SOURCE.md files describe them.
RAW_LAYOUTS = {
    "smart_hysteresis": ("hysteresis_v_150_1hz.csv",
                         dict(header=False, delimiter=",", time_column=2, displacement_column=3,
                              voltage_column=4)),
    "discrete_backlash": ("Model_Vi_Do.dat",
                          dict(header=False, voltage_column=1, displacement_column=5, sample_rate_hz=200)),
}


def test_originals_are_beside_the_repository():
    for name, (raw, _) in RAW_LAYOUTS.items():
        assert (ORIGINALS / name / raw).is_file(), ORIGINALS / name / raw


@pytest.mark.parametrize("name", sorted(SHIPPED_DATASETS))
def test_shipped_csv_equals_the_original(name):
    raw, layout = RAW_LAYOUTS[name]
    original = load_measured(ORIGINALS / name / raw, **layout)
    shipped = load_measured(shipped_dataset(name))
    assert_same(shipped, original.time_s, original.voltage_V, original.displacement_um)
    assert shipped.sample_rate_hz == pytest.approx(original.sample_rate_hz, rel=1e-12)
    folder = shipped_dataset(name).parent
    assert (folder / "LICENSE").read_bytes() == (ORIGINALS / name / "LICENSE").read_bytes()
    assert "MIT" in (folder / "SOURCE.md").read_text(encoding="utf-8")
    assert shipped_dataset(name).read_text().splitlines()[0] == "time_s,voltage_V,displacement_um"


def test_smart_original_cells_survive_as_written():
    """Spot check against the raw text itself, not through the loader."""
    raw_lines = (ORIGINALS / "smart_hysteresis" / "hysteresis_v_150_1hz.csv").read_text().splitlines()
    data = load_measured(shipped_dataset("smart_hysteresis"))
    for k in (0, 1, 12_345, 16_778, 50_000):
        _, t, d, v = raw_lines[k].split(",")
        assert (data.time_s[k], data.displacement_um[k], data.voltage_V[k]) == (float(t), float(d), float(v))


def test_shipped_smart_hysteresis_facts():
    data = load_measured(shipped_dataset("smart_hysteresis"))
    assert len(data) == 50_001
    assert data.time_s[0] == 0.0 and data.time_s[-1] == 10.0
    assert data.voltage_V.min() == -150.0 and data.voltage_V.max() == 150.0
    assert data.sample_rate_hz == pytest.approx(5000.0, rel=1e-9)
    assert -20 < data.displacement_um.min() < -19 and 19 < data.displacement_um.max() < 20


def test_shipped_discrete_backlash_facts():
    data = load_measured(shipped_dataset("discrete_backlash"))
    assert len(data) == 8027
    assert np.array_equal(data.time_s, np.arange(8027) / 200.0)
    assert data.voltage_V.min() == 0.0 and data.voltage_V.max() == 3.6
    assert data.sample_rate_hz == pytest.approx(200.0, rel=1e-9)
    assert -124 < data.displacement_um.min() and data.displacement_um.max() < -73


def test_converter_reproduces_the_shipped_files(tmp_path):
    spec = importlib.util.spec_from_file_location("convert_measured", REPO / "data" / "measured" / "convert.py")
    convert = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(convert)
    written = convert.convert(ORIGINALS, tmp_path)
    assert len(written) == len(SHIPPED_DATASETS)
    for name in SHIPPED_DATASETS:
        rel = Path(name) / SHIPPED_DATASETS[name]
        assert (tmp_path / rel).read_bytes() == shipped_dataset(name).read_bytes()


def test_unknown_shipped_dataset():
    with pytest.raises(DataError, match="discrete_backlash, smart_hysteresis"):
        shipped_dataset("nope")
