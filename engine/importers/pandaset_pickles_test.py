#!/usr/bin/python3
"""Tests of pandaset_pickles.py, the reader `pf import pandaset` runs: it is run
as a process (as pf runs it) on DataFrames pickled here, and on one frame of
the sample sequence when the data is there (skipped, saying so, otherwise).

Run by ctest (engine/importers/CMakeLists.txt):
  pandaset_pickles_test.py --module PATH --data-dir DIR [unittest arguments]
PF_DATA_DIR in the environment overrides --data-dir. Needs Debian's
python3-pandas.
"""
import argparse
import gzip
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy
import pandas

MODULE = ""
DATA_DIR = ""


def run_module(*args, env=None):
    return subprocess.run(["/usr/bin/python3", MODULE, *args], capture_output=True, text=True,
                          timeout=120, env=env)


def write_pickle(frame, path):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with gzip.open(path, "wb") as f:
        frame.to_pickle(f)


class ConversionTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.seq = os.path.join(self.tmp.name, "seq")
        self.out = os.path.join(self.tmp.name, "out")

    def tearDown(self):
        self.tmp.cleanup()

    def test_lidar_and_cuboids_come_out_as_npy_and_json(self):
        # LiDAR columns in another order, one extra; d is an integer column.
        points = pandas.DataFrame({
            "d": numpy.array([0, 1, 0], dtype=numpy.int64),
            "t": [1557539959.399091, 1557539959.45, 1557539959.5019503],
            "extra": ["a", "b", "c"],
            "z": [0.1, -2.5, 3.0],
            "y": [-46.931262, 1e-7, 12.0],
            "x": [-44.527659, 0.0, 1234.5678901234],
            "i": [22.0, 255.0, 0.0],
        })
        write_pickle(points, os.path.join(self.seq, "lidar", "07.pkl.gz"))
        boxes = pandas.DataFrame({
            "uuid": ["e83d78e4-5b11-4ad5-ac71-917b5cd19c94", "f0b32b02"],
            "label": ["Car", "Pedestrian"],
            "yaw": [-0.8400444222766996, 2.414188],
            "stationary": [True, False],
            "position.x": [7.361, -8.618],
            "cuboids.sensor_id": numpy.array([-1, 0], dtype=numpy.int64),
            "attributes.pedestrian_age": [float("nan"), "Adult"],
        })
        write_pickle(boxes, os.path.join(self.seq, "annotations", "cuboids", "30.pkl.gz"))
        run = run_module(self.seq, self.out, "7", "30")
        self.assertEqual(run.returncode, 0, run.stderr)

        array = numpy.load(os.path.join(self.out, "lidar", "7.npy"), allow_pickle=False)
        self.assertEqual(array.dtype, numpy.float64)
        self.assertEqual(array.shape, (3, 6))
        expected = points[["x", "y", "z", "i", "t", "d"]].to_numpy(dtype=numpy.float64)
        self.assertTrue(numpy.array_equal(array, expected))  # Every digit kept.

        with open(os.path.join(self.out, "cuboids", "30.json"), encoding="utf-8") as f:
            rows = json.load(f)
        self.assertEqual(rows, [
            {"uuid": "e83d78e4-5b11-4ad5-ac71-917b5cd19c94", "label": "Car",
             "yaw": -0.8400444222766996, "stationary": True, "position.x": 7.361,
             "cuboids.sensor_id": -1, "attributes.pedestrian_age": None},
            {"uuid": "f0b32b02", "label": "Pedestrian", "yaw": 2.414188, "stationary": False,
             "position.x": -8.618, "cuboids.sensor_id": 0, "attributes.pedestrian_age": "Adult"},
        ])
        self.assertIs(type(rows[0]["stationary"]), bool)
        # A frame without a pickle gets no file.
        self.assertEqual(os.listdir(os.path.join(self.out, "lidar")), ["7.npy"])
        self.assertEqual(os.listdir(os.path.join(self.out, "cuboids")), ["30.json"])

    def test_missing_column_and_corrupt_pickle_are_exit_2_naming_the_file(self):
        write_pickle(pandas.DataFrame({"x": [1.0], "y": [2.0]}), os.path.join(self.seq, "lidar", "01.pkl.gz"))
        run = run_module(self.seq, self.out, "1")
        self.assertEqual(run.returncode, 2)
        self.assertIn("lidar/01.pkl.gz", run.stderr)
        self.assertIn("no column z, i, t, d", run.stderr)

        os.makedirs(os.path.join(self.seq, "annotations", "cuboids"))
        with open(os.path.join(self.seq, "annotations", "cuboids", "02.pkl.gz"), "wb") as f:
            f.write(b"not a gzip file")
        run = run_module(self.seq, self.out, "2")
        self.assertEqual(run.returncode, 2)
        self.assertIn("annotations/cuboids/02.pkl.gz", run.stderr)

    def test_bad_arguments_are_exit_2(self):
        self.assertEqual(run_module(self.seq).returncode, 2)
        run = run_module(self.seq, self.out, "thirty")
        self.assertEqual(run.returncode, 2)
        self.assertIn("bad frame number", run.stderr)

    def test_without_pandas_exit_3_names_the_debian_package(self):
        # A pandas that cannot be imported shadows the installed one.
        shadow = os.path.join(self.tmp.name, "shadow")
        os.makedirs(shadow)
        with open(os.path.join(shadow, "pandas.py"), "w", encoding="utf-8") as f:
            f.write("raise ImportError('No module named pandas')\n")
        env = dict(os.environ, PYTHONPATH=shadow)
        run = run_module(self.seq, self.out, "1", env=env)
        self.assertEqual(run.returncode, 3)
        self.assertIn("apt-get install python3-pandas", run.stderr)


class SampleSequenceTest(unittest.TestCase):
    def test_frame_30_of_the_sample(self):
        seq = os.path.join(DATA_DIR, "pandaset_002")
        if not DATA_DIR or not os.path.isdir(seq):
            self.skipTest("sample data 'pandaset_002' not found: set PF_DATA_DIR (CMake -DPF_DATA_DIR "
                          "or the environment) to the shared/data directory")
        with tempfile.TemporaryDirectory() as out:
            run = run_module(seq, out, "30")
            self.assertEqual(run.returncode, 0, run.stderr)
            array = numpy.load(os.path.join(out, "lidar", "30.npy"))
            source = pandas.read_pickle(os.path.join(seq, "lidar", "30.pkl.gz"))
            self.assertEqual(array.shape, (len(source), 6))
            self.assertTrue(numpy.array_equal(array[:, 0], source["x"].to_numpy()))
            self.assertTrue(numpy.array_equal(array[:, 4], source["t"].to_numpy()))
            self.assertEqual(set(array[:, 5]), {0.0, 1.0})  # Both LiDARs.
            with open(os.path.join(out, "cuboids", "30.json"), encoding="utf-8") as f:
                rows = json.load(f)
            boxes = pandas.read_pickle(os.path.join(seq, "annotations", "cuboids", "30.pkl.gz"))
            self.assertEqual(len(rows), len(boxes))
            self.assertEqual(rows[0]["uuid"], boxes["uuid"].iloc[0])
            self.assertTrue(math.isclose(rows[0]["yaw"], boxes["yaw"].iloc[0], rel_tol=0, abs_tol=0))


def main():
    global MODULE, DATA_DIR
    parser = argparse.ArgumentParser()
    parser.add_argument("--module", required=True)
    parser.add_argument("--data-dir", default="")
    args, rest = parser.parse_known_args()
    MODULE = args.module
    DATA_DIR = os.environ.get("PF_DATA_DIR") or args.data_dir
    unittest.main(argv=[sys.argv[0]] + rest)


if __name__ == "__main__":
    main()
