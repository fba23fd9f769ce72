"""Fixtures shared by test modules."""

from __future__ import annotations

import os

import pytest
from _browser import Browser, chromium_path


@pytest.fixture(scope="module")
def browser():
    """A Chromium for a test module; skips when none is installed, and fails instead under CI."""
    if chromium_path() is None:
        why = "Chromium is not installed (apt-get install -y chromium; CI's .ci/run installs it)"
        if os.environ.get("CI") == "true":
            pytest.fail(why)
        pytest.skip(why)
    b = Browser(1000, 700)
    yield b
    b.close()

