"""Shared fixtures: a seeded rng, and a headless GL context that skips — except in CI."""

from __future__ import annotations

import os

import numpy as np
import pytest

IN_CI = os.environ.get("CI", "").lower() in {"1", "true", "yes"}


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def gl_ctx():
    """A headless OpenGL 3.3+ context (EGL/llvmpipe). Skips without GL, fails in CI."""
    try:
        from terrascape.render.context import create_headless_context

        ctx = create_headless_context()
    except Exception as exc:
        if IN_CI:
            pytest.fail(f"CI must have headless GL, but: {exc}")
        pytest.skip(f"no headless OpenGL: {exc}")
    yield ctx
    ctx.release()
