"""The examples run as a user runs them (executed, not just present), and draw what
they say they draw."""

import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO


def test_cornell_example_renders_scrubs_and_plots(tmp_path):
    pytest.importorskip("matplotlib")
    from matplotlib.image import imread

    run = subprocess.run([sys.executable, str(REPO / "examples" / "cornell.py"), "--out",
                          str(tmp_path), "--size", "32", "--spp", "8"],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "wrote" in run.stdout and "% at 64 spp" in run.stdout
    frames = [imread(tmp_path / f) for f in ["light_in_flight.png", "light_in_flight_later.png"]]
    # Two moments of the light in flight, each an image with something in it.
    assert all(f.std() > 0.01 for f in frames)
    assert not np.array_equal(frames[0], frames[1])
    assert imread(tmp_path / "convergence.png").std() > 0.01
    # The LiDAR measurement: most pixels see a return, its figure drawn.
    found = re.search(r"LiDAR: (\d+) of (\d+) pixels with a return", run.stdout)
    assert found, run.stdout
    with_return, pixels = map(int, found.groups())
    assert with_return > 0.9 * pixels
    assert imread(tmp_path / "lidar.png").std() > 0.01
