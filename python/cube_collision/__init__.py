from ._core import *  # noqa
from ._core import CollisionManager, Geometry, Body, ALL_BITS  # noqa
