#!/usr/bin/python3
"""Converts PandaSet's pickled pandas DataFrames into plain files for
`pf import pandaset` (engine/importers/pandaset_importer.h), which
decides every convention and writes the clip; this module only copies values.

  pandaset_pickles.py SEQ_DIR OUT_DIR FRAME [FRAME ...]

For each FRAME (an integer; the files are named by it, e.g. 30 -> 30.pkl.gz):
- SEQ_DIR/lidar/NN.pkl.gz -> OUT_DIR/lidar/FRAME.npy: float64 [N, 6], the
  columns x, y, z, i, t, d in that order, rows in the DataFrame's order.
- SEQ_DIR/annotations/cuboids/NN.pkl.gz -> OUT_DIR/cuboids/FRAME.json: a JSON
  array with one object per row, keyed by column name ("position.x", ...);
  missing values (NaN) become null, numbers keep every digit.
A frame whose pickle is absent gets no output file (the importer warns).

Exit status: 0 done; 2 bad arguments or an unreadable pickle (message on
stderr); 3 pandas (Debian's python3-pandas) is not installed.
Needs /usr/bin/python3 with python3-pandas (scripts/install-deps.sh).
"""
import gzip
import json
import math
import os
import sys

EXIT_BAD_INPUT = 2
EXIT_NO_PANDAS = 3
LIDAR_COLUMNS = ("x", "y", "z", "i", "t", "d")


def frame_file(directory, frame):
    """Path of FRAME's pickle in `directory`: NN.pkl.gz, zero-padded to two
    digits as PandaSet names them, or unpadded; None when neither exists."""
    for name in (f"{frame:02d}.pkl.gz", f"{frame}.pkl.gz"):
        path = os.path.join(directory, name)
        if os.path.isfile(path):
            return path
    return None


def read_pickle(pandas, path):
    with gzip.open(path, "rb") as f:
        return pandas.read_pickle(f)


def plain(value):
    """A JSON-ready copy of one DataFrame cell (numpy scalars to Python)."""
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def convert_lidar(pandas, numpy, path, out_path):
    frame = read_pickle(pandas, path)
    missing = [c for c in LIDAR_COLUMNS if c not in frame.columns]
    if missing:
        raise ValueError(f"{path}: no column {', '.join(missing)} (have {', '.join(map(str, frame.columns))})")
    array = numpy.ascontiguousarray(frame[list(LIDAR_COLUMNS)].to_numpy(dtype=numpy.float64))
    numpy.save(out_path, array, allow_pickle=False)


def convert_cuboids(pandas, path, out_path):
    frame = read_pickle(pandas, path)
    columns = [str(c) for c in frame.columns]
    rows = [{c: plain(v) for c, v in zip(columns, row)} for row in frame.itertuples(index=False, name=None)]
    with open(out_path, "w", encoding="utf-8") as f:
        json.dump(rows, f, allow_nan=False)


def main(argv):
    if len(argv) < 4:
        print("usage: pandaset_pickles.py SEQ_DIR OUT_DIR FRAME [FRAME ...]", file=sys.stderr)
        return EXIT_BAD_INPUT
    seq_dir, out_dir = argv[1], argv[2]
    try:
        frames = [int(f) for f in argv[3:]]
    except ValueError as e:
        print(f"bad frame number: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        import numpy
        import pandas
    except ImportError as e:
        print(f"cannot import pandas ({e}): install Debian's python3-pandas "
              "(apt-get install python3-pandas)", file=sys.stderr)
        return EXIT_NO_PANDAS
    os.makedirs(os.path.join(out_dir, "lidar"), exist_ok=True)
    os.makedirs(os.path.join(out_dir, "cuboids"), exist_ok=True)
    for frame in frames:
        lidar = frame_file(os.path.join(seq_dir, "lidar"), frame)
        cuboids = frame_file(os.path.join(seq_dir, "annotations", "cuboids"), frame)
        current = None
        try:
            if lidar:
                current = lidar
                convert_lidar(pandas, numpy, lidar, os.path.join(out_dir, "lidar", f"{frame}.npy"))
            if cuboids:
                current = cuboids
                convert_cuboids(pandas, cuboids, os.path.join(out_dir, "cuboids", f"{frame}.json"))
        except Exception as e:  # Any unreadable pickle: reported with its path.
            print(f"{current}: {type(e).__name__}: {e}", file=sys.stderr)
            return EXIT_BAD_INPUT
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
