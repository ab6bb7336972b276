"""Fixtures shared by the tetopt Python tests.

The CLI binary comes from $TETOPT_CLI (set by tests/scripts/test_python.sh),
or sits next to the build tree's python/ folder (<build>/tetopt).
"""
import os
import pathlib
import subprocess

import pytest

import tetopt


def _find_cli():
    env = os.environ.get("TETOPT_CLI")
    if env:
        return pathlib.Path(env)
    guess = pathlib.Path(tetopt.__file__).resolve().parents[2] / "tetopt"
    return guess if guess.exists() else None


@pytest.fixture(scope="session")
def cli():
    path = _find_cli()
    if path is None or not path.exists():
        pytest.skip("tetopt CLI not found (set TETOPT_CLI)")
    return str(path)


def run_cli(cli, *args):
    r = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"tetopt {' '.join(map(str, args))} failed ({r.returncode}): {r.stderr}"
    return r.stdout


@pytest.fixture(scope="session")
def box(cli, tmp_path_factory):
    """A jittered two-region box mesh written by `tetopt generate` (1296 tets)."""
    d = tmp_path_factory.mktemp("box")
    path = d / "box.mesh"
    run_cli(cli, "generate", path, "--cells", 6, 6, 6, "--jitter", 0.4, "--regions", 2, "--seed", 7)
    return path
