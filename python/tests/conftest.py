"""Fixtures of the tests of the Python module `hisfm` (build/python).

Run from the project root after the build (scripts/test.sh does):
    PYTHONPATH=build/python python3 -m pytest python/tests
HISFM_BINARY_DIR names another build folder; HISFM_DATA_DIR the shared
scenes (optional: their tests are skipped without them).
"""
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("HISFM_BINARY_DIR", ROOT / "build"))
HISFM = BUILD / "hisfm"


def run_hisfm(*args):
    """Runs the `hisfm` command; returns (exit code, stdout, stderr)."""
    result = subprocess.run([str(HISFM), *map(str, args)],
                            capture_output=True, text=True, check=False)
    return result.returncode, result.stdout, result.stderr


def cli_error(*args):
    """The one-line error of a failing `hisfm` command, without 'error: '."""
    code, _, stderr = run_hisfm(*args)
    assert code != 0, stderr
    lines = [line for line in stderr.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1, stderr
    return lines[0][len("error: "):]


@pytest.fixture(scope="session")
def scene(tmp_path_factory):
    """A synthetic ambiguous scene (symmetric2, 24 images, seed 1) written by
    `hisfm synth`: database.db, images/ and the ground truth model."""
    out = tmp_path_factory.mktemp("scene") / "symmetric2"
    code, _, stderr = run_hisfm("synth", "--scene", "symmetric2",
                                "--num_images", 24, "--seed", 1,
                                "--output_path", out, "--log_level", "warn")
    assert code == 0, stderr
    return out
