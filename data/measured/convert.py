"""Convert the shipped measured data sets from their original layouts to the
standard CSV (``time_s,voltage_V,displacement_um``).

Usage::

    python data/measured/convert.py [ORIGINALS]

``ORIGINALS`` is the folder holding one subfolder per data set with the files
as published (default: ``../shared/data`` beside the repository).  The
originals are read with :func:`pysim.identification.data.load_measured` and its layout
options and written with :func:`pysim.identification.data.save_measured`, so values keep every
digit and the conversion exercises the project's own loader.  Each data set's
LICENSE is copied beside the converted file; SOURCE.md there says where it
came from.
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from pysim.identification.data import SHIPPED_DATASETS, load_measured, save_measured

HERE = Path(__file__).resolve().parent

#: Original file name and the layout options that read it.
ORIGINALS = {
    # No header; columns [empty, time (s), displacement (µm), voltage (V)].
    "smart_hysteresis": ("hysteresis_v_150_1hz.csv",
                         dict(header=False, delimiter=",", time_column=2, displacement_column=3,
                              voltage_column=4)),
    # No header, whitespace-separated, 7 columns; voltage in 1, displacement in 5;
    # no time column: sampled at 200 Hz.
    "discrete_backlash": ("Model_Vi_Do.dat",
                          dict(header=False, delimiter="whitespace", voltage_column=1,
                               displacement_column=5, sample_rate_hz=200.0)),
}


def convert(originals: Path, target: Path = HERE) -> list:
    """Convert every data set of :data:`ORIGINALS`; return the files written."""
    written = []
    for name, (raw_name, layout) in ORIGINALS.items():
        data = load_measured(originals / name / raw_name, **layout)
        out = target / name / SHIPPED_DATASETS[name]
        save_measured(data, out)
        shutil.copyfile(originals / name / "LICENSE", target / name / "LICENSE")
        written.append(out)
        print(f"{out.relative_to(target)}: {len(data)} samples, {data.sample_rate_hz:g} Hz, "
              f"voltage {data.voltage_V.min():g}..{data.voltage_V.max():g} V")
    return written


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("originals", nargs="?", type=Path, default=HERE.parent.parent.parent / "shared" / "data",
                        help="folder with one subfolder per original data set")
    args = parser.parse_args(argv)
    convert(args.originals)
    return 0


if __name__ == "__main__":
    sys.exit(main())
