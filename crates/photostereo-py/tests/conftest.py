"""Shared fixtures: the CLI binary and synthetic datasets it renders (never seen before:
rendered fresh into a temporary directory by ``photostereo synth``)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]

# Every synthetic dataset here: 12 lights, 16-bit PNG, the same lights for all (so one
# calibration sphere serves every target).
K = "12"


def _bin() -> Path:
    b = Path(os.environ.get("PHOTOSTEREO_BIN", REPO / "target" / "release" / "photostereo"))
    if not b.is_file():
        pytest.fail(
            f"{b} not found: build the CLI first (cargo build --release) or set PHOTOSTEREO_BIN"
        )
    return b


@pytest.fixture(scope="session")
def cli():
    """Run the CLI (`photostereo -q ARGS`), failing the test on a non-zero exit."""
    b = _bin()

    def call(*args: str) -> None:
        r = subprocess.run([str(b), "-q", *map(str, args)], capture_output=True, text=True)
        if r.returncode != 0:
            raise AssertionError(f"photostereo {' '.join(map(str, args))} failed:\n{r.stderr}")

    return call


def synth(cli, out: Path, shape: str, material: str, size: int = 96, *extra: str) -> Path:
    cli("synth", "--shape", shape, "--material", material, "-k", K, "--size", str(size),
        *extra, "-o", out)
    return out


@pytest.fixture(scope="session")
def data(tmp_path_factory, cli):
    """Synthetic datasets: a shiny vase with its calibration sphere, a shiny blob under
    the same lights, a Lambertian blob with a matte sphere, a small Lambertian bowl
    with interreflections."""
    d = tmp_path_factory.mktemp("data")
    vase = synth(cli, d / "vase", "vase", "plastic", 96, "--calib-sphere", "40")
    blob = synth(cli, d / "blob", "blob", "plastic", 96, "--seed", "3")
    matte = synth(cli, d / "matte", "blob", "lambertian", 96, "--calib-sphere", "40")
    bowl = synth(cli, d / "bowl", "bowl", "lambertian", 40, "--interreflections")
    return {
        "vase": vase,
        "sphere": vase / "sphere",
        "blob": blob,
        "matte": matte,
        "matte_sphere": matte / "sphere",
        "bowl": bowl,
        "root": d,
    }
