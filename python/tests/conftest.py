import numpy as np
import pytest


def random_actions(avail, rng):
    """One uniformly random available action per agent."""
    avail = np.asarray(avail)
    return (avail * rng.random(avail.shape)).argmax(axis=1)


@pytest.fixture
def rng():
    return np.random.default_rng(0)


def pytest_configure(config):
    # Under `cargo test` (python/tests/pytest.rs) the freshly built extension is staged in a
    # temporary directory: make sure that, not an installed copy, is under test.
    import os

    staged = os.environ.get("AVACRAFT_STAGED")
    if staged:
        import avacraft

        here = os.path.dirname(os.path.abspath(avacraft.__file__))
        assert os.path.samefile(here, staged), f"testing {here}, not the staged build {staged}"
