"""Tests of the Python module, run by ctest under /usr/bin/python3 (tests/python/CMakeLists.txt).

Environment: IMUFORGE_BIN (the imuforge program), IMUFORGE_SOURCE_DIR, IMUFORGE_REAL_DATA_DIR, TMPDIR.
The module is compared with the command-line program on the same files: same numbers, not just "runs".
"""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import imuforge

BIN = os.environ["IMUFORGE_BIN"]
SRC = os.environ["IMUFORGE_SOURCE_DIR"]
REAL = os.environ.get("IMUFORGE_REAL_DATA_DIR", "")
EX = os.path.join(SRC, "docs", "examples")


def cli(*args):
    subprocess.run([BIN, *args], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


class Logs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="imuforge-py-")
        cls.addClassCleanup(shutil.rmtree, cls.dir, ignore_errors=True)
        cls.csv = os.path.join(cls.dir, "sim.csv")
        cli("simulate", "--campaign", os.path.join(EX, "campaign-small.json"), "--sensor",
            os.path.join(EX, "sensor-consumer.json"), "--seed", "3", "--rate", "50", "--out", cls.csv)

    def test_read_matches_every_encoding(self):
        h5 = os.path.join(self.dir, "sim.h5")
        cli("convert", "--in", self.csv, "--out", h5)
        a, b = imuforge.read_log(self.csv), imuforge.read_log(h5)
        self.assertEqual((a["encoding"], b["encoding"]), ("csv", "h5"))
        self.assertGreater(len(a["t_s"]), 5000)
        self.assertEqual(a["raw"].dtype, np.int32)
        self.assertEqual(a["raw"].shape, (len(a["t_s"]), 6))
        for k in ("t_s", "raw", "f_ref", "w_ref", "segment", "has_ref", "accel_mps2"):
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)
        self.assertEqual(a["meta"]["serial"], "SIM-0001")
        lsb = a["meta"]["accel_lsb_mps2"]
        np.testing.assert_array_equal(a["accel_mps2"], a["raw"][:, :3] * lsb)
        # Fixture data: references present, gravity-sized specific force.
        self.assertTrue(a["has_ref"].all())
        self.assertAlmostEqual(float(np.median(np.linalg.norm(a["f_ref"], axis=1))), 9.80, delta=0.02)

    def test_write_log_round_trip_bit_exact(self):
        a = imuforge.read_log(self.csv)
        for fmt in ("csv", "bin", "h5"):
            out = os.path.join(self.dir, "rt." + fmt)
            imuforge.write_log(out, a, format=fmt)
            b = imuforge.read_log(out)
            for k in ("t_s", "raw", "f_ref", "w_ref", "temp_C", "segment"):
                np.testing.assert_array_equal(a[k], b[k], err_msg=fmt + " " + k)
            self.assertEqual(a["meta"], b["meta"])
        # The CSV written from Python is byte-identical to the one the program wrote.
        with open(self.csv, "rb") as f1, open(os.path.join(self.dir, "rt.csv"), "rb") as f2:
            self.assertEqual(f1.read(), f2.read())

    def test_errors_name_the_file(self):
        bad = os.path.join(self.dir, "bad.csv")
        with open(bad, "w") as f:
            f.write("# format_version=1\nt_s,segment\n")
        with self.assertRaises(ValueError) as e:
            imuforge.read_log(bad)
        self.assertIn(bad, str(e.exception))
        self.assertIn("lacks required column", str(e.exception))
        with self.assertRaises(Exception):
            imuforge.write_log(bad, {"meta": {}, "t_s": np.zeros(3), "raw": np.zeros((3, 5))})

    def test_solve_fixture_matches_the_program(self):
        out = os.path.join(self.dir, "cal-cli.json")
        cli("solve", "--log", self.csv, "--model", os.path.join(EX, "model-basic.json"), "--out", out)
        with open(os.path.join(EX, "model-basic.json")) as f:
            model = json.load(f)                       # a dict works as well as a path
        cal = imuforge.solve(self.csv, model)
        ref = imuforge.read_cal(out)
        self.assertEqual(cal["parameters"], ref["parameters"])
        self.assertGreater(len(cal["parameters"]), 10)
        imuforge.write_cal(os.path.join(self.dir, "cal-py.json"), cal)
        self.assertEqual(imuforge.read_cal(os.path.join(self.dir, "cal-py.json"))["parameters"], ref["parameters"])
        with self.assertRaises(Exception):
            imuforge.write_cal(os.path.join(self.dir, "x.json"), {"format": "not-a-cal"})

    def test_diagnose_returns_the_report(self):
        d = imuforge.diagnose(self.csv, os.path.join(EX, "model-basic.json"))
        self.assertEqual(d["inputs"]["mode"], "fixture")
        self.assertIn("gap", json.dumps(d))
        self.assertNotIn("fixture_errors", d)
        # With the log's campaign the table's axis errors are estimated, as `imuforge diagnose --campaign` does.
        dc = imuforge.diagnose(self.csv, os.path.join(EX, "model-basic.json"), campaign=os.path.join(EX, "campaign-small.json"))
        self.assertEqual(len(dc["fixture_errors"]["parameters"]), 3 * 3)
        with self.assertRaises(Exception):
            imuforge.diagnose(self.csv, os.path.join(EX, "model-basic.json"), campaign=os.path.join(self.dir, "none.json"))


class Navigate(unittest.TestCase):
    def test_same_figures_as_the_program(self):
        d = tempfile.mkdtemp(prefix="imuforge-py-nav-")
        self.addCleanup(shutil.rmtree, d, ignore_errors=True)
        nav = imuforge.navigate(os.path.join(EX, "trajectory-urban.json"), os.path.join(EX, "sensor-consumer.json"),
                                runs=4, seed=3, threads=1)
        names = [c["name"] for c in nav["candidates"]]
        self.assertEqual(names[0], "uncompensated")
        self.assertEqual(names[-1], "oracle")
        # Same numbers as the program for the same seed.
        subprocess.run([BIN, "navigate", "--trajectory", os.path.join(EX, "trajectory-urban.json"), "--sensor",
                        os.path.join(EX, "sensor-consumer.json"), "--runs", "4", "--seed", "3", "--threads", "1",
                        "--out", d], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(os.path.join(d, "nav.json")) as f:
            ref = json.load(f)
        self.assertEqual([c["name"] for c in ref["candidates"]], names)
        for a, b in zip(ref["candidates"], nav["candidates"]):
            self.assertEqual(a["horizontal_position_error_m"], b["horizontal_position_error_m"], a["name"])
        # The oracle table (true parameters) navigates better than raw counts at the outage end (consumer part:
        # 5.3 km vs 11.6 km median after 60 s with 4 runs, seed 3).
        last = lambda c: c["horizontal_position_error_m"][-1]["median"]
        self.assertLess(last(nav["candidates"][-1]), 0.7 * last(nav["candidates"][0]))


@unittest.skipUnless(REAL and os.path.isdir(os.path.join(REAL, "xsens-mti-imutk")), "real recordings absent")
class RealXsens(unittest.TestCase):
    def test_reference_free_table_and_kernel(self):
        d = tempfile.mkdtemp(prefix="imuforge-py-x-")
        self.addCleanup(shutil.rmtree, d, ignore_errors=True)
        x = os.path.join(REAL, "xsens-mti-imutk")
        log_path = os.path.join(d, "xsens.h5")
        s = imuforge.import_recording("xsens-imutk", os.path.join(x, "xsens_acc.txt"), log_path,
                                      in_gyro=os.path.join(x, "xsens_gyro.txt"))
        self.assertEqual(s["rows"], 51175)
        tbl = os.path.join(d, "x.tbl")
        cal = imuforge.solve(log_path, os.path.join(EX, "model-basic.json"), mode="reference-free", table=tbl, serial="7")
        rf = cal["reference_free"]
        self.assertGreaterEqual(rf["static_poses"], 30)
        self.assertLess(rf["gravity_rms_after_mps2"], 0.01 * rf["gravity_rms_before_mps2"])
        # The firmware kernel with the written table: |f| at the detected poses is g to within 0.01 m/s².
        log = imuforge.read_log(log_path)
        acc, gyro, status = imuforge.compensate(tbl, log["raw"], log["temp_C"])
        self.assertEqual(acc.shape, (51175, 3))
        still = np.linalg.norm(gyro, axis=1) < 0.01
        err = np.abs(np.linalg.norm(acc[still], axis=1) - rf["gravity_mps2"])
        self.assertGreater(still.sum(), 10000)
        self.assertLess(float(np.median(err)), 0.01)
        t = imuforge.read_table(tbl)
        self.assertEqual(t["device_serial"], 7)
        imuforge.write_table(os.path.join(d, "y.tbl"), t)
        with open(tbl, "rb") as f1, open(os.path.join(d, "y.tbl"), "rb") as f2:
            self.assertEqual(f1.read(), f2.read())


if __name__ == "__main__":
    unittest.main(verbosity=2)
