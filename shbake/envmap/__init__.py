"""Environment maps in: reading, validation, layouts, solid angles, sun extraction."""

from shbake.envmap.environment import Environment, load_environment
from shbake.envmap.layouts import LAYOUTS

__all__ = ["Environment", "LAYOUTS", "load_environment"]
