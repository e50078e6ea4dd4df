import os


# Strict numerics in tests only: the library itself never flips global configuration.
os.environ.setdefault("JAX_PLATFORMS", "cpu")
os.environ["RHYTHMJAX_CACHE_DIR"] = "0"  # in-process CLI tests leave no compilation cache

import jax
import jax.random as jr
import pytest
from hypothesis import settings


jax.config.update("jax_numpy_rank_promotion", "raise")

settings.register_profile("ci", deadline=None, max_examples=200)
settings.register_profile("nightly", deadline=None, max_examples=10_000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def getkey():
    """Fresh PRNG keys from a fixed seed (STYLE R14)."""
    keys = iter(jr.split(jr.PRNGKey(5678), 10_000))
    return lambda: next(keys)
