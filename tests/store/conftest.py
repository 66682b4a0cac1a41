import pytest
from storetest_cubes import make_cube


@pytest.fixture
def cube():
    """A fresh 3 x 4 x 2 x 1 cube with two outputs, nothing computed."""
    return make_cube()
