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


def _memory_maps() -> int:
    """The process's memory mappings (Linux; 0 elsewhere)."""
    try:
        with open("/proc/self/maps") as f:
            return sum(1 for _ in f)
    except OSError:
        return 0


@pytest.fixture(autouse=True, scope="module")
def release_compiled_programs():
    """Each XLA CPU executable holds about 18 memory mappings until its jit cache lets it go; the
    whole suite in one process compiles a few thousand and reached Linux's default
    vm.max_map_count (65 530), where XLA aborts mid-compile (CI exit 139 in test_rhythm). The
    caches are emptied after every test module, so the count stays that of one module."""
    yield
    jax.clear_caches()
    if os.environ.get("RHYTHMJAX_TEST_MAPS"):
        print(f"\n[memory maps after the module: {_memory_maps()}]")


@pytest.fixture
def selfcal_calls(monkeypatch):
    """The keyword arguments of every `fit.selfcal.fit_selfcal` call (the command's), in order:
    the real function runs behind a recorder."""
    import fit.selfcal as sc

    calls, real = [], sc.fit_selfcal

    def recorded(*a, **kw):
        calls.append(kw)
        return real(*a, **kw)

    monkeypatch.setattr(sc, "fit_selfcal", recorded)
    return calls
