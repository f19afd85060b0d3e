import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    """The one seeded generator every test draws from."""
    return np.random.default_rng(12345)
